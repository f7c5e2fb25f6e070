//! Scene-loading errors: each names the file, the line where known, the key and what was
//! wrong.

use std::fmt;
use std::path::{Path, PathBuf};

/// Why a scene could not be loaded.
#[derive(Debug, thiserror::Error)]
pub struct SceneError {
    /// The file at fault (the scene file, or a file it refers to).
    pub file: PathBuf,
    /// 1-based line in `file`, when known.
    pub line: Option<usize>,
    /// The dotted key at fault (`film.width`, `light[2].direction`), or empty.
    pub key: String,
    /// What was wrong, in words.
    pub message: String,
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file.display())?;
        if let Some(line) = self.line {
            write!(f, ":{line}")?;
        }
        if !self.key.is_empty() {
            write!(f, ": {}", self.key)?;
        }
        write!(f, ": {}", self.message)
    }
}

impl SceneError {
    /// An error about `key` in `file` at `line`.
    pub fn new(
        file: impl Into<PathBuf>,
        line: Option<usize>,
        key: impl Into<String>,
        message: impl Into<String>,
    ) -> Self {
        SceneError {
            file: file.into(),
            line,
            key: key.into(),
            message: message.into(),
        }
    }
}

/// Reads a whole file after checking that it is at most `max_bytes` long (a crafted or
/// mistaken path to a huge file is rejected before anything is allocated). `what` names the
/// kind of file in errors (`"OBJ"`, `"scene file"`).
pub(crate) fn read_bytes(path: &Path, what: &str, max_bytes: u64) -> Result<Vec<u8>, SceneError> {
    let fail = |msg: String| SceneError::new(path, None, "", msg);
    let meta = std::fs::metadata(path).map_err(|e| fail(format!("cannot read {what}: {e}")))?;
    if !meta.is_file() {
        // (A device such as /dev/zero reports no length and never ends.)
        return Err(fail(format!("cannot read {what}: not a regular file")));
    }
    let len = meta.len();
    if len > max_bytes {
        return Err(fail(format!(
            "cannot read {what}: the file is {len} bytes, more than the {max_bytes} supported"
        )));
    }
    std::fs::read(path).map_err(|e| fail(format!("cannot read {what}: {e}")))
}

/// [`read_bytes`] for a text file (UTF-8).
pub(crate) fn read_text(path: &Path, what: &str, max_bytes: u64) -> Result<String, SceneError> {
    String::from_utf8(read_bytes(path, what, max_bytes)?).map_err(|e| {
        SceneError::new(
            path,
            None,
            "",
            format!(
                "cannot read {what}: not UTF-8 text (invalid byte at offset {})",
                e.utf8_error().valid_up_to()
            ),
        )
    })
}

/// Runs a loader; a panic inside it (in a dependency, on input that the checks let
/// through) becomes an error naming `file` instead of taking the program down. See
/// [`lamina_leaf::guard`]; the panic hook stays quiet for it.
pub(crate) fn guarded<T>(
    file: &Path,
    f: impl FnOnce() -> Result<T, SceneError>,
) -> Result<T, SceneError> {
    lamina_leaf::guard::catch_panic(f).unwrap_or_else(|message| {
        Err(SceneError::new(
            file,
            None,
            "",
            lamina_leaf::guard::panic_error_message(&message),
        ))
    })
}

/// The shared fault point of the loaders' guards (see [`lamina_leaf::guard::fault_point`]).
pub(crate) use lamina_leaf::guard::fault_point;

/// Maps byte offsets in a text to 1-based line numbers.
#[derive(Clone, Debug)]
pub struct LineIndex {
    starts: Vec<usize>,
}

impl LineIndex {
    /// Indexes `text`.
    pub fn new(text: &str) -> Self {
        let mut starts = vec![0];
        starts.extend(text.match_indices('\n').map(|(i, _)| i + 1));
        LineIndex { starts }
    }

    /// The 1-based line holding byte `offset`.
    pub fn line(&self, offset: usize) -> usize {
        match self.starts.binary_search(&offset) {
            Ok(i) => i + 1,
            Err(i) => i,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_numbers() {
        let idx = LineIndex::new("a\nbc\n\nd");
        assert_eq!(idx.line(0), 1);
        assert_eq!(idx.line(2), 2);
        assert_eq!(idx.line(3), 2);
        assert_eq!(idx.line(5), 3);
        assert_eq!(idx.line(6), 4);
    }

    #[test]
    fn display_names_file_line_key() {
        let e = SceneError::new("s.toml", Some(3), "film.width", "must be > 0, got 0");
        assert_eq!(e.to_string(), "s.toml:3: film.width: must be > 0, got 0");
    }
}
