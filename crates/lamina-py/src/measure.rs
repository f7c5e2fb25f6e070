//! `lamina.measure`: the scene's `[[sensor]]`s, as Python dicts of NumPy arrays.
//!
//! The sensors run on a thread of their own with the GIL released (as `lamina.render`
//! does); the calling thread checks Python's signals every 50 ms, and Ctrl-C stops the
//! sensors (`KeyboardInterrupt`). A film with `bands` runs them three bands at a time, like
//! its images; every array then has one column per band.

use crate::errors::render_error;
use crate::scene::Scene;
use crate::worker::{Event, run_detached};
use lamina_render::sensors::absorbed::AbsorbedResult;
use lamina_render::sensors::{self, Estimate, MeasureOptions, Measurement, SensorOutput};
use lamina_scene::radiometry::SensorKind;
use numpy::ndarray::{Array1, Array2, Array3};
use numpy::{PyArray1, PyArray2, PyArray3};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::sync::mpsc;

/// Values and standard errors, `(rows, channels)` each.
type Table<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<f64>>);

/// One sensor over every band group: `outs[g]` holds the bands `groups[g]`.
struct Runs<'a> {
    outs: Vec<&'a SensorOutput>,
    groups: &'a [Vec<usize>],
    k: usize,
}

impl Runs<'_> {
    /// Values and standard errors of every channel of the estimate `get` picks.
    fn gather(&self, get: &dyn Fn(&SensorOutput) -> Option<Estimate>) -> (Vec<f64>, Vec<f64>) {
        sensors::gather(&self.outs, self.groups, self.k, get)
            .into_iter()
            .unzip()
    }

    /// `(n, k)` arrays of the estimates `get(i)` for `i < n`.
    fn table<'py>(
        &self,
        py: Python<'py>,
        n: usize,
        get: &dyn Fn(&SensorOutput, usize) -> Option<Estimate>,
    ) -> PyResult<Table<'py>> {
        let (mut v, mut s) = (
            Vec::with_capacity(n * self.k),
            Vec::with_capacity(n * self.k),
        );
        for i in 0..n {
            let (a, b) = self.gather(&|o| get(o, i));
            v.extend(a);
            s.extend(b);
        }
        let shape = |d: Vec<f64>| {
            Array2::from_shape_vec((n, self.k), d).map_err(|e| render_error(format!("shape: {e}")))
        };
        Ok((
            PyArray2::from_owned_array(py, shape(v)?),
            PyArray2::from_owned_array(py, shape(s)?),
        ))
    }

    /// `{"value": (k,), "std": (k,)}`.
    fn pair<'py>(
        &self,
        py: Python<'py>,
        get: &dyn Fn(&SensorOutput) -> Option<Estimate>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let (v, s) = self.gather(get);
        let d = PyDict::new(py);
        d.set_item("value", PyArray1::from_vec(py, v))?;
        d.set_item("std", PyArray1::from_vec(py, s))?;
        Ok(d)
    }
}

fn absorbed(o: &SensorOutput) -> Option<&AbsorbedResult> {
    match &o.measurement {
        Measurement::Absorbed(a) => Some(a),
        _ => None,
    }
}

/// One sensor's dict.
fn sensor_dict<'py>(
    py: Python<'py>,
    runs: &Runs,
    names: &[String],
) -> PyResult<Bound<'py, PyDict>> {
    let first = runs.outs[0];
    let s = &first.sensor;
    let d = PyDict::new(py);
    d.set_item("name", &s.name)?;
    d.set_item("samples", s.samples)?;
    d.set_item("channels", names.to_vec())?;
    d.set_item("channel", s.channel.map(|c| names[c].clone()))?;
    d.set_item(
        "seconds",
        runs.outs
            .iter()
            .map(|o| o.elapsed.as_secs_f64())
            .sum::<f64>(),
    )?;
    d.set_item("rays", runs.outs.iter().map(|o| o.rays).sum::<u64>())?;
    match (&first.measurement, &s.kind) {
        (Measurement::Brf(r), SensorKind::Brf { sweeps, .. }) => {
            d.set_item("type", "brf")?;
            d.set_item("sun_zenith", r.sun_zenith)?;
            let (e, _) = runs.gather(&|o| match &o.measurement {
                Measurement::Brf(b) => Some(Estimate {
                    value: b.irradiance,
                    std: glam::DVec3::ZERO,
                }),
                _ => None,
            });
            d.set_item("irradiance", PyArray1::from_vec(py, e))?;
            let list = PyList::empty(py);
            for (si, sweep) in sweeps.iter().enumerate() {
                let w = PyDict::new(py);
                w.set_item("label", &sweep.label)?;
                w.set_item("file", sweep.file.to_string_lossy().into_owned())?;
                let col = |f: fn(&lamina_scene::radiometry::BrfDirection) -> f32| {
                    PyArray1::from_vec(py, sweep.directions.iter().map(|x| f(x) as f64).collect())
                };
                w.set_item("zenith", col(|x| x.zenith))?;
                w.set_item("relative_azimuth", col(|x| x.relative_azimuth))?;
                w.set_item("signed_zenith", col(|x| x.signed_zenith))?;
                let (v, e) =
                    runs.table(py, sweep.directions.len(), &|o, i| match &o.measurement {
                        Measurement::Brf(b) => b.sweeps.get(si)?.get(i).copied(),
                        _ => None,
                    })?;
                w.set_item("brf", v)?;
                w.set_item("std", e)?;
                list.append(w)?;
            }
            d.set_item("sweeps", list)?;
        }
        (Measurement::Irradiance(r), SensorKind::Irradiance { .. }) => {
            d.set_item("type", "irradiance")?;
            let n = r.cells.len();
            let rects: Vec<[f64; 4]> = r
                .cells
                .iter()
                .map(|c| [c.rect.min.x, c.rect.max.x, c.rect.min.y, c.rect.max.y].map(|x| x as f64))
                .collect();
            let rect = Array2::from_shape_vec((n, 4), rects.concat())
                .map_err(|e| render_error(format!("shape: {e}")))?;
            d.set_item("cells", PyArray2::from_owned_array(py, rect))?;
            let cell = |o: &SensorOutput, i: usize, up: bool| match &o.measurement {
                Measurement::Irradiance(x) => {
                    x.cells.get(i).map(|c| if up { c.up } else { c.down })
                }
                _ => None,
            };
            let (dv, ds) = runs.table(py, n, &|o, i| cell(o, i, false))?;
            let (uv, us) = runs.table(py, n, &|o, i| cell(o, i, true))?;
            d.set_item("down", dv)?;
            d.set_item("down_std", ds)?;
            d.set_item("up", uv)?;
            d.set_item("up_std", us)?;
        }
        (Measurement::Absorbed(r), SensorKind::Absorbed { .. }) => {
            d.set_item("type", "absorbed")?;
            for (name, pick) in AbsorbedResult::MEASURES {
                d.set_item(name, runs.pair(py, &|o| absorbed(o).map(pick))?)?;
            }
            // Per material and per object: name -> {value, std}.
            type List = fn(&AbsorbedResult) -> &[(String, Estimate)];
            let lists: [(&str, List); 2] =
                [("materials", |a| &a.materials), ("objects", |a| &a.objects)];
            for (key, list) in lists {
                let per = PyDict::new(py);
                for (k, (name, _)) in list(r).iter().enumerate() {
                    per.set_item(
                        name,
                        runs.pair(py, &|o| {
                            absorbed(o).and_then(|a| list(a).get(k)).map(|m| m.1)
                        })?,
                    )?;
                }
                d.set_item(key, per)?;
            }
        }
        (Measurement::Fisheye(r), SensorKind::Fisheye { .. }) => {
            d.set_item("type", "fisheye")?;
            let (w, h) = (r.image.width as usize, r.image.height as usize);
            let mut data = vec![0f32; w * h * runs.k];
            for (o, group) in runs.outs.iter().zip(runs.groups) {
                if let Measurement::Fisheye(f) = &o.measurement {
                    for (px, p) in f.image.pixels.iter().enumerate() {
                        for (j, &c) in group.iter().enumerate().take(3) {
                            data[px * runs.k + c] = p[j];
                        }
                    }
                }
            }
            let img = Array3::from_shape_vec((h, w, runs.k), data)
                .map_err(|e| render_error(format!("shape: {e}")))?;
            d.set_item("image", PyArray3::from_owned_array(py, img))?;
            let rings = r.gap.len();
            let zen: Vec<f64> = (0..rings)
                .map(|k| (k as f64 + 0.5) * sensors::fisheye::RING_DEG as f64)
                .collect();
            d.set_item(
                "gap_zenith",
                PyArray1::from_owned_array(py, Array1::from(zen)),
            )?;
            d.set_item(
                "gap_fraction",
                PyArray1::from_vec(py, r.gap.iter().map(|g| g.0).collect()),
            )?;
            d.set_item(
                "gap_std",
                PyArray1::from_vec(py, r.gap.iter().map(|g| g.1).collect()),
            )?;
        }
        _ => {}
    }
    Ok(d)
}

/// Runs the scene's `[[sensor]]`s (BRF, irradiance, absorbed power, fisheye) and returns
/// one dict per sensor, in file order: `name`, `type`, `channels` (`R, G, B` or the film's
/// bands), `channel`, `samples`, `seconds`, `rays`, and per type: `brf`: `sun_zenith`,
/// `irradiance` (W m⁻², per channel), `sweeps` (each `label`, `file`, `zenith`,
/// `relative_azimuth`, `signed_zenith`, `brf` and `std` as `(directions, channels)`
/// arrays); `irradiance`: `cells` (`(n, 4)`: x_min, x_max, z_min, z_max), `down`,
/// `down_std`, `up`, `up_std` (`(n, channels)`, W m⁻²); `absorbed`: `albedo`, `fabs`,
/// `ftran`, `ftran_uncollided`, `escaped`, `incident` and per name in `materials` and
/// `objects`, each `{"value", "std"}` per channel (fractions of the incident power;
/// `incident` in W m⁻²); `fisheye`: `image` (`(n, n, channels)` radiance), `gap_zenith`,
/// `gap_fraction`, `gap_std` (5° rings). Values match `lamina render`'s sensor files for
/// the same seed. The files the scene names are not written (the CLI writes them).
/// `sample_scale` multiplies every sensor's sample count.
#[pyfunction]
#[pyo3(signature = (scene, *, seed=0, threads=None, sample_scale=None))]
pub fn measure<'py>(
    py: Python<'py>,
    scene: PyRef<'py, Scene>,
    seed: u64,
    threads: Option<usize>,
    sample_scale: Option<f64>,
) -> PyResult<Bound<'py, PyList>> {
    if threads == Some(0) {
        return Err(pyo3::exceptions::PyValueError::new_err(
            "threads must be at least 1",
        ));
    }
    if let Some(k) = sample_scale
        && !(k > 0.0 && k.is_finite())
    {
        return Err(pyo3::exceptions::PyValueError::new_err(format!(
            "sample_scale must be a positive number, got {k}"
        )));
    }
    let base = scene.scene.clone();
    let spectral = scene.spectral.clone();
    drop(scene);
    if base.radiometry.sensors.is_empty() {
        return Ok(PyList::empty(py));
    }
    let (names, groups): (Vec<String>, Vec<Vec<usize>>) = match &spectral {
        None => (sensors::channel_names(), vec![vec![0, 1, 2]]),
        Some(sp) => (
            sp.bands.iter().map(|b| b.name.clone()).collect(),
            lamina_render::bands::band_groups(sp.bands.len()),
        ),
    };
    let cancel = Arc::new(AtomicBool::new(false));
    let opts = MeasureOptions {
        seed,
        threads,
        sample_scale,
        cancel: Some(cancel.clone()),
        progress: None,
        ..Default::default()
    };
    let groups_w = groups.clone();
    let work = move || -> Result<Vec<Vec<SensorOutput>>, String> {
        let mut all = Vec::new();
        for g in &groups_w {
            let r = match &spectral {
                None => sensors::measure(&base, &opts),
                Some(sp) => lamina_render::bands::group_scene(&base, &sp.bands, g)
                    .and_then(|s| sensors::measure(&s, &opts)),
            };
            all.push(r.map_err(|e| e.to_string())?);
        }
        Ok(all)
    };
    let all = run_detached(
        py,
        "sensors",
        &cancel,
        mpsc::channel::<Event<(), _>>(),
        work,
        |_, ()| Ok(()),
    )?
    .map_err(render_error)?;
    let list = PyList::empty(py);
    for s in 0..all[0].len() {
        let runs = Runs {
            outs: all.iter().map(|g| &g[s]).collect(),
            groups: &groups,
            k: names.len(),
        };
        list.append(sensor_dict(py, &runs, &names)?)?;
    }
    Ok(list)
}
