//! Safe output for every lamina command: the one place that writes files the user will keep.
//!
//! * [`atomic`]: a file appears whole or not at all (temporary file in the same folder,
//!   fsync, rename); on any error or interrupt the temporary file is removed.
//! * [`image_out`]: images are encoded in memory with an encoder chosen from the file name
//!   *before* any file is created, then written atomically, so an unsupported format or a
//!   failed encode leaves nothing behind.
//! * [`folder`]: output folders (a leaf folder, an exported scene) are replaced only when
//!   lamina wrote them and they hold nothing else, or with an explicit `--force` that keeps
//!   the user's other files; an output never overwrites one of the command's inputs.
//! * [`owned`]: every file lamina writes carries a mark (PNG `tEXt`, JPEG comment, EXR
//!   `software`, GLB `asset.generator`); a named output file is replaced only when it has
//!   the mark, or with `--force`, and never when it is one of the command's inputs.
//! * [`interrupt`]: one Ctrl-C handler per process and one rule for what Ctrl-C means.
//!
//! The rules these implement are stated once, in ARCHITECTURE.md ("Output and
//! interruption").

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod atomic;
pub mod folder;
pub mod font;
pub mod image_out;
pub mod interrupt;
pub mod owned;

pub use atomic::{WriteError, write_bytes, write_file};
pub use folder::{FolderError, FolderSpec, FolderState, Replace, Staged, check_folder, stage};
pub use image_out::{ImageOutError, save_image};
pub use owned::{FileError, FileState, GENERATOR, check_file, file_state, text_mark_line};
