//! The rule for a file a command was told to write (`-o`, `--sheet`, `--screenshot`):
//! [`lamina_io::owned`] says it, this applies it with the command's `--force`.
//!
//! Each command checks its output files twice: before its work (so a render is not wasted
//! on an output it may not write) and again just before writing (the user may have put a
//! file there meanwhile).

use anyhow::Result;
use lamina_io::Replace;
use std::path::{Path, PathBuf};

/// `--force` as a replace policy.
pub fn replace_mode(force: bool) -> Replace {
    if force {
        Replace::Force
    } else {
        Replace::IfOurs
    }
}

/// `Ok` when `path` may be written: absent, written by lamina, or any file with `force`;
/// never a folder or one of `inputs`. The error names the file and says what to do.
pub fn claim(path: &Path, force: bool, inputs: &[PathBuf]) -> Result<()> {
    Ok(lamina_io::check_file(path, replace_mode(force), inputs)?)
}

/// The files directly inside `dir` (a leaf folder a contact sheet reads), for [`claim`]'s
/// `inputs`; empty when the folder cannot be read (then nothing there can be overwritten).
pub fn files_in(dir: &Path) -> Vec<PathBuf> {
    std::fs::read_dir(dir)
        .map(|entries| entries.flatten().map(|e| e.path()).collect())
        .unwrap_or_default()
}
