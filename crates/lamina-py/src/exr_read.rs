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
        .find(|(k, _)| *k == "lamina.channels")
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

/// Writes an `(H, W, 3)` RGB radiance array (a `render` result) as `.exr` (linear float)
/// or `.png` (8-bit sRGB after the scene film's exposure and tone map, or `exposure` in
/// stops and `tonemap` = `"aces"`, `"reinhard"` or `"clamp"` when no scene is given), as
/// `lamina render` writes it: atomically, marked as lamina's. A file lamina did not write
/// is kept and an error raised unless `force=True`.
#[pyfunction]
#[pyo3(signature = (path, image, scene=None, *, exposure=0.0, tonemap="aces", force=false))]
pub fn write_image(
    py: Python<'_>,
    path: PathBuf,
    image: numpy::PyArrayLike3<'_, f32, numpy::AllowTypeChange>,
    scene: Option<PyRef<'_, crate::scene::Scene>>,
    exposure: f32,
    tonemap: &str,
    force: bool,
) -> PyResult<()> {
    use pyo3::exceptions::PyValueError;
    let shape = image.as_array().shape().to_vec();
    if shape.len() != 3 || shape[2] != 3 || shape[0] == 0 || shape[1] == 0 {
        return Err(PyValueError::new_err(format!(
            "image must have shape (H, W, 3) (linear RGB), got {shape:?}"
        )));
    }
    let view = image.as_array();
    let pixels: Vec<glam::Vec3> = view
        .outer_iter()
        .flat_map(|row| {
            row.outer_iter()
                .map(|p| glam::Vec3::new(p[0], p[1], p[2]))
                .collect::<Vec<_>>()
        })
        .collect();
    let img = lamina_image::Image {
        width: shape[1] as u32,
        height: shape[0] as u32,
        pixels,
    };
    let mut film = match &scene {
        Some(s) => s.scene.film,
        None => {
            let mut f = lamina_scene::Film::new(img.width, img.height, 1);
            f.exposure = exposure;
            f.tonemap = match tonemap {
                "aces" => lamina_scene::ToneMap::Aces,
                "reinhard" => lamina_scene::ToneMap::Reinhard,
                "clamp" => lamina_scene::ToneMap::Clamp,
                other => {
                    return Err(PyValueError::new_err(format!(
                        "tonemap '{other}': use aces, reinhard or clamp"
                    )));
                }
            };
            f
        }
    };
    (film.width, film.height) = (img.width, img.height);
    let replace = if force {
        lamina_io::Replace::Force
    } else {
        lamina_io::Replace::IfOurs
    };
    py.detach(|| {
        lamina_io::check_file(&path, replace, &[]).map_err(|e| render_error(e.to_string()))?;
        lamina_image::write_image(&path, &img, &film).map_err(|e| render_error(e.to_string()))
    })
}
