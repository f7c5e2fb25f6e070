//! `lamina._lamina`, the extension module of the `lamina` Python package (python/lamina):
//! scenes loaded from files or built from dicts through the same loader as the CLI
//! ([`scene`]), renders returned as NumPy arrays with the GIL released, progress reported
//! and Ctrl-C honoured ([`render`]), the scene's sensors as dicts of arrays ([`measure`]), leaf optics vectorised over NumPy arrays ([`leaf`]),
//! PROSPECT and its inversion ([`spectra`]), and images written and read back
//! ([`exr_read`]).
//!
//! Errors are Python exceptions, never a crash of the interpreter: [`errors`] maps every
//! lamina error to `lamina.SceneError`, `lamina.LeafError` (both `ValueError`s) or
//! `lamina.RenderError` (a `RuntimeError`), and a panic inside lamina is caught and raised
//! as one of them (PyO3 turns any panic that escapes into `PanicException`).

// The workspace rule: `unsafe` only in lamina-accel. PyO3's and rust-numpy's FFI lives in
// those crates; their macros' expansions here pass `forbid`.
#![forbid(unsafe_code)]

mod convert;
mod errors;
mod exr_read;
mod leaf;
mod measure;
mod render;
mod scene;
mod spectra;
mod worker;

use pyo3::prelude::*;

/// The native half of the `lamina` package; import `lamina`, not this module.
#[pymodule]
fn _lamina(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("SceneError", py.get_type::<errors::SceneError>())?;
    m.add("LeafError", py.get_type::<errors::LeafError>())?;
    m.add("RenderError", py.get_type::<errors::RenderError>())?;
    m.add_class::<scene::Scene>()?;
    m.add_class::<leaf::Leaf>()?;
    m.add_function(wrap_pyfunction!(scene::load_scene, m)?)?;
    m.add_function(wrap_pyfunction!(render::render, m)?)?;
    m.add_function(wrap_pyfunction!(render::render_gpu, m)?)?;
    m.add_function(wrap_pyfunction!(measure::measure, m)?)?;
    m.add_function(wrap_pyfunction!(spectra::prospect, m)?)?;
    m.add_function(wrap_pyfunction!(spectra::fit_leaf, m)?)?;
    m.add_function(wrap_pyfunction!(exr_read::read_exr, m)?)?;
    m.add_function(wrap_pyfunction!(exr_read::write_image, m)?)?;
    Ok(())
}
