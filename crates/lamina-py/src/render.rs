//! `lamina.render` and `lamina.render_gpu`: a scene to a float32 NumPy array.
//!
//! The render runs on a thread of its own with the GIL released; the calling thread waits
//! for it, and every 50 ms (or when a pass completes) takes the GIL back for a moment to
//! call the progress callback and to let Python handle signals. Ctrl-C (or an exception in
//! the callback) sets the render's cancel flag: it stops at its next tile (well under a
//! second) and the exception is raised. The image is converted once, into the array that
//! is returned.

use crate::errors::{guarded, render_error};
use crate::scene::Scene;
use crate::worker::{Event, run_detached};
use lamina_render::{Progress, RenderOptions, RenderOutput, RenderStats};
use numpy::PyArray3;
use numpy::ndarray::Array3;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::sync::mpsc;
use std::time::Duration;

/// The worker's messages: the band group in flight, how many there are, and the pass.
type Msg = Event<(usize, usize, Progress), Rendered>;

/// A finished render: `height x width x channels` values, row-major, top row first.
struct Rendered {
    width: usize,
    height: usize,
    channels: usize,
    data: Vec<f32>,
    stats: Vec<RenderStats>,
}

impl Rendered {
    /// An RGB image's pixels, copied once into the interleaved buffer.
    fn rgb(image: &lamina_image::Image, stats: Vec<RenderStats>) -> Rendered {
        Rendered {
            width: image.width as usize,
            height: image.height as usize,
            channels: 3,
            data: image.pixels.iter().flat_map(|p| p.to_array()).collect(),
            stats,
        }
    }
}

fn progress_dict<'py>(
    py: Python<'py>,
    group: usize,
    groups: usize,
    p: &Progress,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("spp_done", p.spp_done)?;
    d.set_item("spp_total", p.spp_total)?;
    d.set_item("passes_done", p.passes_done)?;
    d.set_item("passes_total", p.passes_total)?;
    d.set_item("elapsed", p.elapsed.as_secs_f64())?;
    d.set_item("group", group)?;
    d.set_item("groups", groups)?;
    Ok(d)
}

fn stats_dict<'py>(py: Python<'py>, all: &[RenderStats]) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let first = all[0];
    let secs: f64 = all.iter().map(|s| s.elapsed.as_secs_f64()).sum();
    d.set_item("elapsed", secs)?;
    d.set_item(
        "accel_build",
        all.iter().map(|s| s.accel_build.as_secs_f64()).sum::<f64>(),
    )?;
    d.set_item("spp", all.iter().map(|s| s.spp_done).min().unwrap_or(0))?;
    d.set_item("samples", all.iter().map(|s| s.samples).sum::<u64>())?;
    d.set_item("rays", all.iter().map(|s| s.rays).sum::<u64>())?;
    d.set_item("stopped_early", all.iter().any(|s| s.stopped_early))?;
    d.set_item("renders", all.len())?;
    d.set_item(
        "spectral_setup",
        all.iter()
            .map(|s| s.spectral_setup.as_secs_f64())
            .sum::<f64>(),
    )?;
    d.set_item("primitives", first.primitives)?;
    d.set_item("instances", first.instances)?;
    Ok(d)
}

/// Renders `scene` on a worker thread while this one (GIL released) relays progress and
/// watches for Ctrl-C.
fn run_render(
    py: Python<'_>,
    scene: &Scene,
    mut opts: RenderOptions,
    progress: Option<Py<PyAny>>,
) -> PyResult<Rendered> {
    let cancel = Arc::new(AtomicBool::new(false));
    opts.cancel = Some(cancel.clone());
    let (tx, rx) = mpsc::channel::<Msg>();
    let scene_arc = scene.scene.clone();
    let spectral = scene.spectral.clone();
    {
        // Every render is one (a band render too): group 0 of 1 in the progress dicts.
        let tx = tx.clone();
        opts.progress = Some(Arc::new(move |p: Progress| {
            let _ = tx.send(Event::Message((0, 1, p)));
        }));
    }
    let work = move || -> Result<Rendered, String> {
        let one = |s: &lamina_scene::Scene| -> Result<RenderOutput, String> {
            lamina_render::render(s, &opts).map_err(|e| e.to_string())
        };
        match &spectral {
            None => {
                let out = one(&scene_arc)?;
                Ok(Rendered::rgb(&out.image, vec![out.stats]))
            }
            Some(sp) => {
                // Every band in one render (each camera path carries them all).
                let out = lamina_render::render_bands(&scene_arc, &sp.bands, &opts)
                    .map_err(|e| e.to_string())?;
                let k_all = out.planes.len();
                let n = (out.width * out.height) as usize;
                let mut data = vec![0.0f32; n * k_all];
                for (k, plane) in out.planes.iter().enumerate() {
                    for (px, v) in plane.iter().enumerate() {
                        data[px * k_all + k] = *v;
                    }
                }
                Ok(Rendered {
                    width: out.width as usize,
                    height: out.height as usize,
                    channels: k_all,
                    data,
                    stats: vec![out.stats],
                })
            }
        }
    };
    let on_progress =
        move |py: Python<'_>, (group, groups, p): (usize, usize, Progress)| match &progress {
            Some(cb) => cb
                .call1(py, (progress_dict(py, group, groups, &p)?,))
                .map(drop),
            None => Ok(()),
        };
    run_detached(py, "render", &cancel, (tx, rx), work, on_progress)?.map_err(render_error)
}

/// The render as an `(H, W, C)` float32 array: its buffer moved (not copied) into NumPy.
fn to_array<'py>(py: Python<'py>, r: Rendered) -> PyResult<Bound<'py, PyArray3<f32>>> {
    let a = Array3::from_shape_vec((r.height, r.width, r.channels), r.data)
        .map_err(|e| render_error(format!("image shape: {e}")))?;
    Ok(PyArray3::from_owned_array(py, a))
}

/// Renders `scene` with the offline path tracer: linear radiance (W m⁻² sr⁻¹), an
/// `(height, width, 3)` float32 array of linear Rec.709 RGB, top row first; or
/// `(height, width, K)` with one channel per band (band-mean spectral radiance,
/// W m⁻² sr⁻¹ nm⁻¹) when the film has `bands`. The same scene, seed and spp give the same
/// array as `lamina render --seed` writes to EXR, bit for bit.
///
/// `spp` overrides `film.spp`; `threads` defaults to all cores; `time_limit` (seconds)
/// stops at a pass boundary and returns what is done; `progress` is called with a dict
/// after every pass. The GIL is released while rendering; Ctrl-C raises KeyboardInterrupt
/// within a second. With `stats=True` returns `(image, stats_dict)`.
#[pyfunction]
#[pyo3(signature = (scene, *, spp=None, seed=0, threads=None, time_limit=None, progress=None, stats=false, accel="lamina"))]
#[allow(clippy::too_many_arguments)]
pub fn render<'py>(
    py: Python<'py>,
    scene: PyRef<'py, Scene>,
    spp: Option<u32>,
    seed: u64,
    threads: Option<usize>,
    time_limit: Option<f64>,
    progress: Option<Py<PyAny>>,
    stats: bool,
    accel: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let Some(accel) = lamina_render::accel::Backend::parse(accel) else {
        return Err(pyo3::exceptions::PyValueError::new_err(format!(
            "accel must be 'lamina' or 'embree', got '{accel}'"
        )));
    };
    if spp == Some(0) {
        return Err(pyo3::exceptions::PyValueError::new_err(
            "spp must be at least 1",
        ));
    }
    if threads == Some(0) {
        return Err(pyo3::exceptions::PyValueError::new_err(
            "threads must be at least 1",
        ));
    }
    let time_limit = match time_limit {
        None => None,
        Some(s) if s.is_finite() && s > 0.0 => Some(Duration::from_secs_f64(s)),
        Some(s) => {
            return Err(pyo3::exceptions::PyValueError::new_err(format!(
                "time_limit must be a positive number of seconds, got {s}"
            )));
        }
    };
    if let Some(cb) = &progress
        && !cb.bind(py).is_callable()
    {
        return Err(pyo3::exceptions::PyTypeError::new_err(
            "progress must be a callable taking one dict",
        ));
    }
    let opts = RenderOptions {
        spp,
        threads,
        seed,
        time_limit,
        accel,
        // A progress display gets its first pass after one sample per pixel (passes of 1,
        // 1, 2, 4, 8, then 16); without one, passes of 16 (faster, the same image).
        progressive: progress.is_some(),
        ..Default::default()
    };
    let scene_owned = scene.clone();
    drop(scene);
    let mut r = run_render(py, &scene_owned, opts, progress)?;
    let all_stats = std::mem::take(&mut r.stats);
    let img = to_array(py, r)?.into_any();
    if stats {
        let s = stats_dict(py, &all_stats)?;
        Ok((img, s).into_pyobject(py)?.into_any())
    } else {
        Ok(img)
    }
}

/// Renders `scene` with the real-time GPU approximation (wgpu; Vulkan, or Mesa's lavapipe
/// without a GPU): an `(height, width, 3)` float32 array of linear Rec.709 radiance, like
/// `render`. Raises `lamina.RenderError` when no adapter exists or for a spectral film.
/// With `warnings=True` returns `(image, list of what the approximation changed)`. `lod`:
/// level of detail for foliage, the leaf area in pixels below which a plant's leaves thin
/// out (their area kept); 0 draws every leaf.
#[pyfunction]
#[pyo3(signature = (scene, *, warnings=false, lod=1.0))]
pub fn render_gpu<'py>(
    py: Python<'py>,
    scene: PyRef<'py, Scene>,
    warnings: bool,
    lod: f64,
) -> PyResult<Bound<'py, PyAny>> {
    if !(0.0..=1e4).contains(&lod) {
        return Err(render_error(format!(
            "lod={lod}: the leaf area in pixels must be from 0 (every leaf) to 10000"
        )));
    }
    if scene.spectral.is_some() {
        return Err(render_error(
            "render_gpu renders RGB only: this scene's film has spectral bands",
        ));
    }
    let s = scene.scene.clone();
    drop(scene);
    let (image, warns) = py.detach(|| {
        guarded(render_error, || {
            let ctx = lamina_gpu::GpuContext::headless(&lamina_gpu::ContextOptions::default())
                .map_err(|e| render_error(format!("no GPU adapter: {e}")))?;
            let settings = lamina_gpu::RenderSettings {
                lod_pixels: lod as f32,
                ..Default::default()
            };
            lamina_gpu::render_scene(&ctx, &s, settings).map_err(render_error)
        })
    })?;
    let img = to_array(py, Rendered::rgb(&image, Vec::new()))?.into_any();
    if warnings {
        Ok((img, warns).into_pyobject(py)?.into_any())
    } else {
        Ok(img)
    }
}
