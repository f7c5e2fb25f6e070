//! Scene files (TOML) to [`Scene`]: the [`Loader`] that every table reader shares (the
//! scene file, its lines and folder, the scene-wide budgets) and the order in which the
//! tables are read. Each table type is read by its own module (`camera`, `film`, `light`,
//! `material`, `object`, ...) from a [`crate::dict::Dict`]; paths are relative to the scene
//! file.

use crate::dict::{S, Table};
use crate::error::{LineIndex, SceneError, guarded, read_text};
use crate::limits::Budgets;
use crate::scene::*;
use crate::transform::Transform;
use glam::Vec3;
use lamina_leaf::{Encoding, Texture};
use serde::Deserialize;
use std::cell::Cell;
use std::collections::HashMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

/// Loads a scene file (at most [`crate::limits::MAX_SCENE_FILE_BYTES`]) and everything it
/// refers to. Every limit of [`crate::limits`] is checked before the allocation it bounds;
/// a panic inside a dependency is an error naming the file being loaded.
pub fn load_scene(path: &Path) -> Result<Scene, SceneError> {
    load_scene_with_output(path).map(|(s, _)| s)
}

/// [`load_scene`], and the film's spectral output (`[film] bands`), if it asks for one.
pub fn load_scene_with_output(path: &Path) -> Result<(Scene, Option<SpectralOutput>), SceneError> {
    guarded(path, || {
        let text = read_text(path, "scene file", crate::limits::MAX_SCENE_FILE_BYTES)?;
        parse_with_output(&text, path, Budgets::default())
    })
}

/// What `[film] bands` asks for: render these bands (three at a time) instead of RGB.
#[derive(Clone, Debug, PartialEq)]
pub struct SpectralOutput {
    /// The bands, in file order (the EXR's channel order).
    pub bands: Vec<lamina_leaf::spectrum::bands::Band>,
    /// Indices into `bands` of the PNG's red, green and blue.
    pub false_color: [usize; 3],
}

/// Parses scene-file text; `path` names the file in errors and anchors relative paths.
/// The entry point for fuzzing (files it refers to are read relative to `path`).
pub fn parse_scene(text: &str, path: &Path) -> Result<Scene, SceneError> {
    guarded(path, || parse_with(text, path, Budgets::default()))
}

/// [`parse_scene`], and the film's spectral output (`[film] bands`), if it asks for one.
pub fn parse_scene_with_output(
    text: &str,
    path: &Path,
) -> Result<(Scene, Option<SpectralOutput>), SceneError> {
    guarded(path, || parse_with_output(text, path, Budgets::default()))
}

/// Re-reads the settings of an edited scene text into `scene`, which was loaded from the
/// text `old` of the same file `path`: the camera, film, integrator, sky and lights, and each
/// `[[material]]` table whose content changed. The geometry (`[[object]]` tables, and the
/// meshes, prototypes and instances built from them) is kept as it is, so an edit of the
/// view, the light or a material costs only what it changes (the Python package's scene
/// edits). The new text goes through the same checks and readers as a file load; on error
/// `scene` and `spectral` are left as they were.
///
/// Refused, naming the key: a change to an `[[object]]` table (reload the scene instead),
/// a different number of `[[material]]` tables, or a renamed material (objects were bound
/// to materials by name when the geometry was built).
pub fn reload_settings(
    scene: &mut Scene,
    spectral: &mut Option<SpectralOutput>,
    old: &str,
    new: &str,
    path: &Path,
) -> Result<(), SceneError> {
    guarded(path, || {
        let ld = Loader {
            file: path.to_owned(),
            lines: LineIndex::new(new),
            base: path.parent().map(Path::to_owned).unwrap_or_default(),
            budgets: Budgets::default(),
            instances: Cell::new(0),
            leaves: Cell::new(0),
            leaf_texels: Cell::new(0),
            spectral: std::cell::RefCell::new(None),
        };
        let doc: SceneFile = toml::from_str(new).map_err(|e| toml_error(path, new, &e))?;
        let plain = |text: &str| -> Result<toml::Table, SceneError> {
            toml::from_str(text).map_err(|e| toml_error(path, text, &e))
        };
        let (was, now) = (plain(old)?, plain(new)?);
        let whole = |key: &str, msg: String| SceneError::new(path, None, key, msg);
        if was.get("object") != now.get("object") {
            return Err(whole(
                "object",
                "the [[object]] tables changed: they hold the geometry, which an edit keeps; \
                 load the scene again to change them"
                    .into(),
            ));
        }
        let tables = |t: &toml::Table| match t.get("material") {
            Some(toml::Value::Array(a)) => a.clone(),
            _ => Vec::new(),
        };
        let (mats_was, mats_now) = (tables(&was), tables(&now));
        if mats_was.len() != mats_now.len() {
            return Err(whole(
                "material",
                format!(
                    "the scene had {} [[material]] tables and now has {}: materials can be \
                     edited, not added or removed, without loading the scene again",
                    mats_was.len(),
                    mats_now.len()
                ),
            ));
        }
        ld.check_types(&doc)?;
        let camera = crate::table::camera::read(&ld, &doc.camera)?;
        let film = crate::table::film::read(&ld, doc.film.as_ref())?;
        let integrator = crate::table::integrator::read(&ld, doc.integrator.as_ref())?;
        let (sky, lights) = ld.sky_and_lights(&doc)?;
        let mut changed = Vec::new();
        for (i, m) in doc.material.iter().enumerate() {
            if mats_was[i] == mats_now[i] {
                continue;
            }
            let name = crate::material::name(&ld, i, m)?;
            if scene.materials.get(i).map(|m| m.name()) != Some(*name.get_ref()) {
                return Err(ld.err(
                    name.span(),
                    format!("material[{i}].name"),
                    "a material cannot be renamed: objects were bound to it by name when the \
                     scene was loaded",
                ));
            }
            changed.push((i, crate::material::read(&ld, i, m)?));
        }
        let by_name: HashMap<String, u32> = scene
            .materials
            .iter()
            .enumerate()
            .map(|(i, m)| (m.name().to_string(), i as u32))
            .collect();
        let radiometry = ld.radiometry(&doc, scene, &lights, &by_name)?;
        scene.camera = camera;
        scene.film = film;
        scene.integrator = integrator;
        scene.sky = sky;
        scene.lights = lights;
        for (i, m) in changed {
            scene.materials[i] = m;
        }
        scene.radiometry = radiometry;
        *spectral = ld.spectral.into_inner();
        Ok(())
    })
}

/// The tables of a scene file, each kept whole (keys and values spanned) for its reader.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    camera: S<Table>,
    film: Option<S<Table>>,
    integrator: Option<S<Table>>,
    sky: Option<S<Table>>,
    #[serde(default)]
    light: Vec<S<Table>>,
    #[serde(default)]
    material: Vec<S<Table>>,
    #[serde(default)]
    object: Vec<S<Table>>,
    domain: Option<S<Table>>,
    #[serde(default)]
    sensor: Vec<S<Table>>,
}

/// [`parse_scene`] with the scene-wide budgets `budgets` (tests use small ones).
pub(crate) fn parse_with(text: &str, path: &Path, budgets: Budgets) -> Result<Scene, SceneError> {
    parse_with_output(text, path, budgets).map(|(s, _)| s)
}

pub(crate) fn parse_with_output(
    text: &str,
    path: &Path,
    budgets: Budgets,
) -> Result<(Scene, Option<SpectralOutput>), SceneError> {
    crate::error::fault_point("scene");
    let ld = Loader {
        file: path.to_owned(),
        lines: LineIndex::new(text),
        base: path.parent().map(Path::to_owned).unwrap_or_default(),
        budgets,
        instances: Cell::new(0),
        leaves: Cell::new(0),
        leaf_texels: Cell::new(0),
        spectral: std::cell::RefCell::new(None),
    };
    let doc: SceneFile = toml::from_str(text).map_err(|e| toml_error(path, text, &e))?;
    let scene = ld.build(doc)?;
    Ok((scene, ld.spectral.into_inner()))
}

/// Converts a TOML error into ours, with the line of its span.
pub(crate) fn toml_error(file: &Path, text: &str, e: &toml::de::Error) -> SceneError {
    let line = e.span().map(|s| LineIndex::new(text).line(s.start));
    let key = line.map(|l| key_at_line(text, l)).unwrap_or_default();
    SceneError::new(file, line, key, e.message().trim().to_string())
}

/// The dotted key assigned on 1-based `line` (`film.width`, `light[1].direction`), from
/// the nearest table header above it, for syntax and type errors that toml reports by
/// position only. Empty when the line assigns nothing.
fn key_at_line(text: &str, line: usize) -> String {
    let lines: Vec<&str> = text.lines().collect();
    let Some(this) = lines.get(line.wrapping_sub(1)) else {
        return String::new();
    };
    let Some((lhs, _)) = this.split_once('=') else {
        return String::new();
    };
    let name = lhs.trim();
    let plain = |c: char| c.is_ascii_alphanumeric() || "_-.".contains(c);
    if name.is_empty() || !name.chars().all(plain) {
        return String::new();
    }
    // Nearest header above, and how many times an array-of-tables header occurred.
    for (i, l) in lines[..line - 1].iter().enumerate().rev() {
        let l = l.trim();
        if let Some(h) = l
            .strip_prefix("[[")
            .and_then(|r| r.split_once("]]"))
            .map(|(h, _)| h.trim())
        {
            let index = lines[..=i]
                .iter()
                .filter(|x| {
                    x.trim()
                        .strip_prefix("[[")
                        .is_some_and(|r| r.trim_start().starts_with(h))
                })
                .count()
                - 1;
            return format!("{h}[{index}].{name}");
        }
        if let Some(h) = l
            .strip_prefix('[')
            .and_then(|r| r.split_once(']'))
            .map(|(h, _)| h.trim())
        {
            return format!("{h}.{name}");
        }
    }
    name.to_string()
}

/// What every table reader shares while one scene file is loaded: where errors point, the
/// folder relative paths start from, and the scene-wide budgets spent so far.
pub(crate) struct Loader {
    /// The scene file.
    pub(crate) file: PathBuf,
    lines: LineIndex,
    /// The scene file's folder: relative paths start here.
    pub(crate) base: PathBuf,
    /// The scene-wide limits.
    pub(crate) budgets: Budgets,
    /// Instances of the objects built so far.
    pub(crate) instances: Cell<usize>,
    /// Leaves (cards, plant leaves) generated so far.
    leaves: Cell<u64>,
    /// Texels of procedural leaf maps generated so far.
    leaf_texels: Cell<u64>,
    /// `[film] bands`, when the film asks for them.
    pub(crate) spectral: std::cell::RefCell<Option<SpectralOutput>>,
}

impl Loader {
    /// An error in the scene file at `span`, about `key`.
    pub(crate) fn err(
        &self,
        span: Range<usize>,
        key: impl Into<String>,
        msg: impl Into<String>,
    ) -> SceneError {
        SceneError::new(&self.file, Some(self.lines.line(span.start)), key, msg)
    }

    /// A path from the scene file, relative to its folder.
    pub(crate) fn path(&self, p: &str) -> PathBuf {
        self.base.join(p)
    }

    /// Loads the image at `p` (relative to the scene file) as a texture; errors name `key`.
    pub(crate) fn texture(
        &self,
        p: &S<&str>,
        key: &str,
        enc: Encoding,
    ) -> Result<Texture, SceneError> {
        let path = self.path(p.get_ref());
        Texture::load(&path, enc).map_err(|e| self.err(p.span(), key, e.to_string()))
    }

    /// Leaves the scene may still generate ([`crate::limits::MAX_SCENE_LEAVES`] in all).
    pub(crate) fn leaves_left(&self) -> u64 {
        self.budgets.leaves.saturating_sub(self.leaves.get())
    }

    /// Counts `n` more leaves for `key` (at `span`), or says that the scene would have more
    /// than [`crate::limits::MAX_SCENE_LEAVES`].
    pub(crate) fn spend_leaves(
        &self,
        span: Range<usize>,
        key: &str,
        n: u64,
    ) -> Result<(), SceneError> {
        let total = self.leaves.get().saturating_add(n);
        if total > self.budgets.leaves {
            return Err(self.err(
                span,
                key,
                format!(
                    "{n} leaves here make {total} leaves (leaf cards and plant leaves) in the scene, more than the {} supported in all",
                    self.budgets.leaves
                ),
            ));
        }
        self.leaves.set(total);
        Ok(())
    }

    /// Counts `n` more texels of procedural leaf maps for `key`, or says that the scene
    /// would have more than [`crate::limits::MAX_SCENE_LEAF_TEXELS`].
    pub(crate) fn spend_leaf_texels(
        &self,
        span: Range<usize>,
        key: &str,
        n: u64,
    ) -> Result<(), SceneError> {
        let total = self.leaf_texels.get().saturating_add(n);
        if total > self.budgets.leaf_texels {
            return Err(self.err(
                span,
                key,
                format!(
                    "{n} texels of procedural leaf maps here make {total} in the scene, more than the {} supported in all (lower the resolution or the number of leaf variants)",
                    self.budgets.leaf_texels
                ),
            ));
        }
        self.leaf_texels.set(total);
        Ok(())
    }

    /// Checks that `n` more instances for `key` keep the scene within
    /// [`crate::limits::MAX_INSTANCES`] in all (does not count them).
    pub(crate) fn check_instances(
        &self,
        span: Range<usize>,
        key: &str,
        n: usize,
    ) -> Result<(), SceneError> {
        let before = self.instances.get();
        let total = before.saturating_add(n);
        if total > self.budgets.instances {
            return Err(self.err(
                span,
                key,
                format!(
                    "{n} instances here and {before} in the objects before make {total} instances, more than the {} supported in all",
                    self.budgets.instances
                ),
            ));
        }
        Ok(())
    }

    /// A transform from parts, validated (see [`crate::instances::checked_transform`]);
    /// errors at `span`, key `key.scale` / `key.translate` / `key.rotate`.
    pub(crate) fn transform_parts(
        &self,
        scale: Vec3,
        rot: Vec3,
        tr: Vec3,
        span: Range<usize>,
        key: &str,
    ) -> Result<Transform, SceneError> {
        crate::instances::checked_transform(scale, rot, tr)
            .map_err(|(k, m)| self.err(span, format!("{key}.{k}"), m))
    }

    /// Checks every key of the file and its TOML type before any table is read, so that a
    /// misspelt or mistyped key is reported first, wherever it is.
    fn check_types(&self, doc: &SceneFile) -> Result<(), SceneError> {
        crate::table::camera::check(self, &doc.camera)?;
        if let Some(f) = &doc.film {
            crate::table::film::check(self, f)?;
        }
        if let Some(s) = &doc.sky {
            crate::table::sky::check(self, s)?;
        }
        for (i, l) in doc.light.iter().enumerate() {
            crate::light::check(self, i, l)?;
        }
        for (i, m) in doc.material.iter().enumerate() {
            crate::material::check(self, i, m)?;
        }
        for (i, o) in doc.object.iter().enumerate() {
            crate::object::check(self, i, o)?;
        }
        if let Some(d) = &doc.domain {
            crate::table::domain::check(self, d)?;
        }
        for (i, s) in doc.sensor.iter().enumerate() {
            crate::sensor::check(self, i, s)?;
        }
        Ok(())
    }

    /// Reads `[domain]` and the `[[sensor]]` tables into a copy of `scene.radiometry` (its
    /// `objects` filled in), and checks them against the scene's geometry and `lights`: only
    /// the sun and sky light a periodic domain, and every object fits the periodic cell.
    fn radiometry(
        &self,
        doc: &SceneFile,
        scene: &Scene,
        lights: &[Light],
        materials: &HashMap<String, u32>,
    ) -> Result<lamina_core::Radiometry, SceneError> {
        let mut out = lamina_core::Radiometry {
            objects: scene.radiometry.objects.clone(),
            ..Default::default()
        };
        let periodic = crate::table::domain::read(self, doc.domain.as_ref())?;
        if let (Some(p), Some(dt)) = (&periodic, &doc.domain) {
            for (i, l) in lights.iter().enumerate() {
                if !matches!(l, Light::Sun { .. }) {
                    let span = doc.light.get(i).map_or(dt.span(), |t| t.span());
                    return Err(self.err(
                        span,
                        format!("light[{i}].type"),
                        "only the sun and the sky can light a periodic domain (a lamp would repeat in every cell)",
                    ));
                }
            }
            out.periodic = Some(*p);
            if scene.meshes.is_empty() && scene.instances.is_empty() {
                return Err(self.err(
                    dt.span(),
                    "domain.periodic",
                    "the periodic domain holds no geometry: its height range is empty",
                ));
            }
            if let Err(e) = lamina_core::radiometry::periodic_copies(scene, &p.cell) {
                let objects = &out.objects;
                let at = objects.iter().position(|o| {
                    e.mesh.is_some_and(|m| o.meshes.contains(&m))
                        || e.instance.is_some_and(|i| o.instances.contains(&i))
                });
                return Err(match at {
                    Some(k) => self.err(
                        // The object's `name` (or `type`) line: a table's own span may start
                        // at its header or before it.
                        doc.object[k]
                            .get_ref()
                            .iter()
                            .find(|(key, _)| key.get_ref() == "name")
                            .or_else(|| {
                                doc.object[k]
                                    .get_ref()
                                    .iter()
                                    .find(|(key, _)| key.get_ref() == "type")
                            })
                            .map_or(doc.object[k].span(), |(key, _)| key.span()),
                        format!("object[{k}]"),
                        format!(
                            "'{}' does not fit the periodic cell (domain.periodic): {}",
                            objects[k].name, e.message
                        ),
                    ),
                    None => self.err(dt.span(), "domain.periodic", e.message),
                });
            }
        }
        let channels: Vec<String> = match &*self.spectral.borrow() {
            Some(s) => s.bands.iter().map(|b| b.name.clone()).collect(),
            None => ["R", "G", "B"].map(String::from).to_vec(),
        };
        let cx = crate::sensor::Context {
            cell: periodic.map(|p| p.cell),
            materials,
        };
        out.sensors = doc
            .sensor
            .iter()
            .enumerate()
            .map(|(i, t)| crate::sensor::read(self, i, t, &cx, &channels))
            .collect::<Result<_, _>>()?;
        let distant_only = out
            .sensors
            .iter()
            .any(|s| matches!(s.kind, lamina_core::radiometry::SensorKind::Absorbed { .. }));
        if distant_only {
            for (i, l) in lights.iter().enumerate() {
                if !matches!(l, Light::Sun { .. }) {
                    let span = doc.light.get(i).map_or(doc.camera.span(), |t| t.span());
                    return Err(self.err(
                        span,
                        format!("light[{i}].type"),
                        "an absorbed sensor counts the light of the sun and the sky only: this light would be left out",
                    ));
                }
            }
        }
        Ok(out)
    }

    /// Reads `[sky]` and the `[[light]]` tables; a physical sky's sun is added as the last
    /// light (band renders find it there).
    fn sky_and_lights(&self, doc: &SceneFile) -> Result<(Option<Sky>, Vec<Light>), SceneError> {
        let (sky, sky_sun) = match doc.sky.as_ref() {
            Some(s) => {
                let (sky, sun) = crate::table::sky::read(self, s)?;
                (Some(sky), sun)
            }
            None => (None, None),
        };
        let mut lights = doc
            .light
            .iter()
            .enumerate()
            .map(|(i, l)| crate::light::read(self, i, l))
            .collect::<Result<Vec<_>, _>>()?;
        lights.extend(sky_sun);
        Ok((sky, lights))
    }

    /// Reads the tables in order: camera, film, integrator, sky, lights, materials (names
    /// unique), objects (which may add the materials of the files they import).
    fn build(&self, doc: SceneFile) -> Result<Scene, SceneError> {
        self.check_types(&doc)?;
        let camera = crate::table::camera::read(self, &doc.camera)?;
        let film = crate::table::film::read(self, doc.film.as_ref())?;
        let integrator = crate::table::integrator::read(self, doc.integrator.as_ref())?;
        let (sky, lights) = self.sky_and_lights(&doc)?;
        let mut materials = Vec::new();
        let mut by_name = HashMap::new();
        for (i, m) in doc.material.iter().enumerate() {
            let name = crate::material::name(self, i, m)?;
            if by_name
                .insert(name.get_ref().to_string(), materials.len() as u32)
                .is_some()
            {
                return Err(self.err(
                    name.span(),
                    format!("material[{i}].name"),
                    format!("'{}' is defined twice", name.get_ref()),
                ));
            }
            materials.push(crate::material::read(self, i, m)?);
        }
        let mut meshes = Vec::new();
        let mut prototypes = Vec::new();
        let mut instances = Vec::new();
        let mut objects = Vec::new();
        for (i, o) in doc.object.iter().enumerate() {
            let g = crate::object::read(self, i, o, &by_name, &mut materials)?;
            let name = o
                .get_ref()
                .iter()
                .find(|(k, _)| k.get_ref() == "name")
                .and_then(|(_, v)| match v.get_ref() {
                    crate::dict::Value::String(s) => Some(s.clone()),
                    _ => None,
                })
                .unwrap_or_else(|| format!("object[{i}]"));
            let (m0, i0) = (meshes.len() as u32, instances.len() as u32);
            objects.push(lamina_core::radiometry::ObjectRecord {
                name,
                meshes: m0..m0 + g.meshes.len() as u32,
                instances: i0..i0 + g.instances.len() as u32,
            });
            // Instances the object brought without placements (glTF meshes used by several
            // nodes, curved leaves); placed objects were checked before their allocation.
            self.check_instances(o.span(), &format!("object[{i}]"), g.instances.len())?;
            self.instances.set(self.instances.get() + g.instances.len());
            let first = prototypes.len() as u32;
            meshes.extend(g.meshes);
            prototypes.extend(g.prototypes);
            instances.extend(g.instances.into_iter().map(|mut inst| {
                inst.prototype += first;
                inst
            }));
        }
        let mut scene = Scene {
            radiometry: lamina_core::Radiometry {
                objects,
                ..Default::default()
            },
            camera,
            film,
            integrator,
            lights,
            sky,
            materials,
            meshes,
            prototypes,
            instances,
        };
        scene.radiometry = self.radiometry(&doc, &scene, &scene.lights, &by_name)?;
        Ok(scene)
    }
}
