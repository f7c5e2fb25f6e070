//! `lamina.read_exr`: an EXR image (lamina's renders and band renders, or any flat EXR)
//! as a float32 array, to compare with `lamina.render` or to load a CLI render.

use crate::errors::render_error;
use numpy::PyArray3;
use numpy::ndarray::Array3;
use pyo3::prelude::*;
use std::path::PathBuf;

/// Reads the first layer of an EXR file: `(image, channel_names)`, the image an
/// `(height, width, C)` float32 array (top row first) with the channels in the order lamina
/// writes them (`R, G, B` for RGB; band order for band renders, from the `lamina.channels`
/// attribute where present; otherwise alphabetical, as stored).
#[pyfunction]
pub fn read_exr<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, PyAny>> {
    use exr::prelude::*;
    let img = py
        .detach(|| read_all_flat_layers_from_file(&path))
        .map_err(|e| render_error(format!("cannot read '{}': {e}", path.display())))?;
    let layer = img
        .layer_data
        .first()
        .ok_or_else(|| render_error(format!("'{}' holds no image layer", path.display())))?;
    let size = layer.size;
    let (w, h) = (size.width(), size.height());
    let stored: Vec<String> = layer
        .channel_data
        .list
        .iter()
        .map(|c| c.name.to_string())
        .collect();
    // lamina writes RGB and band order; EXR stores channels sorted by name.
    let mut order: Vec<usize> = (0..stored.len()).collect();
    let rgb = ["R", "G", "B"];
    if rgb.iter().all(|c| stored.iter().any(|s| s == c)) && stored.len() == 3 {
        order = rgb
            .iter()
            .map(|c| stored.iter().position(|s| s == c).unwrap_or(0))
            .collect();
    } else if let Some(names) = img
        .attributes
        .other
        .iter()
        .chain(layer.attributes.other.iter())
        .find(|(k, _)| k.to_string() == "lamina.channels")
        .and_then(|(_, v)| match v {
            AttributeValue::Text(t) => Some(t.to_string()),
            _ => None,
        })
    {
        let wanted: Vec<&str> = names.split(',').map(str::trim).collect();
        if wanted.iter().all(|n| stored.iter().any(|s| s == n)) {
            order = wanted
                .iter()
                .map(|n| stored.iter().position(|s| s == n).unwrap_or(0))
                .collect();
        }
    }
    let c = order.len();
    let mut data = vec![0f32; w * h * c];
    for (k, &ch) in order.iter().enumerate() {
        let samples = &layer.channel_data.list[ch].sample_data;
        for i in 0..w * h {
            data[i * c + k] = samples.value_by_flat_index(i).to_f32();
        }
    }
    let names: Vec<String> = order.iter().map(|&i| stored[i].clone()).collect();
    let a = Array3::from_shape_vec((h, w, c), data).map_err(|e| render_error(e.to_string()))?;
    Ok((PyArray3::from_owned_array(py, a), names)
        .into_pyobject(py)?
        .into_any())
}
