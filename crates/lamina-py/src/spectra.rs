//! `lamina.prospect` (PROSPECT-D and PRO leaf spectra) and `lamina.fit_leaf` (PROSPECT
//! inverted on a measured spectrum), as NumPy arrays; the same code as `lamina leaf
//! prospect` and `lamina leaf fit`.

use crate::errors::leaf_error;
use lamina_leaf::measured::{MeasuredError, MeasuredSpectrum};
use lamina_leaf::{LeafSpectrum, PigmentInputs, Pigments, ProspectModel};
use numpy::{AllowTypeChange, PyArray1, PyArrayLike1, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::fmt::Write;
use std::path::Path;

/// Pigments as a dict (`model` plus the inputs of that model).
pub fn pigments_dict<'py>(py: Python<'py>, p: &Pigments) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let pro = p.model() == ProspectModel::Pro;
    d.set_item("model", if pro { "pro" } else { "d" })?;
    for (k, v) in [
        ("n", p.n),
        ("cab", p.cab),
        ("car", p.car),
        ("anth", p.anth),
        ("cbrown", p.cbrown),
        ("cw", p.cw),
    ] {
        d.set_item(k, v)?;
    }
    if pro {
        d.set_item("prot", p.prot)?;
        d.set_item("cbc", p.cbc)?;
    } else {
        d.set_item("cm", p.cm)?;
    }
    d.set_item("alpha", p.alpha)?;
    Ok(d)
}

/// A leaf's directional-hemispherical reflectance and transmittance from PROSPECT-D
/// (Féret et al. 2017) or PROSPECT-PRO (2021), 400-2500 nm at 1 nm. Returns
/// `(wavelength_nm, R, T)`, three `(2101,)` float64 arrays.
///
/// Inputs (per unit leaf area; missing ones take a typical leaf's values): `n` structure
/// (plates), `cab` chlorophyll a+b and `car` carotenoids (µg/cm²), `anth` anthocyanins
/// (µg/cm²), `cbrown` brown pigments (a.u.), `cw` water (cm), `cm` dry matter (g/cm², D
/// only), `prot` proteins and `cbc` carbon-based constituents (g/cm², `model="pro"`
/// only), `alpha` the surface's incidence cone (degrees, 40). Values outside PROSPECT's
/// published ranges raise `lamina.LeafError` naming the input.
#[pyfunction]
#[pyo3(signature = (*, n=None, cab=None, car=None, anth=None, cbrown=None, cw=None, cm=None, prot=None, cbc=None, alpha=None, model="d"))]
#[allow(clippy::too_many_arguments)]
pub fn prospect<'py>(
    py: Python<'py>,
    n: Option<f64>,
    cab: Option<f64>,
    car: Option<f64>,
    anth: Option<f64>,
    cbrown: Option<f64>,
    cw: Option<f64>,
    cm: Option<f64>,
    prot: Option<f64>,
    cbc: Option<f64>,
    alpha: Option<f64>,
    model: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let model = match model.to_ascii_lowercase().as_str() {
        "d" | "prospect-d" => ProspectModel::D,
        "pro" | "prospect-pro" => ProspectModel::Pro,
        other => {
            return Err(leaf_error(format!(
                "model '{other}': use 'd' (PROSPECT-D) or 'pro' (PROSPECT-PRO)"
            )));
        }
    };
    let inputs = PigmentInputs {
        model,
        n,
        cab,
        car,
        anth,
        cbrown,
        cw,
        cm,
        prot,
        cbc,
        alpha,
    };
    let p = inputs.resolve("", "model='pro'").map_err(leaf_error)?;
    let s = lamina_leaf::prospect(&p);
    let nm: Vec<f64> = (0..s.r.len()).map(LeafSpectrum::wavelength).collect();
    Ok((
        PyArray1::from_vec(py, nm),
        PyArray1::from_vec(py, s.r),
        PyArray1::from_vec(py, s.t),
    )
        .into_pyobject(py)?
        .into_any())
}

/// Fits PROSPECT-D (N, Cab, Car, Anth, Cbrown, Cw, Cm and the surface parameter alpha) to
/// a measured leaf: `wavelengths` (nm, increasing, at least 10 inside 400-2500), `r` and
/// optionally `t` (directional-hemispherical, in [0, 1]). The same checks and fit as
/// `lamina leaf fit`; without `t`, T is predicted (and a `UserWarning` says so).
/// `band_weight` (default 8, as the CLI's `--band-weight`): how many times its band's width
/// of spectrum each band mean's error (450-500, 500-570, 620-700, 800-900, 1550-1750 nm)
/// weighs in the cost; 0 fits per nanometre alone.
///
/// Returns a dict: `pigments` (a dict, usable as `Leaf.from_dict({"pigments": ...})`),
/// `wavelengths`, `model_r`, `model_t` (PROSPECT at the measured wavelengths), `rmse_r`,
/// `rmse_t` (`None` without `t`), `iterations`.
#[pyfunction]
#[pyo3(signature = (wavelengths, r, t=None, band_weight=lamina_leaf::fit::BAND_WEIGHT))]
pub fn fit_leaf<'py>(
    py: Python<'py>,
    wavelengths: PyArrayLike1<'py, f64, AllowTypeChange>,
    r: PyArrayLike1<'py, f64, AllowTypeChange>,
    t: Option<PyArrayLike1<'py, f64, AllowTypeChange>>,
    band_weight: f64,
) -> PyResult<Bound<'py, PyDict>> {
    if !(0.0..=1000.0).contains(&band_weight) {
        return Err(leaf_error(format!(
            "band_weight {band_weight} is not a weight from 0 to 1000"
        )));
    }
    let nm = wavelengths.as_array().to_vec();
    let rv = r.as_array().to_vec();
    let tv = t.as_ref().map(|t| t.as_array().to_vec());
    for (name, len) in [
        ("r", r.len()),
        ("t", t.as_ref().map_or(nm.len(), |t| t.len())),
    ] {
        if len != nm.len() {
            return Err(leaf_error(format!(
                "{name} has {len} values and wavelengths {}: they must have the same length",
                nm.len()
            )));
        }
    }
    // The arrays as the text of a spectrum file, so that the file reader's checks (sorted,
    // finite, in [0, 1], R + T <= 1, enough samples inside 400-2500 nm) apply; its line k
    // is sample k - 1.
    let mut text = String::new();
    for i in 0..nm.len() {
        let _ = match &tv {
            Some(t) => writeln!(text, "{} {} {}", nm[i], rv[i], t[i]),
            None => writeln!(text, "{} {}", nm[i], rv[i]),
        };
    }
    let m = MeasuredSpectrum::parse(&text, Path::new("<arrays>")).map_err(|e| match e {
        MeasuredError::Line { line, message, .. } => leaf_error(format!(
            "sample {} (wavelength {} nm): {message}",
            line - 1,
            nm.get(line - 1).copied().unwrap_or(f64::NAN)
        )),
        MeasuredError::File { message, .. } => leaf_error(format!("the spectrum {message}")),
        other => leaf_error(other),
    })?;
    if m.t.is_none() {
        let warn = py.get_type::<pyo3::exceptions::PyUserWarning>();
        PyErr::warn(
            py,
            &warn,
            c"fit_leaf: no transmittance given; the fitted leaf's T is predicted, not fitted",
            1,
        )?;
    }
    let opts = lamina_leaf::fit::FitOptions { band_weight };
    let fit = py.detach(|| lamina_leaf::fit::fit_prospect_with(&m, &opts));
    let d = PyDict::new(py);
    d.set_item("pigments", pigments_dict(py, &fit.pigments)?)?;
    d.set_item("wavelengths", PyArray1::from_vec(py, m.nm.clone()))?;
    d.set_item("model_r", PyArray1::from_vec(py, fit.model_r))?;
    d.set_item("model_t", PyArray1::from_vec(py, fit.model_t))?;
    d.set_item("rmse_r", fit.rmse_r)?;
    d.set_item("rmse_t", fit.rmse_t)?;
    d.set_item("iterations", fit.iterations)?;
    Ok(d)
}
