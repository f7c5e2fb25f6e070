//! lamina's errors as Python exceptions.
//!
//! * `lamina.SceneError(ValueError)`: a scene could not be loaded or edited. Attributes
//!   `file` (the file at fault, `None` for a scene given as a dict), `line` (1-based, or
//!   `None`), `key` (the dotted key such as `film.width` or `material[1].roughness`, or
//!   `None`) and `message` (what was wrong).
//! * `lamina.LeafError(ValueError)`: a leaf, its maps, its pigments or a spectrum.
//! * `lamina.RenderError(RuntimeError)`: a render failed (an invalid option, no GPU, ...).

use pyo3::create_exception;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use std::path::Path;

create_exception!(
    lamina,
    SceneError,
    PyValueError,
    "A scene could not be loaded or edited: `.file`, `.line`, `.key` and `.message` say where \
     and what."
);
create_exception!(
    lamina,
    LeafError,
    PyValueError,
    "A leaf, its maps, its pigments or a spectrum is invalid."
);
create_exception!(
    lamina,
    RenderError,
    PyRuntimeError,
    "A render failed (an invalid option, no GPU adapter, ...)."
);

/// A `lamina.SceneError` from the loader's error. `dict_file` is the stand-in path of a
/// scene given as a dict: errors there have no file and no line (the line would be one of
/// the generated TOML), only the key.
pub fn scene_error(e: &lamina_scene::SceneError, dict_file: Option<&Path>) -> PyErr {
    let in_dict = dict_file.is_some_and(|d| d == e.file);
    let (file, line) = if in_dict {
        (None, None)
    } else {
        (Some(e.file.display().to_string()), e.line)
    };
    let key = (!e.key.is_empty()).then(|| e.key.clone());
    let text = if in_dict {
        match &key {
            Some(k) => format!("scene dict: {k}: {}", e.message),
            None => format!("scene dict: {}", e.message),
        }
    } else {
        e.to_string()
    };
    with_attributes(
        PyErr::new::<SceneError, _>(text),
        file,
        line,
        key,
        &e.message,
    )
}

/// A `lamina.SceneError` about `key` of a scene (no file), e.g. a value with no TOML form.
pub fn scene_key_error(file: Option<&Path>, key: &str, message: &str) -> PyErr {
    let where_ = match file {
        Some(f) => f.display().to_string(),
        None => "scene dict".to_string(),
    };
    with_attributes(
        PyErr::new::<SceneError, _>(format!("{where_}: {key}: {message}")),
        file.map(|f| f.display().to_string()),
        None,
        Some(key.to_string()),
        message,
    )
}

fn with_attributes(
    err: PyErr,
    file: Option<String>,
    line: Option<usize>,
    key: Option<String>,
    message: &str,
) -> PyErr {
    Python::attach(|py| {
        let v = err.value(py);
        // Setting attributes on a fresh exception instance cannot fail but for memory.
        let _ = v.setattr("file", file);
        let _ = v.setattr("line", line);
        let _ = v.setattr("key", key);
        let _ = v.setattr("message", message);
    });
    err
}

/// A `lamina.LeafError` with `message`.
pub fn leaf_error(message: impl std::fmt::Display) -> PyErr {
    PyErr::new::<LeafError, _>(message.to_string())
}

/// A `lamina.RenderError` with `message`.
pub fn render_error(message: impl std::fmt::Display) -> PyErr {
    PyErr::new::<RenderError, _>(message.to_string())
}

/// Runs `f`, turning a panic inside lamina into `make(message)` instead of PyO3's
/// `PanicException` (a panic is a lamina bug, but the user's interpreter lives on either
/// way; this names it).
pub fn guarded<T>(
    make: impl FnOnce(String) -> PyErr,
    f: impl FnOnce() -> PyResult<T>,
) -> PyResult<T> {
    lamina_leaf::guard::catch_panic(f).unwrap_or_else(|message| {
        Err(make(format!(
            "lamina failed instead of returning an error (a bug in lamina or a library it \
             uses; please report it): {message}"
        )))
    })
}
