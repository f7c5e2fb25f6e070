//! Scene files (TOML) to [`Scene`]: parsing, validation with file/line/key errors, and
//! loading of everything the file refers to (maps, meshes, leaf-card files), with paths
//! relative to the scene file.

use crate::cards::{LeafCard, append_cards};
use crate::error::{LineIndex, SceneError, guarded, read_text};
use crate::file::*;
use crate::limits::Budgets;
use crate::scene::*;
use crate::transform::Transform;
use glam::Vec3;
use lamina_leaf::{Encoding, Texture};
use std::cell::Cell;
use std::collections::HashMap;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Loads a scene file (at most [`crate::limits::MAX_SCENE_FILE_BYTES`]) and everything it
/// refers to. Every limit of [`crate::limits`] is checked before the allocation it bounds;
/// a panic inside a dependency is an error naming the file being loaded.
pub fn load_scene(path: &Path) -> Result<Scene, SceneError> {
    guarded(path, || {
        let text = read_text(path, "scene file", crate::limits::MAX_SCENE_FILE_BYTES)?;
        parse_with(&text, path, Budgets::default())
    })
}

/// Parses scene-file text; `path` names the file in errors and anchors relative paths.
/// The entry point for fuzzing (files it refers to are read relative to `path`).
pub fn parse_scene(text: &str, path: &Path) -> Result<Scene, SceneError> {
    guarded(path, || parse_with(text, path, Budgets::default()))
}

/// [`parse_scene`] with the scene-wide budgets `budgets` (tests use small ones).
pub(crate) fn parse_with(text: &str, path: &Path, budgets: Budgets) -> Result<Scene, SceneError> {
    crate::error::fault_point("scene");
    let cx = Ctx {
        file: path.to_owned(),
        lines: LineIndex::new(text),
        base: path.parent().map(Path::to_owned).unwrap_or_default(),
        budgets,
        instances: Cell::new(0),
        leaves: Cell::new(0),
        leaf_texels: Cell::new(0),
    };
    let doc: SceneFile = toml::from_str(text).map_err(|e| toml_error(path, text, &e))?;
    cx.build(doc)
}

/// Converts a TOML error into ours, with the line of its span.
pub fn toml_error(file: &Path, text: &str, e: &toml::de::Error) -> SceneError {
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

/// Resolves a material name (with its span) to an index; the key names it in errors.
type MaterialLookup<'a> = dyn Fn(&S<String>, &str) -> Result<u32, SceneError> + 'a;

pub(crate) struct Ctx {
    pub(crate) file: PathBuf,
    lines: LineIndex,
    pub(crate) base: PathBuf,
    /// The scene-wide limits.
    budgets: Budgets,
    /// Instances of the objects built so far.
    instances: Cell<usize>,
    /// Leaves (cards, plant leaves) generated so far.
    leaves: Cell<u64>,
    /// Texels of procedural leaf maps generated so far.
    leaf_texels: Cell<u64>,
}

fn v3(a: [f32; 3]) -> Vec3 {
    Vec3::from(a)
}

impl Ctx {
    pub(crate) fn err(
        &self,
        span: Range<usize>,
        key: impl Into<String>,
        msg: impl Into<String>,
    ) -> SceneError {
        SceneError::new(&self.file, Some(self.lines.line(span.start)), key, msg)
    }

    pub(crate) fn path(&self, p: &S<String>) -> PathBuf {
        self.base.join(p.get_ref())
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
    fn check_instances(&self, span: Range<usize>, key: &str, n: usize) -> Result<(), SceneError> {
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

    fn vec3(&self, v: &S<[f32; 3]>, key: &str) -> Result<Vec3, SceneError> {
        let a = *v.get_ref();
        if a.iter().any(|c| !c.is_finite()) {
            return Err(self.err(
                v.span(),
                key,
                format!("must be three finite numbers, got {a:?}"),
            ));
        }
        Ok(v3(a))
    }

    fn direction(&self, v: &S<[f32; 3]>, key: &str) -> Result<Vec3, SceneError> {
        let d = self.vec3(v, key)?;
        if d.length_squared() < 1e-12 {
            return Err(self.err(v.span(), key, "must be a non-zero direction"));
        }
        Ok(d.normalize())
    }

    fn color(&self, v: &S<ColorValue>, key: &str, max: Option<f32>) -> Result<Vec3, SceneError> {
        let c = v.get_ref().0;
        if !c.is_finite() || c.min_element() < 0.0 {
            return Err(self.err(
                v.span(),
                key,
                format!("must be finite and >= 0, got {:?}", c.to_array()),
            ));
        }
        if let Some(m) = max
            && c.max_element() > m
        {
            return Err(self.err(
                v.span(),
                key,
                format!("must be in [0, {m}], got {:?}", c.to_array()),
            ));
        }
        Ok(c)
    }

    fn float(
        &self,
        v: &S<f32>,
        key: &str,
        min: f32,
        max: f32,
        open_min: bool,
    ) -> Result<f32, SceneError> {
        let x = *v.get_ref();
        let ok = x.is_finite() && x <= max && if open_min { x > min } else { x >= min };
        if !ok {
            let lo = if open_min { "(" } else { "[" };
            return Err(self.err(
                v.span(),
                key,
                format!("must be in {lo}{min}, {max}], got {x}"),
            ));
        }
        Ok(x)
    }

    pub(crate) fn count(
        &self,
        v: &S<i64>,
        key: &str,
        min: i64,
        max: i64,
    ) -> Result<u32, SceneError> {
        let x = *v.get_ref();
        if x < min || x > max {
            return Err(self.err(
                v.span(),
                key,
                format!("must be an integer in [{min}, {max}], got {x}"),
            ));
        }
        Ok(x as u32)
    }

    /// [`Self::float`] for an optional key, `default` when absent.
    pub(crate) fn opt_float(
        &self,
        v: &Option<S<f32>>,
        key: &str,
        min: f32,
        max: f32,
        open_min: bool,
        default: f32,
    ) -> Result<f32, SceneError> {
        v.as_ref()
            .map_or(Ok(default), |v| self.float(v, key, min, max, open_min))
    }

    /// [`Self::count`] for an optional key, `default` when absent.
    pub(crate) fn opt_count(
        &self,
        v: &Option<S<i64>>,
        key: &str,
        min: i64,
        max: i64,
        default: u32,
    ) -> Result<u32, SceneError> {
        v.as_ref()
            .map_or(Ok(default), |v| self.count(v, key, min, max))
    }

    /// A required vector key: present (else an error naming it) and finite.
    fn req_vec3(
        &self,
        v: &Option<S<[f32; 3]>>,
        table: Range<usize>,
        key: &str,
        kind: &str,
    ) -> Result<Vec3, SceneError> {
        self.vec3(self.require(v, table, key, kind)?, key)
    }

    /// A required direction key: present, finite and non-zero; normalised.
    fn req_direction(
        &self,
        v: &Option<S<[f32; 3]>>,
        table: Range<usize>,
        key: &str,
        kind: &str,
    ) -> Result<Vec3, SceneError> {
        self.direction(self.require(v, table, key, kind)?, key)
    }

    /// A required colour key: present, finite and non-negative.
    fn req_color(
        &self,
        v: &Option<S<ColorValue>>,
        table: Range<usize>,
        key: &str,
        kind: &str,
    ) -> Result<Vec3, SceneError> {
        self.color(self.require(v, table, key, kind)?, key, None)
    }

    /// The required `corner`, `edge_u`, `edge_v` of a parallelogram under `prefix`, with
    /// edges that span a non-zero area.
    fn parallelogram(
        &self,
        corner: &Option<S<[f32; 3]>>,
        edge_u: &Option<S<[f32; 3]>>,
        edge_v: &Option<S<[f32; 3]>>,
        table: Range<usize>,
        prefix: &str,
        kind: &str,
    ) -> Result<(Vec3, Vec3, Vec3), SceneError> {
        let key = |n: &str| format!("{prefix}.{n}");
        let c = self.req_vec3(corner, table.clone(), &key("corner"), kind)?;
        let eu = self.require(edge_u, table.clone(), &key("edge_u"), kind)?;
        let u = self.vec3(eu, &key("edge_u"))?;
        let v = self.req_vec3(edge_v, table, &key("edge_v"), kind)?;
        if u.cross(v).length_squared() < 1e-16 {
            return Err(self.err(
                eu.span(),
                key("edge_u"),
                "edge_u and edge_v must span a non-zero area",
            ));
        }
        Ok((c, u, v))
    }

    /// Rejects keys set on a table whose type does not use them.
    fn only(
        &self,
        table: Range<usize>,
        what: &str,
        kind: &str,
        keys: &[(&str, bool)],
        allowed: &[&str],
    ) -> Result<(), SceneError> {
        for (name, present) in keys {
            if *present && !allowed.contains(name) {
                return Err(self.err(
                    table.clone(),
                    format!("{what}.{name}"),
                    format!(
                        "is not a key of a {what} of type '{kind}' (it takes: type, {}{})",
                        allowed.join(", "),
                        if what.starts_with("object[") {
                            ", and on every object: name, material, transform (or scale, rotate_x, rotate_y, rotate_z, translate), instances, instances_file"
                        } else {
                            ""
                        }
                    ),
                ));
            }
        }
        Ok(())
    }

    fn require<'a, T>(
        &self,
        v: &'a Option<S<T>>,
        table: Range<usize>,
        key: &str,
        kind: &str,
    ) -> Result<&'a S<T>, SceneError> {
        v.as_ref()
            .ok_or_else(|| self.err(table, key, format!("is required for type '{kind}'")))
    }

    fn texture(&self, p: &S<String>, key: &str, enc: Encoding) -> Result<Texture, SceneError> {
        let path = self.path(p);
        Texture::load(&path, enc).map_err(|e| self.err(p.span(), key, e.to_string()))
    }

    fn build(&self, doc: SceneFile) -> Result<Scene, SceneError> {
        let camera = self.camera(&doc.camera)?;
        let film = self.film(doc.film.as_ref())?;
        let integrator = self.integrator(doc.integrator.as_ref())?;
        let sky = doc.sky.as_ref().map(|s| self.sky(s)).transpose()?;
        let lights = doc
            .light
            .iter()
            .enumerate()
            .map(|(i, l)| self.light(i, l))
            .collect::<Result<Vec<_>, _>>()?;
        let mut materials = Vec::new();
        let mut by_name = HashMap::new();
        for (i, m) in doc.material.iter().enumerate() {
            let name = m.get_ref().name.get_ref().clone();
            if by_name
                .insert(name.clone(), materials.len() as u32)
                .is_some()
            {
                return Err(self.err(
                    m.get_ref().name.span(),
                    format!("material[{i}].name"),
                    format!("'{name}' is defined twice"),
                ));
            }
            materials.push(self.material(i, m)?);
        }
        let mut meshes = Vec::new();
        let mut prototypes = Vec::new();
        let mut instances = Vec::new();
        for (i, o) in doc.object.iter().enumerate() {
            let g = self.object(i, o, &by_name, &mut materials)?;
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
        let scene = Scene {
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
        Ok(scene)
    }

    fn camera(&self, t: &S<CameraTable>) -> Result<Camera, SceneError> {
        let c = t.get_ref();
        let position = self.vec3(&c.position, "camera.position")?;
        let look_at = self.vec3(&c.look_at, "camera.look_at")?;
        let forward = look_at - position;
        if forward.length_squared() < 1e-12 {
            return Err(self.err(
                c.look_at.span(),
                "camera.look_at",
                "must differ from camera.position",
            ));
        }
        let up = match &c.up {
            Some(u) => self.direction(u, "camera.up")?,
            None => Vec3::Y,
        };
        if forward.normalize().cross(up).length_squared() < 1e-8 {
            let span = c.up.as_ref().map_or(t.span(), |u| u.span());
            return Err(self.err(
                span,
                "camera.up",
                "must not be parallel to the viewing direction (look_at - position)",
            ));
        }
        let fov_deg = self.opt_float(&c.fov, "camera.fov", 0.0, 179.0, true, 40.0)?;
        let aperture_radius = self.opt_float(
            &c.aperture_radius,
            "camera.aperture_radius",
            0.0,
            1e3,
            false,
            0.0,
        )?;
        let focus_distance = self.opt_float(
            &c.focus_distance,
            "camera.focus_distance",
            0.0,
            1e9,
            true,
            forward.length(),
        )?;
        Ok(Camera {
            position,
            look_at,
            up,
            fov_deg,
            aperture_radius,
            focus_distance,
        })
    }

    fn film(&self, t: Option<&S<FilmTable>>) -> Result<Film, SceneError> {
        let mut film = Film::new(640, 480, 64);
        let Some(t) = t else { return Ok(film) };
        let f = t.get_ref();
        if let Some(v) = &f.width {
            film.width = self.count(v, "film.width", 1, 16384)?;
        }
        if let Some(v) = &f.height {
            film.height = self.count(v, "film.height", 1, 16384)?;
        }
        if let Some(v) = &f.spp {
            film.spp = self.count(v, "film.spp", 1, 1 << 20)?;
        }
        let radius = f
            .filter_radius
            .as_ref()
            .map(|v| self.float(v, "film.filter_radius", 0.0, 8.0, true))
            .transpose()?;
        let sigma = f
            .filter_sigma
            .as_ref()
            .map(|v| self.float(v, "film.filter_sigma", 0.0, 8.0, true))
            .transpose()?;
        if let Some(v) = &f.filter {
            film.filter = match v.get_ref().as_str() {
                "box" => PixelFilter::Box,
                "tent" => PixelFilter::Tent {
                    radius: radius.unwrap_or(1.0),
                },
                "gaussian" => PixelFilter::Gaussian {
                    radius: radius.unwrap_or(1.5),
                    sigma: sigma.unwrap_or(0.5),
                },
                other => {
                    return Err(self.err(
                        v.span(),
                        "film.filter",
                        format!("unknown filter '{other}' (box, tent, gaussian)"),
                    ));
                }
            };
        } else if radius.is_some() || sigma.is_some() {
            film.filter = PixelFilter::Gaussian {
                radius: radius.unwrap_or(1.5),
                sigma: sigma.unwrap_or(0.5),
            };
        }
        if let Some(v) = &f.exposure {
            film.exposure = self.float(v, "film.exposure", -30.0, 30.0, false)?;
        }
        if let Some(v) = &f.tonemap {
            film.tonemap = match v.get_ref().as_str() {
                "clamp" => ToneMap::Clamp,
                "aces" => ToneMap::Aces,
                "reinhard" => ToneMap::Reinhard,
                other => {
                    return Err(self.err(
                        v.span(),
                        "film.tonemap",
                        format!("unknown tone map '{other}' (clamp, aces, reinhard)"),
                    ));
                }
            };
        }
        Ok(film)
    }

    fn integrator(&self, t: Option<&S<IntegratorTable>>) -> Result<Integrator, SceneError> {
        let Some(t) = t else {
            return Ok(Integrator::Path {
                max_depth: 8,
                rr_depth: 3,
            });
        };
        let i = t.get_ref();
        let kind = i.kind.as_ref().map_or("path", |k| k.get_ref().as_str());
        match kind {
            "path" => {
                self.only(
                    t.span(),
                    "integrator",
                    kind,
                    &[("ambient", i.ambient.is_some())],
                    &["max_depth", "rr_depth"],
                )?;
                let max_depth = self.opt_count(&i.max_depth, "integrator.max_depth", 1, 1024, 8)?;
                let rr_depth = self.opt_count(&i.rr_depth, "integrator.rr_depth", 1, 1024, 3)?;
                Ok(Integrator::Path {
                    max_depth,
                    rr_depth,
                })
            }
            "paper" => {
                self.only(
                    t.span(),
                    "integrator",
                    kind,
                    &[
                        ("max_depth", i.max_depth.is_some()),
                        ("rr_depth", i.rr_depth.is_some()),
                    ],
                    &["ambient"],
                )?;
                let ambient = i
                    .ambient
                    .as_ref()
                    .map(|v| self.color(v, "integrator.ambient", None))
                    .transpose()?;
                Ok(Integrator::Paper { ambient })
            }
            other => {
                let span = i.kind.as_ref().map_or(t.span(), |k| k.span());
                Err(self.err(
                    span,
                    "integrator.type",
                    format!("unknown integrator '{other}' (path, paper)"),
                ))
            }
        }
    }

    fn sky(&self, t: &S<SkyTable>) -> Result<Sky, SceneError> {
        let s = t.get_ref();
        let kind = s.kind.get_ref().as_str();
        let keys = [
            ("radiance", s.radiance.is_some()),
            ("file", s.file.is_some()),
            ("scale", s.scale.is_some()),
            ("rotation", s.rotation.is_some()),
        ];
        match kind {
            "constant" => {
                self.only(t.span(), "sky", kind, &keys, &["radiance"])?;
                let r = self.require(&s.radiance, t.span(), "sky.radiance", kind)?;
                Ok(Sky::Constant(self.color(r, "sky.radiance", None)?))
            }
            "image" => {
                self.only(t.span(), "sky", kind, &keys, &["file", "scale", "rotation"])?;
                let file = self.require(&s.file, t.span(), "sky.file", kind)?;
                let map = self.texture(file, "sky.file", Encoding::Srgb)?;
                if map
                    .texels()
                    .iter()
                    .any(|t| !t.is_finite() || t.min_element() < 0.0)
                {
                    return Err(self.err(
                        file.span(),
                        "sky.file",
                        "the image has negative or non-finite texels",
                    ));
                }
                let scale = self.opt_float(&s.scale, "sky.scale", 0.0, 1e9, false, 1.0)?;
                let rotation_deg =
                    self.opt_float(&s.rotation, "sky.rotation", -360.0, 360.0, false, 0.0)?;
                Ok(Sky::Image {
                    map,
                    scale,
                    rotation_deg,
                })
            }
            other => Err(self.err(
                s.kind.span(),
                "sky.type",
                format!("unknown sky type '{other}' (constant, image)"),
            )),
        }
    }

    fn light(&self, i: usize, t: &S<LightTable>) -> Result<Light, SceneError> {
        let l = t.get_ref();
        let kind = l.kind.get_ref().as_str();
        let p = format!("light[{i}]");
        let k = |n: &str| format!("{p}.{n}");
        let keys = [
            ("direction", l.direction.is_some()),
            ("irradiance", l.irradiance.is_some()),
            ("angular_diameter", l.angular_diameter.is_some()),
            ("position", l.position.is_some()),
            ("intensity", l.intensity.is_some()),
            ("corner", l.corner.is_some()),
            ("edge_u", l.edge_u.is_some()),
            ("edge_v", l.edge_v.is_some()),
            ("radiance", l.radiance.is_some()),
            ("two_sided", l.two_sided.is_some()),
            ("center", l.center.is_some()),
            ("radius", l.radius.is_some()),
        ];
        let span = t.span();
        match kind {
            "sun" => {
                self.only(
                    span.clone(),
                    &p,
                    kind,
                    &keys,
                    &["direction", "irradiance", "angular_diameter"],
                )?;
                let direction =
                    self.req_direction(&l.direction, span.clone(), &k("direction"), kind)?;
                let irradiance =
                    self.req_color(&l.irradiance, span.clone(), &k("irradiance"), kind)?;
                let angular_diameter_deg = self.opt_float(
                    &l.angular_diameter,
                    &k("angular_diameter"),
                    0.0,
                    90.0,
                    false,
                    0.53,
                )?;
                Ok(Light::Sun {
                    direction,
                    irradiance,
                    angular_diameter_deg,
                })
            }
            "point" => {
                self.only(span.clone(), &p, kind, &keys, &["position", "intensity"])?;
                let position = self.req_vec3(&l.position, span.clone(), &k("position"), kind)?;
                let intensity =
                    self.req_color(&l.intensity, span.clone(), &k("intensity"), kind)?;
                Ok(Light::Point {
                    position,
                    intensity,
                })
            }
            "quad" => {
                self.only(
                    span.clone(),
                    &p,
                    kind,
                    &keys,
                    &["corner", "edge_u", "edge_v", "radiance", "two_sided"],
                )?;
                let (corner, edge_u, edge_v) =
                    self.parallelogram(&l.corner, &l.edge_u, &l.edge_v, span.clone(), &p, kind)?;
                let radiance = self.req_color(&l.radiance, span.clone(), &k("radiance"), kind)?;
                let two_sided = l.two_sided.as_ref().is_some_and(|v| *v.get_ref());
                Ok(Light::Quad {
                    corner,
                    edge_u,
                    edge_v,
                    radiance,
                    two_sided,
                })
            }
            "sphere" => {
                self.only(
                    span.clone(),
                    &p,
                    kind,
                    &keys,
                    &["center", "radius", "radiance"],
                )?;
                let center = self.req_vec3(&l.center, span.clone(), &k("center"), kind)?;
                let radius = self.float(
                    self.require(&l.radius, span.clone(), &k("radius"), kind)?,
                    &k("radius"),
                    0.0,
                    1e9,
                    true,
                )?;
                let radiance = self.req_color(&l.radiance, span.clone(), &k("radiance"), kind)?;
                Ok(Light::Sphere {
                    center,
                    radius,
                    radiance,
                })
            }
            other => Err(self.err(
                l.kind.span(),
                k("type"),
                format!("unknown light type '{other}' (sun, point, quad, sphere)"),
            )),
        }
    }

    fn alpha_mask(&self, m: &MaterialTable, key: &str) -> Result<Option<AlphaMask>, SceneError> {
        // `alpha_map` (pbr only, checked by the caller) is another name for `alpha`.
        let (p, map_key) = match (&m.alpha, &m.alpha_map) {
            (Some(_), Some(b)) => {
                return Err(self.err(
                    b.span(),
                    format!("{key}.alpha_map"),
                    "give either 'alpha' or 'alpha_map', not both",
                ));
            }
            (Some(a), None) => (a, "alpha"),
            (None, Some(b)) => (b, "alpha_map"),
            (None, None) => {
                if let Some(c) = &m.alpha_cutoff {
                    return Err(self.err(
                        c.span(),
                        format!("{key}.alpha_cutoff"),
                        "needs an alpha map ('alpha = \"matte.png\"')",
                    ));
                }
                return Ok(None);
            }
        };
        let map = self.texture(p, &format!("{key}.{map_key}"), Encoding::Linear)?;
        let cutoff = self.opt_float(
            &m.alpha_cutoff,
            &format!("{key}.alpha_cutoff"),
            0.0,
            1.0,
            false,
            0.5,
        )?;
        // A matte with an alpha channel that is not all opaque is read from that channel.
        let use_alpha_channel = map.texels().iter().any(|t| t.w < 1.0);
        Ok(Some(AlphaMask {
            map,
            use_alpha_channel,
            cutoff,
        }))
    }

    fn color_input(
        &self,
        value: &Option<S<ColorValue>>,
        map: &Option<S<String>>,
        key: &str,
        default: Vec3,
    ) -> Result<ColorInput, SceneError> {
        let factor = value
            .as_ref()
            .map(|v| self.color(v, key, Some(1.0)))
            .transpose()?;
        Ok(match map {
            Some(p) => ColorInput::Texture {
                map: self.texture(p, &format!("{key}_map"), Encoding::Srgb)?,
                factor: factor.unwrap_or(Vec3::ONE),
            },
            None => ColorInput::Constant(factor.unwrap_or(default)),
        })
    }

    fn material(&self, i: usize, t: &S<MaterialTable>) -> Result<Material, SceneError> {
        let m = t.get_ref();
        let name = m.name.get_ref().clone();
        let kind = m.kind.get_ref().as_str();
        let p = format!("material[{i}]");
        let keys = [
            ("reflectance", m.reflectance.is_some()),
            ("reflectance_map", m.reflectance_map.is_some()),
            ("transmittance", m.transmittance.is_some()),
            ("transmittance_map", m.transmittance_map.is_some()),
            ("alpha", m.alpha.is_some()),
            ("alpha_cutoff", m.alpha_cutoff.is_some()),
            ("file", m.file.is_some()),
            ("species", m.species.is_some()),
            ("seed", m.seed.is_some()),
            ("resolution", m.resolution.is_some()),
            ("maps", m.maps.is_some()),
            ("params", m.params.is_some()),
            ("base_color", m.base_color.is_some()),
            ("base_color_map", m.base_color_map.is_some()),
            ("metallic", m.metallic.is_some()),
            ("roughness", m.roughness.is_some()),
            ("metallic_roughness_map", m.metallic_roughness_map.is_some()),
            ("ior", m.ior.is_some()),
            ("transmission", m.transmission.is_some()),
            ("transmission_color", m.transmission_color.is_some()),
            ("normal_map", m.normal_map.is_some()),
            ("normal_scale", m.normal_scale.is_some()),
            ("alpha_map", m.alpha_map.is_some()),
        ];
        match kind {
            "diffuse" => {
                self.only(
                    t.span(),
                    &p,
                    kind,
                    &keys,
                    &[
                        "name",
                        "reflectance",
                        "reflectance_map",
                        "alpha",
                        "alpha_cutoff",
                    ],
                )?;
                let reflectance = self.color_input(
                    &m.reflectance,
                    &m.reflectance_map,
                    &format!("{p}.reflectance"),
                    Vec3::splat(0.5),
                )?;
                Ok(Material::Diffuse {
                    name,
                    reflectance,
                    alpha: self.alpha_mask(m, &p)?,
                })
            }
            "diffuse_transmission" => {
                self.only(
                    t.span(),
                    &p,
                    kind,
                    &keys,
                    &[
                        "name",
                        "reflectance",
                        "reflectance_map",
                        "transmittance",
                        "transmittance_map",
                        "alpha",
                        "alpha_cutoff",
                    ],
                )?;
                let reflectance = self.color_input(
                    &m.reflectance,
                    &m.reflectance_map,
                    &format!("{p}.reflectance"),
                    Vec3::splat(0.25),
                )?;
                let transmittance = self.color_input(
                    &m.transmittance,
                    &m.transmittance_map,
                    &format!("{p}.transmittance"),
                    Vec3::splat(0.25),
                )?;
                if let (ColorInput::Constant(r), ColorInput::Constant(tr)) =
                    (&reflectance, &transmittance)
                    && (*r + *tr).max_element() > 1.0 + 1e-6
                {
                    let span = m.transmittance.as_ref().map_or(t.span(), |v| v.span());
                    return Err(self.err(
                        span,
                        format!("{p}.transmittance"),
                        format!("reflectance + transmittance must be <= 1 per channel (energy), got {:?}", (*r + *tr).to_array()),
                    ));
                }
                Ok(Material::DiffuseTransmission {
                    name,
                    reflectance,
                    transmittance,
                    alpha: self.alpha_mask(m, &p)?,
                })
            }
            "leaf" => {
                self.only(
                    t.span(),
                    &p,
                    kind,
                    &keys,
                    &[
                        "name",
                        "file",
                        "species",
                        "seed",
                        "resolution",
                        "maps",
                        "params",
                    ],
                )?;
                let leaf = crate::leaf::load_leaf_material(self, &p, m)?;
                Ok(Material::Leaf {
                    name,
                    leaf: Arc::new(leaf),
                })
            }
            "pbr" => {
                self.only(
                    t.span(),
                    &p,
                    kind,
                    &keys,
                    &[
                        "name",
                        "base_color",
                        "base_color_map",
                        "metallic",
                        "roughness",
                        "metallic_roughness_map",
                        "ior",
                        "transmission",
                        "transmission_color",
                        "normal_map",
                        "normal_scale",
                        "alpha",
                        "alpha_map",
                        "alpha_cutoff",
                    ],
                )?;
                self.pbr_material(name, m, &p)
                    .map(|x| Material::Pbr(Box::new(x)))
            }
            other => Err(self.err(
                m.kind.span(),
                format!("{p}.type"),
                format!(
                    "unknown material type '{other}' (diffuse, diffuse_transmission, leaf, pbr)"
                ),
            )),
        }
    }

    /// A `type = "pbr"` material (glTF metallic-roughness); keys already checked.
    fn pbr_material(
        &self,
        name: String,
        m: &MaterialTable,
        p: &str,
    ) -> Result<PbrMaterial, SceneError> {
        let key = |k: &str| format!("{p}.{k}");
        let base_color = self.color_input(
            &m.base_color,
            &m.base_color_map,
            &key("base_color"),
            Vec3::splat(0.8),
        )?;
        let metallic = self.opt_float(&m.metallic, &key("metallic"), 0.0, 1.0, false, 0.0)?;
        let roughness = self.opt_float(&m.roughness, &key("roughness"), 0.0, 1.0, false, 0.5)?;
        let metallic_roughness = m
            .metallic_roughness_map
            .as_ref()
            .map(|f| self.texture(f, &key("metallic_roughness_map"), Encoding::Linear))
            .transpose()?;
        let ior = self.opt_float(&m.ior, &key("ior"), 1.0, 3.0, false, 1.5)?;
        let transmission =
            self.opt_float(&m.transmission, &key("transmission"), 0.0, 1.0, false, 0.0)?;
        let transmission_color = m
            .transmission_color
            .as_ref()
            .map(|c| self.color(c, &key("transmission_color"), Some(1.0)))
            .transpose()?
            .unwrap_or(Vec3::ONE);
        let normal_map = match &m.normal_map {
            Some(f) => Some(NormalMap {
                map: self.texture(f, &key("normal_map"), Encoding::Linear)?,
                scale: self.opt_float(
                    &m.normal_scale,
                    &key("normal_scale"),
                    0.0,
                    10.0,
                    false,
                    1.0,
                )?,
            }),
            None => {
                if let Some(s) = &m.normal_scale {
                    return Err(self.err(
                        s.span(),
                        key("normal_scale"),
                        "needs a normal map ('normal_map = \"normals.png\"')",
                    ));
                }
                None
            }
        };
        Ok(PbrMaterial {
            name,
            base_color,
            metallic,
            roughness,
            metallic_roughness,
            ior,
            transmission,
            transmission_map: None,
            transmission_color: ColorInput::Constant(transmission_color),
            normal_map,
            alpha: self.alpha_mask(m, p)?,
        })
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

    fn transform(&self, t: &Option<S<TransformTable>>, key: &str) -> Result<Transform, SceneError> {
        let Some(t) = t else {
            return Ok(Transform::default());
        };
        self.table_transform(t, key)
    }

    fn table_transform(&self, t: &S<TransformTable>, key: &str) -> Result<Transform, SceneError> {
        let tt = t.get_ref();
        let scale = tt.scale.map_or(Vec3::ONE, |s| s.0);
        let rot = Vec3::new(
            tt.rotate_x.unwrap_or(0.0),
            tt.rotate_y.unwrap_or(0.0),
            tt.rotate_z.unwrap_or(0.0),
        );
        let tr = tt.translate.map_or(Vec3::ZERO, Vec3::from);
        self.transform_parts(scale, rot, tr, t.span(), key)
    }

    /// The object's transform: `transform = { ... }` or the same keys on the object itself.
    fn object_transform(&self, o: &ObjectTable, p: &str) -> Result<Transform, SceneError> {
        let inline: [Option<Range<usize>>; 5] = [
            o.scale.as_ref().map(|v| v.span()),
            o.rotate_x.as_ref().map(|v| v.span()),
            o.rotate_y.as_ref().map(|v| v.span()),
            o.rotate_z.as_ref().map(|v| v.span()),
            o.translate.as_ref().map(|v| v.span()),
        ];
        let Some(first) = inline.iter().flatten().next().cloned() else {
            return self.transform(&o.transform, &format!("{p}.transform"));
        };
        if let Some(t) = &o.transform {
            return Err(self.err(
                t.span(),
                format!("{p}.transform"),
                "give the transform either as 'transform = { ... }' or as scale/rotate_x/rotate_y/rotate_z/translate keys on the object, not both",
            ));
        }
        let f = |v: &Option<S<f32>>| v.as_ref().map_or(0.0, |v| *v.get_ref());
        let scale = o.scale.as_ref().map_or(Vec3::ONE, |s| s.get_ref().0);
        let rot = Vec3::new(f(&o.rotate_x), f(&o.rotate_y), f(&o.rotate_z));
        let tr = o
            .translate
            .as_ref()
            .map_or(Vec3::ZERO, |t| v3(*t.get_ref()));
        crate::instances::checked_transform(scale, rot, tr).map_err(|(k, m)| {
            let span = match k {
                "scale" => o.scale.as_ref().map(|v| v.span()),
                "translate" => o.translate.as_ref().map(|v| v.span()),
                _ => None,
            };
            self.err(span.unwrap_or(first), format!("{p}.{k}"), m)
        })
    }

    /// The object's placements when it has `instances` and/or `instances_file`.
    fn placements(
        &self,
        p: &str,
        o: &ObjectTable,
        table: Range<usize>,
    ) -> Result<Option<Vec<glam::Affine3A>>, SceneError> {
        if o.instances.is_none() && o.instances_file.is_none() {
            return Ok(None);
        }
        let mut out = Vec::new();
        if let Some(rows) = &o.instances {
            for (j, row) in rows.get_ref().iter().enumerate() {
                let t = self.table_transform(row, &format!("{p}.instances[{j}]"))?;
                out.push(crate::instances::affine(&t));
            }
        }
        if let Some(f) = &o.instances_file {
            let left = self
                .budgets
                .instances
                .saturating_sub(self.instances.get())
                .saturating_sub(out.len());
            let rows = crate::instances::read_instances_csv_capped(&self.path(f), left)?;
            out.extend(rows.iter().map(crate::instances::affine));
        }
        if out.is_empty() {
            return Err(self.err(
                table,
                format!("{p}.instances"),
                "no placements: give at least one (or drop 'instances' to place the object once)",
            ));
        }
        if out.len() > crate::instances::MAX_INSTANCES {
            return Err(self.err(
                table,
                format!("{p}.instances"),
                format!(
                    "{} instances is more than the {} supported",
                    out.len(),
                    crate::instances::MAX_INSTANCES
                ),
            ));
        }
        Ok(Some(out))
    }

    fn object(
        &self,
        i: usize,
        t: &S<ObjectTable>,
        materials: &HashMap<String, u32>,
        scene_materials: &mut Vec<Material>,
    ) -> Result<Geometry, SceneError> {
        let o = t.get_ref();
        let kind = o.kind.get_ref().as_str();
        let p = format!("object[{i}]");
        let keys = [
            ("file", o.file.is_some()),
            ("corner", o.corner.is_some()),
            ("edge_u", o.edge_u.is_some()),
            ("edge_v", o.edge_v.is_some()),
            ("cards", o.cards.is_some()),
            ("plant", o.plant.is_some()),
            ("leaves", o.leaves.is_some()),
        ];
        let xf = self.object_transform(o, &p)?;
        let placements = self.placements(&p, o, t.span())?;
        let lookup = |name: &S<String>, key: &str| -> Result<u32, SceneError> {
            materials.get(name.get_ref()).copied().ok_or_else(|| {
                let mut names: Vec<_> = materials.keys().cloned().collect();
                names.sort();
                self.err(
                    name.span(),
                    key,
                    format!(
                        "no material named '{}' (defined: {})",
                        name.get_ref(),
                        names.join(", ")
                    ),
                )
            })
        };
        let mat_key = format!("{p}.material");
        let geometry = match kind {
            "gltf" | "obj" | "plant" => {
                let imported = match kind {
                    "gltf" => {
                        self.only(t.span(), &p, kind, &keys, &["file", "materials"])?;
                        let f = self.require(&o.file, t.span(), &format!("{p}.file"), kind)?;
                        let path = self.path(f);
                        // Meshes used by several nodes stay prototypes, also when the object
                        // itself is placed many times (see the placements below).
                        let g = crate::gltf_import::load_gltf(&path, &xf)?;
                        for w in &g.warnings {
                            eprintln!("warning: {}: {w}", path.display());
                        }
                        Imported {
                            geometry: Geometry {
                                meshes: g.meshes,
                                prototypes: g.prototypes,
                                instances: g.instances,
                            },
                            materials: g.materials,
                            material_names: g.material_names,
                            source: "the glTF file",
                        }
                    }
                    "obj" => {
                        self.only(t.span(), &p, kind, &keys, &["file", "materials"])?;
                        let f = self.require(&o.file, t.span(), &format!("{p}.file"), kind)?;
                        let path = self.path(f);
                        let obj = crate::obj::load_obj(&path)?;
                        for w in &obj.warnings {
                            eprintln!("warning: {}: {w}", path.display());
                        }
                        let mut meshes = obj.meshes;
                        for m in &mut meshes {
                            apply_transform(m, &xf);
                        }
                        Imported {
                            geometry: Geometry {
                                meshes,
                                ..Default::default()
                            },
                            materials: obj.materials,
                            material_names: obj.material_names,
                            source: "the OBJ file",
                        }
                    }
                    _ => {
                        self.only(
                            t.span(),
                            &p,
                            kind,
                            &keys,
                            &["plant", "file", "materials", "leaves"],
                        )?;
                        let curved = self.curved_leaves(&p, o.leaves.as_ref())?;
                        let params = crate::plant_object::plant_params(
                            self,
                            &p,
                            o.plant.as_ref(),
                            o.file.as_ref(),
                            t.span(),
                        )?;
                        // The scene-wide budgets, before anything is generated.
                        let r = params
                            .resolve()
                            .map_err(|e| self.err(t.span(), format!("{p}.plant"), e.to_string()))?;
                        let plant_span = o.plant.as_ref().map_or(t.span(), |x| x.span());
                        self.spend_leaves(
                            plant_span.clone(),
                            &format!("{p}.plant.leaf_count"),
                            r.leaf_count as u64,
                        )?;
                        self.spend_leaf_texels(
                            plant_span,
                            &format!("{p}.plant.leaf_resolution"),
                            r.leaf_variants as u64 * (r.leaf_resolution as u64).pow(2),
                        )?;
                        let plant = lamina_plant::generate_plant(&params)
                            .map_err(|e| self.err(t.span(), format!("{p}.plant"), e.to_string()))?;
                        let (geometry, mats) = if curved {
                            let parts = plant.into_instanced_parts(
                                0,
                                0,
                                lamina_plant::instanced::LeafBend::default(),
                            );
                            let place = glam::Affine3A::from_mat4(xf.m);
                            let mut meshes = parts.meshes;
                            for m in &mut meshes {
                                apply_transform(m, &xf);
                            }
                            let instances = parts
                                .instances
                                .into_iter()
                                .map(|i| Instance {
                                    transform: place * i.transform,
                                    ..i
                                })
                                .collect();
                            let geometry = Geometry {
                                meshes,
                                prototypes: parts.prototypes,
                                instances,
                            };
                            (geometry, parts.materials)
                        } else {
                            let (mut meshes, mats) = plant.into_scene_parts(0);
                            for m in &mut meshes {
                                apply_transform(m, &xf);
                            }
                            let geometry = Geometry {
                                meshes,
                                ..Default::default()
                            };
                            (geometry, mats)
                        };
                        Imported {
                            geometry,
                            material_names: mats
                                .iter()
                                .map(|m| material_name(m).to_owned())
                                .collect(),
                            materials: mats,
                            source: "the plant",
                        }
                    }
                };
                self.bind_materials(&p, o, imported, scene_materials, &lookup)?
            }
            _ => {
                if let Some(m) = &o.materials {
                    return Err(self.err(
                        m.span(),
                        format!("{p}.materials"),
                        "only gltf, obj and plant objects take 'materials'; use 'material'",
                    ));
                }
                let material = lookup(
                    self.require(&o.material, t.span(), &mat_key, kind)?,
                    &mat_key,
                )?;
                let meshes = self.simple_object(&p, kind, t, &keys, &xf, material)?;
                Geometry {
                    meshes,
                    ..Default::default()
                }
            }
        };
        let user_placed = placements.is_some();
        let geometry = match placements {
            None => geometry,
            Some(placements) => {
                let name = o
                    .name
                    .as_ref()
                    .map_or_else(|| p.clone(), |n| n.get_ref().clone());
                self.place(&p, t.span(), name, geometry, &placements)?
            }
        };
        self.check_extent(&p, &geometry, t.span(), user_placed)?;
        Ok(geometry)
    }

    /// Places an object's geometry at every placement. Its world-space meshes become one
    /// prototype `name`, placed once per placement. Its own prototypes (glTF meshes used by
    /// several nodes, curved leaves of a plant) stay prototypes, and every one of their
    /// instances is composed with every placement: the renderers' instancing stays two
    /// levels deep (a placement × inner instance pair costs one instance record), while the
    /// geometry still exists once.
    fn place(
        &self,
        p: &str,
        span: std::ops::Range<usize>,
        name: String,
        geometry: Geometry,
        placements: &[glam::Affine3A],
    ) -> Result<Geometry, SceneError> {
        let per_placement = geometry.instances.len() + usize::from(!geometry.meshes.is_empty());
        let total = per_placement.saturating_mul(placements.len());
        if total > crate::instances::MAX_INSTANCES {
            return Err(self.err(
                span,
                format!("{p}.instances"),
                format!(
                    "{} placements x {per_placement} instances each = {total} instances, more \
                     than the {} supported",
                    placements.len(),
                    crate::instances::MAX_INSTANCES
                ),
            ));
        }
        // The scene-wide total, before the allocation.
        self.check_instances(span.clone(), &format!("{p}.instances"), total)?;
        let mut prototypes = geometry.prototypes;
        let outer = (!geometry.meshes.is_empty()).then(|| {
            prototypes.push(Prototype {
                name,
                meshes: geometry.meshes,
            });
            prototypes.len() as u32 - 1
        });
        let mut instances = Vec::with_capacity(total);
        for place in placements {
            if let Some(prototype) = outer {
                instances.push(Instance {
                    prototype,
                    transform: *place,
                });
            }
            instances.extend(geometry.instances.iter().map(|i| Instance {
                prototype: i.prototype,
                transform: *place * i.transform,
            }));
        }
        Ok(Geometry {
            meshes: Vec::new(),
            prototypes,
            instances,
        })
    }

    /// A plant object's `leaves`: `"cards"` (default) or `"curved"` (instanced curved
    /// leaves; with `instances` each leaf instance is composed with every placement).
    fn curved_leaves(&self, p: &str, leaves: Option<&S<String>>) -> Result<bool, SceneError> {
        let Some(l) = leaves else { return Ok(false) };
        let key = format!("{p}.leaves");
        match l.get_ref().as_str() {
            "cards" => Ok(false),
            "curved" => Ok(true),
            other => Err(self.err(
                l.span(),
                key,
                format!("must be \"cards\" or \"curved\", got \"{other}\""),
            )),
        }
    }

    /// Rejects geometry that, once placed, lies beyond ±[`crate::instances::MAX_COORD`] m
    /// or has a non-finite vertex.
    fn check_extent(
        &self,
        p: &str,
        g: &Geometry,
        span: Range<usize>,
        user_placed: bool,
    ) -> Result<(), SceneError> {
        let max = crate::instances::MAX_COORD;
        let bad = |v: Vec3| !v.is_finite() || v.abs().max_element() > max;
        for m in &g.meshes {
            if let Some(v) = m.positions.iter().find(|&&v| bad(v)) {
                return Err(self.err(
                    span,
                    p,
                    format!(
                        "a vertex lands at {:?}, beyond ±{max:e} m (absurd size, or wrong units?)",
                        v.to_array()
                    ),
                ));
            }
        }
        let bounds: Vec<Option<(Vec3, Vec3)>> = g
            .prototypes
            .iter()
            .map(|pr| {
                let mut it = pr.meshes.iter().flat_map(|m| m.positions.iter().copied());
                let first = it.next()?;
                Some(it.fold((first, first), |(lo, hi), v| (lo.min(v), hi.max(v))))
            })
            .collect();
        for (j, inst) in g.instances.iter().enumerate() {
            let Some(Some((lo, hi))) = bounds.get(inst.prototype as usize) else {
                continue;
            };
            for c in 0..8 {
                let corner = Vec3::new(
                    if c & 1 == 0 { lo.x } else { hi.x },
                    if c & 2 == 0 { lo.y } else { hi.y },
                    if c & 4 == 0 { lo.z } else { hi.z },
                );
                let w: Vec3 = inst.transform.transform_point3(corner);
                if bad(w) {
                    let (key, what) = if user_placed {
                        (format!("{p}.instances[{j}]"), "places".to_string())
                    } else {
                        let name = &g.prototypes[inst.prototype as usize].name;
                        (p.to_string(), format!("a node using mesh '{name}' places"))
                    };
                    return Err(self.err(
                        span,
                        key,
                        format!(
                            "{what} the geometry at {:?}, beyond ±{max:e} m (absurd size, or wrong units?)",
                            w.to_array()
                        ),
                    ));
                }
            }
        }
        Ok(())
    }

    /// `quad` and `leaf_cards`: one scene material, world-space meshes.
    fn simple_object(
        &self,
        p: &str,
        kind: &str,
        t: &S<ObjectTable>,
        keys: &[(&str, bool)],
        xf: &Transform,
        material: u32,
    ) -> Result<Vec<Mesh>, SceneError> {
        let o = t.get_ref();
        match kind {
            "quad" => {
                self.only(t.span(), p, kind, keys, &["corner", "edge_u", "edge_v"])?;
                let (corner, edge_u, edge_v) =
                    self.parallelogram(&o.corner, &o.edge_u, &o.edge_v, t.span(), p, kind)?;
                let mut mesh = Mesh::quad(corner, edge_u, edge_v, material);
                apply_transform(&mut mesh, xf);
                Ok(vec![mesh])
            }
            "leaf_cards" => {
                self.only(t.span(), p, kind, keys, &["file", "cards"])?;
                let mut cards: Vec<LeafCard> = Vec::new();
                if let Some(rows) = &o.cards {
                    for (j, row) in rows.get_ref().iter().enumerate() {
                        cards
                            .push(LeafCard::new(row).map_err(|m| {
                                self.err(rows.span(), format!("{p}.cards[{j}]"), m)
                            })?);
                    }
                }
                if let Some(f) = &o.file {
                    let left = self.leaves_left().saturating_sub(cards.len() as u64);
                    let max = usize::try_from(left).unwrap_or(usize::MAX);
                    cards.extend(crate::cards::read_card_file_capped(&self.path(f), max)?);
                }
                self.spend_leaves(t.span(), &format!("{p}.cards"), cards.len() as u64)?;
                if o.cards.is_none() && o.file.is_none() {
                    return Err(self.err(
                        t.span(),
                        format!("{p}.cards"),
                        "a leaf_cards object needs 'cards' or 'file'",
                    ));
                }
                let cards: Vec<LeafCard> = cards.iter().map(|c| c.transformed(xf)).collect();
                let mut mesh = Mesh {
                    material,
                    ..Default::default()
                };
                append_cards(&mut mesh, &cards);
                Ok(vec![mesh])
            }
            other => Err(self.err(
                o.kind.span(),
                format!("{p}.type"),
                format!("unknown object type '{other}' (quad, leaf_cards, obj, gltf, plant)"),
            )),
        }
    }

    /// Binds an imported object's materials to the scene: the object's `material` replaces
    /// all of them, `materials = { "their name" = "scene name" }` replaces them by name, and
    /// the rest are appended to the scene's materials (only those some mesh uses).
    fn bind_materials(
        &self,
        p: &str,
        o: &ObjectTable,
        imported: Imported,
        scene_materials: &mut Vec<Material>,
        lookup: &MaterialLookup,
    ) -> Result<Geometry, SceneError> {
        let all = o
            .material
            .as_ref()
            .map(|m| lookup(m, &format!("{p}.material")))
            .transpose()?;
        let mut by_name: HashMap<&str, u32> = HashMap::new();
        if let Some(table) = &o.materials {
            for (their_name, v) in table.get_ref() {
                let key = format!("{p}.materials.{their_name}");
                let toml::Value::String(scene_name) = v else {
                    return Err(self.err(
                        table.span(),
                        key,
                        "must be the name of a scene material (a string)",
                    ));
                };
                if !imported.material_names.iter().any(|n| n == their_name) {
                    let have = imported.material_names.join(", ");
                    return Err(self.err(
                        table.span(),
                        key,
                        format!(
                            "{} has no material '{their_name}' (it has: {have})",
                            imported.source
                        ),
                    ));
                }
                let target = lookup(&S::new(table.span(), scene_name.clone()), &key)?;
                by_name.insert(their_name.as_str(), target);
            }
        }
        let mut g = imported.geometry;
        let mut used = vec![false; imported.materials.len()];
        for m in g
            .meshes
            .iter()
            .chain(g.prototypes.iter().flat_map(|pr| pr.meshes.iter()))
        {
            if let Some(u) = used.get_mut(m.material as usize) {
                *u = true;
            }
        }
        let mut remap: Vec<u32> = Vec::with_capacity(imported.materials.len());
        for (i, (mat, name)) in imported
            .materials
            .into_iter()
            .zip(&imported.material_names)
            .enumerate()
        {
            let target = all.or_else(|| by_name.get(name.as_str()).copied());
            remap.push(match target {
                Some(t) => t,
                None if used[i] => {
                    scene_materials.push(mat);
                    scene_materials.len() as u32 - 1
                }
                None => u32::MAX,
            });
        }
        for m in g
            .meshes
            .iter_mut()
            .chain(g.prototypes.iter_mut().flat_map(|pr| pr.meshes.iter_mut()))
        {
            m.material = remap.get(m.material as usize).copied().unwrap_or(u32::MAX);
        }
        Ok(g)
    }
}

/// What one `[[object]]` adds to the scene: world-space meshes, and prototypes with their
/// instances (`Instance::prototype` local to `prototypes`).
#[derive(Debug, Default)]
pub(crate) struct Geometry {
    pub(crate) meshes: Vec<Mesh>,
    pub(crate) prototypes: Vec<Prototype>,
    pub(crate) instances: Vec<Instance>,
}

/// Geometry with its own materials (`Mesh::material` indexes `materials`), from a file or
/// a generator.
struct Imported {
    geometry: Geometry,
    materials: Vec<Material>,
    material_names: Vec<String>,
    /// "the glTF file", for messages.
    source: &'static str,
}

/// A material's name.
fn material_name(m: &Material) -> &str {
    m.name()
}

/// Transforms a mesh in place, keeping its front faces in front.
pub fn apply_transform(mesh: &mut Mesh, t: &Transform) {
    if *t == Transform::default() {
        return;
    }
    for p in &mut mesh.positions {
        *p = t.point(*p);
    }
    for n in &mut mesh.normals {
        *n = t.normal(*n);
    }
    // A tangent follows the surface like a position difference; a mirror flips the
    // bitangent's handedness (see `Mesh::tangents`).
    let w = if t.flips() { -1.0 } else { 1.0 };
    for tg in &mut mesh.tangents {
        *tg = t.vector(tg.truncate()).normalize_or_zero().extend(tg.w * w);
    }
    if t.flips() {
        for tri in &mut mesh.indices {
            tri.swap(1, 2);
        }
    }
}
