//! `lamina.Leaf`: a leaf material (a built-in species, a leaf folder, or parameters as a
//! dict with the keys of a `leaf.toml`) and its BSDF, evaluated and sampled over NumPy
//! arrays of directions with the same code the renderer runs at a leaf hit
//! (`LeafMaterial::bsdf(uv)`, then `eval` / `sample` / `pdf`), and its directional-
//! hemispherical reflectance and transmittance (`lamina_leaf::albedo`, as `lamina leaf
//! albedo` computes them).
//!
//! Directions are in the leaf's local frame: `+z` is the normal on the adaxial (upper)
//! side, `x` runs along the texture's `u`. `wo` points toward the viewer, `wi` toward the
//! light, both away from the surface; they are normalised here (zero or non-finite
//! vectors are errors naming the row).

use crate::errors::{guarded, leaf_error};
use glam::{Vec2, Vec3};
use lamina_leaf::albedo::{AlbedoOptions, Side, directional_albedo};
use lamina_leaf::{Bsdf, LeafDescription, LeafMaterial};
use numpy::{
    AllowTypeChange, PyArray1, PyArray2, PyArrayLikeDyn, PyArrayMethods, PyUntypedArrayMethods,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rayon::prelude::*;
use std::borrow::Cow;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Rows evaluated per parallel task.
const CHUNK: usize = 8192;

/// A leaf material and its BSDF.
///
/// Make one with `Leaf.species("maple")`, `Leaf.load("leaf_dir")` or
/// `Leaf.from_dict({"pigments": {"cab": 40}})`.
#[pyclass(module = "lamina", name = "Leaf", frozen)]
pub struct Leaf {
    material: Arc<LeafMaterial>,
    what: String,
}

/// `n x width` rows of an array-like: shape `(width,)` is one row (`single`), `(n, width)`
/// is `n` rows; borrowed from NumPy's buffer when it is contiguous. Errors name the
/// argument and the shape.
struct Rows<'a> {
    values: Cow<'a, [f64]>,
    n: usize,
    single: bool,
}

fn rows<'a>(
    name: &str,
    a: &'a PyArrayLikeDyn<'_, f64, AllowTypeChange>,
    width: usize,
) -> PyResult<Rows<'a>> {
    let shape = a.shape().to_vec();
    let (n, single) = match shape.as_slice() {
        [w] if *w == width => (1, true),
        [n, w] if *w == width => (*n, false),
        _ => {
            return Err(PyValueError::new_err(format!(
                "{name} must have shape ({width},) or (N, {width}), got {shape:?}"
            )));
        }
    };
    let values = match a.as_slice() {
        Ok(s) => Cow::Borrowed(s),
        Err(_) => Cow::Owned(a.as_array().iter().copied().collect()),
    };
    Ok(Rows { values, n, single })
}

/// The common row count of `all` (each 1 or N), or an error naming the mismatch.
fn broadcast(all: &[(&str, &Rows)]) -> PyResult<usize> {
    let n = all.iter().map(|(_, r)| r.n).max().unwrap_or(1);
    for (name, r) in all {
        if r.n != n && r.n != 1 {
            return Err(PyValueError::new_err(format!(
                "{name} has {} rows where the others have {n} (give 1 row or {n})",
                r.n
            )));
        }
    }
    Ok(n)
}

/// Rows of `width` values converted in parallel by `f`, which returns `None` for a value
/// that is not allowed: then the error `bad(first bad row index, its values)`. One pass
/// over valid input (the first bad row is looked for only when there is one).
fn convert<T: Send + Default>(
    r: &Rows,
    width: usize,
    f: impl Fn(&[f64]) -> Option<T> + Sync,
    bad: impl FnOnce(usize, &[f64]) -> PyErr,
) -> PyResult<Vec<T>> {
    let chunks = || r.values.par_chunks(width).with_min_len(4096);
    let failed = std::sync::atomic::AtomicBool::new(false);
    let out = chunks()
        .map(|v| {
            f(v).unwrap_or_else(|| {
                failed.store(true, std::sync::atomic::Ordering::Relaxed);
                T::default()
            })
        })
        .collect();
    if failed.into_inner() {
        let i = chunks()
            .position_first(|v| f(v).is_none())
            .expect("a row failed");
        return Err(bad(i, &r.values[width * i..width * i + width]));
    }
    Ok(out)
}

/// A 3-wide input's rows as unit vectors; errors name the row.
fn directions(name: &str, r: &Rows) -> PyResult<Vec<Vec3>> {
    convert(
        r,
        3,
        |v| {
            let d = glam::DVec3::new(v[0], v[1], v[2]);
            let len = d.length();
            if !(len.is_finite() && len > 0.0) {
                None
            } else if (len - 1.0).abs() < 1e-6 {
                // Unit vectors (to f32 precision) are kept bit for bit, as the renderer
                // has them.
                Some(d.as_vec3())
            } else {
                Some((d / len).as_vec3())
            }
        },
        |i, v| {
            PyValueError::new_err(format!(
                "{name}[{i}] = [{}, {}, {}] is not a direction (zero, NaN or infinite)",
                v[0], v[1], v[2]
            ))
        },
    )
}

fn uvs(r: &Rows) -> PyResult<Vec<Vec2>> {
    convert(
        r,
        2,
        |v| (v[0].is_finite() && v[1].is_finite()).then(|| Vec2::new(v[0] as f32, v[1] as f32)),
        |i, v| PyValueError::new_err(format!("uv[{i}] = [{}, {}] is not finite", v[0], v[1])),
    )
}

/// The `(wo, wi, uv)` inputs of `eval` and `pdf`, checked and broadcast.
struct Pairs {
    n: usize,
    wo: Vec<Vec3>,
    wi: Vec<Vec3>,
    uv: Vec<Vec2>,
    /// Every input was one row: return one value, not an array of one.
    single: bool,
}

impl Pairs {
    fn new(
        wo: &PyArrayLikeDyn<'_, f64, AllowTypeChange>,
        wi: &PyArrayLikeDyn<'_, f64, AllowTypeChange>,
        uv: &Option<PyArrayLikeDyn<'_, f64, AllowTypeChange>>,
    ) -> PyResult<Pairs> {
        let (wo_r, wi_r, uv_r) = (rows("wo", wo, 3)?, rows("wi", wi, 3)?, uv_rows(uv)?);
        Ok(Pairs {
            n: broadcast(&[("wo", &wo_r), ("wi", &wi_r), ("uv", &uv_r)])?,
            wo: directions("wo", &wo_r)?,
            wi: directions("wi", &wi_r)?,
            uv: uvs(&uv_r)?,
            single: wo_r.single && wi_r.single && uv_r.single,
        })
    }
}

/// Element `i` of a broadcast input (`v` has 1 or N elements).
#[inline]
fn at<T: Copy>(v: &[T], i: usize) -> T {
    if v.len() == 1 { v[0] } else { v[i] }
}

impl Leaf {
    /// Runs `f(bsdf, i, out_row)` for every row `i` in parallel chunks (the GIL
    /// released), `out` holding `width` values per row; the texel's BSDF is built once per
    /// run of equal `uv`s.
    fn for_rows<T: Send>(
        &self,
        py: Python<'_>,
        out: &mut [T],
        width: usize,
        uv: &[Vec2],
        f: impl Fn(&lamina_leaf::LeafBsdf, usize, &mut [T]) + Sync + Send,
    ) {
        let m = &self.material;
        py.detach(|| {
            out.par_chunks_mut(CHUNK * width)
                .enumerate()
                .for_each(|(c, chunk)| {
                    let base = c * CHUNK;
                    let mut cur: Option<(Vec2, lamina_leaf::LeafBsdf)> = None;
                    for (k, o) in chunk.chunks_mut(width).enumerate() {
                        let i = base + k;
                        let t = at(uv, i);
                        // Borrowed, not copied: the texel BSDF is a few hundred bytes.
                        if cur.as_ref().is_none_or(|(u, _)| *u != t) {
                            cur = Some((t, m.bsdf(t)));
                        }
                        f(&cur.as_ref().expect("set above").1, i, o);
                    }
                })
        })
    }

    /// `(n, width)` float64 values from `f`, written straight into a NumPy array (or a
    /// `(width,)` array, or a float for `width == 1`, when `single`).
    fn rows_array<'py>(
        &self,
        py: Python<'py>,
        n: usize,
        width: usize,
        single: bool,
        uv: &[Vec2],
        f: impl Fn(&lamina_leaf::LeafBsdf, usize, &mut [f64]) + Sync + Send,
    ) -> PyResult<Bound<'py, PyAny>> {
        let arr = PyArray2::<f64>::zeros(py, [n, width], false);
        {
            let mut rw = arr.readwrite();
            let out = rw
                .as_slice_mut()
                .map_err(|e| PyValueError::new_err(e.to_string()))?;
            self.for_rows(py, out, width, uv, f);
        }
        Ok(match (single, width) {
            (true, 1) => arr
                .get_owned([0, 0])
                .unwrap_or(0.0)
                .into_pyobject(py)?
                .into_any(),
            (true, _) => arr.reshape([width])?.into_any(),
            (false, 1) => arr.reshape([n])?.into_any(),
            (false, _) => arr.into_any(),
        })
    }

    fn new(material: LeafMaterial, what: String) -> Leaf {
        Leaf {
            material: Arc::new(material),
            what,
        }
    }
}

#[pymethods]
impl Leaf {
    /// A built-in species' procedural leaf (`beech`, `maple`, `oak`, `birch`, `ivy`,
    /// `grass`, `willow`): its seven maps generated at `resolution` pixels from `seed`.
    #[staticmethod]
    #[pyo3(signature = (name, seed=1, resolution=256))]
    fn species(py: Python<'_>, name: &str, seed: u64, resolution: u32) -> PyResult<Leaf> {
        let s: lamina_leafmaps::Species = name
            .parse()
            .map_err(|e: lamina_leafmaps::UnknownSpecies| leaf_error(e))?;
        if !(16..=4096).contains(&resolution) {
            return Err(leaf_error(format!(
                "resolution {resolution}: must be 16 to 4096 pixels"
            )));
        }
        py.detach(|| {
            guarded(leaf_error, || {
                let g =
                    lamina_leafmaps::generate(&lamina_leafmaps::LeafSpec::new(s, seed, resolution));
                let m = LeafMaterial::new(g.maps, g.params).map_err(leaf_error)?;
                Ok(Leaf::new(m, format!("species '{name}'")))
            })
        })
    }

    /// A leaf folder (holding `leaf.toml` and its maps), or a `leaf.toml` itself.
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Leaf> {
        let file = if path.is_dir() {
            path.join("leaf.toml")
        } else {
            path.clone()
        };
        py.detach(|| {
            let desc = LeafDescription::from_toml_file(&file).map_err(leaf_error)?;
            let dir = file.parent().unwrap_or(Path::new("")).to_owned();
            let m = LeafMaterial::load(&desc, &dir).map_err(leaf_error)?;
            Ok(Leaf::new(m, format!("'{}'", file.display())))
        })
    }

    /// A leaf from a dict with the keys of a `leaf.toml`: `params` (the physical
    /// parameters), `maps` (file names relative to `base_dir`) and/or `pigments`
    /// (PROSPECT: `n`, `cab`, `car`, `anth`, `cbrown`, `cw`, `cm` or `prot` + `cbc`,
    /// `alpha`). `Leaf.from_dict({})` is the default leaf; unknown keys are errors.
    #[staticmethod]
    #[pyo3(signature = (d, base_dir=None))]
    fn from_dict(
        py: Python<'_>,
        d: &Bound<'_, PyAny>,
        base_dir: Option<PathBuf>,
    ) -> PyResult<Leaf> {
        let mut table = crate::convert::dict_to_table(d, "a leaf").map_err(leaf_error)?;
        for key in ["maps", "params"] {
            table
                .entry(key)
                .or_insert_with(|| toml::Value::Table(Default::default()));
        }
        let text = toml::to_string(&table).map_err(leaf_error)?;
        let base = base_dir.unwrap_or_else(|| std::env::current_dir().unwrap_or_default());
        py.detach(|| {
            let desc = LeafDescription::from_toml_str(&text, Path::new("<leaf dict>"))
                .map_err(leaf_error)?;
            let m = LeafMaterial::load(&desc, &base).map_err(leaf_error)?;
            Ok(Leaf::new(m, "from a dict".into()))
        })
    }

    /// `f(wo, wi) |cos θi|` (1/sr), the quantity a path tracer multiplies by: reflection
    /// where `wo` and `wi` are on the same side, transmission otherwise. `wo`, `wi`: shape
    /// `(3,)` or `(N, 3)`; `uv`: `(2,)` or `(N, 2)` texture coordinates (default the
    /// leaf's centre). Returns `(N, 3)` linear RGB (or `(3,)` for one row).
    #[pyo3(signature = (wo, wi, uv=None))]
    fn eval<'py>(
        &self,
        py: Python<'py>,
        wo: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
        wi: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
        uv: Option<PyArrayLikeDyn<'py, f64, AllowTypeChange>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let p = Pairs::new(&wo, &wi, &uv)?;
        self.rows_array(py, p.n, 3, p.single, &p.uv, |b, i, o| {
            let f = b.eval(at(&p.wo, i), at(&p.wi, i));
            for (d, v) in o.iter_mut().zip(f.to_array()) {
                *d = v as f64;
            }
        })
    }

    /// The density (per unit solid angle) with which `sample` returns `wi` for `wo`.
    /// Shapes as in `eval`; returns `(N,)` (or a float for one row).
    #[pyo3(signature = (wo, wi, uv=None))]
    fn pdf<'py>(
        &self,
        py: Python<'py>,
        wo: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
        wi: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
        uv: Option<PyArrayLikeDyn<'py, f64, AllowTypeChange>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let p = Pairs::new(&wo, &wi, &uv)?;
        self.rows_array(py, p.n, 1, p.single, &p.uv, |b, i, o| {
            o[0] = b.pdf(at(&p.wo, i), at(&p.wi, i)) as f64;
        })
    }

    /// Draws `wi` for `wo` as the renderer does, from `u`: uniform numbers in [0, 1),
    /// shape `(3,)` or `(N, 3)`. Returns `(wi, f, pdf)`: `wi` `(N, 3)`, `f = f |cos θi|`
    /// `(N, 3)` (so `f / pdf` is the path weight), `pdf` `(N,)`; rows where the sample
    /// carries no energy have `pdf = 0` and zeros.
    #[pyo3(signature = (wo, u, uv=None))]
    fn sample<'py>(
        &self,
        py: Python<'py>,
        wo: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
        u: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
        uv: Option<PyArrayLikeDyn<'py, f64, AllowTypeChange>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let (wo_r, u_r) = (rows("wo", &wo, 3)?, rows("u", &u, 3)?);
        let uv_r = uv_rows(&uv)?;
        let n = broadcast(&[("wo", &wo_r), ("u", &u_r), ("uv", &uv_r)])?;
        let wo = directions("wo", &wo_r)?;
        let uv = uvs(&uv_r)?;
        let us = convert(
            &u_r,
            3,
            |v| {
                v.iter().all(|x| (0.0..1.0).contains(x)).then(|| {
                    Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32)
                        .min(Vec3::splat(1.0 - f32::EPSILON / 2.0))
                })
            },
            |i, v| {
                PyValueError::new_err(format!(
                    "u[{i}] = [{}, {}, {}]: uniform numbers must be in [0, 1)",
                    v[0], v[1], v[2]
                ))
            },
        )?;
        let single = wo_r.single && u_r.single && uv_r.single;
        // Per row: wi (3), f (3), pdf; split into three arrays below.
        let all = self.rows_array(py, n, 7, false, &uv, |b, i, o| {
            let (wi, f, pdf) = b
                .sample(at(&wo, i), at(&us, i))
                .map_or((Vec3::ZERO, Vec3::ZERO, 0.0f32), |s| (s.wi, s.f, s.pdf));
            for (d, v) in o
                .iter_mut()
                .zip(wi.to_array().into_iter().chain(f.to_array()))
            {
                *d = v as f64;
            }
            o[6] = pdf as f64;
        })?;
        let np = py.import("numpy")?;
        let part = |a: usize, b: usize| -> PyResult<Bound<'py, PyAny>> {
            let slice = pyo3::types::PySlice::new(py, a as isize, b as isize, 1);
            let cols = all.get_item((pyo3::types::PySlice::full(py), slice))?;
            let cols = np.call_method1("ascontiguousarray", (cols,))?;
            Ok(match (single, b - a) {
                (true, 1) => cols.get_item((0, 0))?.call_method0("item")?,
                (true, _) => cols.get_item(0)?,
                (false, 1) => cols.call_method1("reshape", (n,))?,
                (false, _) => cols,
            })
        };
        Ok((part(0, 3)?, part(3, 6)?, part(6, 7)?)
            .into_pyobject(py)?
            .into_any())
    }

    /// Directional-hemispherical reflectance and transmittance `(R, T)` for light arriving
    /// at `theta` degrees from the normal on `side` (`"adaxial"` or `"abaxial"`),
    /// integrated from this BSDF's own sampling and averaged over the leaf's opaque texels
    /// (what an integrating sphere measures; `lamina leaf albedo`). An RGB leaf gives
    /// `(3,)` arrays (R, G, B at their nominal 611, 549, 464 nm); a pigment leaf with
    /// `wavelengths` (nm, 400-2500) gives one value per wavelength.
    #[pyo3(signature = (theta=8.0, side="adaxial", wavelengths=None, samples=65536))]
    fn albedo<'py>(
        &self,
        py: Python<'py>,
        theta: f32,
        side: &str,
        wavelengths: Option<PyArrayLikeDyn<'py, f64, AllowTypeChange>>,
        samples: u32,
    ) -> PyResult<Bound<'py, PyAny>> {
        if !(theta.is_finite() && (0.0..=89.0).contains(&theta)) {
            return Err(PyValueError::new_err(format!(
                "theta = {theta}: must be 0 to 89 degrees"
            )));
        }
        if samples < 64 {
            return Err(PyValueError::new_err("samples must be at least 64"));
        }
        let side: Side = side.parse().map_err(PyValueError::new_err)?;
        let opts = AlbedoOptions {
            theta_deg: theta,
            side,
            samples,
            ..Default::default()
        };
        let (r, t): (Vec<f64>, Vec<f64>) = match wavelengths {
            None => {
                let (r, t) = py.detach(|| directional_albedo(&self.material, &opts));
                (
                    r.to_array().map(f64::from).to_vec(),
                    t.to_array().map(f64::from).to_vec(),
                )
            }
            Some(w) => {
                let Some(p) = self.material.pigment_leaf() else {
                    return Err(leaf_error(
                        "wavelengths need a pigment leaf (one with `pigments`); an RGB leaf \
                         has three channels only",
                    ));
                };
                let nm: Vec<f32> = w.as_array().iter().map(|&x| x as f32).collect();
                if let Some((i, x)) = nm
                    .iter()
                    .enumerate()
                    .find(|(_, x)| !(x.is_finite() && (400.0..=2500.0).contains(*x)))
                {
                    return Err(PyValueError::new_err(format!(
                        "wavelengths[{i}] = {x}: PROSPECT covers 400-2500 nm"
                    )));
                }
                let triples: Vec<&[f32]> = nm.chunks(3).collect();
                let parts = py.detach(|| {
                    triples
                        .par_iter()
                        .map(|tr| {
                            let at = [0, 1, 2].map(|k| tr[k.min(tr.len() - 1)]);
                            let m = p.material(at)?;
                            let (r, t) = directional_albedo(&m, &opts);
                            Ok((0..tr.len())
                                .map(|k| (r[k] as f64, t[k] as f64))
                                .collect::<Vec<_>>())
                        })
                        .collect::<Result<Vec<_>, lamina_leaf::LeafError>>()
                });
                let parts = parts.map_err(leaf_error)?;
                parts.into_iter().flatten().unzip()
            }
        };
        Ok((PyArray1::from_vec(py, r), PyArray1::from_vec(py, t))
            .into_pyobject(py)?
            .into_any())
    }

    /// Whether the leaf is there (its alpha matte) at texture coordinates `uv`.
    fn opaque(&self, uv: (f32, f32)) -> bool {
        self.material.opaque(Vec2::new(uv.0, uv.1))
    }

    /// Whether the leaf's colours come from PROSPECT pigments (then `albedo` takes
    /// `wavelengths`).
    #[getter]
    fn is_pigment(&self) -> bool {
        self.material.pigment_leaf().is_some()
    }

    /// The PROSPECT inputs of a pigment leaf as a dict, or `None`.
    #[getter]
    fn pigments<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let Some(p) = self.material.pigment_leaf() else {
            return Ok(None);
        };
        Ok(Some(crate::spectra::pigments_dict(py, p.pigments())?))
    }

    fn __repr__(&self) -> String {
        format!(
            "<lamina.Leaf {}{}>",
            self.what,
            if self.is_pigment() { ", pigments" } else { "" }
        )
    }
}

/// `uv` rows, the leaf's centre when not given.
fn uv_rows<'a>(uv: &'a Option<PyArrayLikeDyn<'_, f64, AllowTypeChange>>) -> PyResult<Rows<'a>> {
    match uv {
        Some(a) => rows("uv", a, 2),
        None => Ok(Rows {
            values: Cow::Borrowed(&[0.5, 0.5]),
            n: 1,
            single: true,
        }),
    }
}
