//! `lamina.Scene`: a loaded scene, from a file (`lamina.load_scene`) or a dict
//! (`Scene.from_dict`), both through lamina-scene's loader: the same keys, checks and
//! messages as a TOML file. A scene keeps the TOML text it was read from, so that an edit
//! (`set`, `set_camera`, `set_material`, ...) is a change of that text read again by the
//! same readers (`lamina_scene::reload_settings`): the camera, film, sky, lights and the
//! changed materials are re-read, the geometry is kept.

use crate::convert::{dict_to_table, to_python, to_toml};
use crate::errors::{guarded, scene_error, scene_key_error};
use lamina_scene::overrides::{Override, apply_overrides};
use lamina_scene::{Light, SpectralOutput};
use pyo3::exceptions::{PyIndexError, PyKeyError, PyTypeError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The stand-in file name of a scene given as a dict (errors there name no file).
const DICT_FILE: &str = "<scene dict>";

/// A scene: camera, film, lights, sky, materials and geometry, ready to render.
///
/// Load one with `lamina.load_scene(path)` or build one with `Scene.from_dict({...})` (the
/// keys of a scene file). Its settings can be changed from Python (`set_camera`,
/// `set_film`, `set_light`, `sun_direction`, `set_material`, or any key with `set`) and it
/// can be rendered again without reloading its geometry.
#[pyclass(module = "lamina", name = "Scene")]
#[derive(Clone)]
pub struct Scene {
    /// The loaded scene (shared with renders in flight; an edit copies it only then).
    pub(crate) scene: Arc<lamina_scene::Scene>,
    /// `[film] bands`, when the film asks for spectral bands.
    pub(crate) spectral: Option<SpectralOutput>,
    /// The TOML text the scene was read from (with the edits made since).
    text: String,
    /// The scene file, or `base_dir/<scene dict>` for a dict.
    path: PathBuf,
    /// Whether the scene came from a dict.
    from_dict: bool,
}

impl Scene {
    fn dict_file(&self) -> Option<&Path> {
        self.from_dict.then_some(self.path.as_path())
    }

    /// The error of the loader, as a `lamina.SceneError`.
    fn err(&self, e: &lamina_scene::SceneError) -> PyErr {
        scene_error(e, self.dict_file())
    }

    /// Applies `edits` (dotted key, Python value) to the text and re-reads the settings.
    fn edit(&mut self, edits: &[(String, Bound<'_, PyAny>)]) -> PyResult<()> {
        let mut overrides = Vec::with_capacity(edits.len());
        for (key, value) in edits {
            if key == "object" || key.starts_with("object[") || key.starts_with("object.") {
                return Err(scene_key_error(
                    self.dict_file().is_none().then_some(self.path.as_path()),
                    key,
                    "objects hold the geometry, which an edit keeps: pass the change to \
                     lamina.load_scene(path, overrides={...}) or Scene.from_dict instead",
                ));
            }
            let v = to_toml(value, key).map_err(|m| self.key_error(key, &m))?;
            overrides.push(Override {
                key: key.clone(),
                value: toml_literal(&v),
            });
        }
        let new = apply_overrides(&self.text, &self.path, &overrides).map_err(|e| self.err(&e))?;
        let mut scene = (*self.scene).clone();
        let mut spectral = self.spectral.clone();
        guarded(crate::errors::render_error, || {
            lamina_scene::reload_settings(&mut scene, &mut spectral, &self.text, &new, &self.path)
                .map_err(|e| self.err(&e))
        })?;
        self.scene = Arc::new(scene);
        self.spectral = spectral;
        self.text = new;
        Ok(())
    }

    fn key_error(&self, key: &str, message: &str) -> PyErr {
        // `message` from `to_toml` starts with the key already.
        let m = message
            .strip_prefix(key)
            .and_then(|m| m.strip_prefix(": "))
            .unwrap_or(message);
        scene_key_error(
            self.dict_file().is_none().then_some(self.path.as_path()),
            key,
            m,
        )
    }

    /// Index of the `[[material]]` table named `name`.
    fn material_table(&self, name: &str) -> PyResult<usize> {
        let doc: toml::Table = toml::from_str(&self.text).map_err(|e| {
            crate::errors::render_error(format!("the scene's own text does not parse: {e}"))
        })?;
        let tables = match doc.get("material") {
            Some(toml::Value::Array(a)) => a.clone(),
            _ => Vec::new(),
        };
        tables
            .iter()
            .position(|t| t.get("name").and_then(|n| n.as_str()) == Some(name))
            .ok_or_else(|| {
                let names: Vec<&str> = tables
                    .iter()
                    .filter_map(|t| t.get("name").and_then(|n| n.as_str()))
                    .collect();
                PyKeyError::new_err(format!(
                    "no [[material]] table named '{name}' in the scene (it has: {}); materials \
                     imported with objects are changed through the object's `materials` key",
                    if names.is_empty() {
                        "none".to_string()
                    } else {
                        names.join(", ")
                    }
                ))
            })
    }

    /// Index of the scene's first sun.
    fn sun_index(&self) -> PyResult<usize> {
        self.scene
            .lights
            .iter()
            .position(|l| matches!(l, Light::Sun { .. }))
            .ok_or_else(|| PyKeyError::new_err("the scene has no sun (a light of type 'sun')"))
    }

    fn load_file(path: &Path, overrides: &[(String, Bound<'_, PyAny>)]) -> PyResult<Scene> {
        let mut list = Vec::new();
        for (key, value) in overrides {
            let v = to_toml(value, key).map_err(|m| {
                scene_key_error(
                    Some(path),
                    key,
                    m.strip_prefix(&format!("{key}: ")).unwrap_or(&m),
                )
            })?;
            list.push(Override {
                key: key.clone(),
                value: toml_literal(&v),
            });
        }
        let fail = |m: String| {
            scene_error(
                &lamina_scene::SceneError::new(
                    path,
                    None,
                    "",
                    format!("cannot read scene file: {m}"),
                ),
                None,
            )
        };
        let meta = std::fs::metadata(path).map_err(|e| fail(e.to_string()))?;
        if !meta.is_file() {
            return Err(fail("not a regular file".into()));
        }
        let max = lamina_scene::limits::MAX_SCENE_FILE_BYTES;
        if meta.len() > max {
            return Err(fail(format!(
                "the file is {} bytes, more than the {max} supported",
                meta.len()
            )));
        }
        let text = std::fs::read_to_string(path).map_err(|e| fail(e.to_string()))?;
        let text = apply_overrides(&text, path, &list).map_err(|e| scene_error(&e, None))?;
        Self::parse(text, path.to_owned(), false)
    }

    fn parse(text: String, path: PathBuf, from_dict: bool) -> PyResult<Scene> {
        let dict_file = from_dict.then_some(path.as_path());
        let (scene, spectral) = lamina_scene::parse_scene_with_output(&text, &path)
            .map_err(|e| scene_error(&e, dict_file))?;
        Ok(Scene {
            scene: Arc::new(scene),
            spectral,
            text,
            path,
            from_dict,
        })
    }
}

/// A TOML value as the text of an override (`[1, 2, 3]`, `"beech"`, `{ cab = 40 }`).
fn toml_literal(v: &toml::Value) -> String {
    // An inline table or array on one line: `toml::Value`'s Display writes values inline.
    v.to_string()
}

/// `(key, value)` pairs of a dict of edits, keys prefixed with `prefix`.
fn pairs<'py>(
    prefix: &str,
    kwargs: Option<&Bound<'py, PyDict>>,
) -> PyResult<Vec<(String, Bound<'py, PyAny>)>> {
    let mut out = Vec::new();
    if let Some(kw) = kwargs {
        for (k, v) in kw.iter() {
            let k: String = k
                .extract()
                .map_err(|_| PyTypeError::new_err("keys must be strings"))?;
            out.push((format!("{prefix}{k}"), v));
        }
    }
    Ok(out)
}

/// An f32 as the f64 with the same shortest decimal form (0.35, not 0.3499999940395355).
fn dec(x: f32) -> f64 {
    format!("{x}").parse().unwrap_or(x as f64)
}

fn vec3(v: glam::Vec3) -> [f64; 3] {
    v.to_array().map(dec)
}

#[pymethods]
impl Scene {
    /// Builds a scene from a dict with the keys of a scene file (`camera`, `film`,
    /// `integrator`, `sky`, `light`, `material`, `object`; lists of dicts for the `[[...]]`
    /// tables). Relative paths (maps, meshes, leaf folders) start at `base_dir` (default:
    /// the current directory). Raises `lamina.SceneError` naming the key on bad input.
    #[staticmethod]
    #[pyo3(signature = (d, base_dir=None))]
    fn from_dict(d: &Bound<'_, PyAny>, base_dir: Option<PathBuf>) -> PyResult<Scene> {
        let base = match base_dir {
            Some(b) => b,
            None => std::env::current_dir().unwrap_or_default(),
        };
        let path = base.join(DICT_FILE);
        let table = dict_to_table(d, "a scene").map_err(|m| {
            let (key, msg) = m.split_once(": ").unwrap_or(("", m.as_str()));
            scene_key_error(None, key, msg)
        })?;
        let text = toml::to_string(&table)
            .map_err(|e| scene_key_error(None, "", &format!("cannot be written as TOML: {e}")))?;
        guarded(crate::errors::render_error, || {
            Self::parse(text, path, true)
        })
    }

    /// Loads a scene file; `overrides` sets keys first, as `lamina render --set` does
    /// (`{"film.spp": 64, "material[0].species": "maple"}`), geometry keys included.
    #[staticmethod]
    #[pyo3(signature = (path, overrides=None))]
    fn load(path: PathBuf, overrides: Option<&Bound<'_, PyDict>>) -> PyResult<Scene> {
        let edits = pairs("", overrides)?;
        guarded(crate::errors::render_error, || {
            Self::load_file(&path, &edits)
        })
    }

    /// The TOML text the scene was read from, with the edits made since (a dict scene's
    /// text can be saved as a scene file; its relative paths start at `base_dir`).
    fn to_toml(&self) -> String {
        self.text.clone()
    }

    /// The scene file, or `None` for a scene built from a dict.
    #[getter]
    fn path(&self) -> Option<PathBuf> {
        (!self.from_dict).then(|| self.path.clone())
    }

    /// Image width in pixels.
    #[getter]
    fn width(&self) -> u32 {
        self.scene.film.width
    }

    /// Image height in pixels.
    #[getter]
    fn height(&self) -> u32 {
        self.scene.film.height
    }

    /// Samples per pixel of `film.spp` (what `render` uses without `spp=`).
    #[getter]
    fn spp(&self) -> u32 {
        self.scene.film.spp
    }

    /// The names of `[film] bands` (the channels of a render), or `None` for an RGB film.
    #[getter]
    fn bands(&self) -> Option<Vec<String>> {
        self.spectral
            .as_ref()
            .map(|s| s.bands.iter().map(|b| b.name.clone()).collect())
    }

    /// The camera as loaded: `position`, `look_at`, `up` (m), `fov` (horizontal, degrees),
    /// `aperture_radius`, `focus_distance` (m): the keys `set_camera` takes.
    #[getter]
    fn camera<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let c = &self.scene.camera;
        let d = PyDict::new(py);
        d.set_item("position", vec3(c.position))?;
        d.set_item("look_at", vec3(c.look_at))?;
        d.set_item("up", vec3(c.up))?;
        d.set_item("fov", dec(c.fov_deg))?;
        d.set_item("aperture_radius", dec(c.aperture_radius))?;
        d.set_item("focus_distance", dec(c.focus_distance))?;
        Ok(d)
    }

    /// The `[film]` table as written (with the edits), keys as in the scene file; values
    /// not written take their defaults (`width`, `height`, `spp`, `exposure` are always
    /// there, as loaded).
    #[getter]
    fn film<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let doc: toml::Table = toml::from_str(&self.text).unwrap_or_default();
        let d = match doc.get("film") {
            Some(v) => to_python(py, v)?.cast_into::<PyDict>()?,
            None => PyDict::new(py),
        };
        let f = &self.scene.film;
        d.set_item("width", f.width)?;
        d.set_item("height", f.height)?;
        d.set_item("spp", f.spp)?;
        d.set_item("exposure", dec(f.exposure))?;
        Ok(d)
    }

    /// The lights as loaded, each a dict with `type` and the keys of its table
    /// (`direction` is the unit vector toward a sun, also when its table gives a
    /// `position`).
    #[getter]
    fn lights<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        let out = PyList::empty(py);
        for l in &self.scene.lights {
            let d = PyDict::new(py);
            match l {
                Light::Sun {
                    direction,
                    irradiance,
                    angular_diameter_deg,
                } => {
                    d.set_item("type", "sun")?;
                    d.set_item("direction", vec3(*direction))?;
                    d.set_item("irradiance", vec3(*irradiance))?;
                    d.set_item("angular_diameter", dec(*angular_diameter_deg))?;
                }
                Light::Point {
                    position,
                    intensity,
                } => {
                    d.set_item("type", "point")?;
                    d.set_item("position", vec3(*position))?;
                    d.set_item("intensity", vec3(*intensity))?;
                }
                Light::Quad {
                    corner,
                    edge_u,
                    edge_v,
                    radiance,
                    two_sided,
                } => {
                    d.set_item("type", "quad")?;
                    d.set_item("corner", vec3(*corner))?;
                    d.set_item("edge_u", vec3(*edge_u))?;
                    d.set_item("edge_v", vec3(*edge_v))?;
                    d.set_item("radiance", vec3(*radiance))?;
                    d.set_item("two_sided", *two_sided)?;
                }
                Light::Sphere {
                    center,
                    radius,
                    radiance,
                } => {
                    d.set_item("type", "sphere")?;
                    d.set_item("center", vec3(*center))?;
                    d.set_item("radius", dec(*radius))?;
                    d.set_item("radiance", vec3(*radiance))?;
                }
            }
            out.append(d)?;
        }
        Ok(out)
    }

    /// The names of all materials: the `[[material]]` tables first, then those the
    /// objects imported (OBJ/MTL, glTF, plants).
    #[getter]
    fn materials(&self) -> Vec<String> {
        self.scene
            .materials
            .iter()
            .map(|m| m.name().to_string())
            .collect()
    }

    /// The `[[material]]` table named `name` as written (with the edits), plus its
    /// `type`: the keys `set_material` takes.
    fn material<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyAny>> {
        let i = self.material_table(name)?;
        let doc: toml::Table = toml::from_str(&self.text).unwrap_or_default();
        let t = doc
            .get("material")
            .and_then(|m| m.as_array())
            .and_then(|a| a.get(i))
            .cloned()
            .unwrap_or(toml::Value::Table(Default::default()));
        to_python(py, &t)
    }

    /// The sun's direction (unit vector toward the sun) of the scene's first sun. Setting it
    /// sets that light's `direction` (any `position` key is dropped).
    #[getter]
    fn sun_direction(&self) -> PyResult<[f64; 3]> {
        let i = self.sun_index()?;
        match &self.scene.lights[i] {
            Light::Sun { direction, .. } => Ok(vec3(*direction)),
            _ => unreachable!("sun_index found a sun"),
        }
    }

    #[setter]
    fn set_sun_direction(&mut self, value: &Bound<'_, PyAny>) -> PyResult<()> {
        let i = self.sun_index()?;
        // `position` (place and time) and `direction` are exclusive: drop the former.
        let mut doc: toml_edit::DocumentMut = self.text.parse().map_err(|e| {
            crate::errors::render_error(format!("the scene's own text does not parse: {e}"))
        })?;
        if let Some(t) = doc
            .get_mut("light")
            .and_then(|l| l.as_array_of_tables_mut())
            .and_then(|a| a.get_mut(i))
        {
            t.remove("position");
        }
        let saved = std::mem::replace(&mut self.text, doc.to_string());
        let r = self.edit(&[(format!("light[{i}].direction"), value.clone())]);
        if r.is_err() {
            self.text = saved;
        }
        r
    }

    /// Sets keys of the `[camera]` table (`position`, `look_at`, `up`, `fov`,
    /// `aperture_radius`, `focus_distance`), checked as in a file.
    #[pyo3(signature = (**kwargs))]
    fn set_camera(&mut self, kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<()> {
        let e = pairs("camera.", kwargs)?;
        self.edit(&e)
    }

    /// Sets keys of the `[film]` table (`width`, `height`, `spp`, `exposure`, `tonemap`,
    /// `filter`, `bands`, ...), checked as in a file.
    #[pyo3(signature = (**kwargs))]
    fn set_film(&mut self, kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<()> {
        let e = pairs("film.", kwargs)?;
        self.edit(&e)
    }

    /// Sets keys of the `index`-th `[[light]]` table (`irradiance`, `direction`,
    /// `position`, `radiance`, ...), checked as in a file.
    #[pyo3(signature = (index, /, **kwargs))]
    fn set_light(&mut self, index: usize, kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<()> {
        if index >= self.scene.lights.len() {
            return Err(PyIndexError::new_err(format!(
                "light {index}: the scene has {} light(s)",
                self.scene.lights.len()
            )));
        }
        let e = pairs(&format!("light[{index}]."), kwargs)?;
        self.edit(&e)
    }

    /// Sets keys of the `[[material]]` table named `material` (`reflectance`, `roughness`,
    /// `species`, `pigments`, ...), checked as in a file; only that material is rebuilt.
    #[pyo3(signature = (material, /, **kwargs))]
    fn set_material(&mut self, material: &str, kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<()> {
        let i = self.material_table(material)?;
        let e = pairs(&format!("material[{i}]."), kwargs)?;
        self.edit(&e)
    }

    /// Sets one key by its dotted path, as `lamina render --set KEY=VALUE` does
    /// (`"film.spp"`, `"light[0].irradiance"`, `"material[1].roughness"`). Object keys
    /// are refused (they change the geometry: load the scene again with `overrides`).
    fn set(&mut self, key: String, value: &Bound<'_, PyAny>) -> PyResult<()> {
        self.edit(&[(key, value.clone())])
    }

    /// Sets several keys at once (`{"camera.fov": 30, "film.spp": 16}`), all or none.
    fn update(&mut self, edits: &Bound<'_, PyDict>) -> PyResult<()> {
        let e = pairs("", Some(edits))?;
        self.edit(&e)
    }

    /// An independent copy (edits of one do not change the other; the geometry is shared
    /// until one of them is edited).
    fn copy(&self) -> Scene {
        self.clone()
    }

    /// Counts: `triangles` (world meshes and prototypes, each prototype once),
    /// `prototypes`, `instances`, `lights`, `materials`.
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let s = &self.scene;
        let tris: usize = s.meshes.iter().map(|m| m.indices.len()).sum::<usize>()
            + s.prototypes
                .iter()
                .flat_map(|p| &p.meshes)
                .map(|m| m.indices.len())
                .sum::<usize>();
        let d = PyDict::new(py);
        d.set_item("triangles", tris)?;
        d.set_item("prototypes", s.prototypes.len())?;
        d.set_item("instances", s.instances.len())?;
        d.set_item("lights", s.lights.len())?;
        d.set_item("materials", s.materials.len())?;
        Ok(d)
    }

    fn __repr__(&self) -> String {
        let f = &self.scene.film;
        let what = match self.dict_file() {
            Some(_) => "from a dict".to_string(),
            None => format!("'{}'", self.path.display()),
        };
        format!(
            "<lamina.Scene {what}: {}x{}, {} spp, {} light(s), {} material(s), {}>",
            f.width,
            f.height,
            f.spp,
            self.scene.lights.len(),
            self.scene.materials.len(),
            match &self.spectral {
                Some(s) => format!("{} bands", s.bands.len()),
                None => "RGB".into(),
            }
        )
    }
}

/// Loads a scene file (TOML; see docs/scene-format.md) and everything it refers to.
/// `overrides` sets keys first, as `lamina render --set` does: `{"film.spp": 64}`.
/// Raises `lamina.SceneError` (with `.file`, `.line`, `.key`) on bad input.
#[pyfunction]
#[pyo3(signature = (path, overrides=None))]
pub fn load_scene(path: PathBuf, overrides: Option<&Bound<'_, PyDict>>) -> PyResult<Scene> {
    let edits = pairs("", overrides)?;
    guarded(crate::errors::render_error, || {
        Scene::load_file(&path, &edits)
    })
}
