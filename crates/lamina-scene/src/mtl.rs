//! MTL materials (as tobj reads them) to lamina materials, for [`crate::obj`].
//!
//! Paths in an MTL file are relative to the MTL file.
//!
//! | MTL | lamina |
//! |---|---|
//! | `Kd` (linear RGB, clamped to [0, 1]; default 1 with a `map_Kd`, else 0.5) | diffuse reflectance |
//! | `map_Kd` (sRGB image) | reflectance texture, multiplied by `Kd` |
//! | alpha channel of `map_Kd` (when not all opaque) | alpha cut-out at 0.5 |
//! | `map_d` (image; its alpha channel if it has one, else its first channel) | alpha cut-out at 0.5 (takes precedence over `map_Kd`'s alpha) |
//! | `d` < 0.5 without maps (`Tr` > 0.5) | fully cut out (invisible), with a warning |
//! | `Tf` (transmission filter, RGB), when not black and not the exporters' default `1 1 1` | `diffuse_transmission` with transmittance `Tf`; reflectance lowered where `Kd + Tf` > 1 |
//!
//! A material with **gloss** (`Ks` not black, or any of `Pr`, `map_Pr`, `Pm`, `map_Pm`) or
//! **relief** (a normal map) becomes [`Material::Pbr`] instead (`Kd`/`map_Kd` the base
//! colour, alpha as above, `Tf` as diffuse transmission `t = max(Tf)`, colour `Tf / t`,
//! base `Kd / (1 - t)`):
//!
//! | MTL | lamina `pbr` |
//! |---|---|
//! | `Pr` ([0, 1]) | roughness |
//! | `Ns` (Phong exponent, >= 0; used without `Pr`) | roughness `= (2 / (Ns + 2))^(1/4)`, see [`phong_exponent_to_roughness`]; neither: 0.5 |
//! | `Pm` ([0, 1]) | metallic (default 0) |
//! | `map_Pr`, `map_Pm` (linear, first channel or `-imfchan`) | packed into the metallic-roughness map (G, B), multiplying `Pr`/`Pm` (1 when only the map is given) |
//! | `Ni` in (1, 3] | ior (else 1.5) |
//! | `norm` | tangent-space normal map (linear, OpenGL/glTF: +y = up in the image), strength `-bm` (default 1, [0, 10]) |
//! | `map_Bump` / `bump`, coloured | the same (exporters such as Blender write normal maps there), with a warning |
//! | `map_Bump` / `bump`, grey | a classic height map: not supported, ignored with a warning |
//!
//! Texture options on any map: `-s u v w` / `-o u v w` become a transform of the
//! material's texture coordinates, `uv' = uv * s + o` (`w` ignored; as three.js and
//! Blender read them), applied to the meshes that use the material — when all its maps
//! agree (a map without them counts as `-s 1 1 -o 0 0`); otherwise they are ignored with a
//! warning. `-clamp on` clamps the map; `-bm` is the normal-map strength; `-imfchan`
//! picks a scalar map's channel; `-blendu`, `-blendv`, `-cc`, `-mm`, `-boost`, `-texres`,
//! `-t`, `-type` are read and ignored (warning). An unknown option or a bad number is an
//! error naming the MTL file, its line and the statement.
//!
//! `Ka`, `Ke`, `map_Ks`, `map_Ns`, `map_Ka` and `illum` are ignored.

use crate::error::SceneError;
use crate::scene::{AlphaMask, ColorInput, Material, NormalMap, PbrMaterial};
use glam::{Vec2, Vec3, Vec4};
use lamina_leaf::texture::Wrap;
use lamina_leaf::{Encoding, Texture};
use std::path::Path;

/// A texture statement split into its options and its file, e.g.
/// `map_Kd -s 2 2 1 -o 0.5 0 0 leaf.png` or `norm -bm 0.8 normals.png`.
#[derive(Clone, Debug, Default, PartialEq)]
struct MapSpec {
    /// The image path (may contain spaces).
    file: String,
    /// `-s u v w`: texture-coordinate scale (`w` ignored).
    scale: Option<Vec2>,
    /// `-o u v w`: texture-coordinate offset (`w` ignored).
    offset: Option<Vec2>,
    /// `-bm mult`: bump / normal strength.
    bm: Option<f32>,
    /// `-clamp on`.
    clamp: bool,
    /// `-imfchan r|g|b|m|l|z`: the channel of a scalar map.
    channel: Option<char>,
    /// Options that were read and ignored (`-blendu`, `-mm`, `-t`, ...).
    ignored: Vec<String>,
}

impl MapSpec {
    /// The map's texture-coordinate transform `uv' = uv * scale + offset`.
    fn uv_transform(&self) -> (Vec2, Vec2) {
        (
            self.scale.unwrap_or(Vec2::ONE),
            self.offset.unwrap_or(Vec2::ZERO),
        )
    }
}

/// Parses a texture statement's value (what follows `map_Kd`, `norm`, ...). Errors name
/// the option and what is wrong with it.
fn parse_map(spec: &str) -> Result<MapSpec, String> {
    let mut out = MapSpec::default();
    let mut rest = spec.trim();
    // Next whitespace-separated word, and the text after it.
    fn word(s: &str) -> (&str, &str) {
        let s = s.trim_start();
        let end = s.find(char::is_whitespace).unwrap_or(s.len());
        (&s[..end], s[end..].trim_start())
    }
    let number = |w: &str, opt: &str| -> Result<f32, String> {
        w.parse::<f32>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| format!("texture option {opt}: '{w}' is not a finite number"))
    };
    loop {
        let (w, after) = word(rest);
        if w.is_empty() {
            return Err(if out == MapSpec::default() {
                "no texture file".into()
            } else {
                "no texture file after the options".into()
            });
        }
        let is_option = w.starts_with('-')
            && w.len() > 1
            && w[1..].starts_with(|c: char| c.is_ascii_alphabetic());
        if !is_option {
            out.file = rest.trim_end().to_string();
            return Ok(out);
        }
        rest = after;
        match w {
            // One to three numbers (u [v [w]]).
            "-s" | "-o" | "-t" => {
                let mut v = Vec::new();
                while v.len() < 3 {
                    let (n, after) = word(rest);
                    match n.parse::<f32>() {
                        Ok(x) => {
                            v.push(number(n, w).map(|_| x)?);
                            rest = after;
                        }
                        Err(_) => break,
                    }
                }
                if v.is_empty() {
                    let (n, _) = word(rest);
                    return Err(format!("texture option {w}: needs numbers, got '{n}'"));
                }
                let def = if w == "-o" { 0.0 } else { 1.0 };
                let uv = Vec2::new(v[0], v.get(1).copied().unwrap_or(def));
                match w {
                    "-s" => out.scale = Some(uv),
                    "-o" => out.offset = Some(uv),
                    _ => out.ignored.push(w.into()),
                }
            }
            "-bm" => {
                let (n, after) = word(rest);
                out.bm = Some(number(n, w)?);
                rest = after;
            }
            "-clamp" | "-blendu" | "-blendv" | "-cc" => {
                let (n, after) = word(rest);
                let on = match n {
                    "on" => true,
                    "off" => false,
                    _ => {
                        return Err(format!(
                            "texture option {w}: needs 'on' or 'off', got '{n}'"
                        ));
                    }
                };
                if w == "-clamp" {
                    out.clamp = on;
                } else {
                    out.ignored.push(w.into());
                }
                rest = after;
            }
            "-imfchan" => {
                let (n, after) = word(rest);
                match n {
                    "r" | "g" | "b" | "m" | "l" => out.channel = n.chars().next(),
                    _ => {
                        return Err(format!(
                            "texture option -imfchan: needs r, g, b, m or l, got '{n}'"
                        ));
                    }
                }
                rest = after;
            }
            "-mm" => {
                for _ in 0..2 {
                    let (n, after) = word(rest);
                    number(n, w)?;
                    rest = after;
                }
                out.ignored.push(w.into());
            }
            "-boost" | "-texres" => {
                let (n, after) = word(rest);
                number(n, w)?;
                rest = after;
                out.ignored.push(w.into());
            }
            "-type" => {
                let (_, after) = word(rest);
                rest = after;
                out.ignored.push(w.into());
            }
            _ => return Err(format!("unknown texture option '{w}'")),
        }
    }
}

/// Phong exponent `Ns` to perceptual roughness: the Beckmann-Phong correspondence
/// `alpha = sqrt(2 / (Ns + 2))` (Walter et al. 2007), and `roughness = sqrt(alpha)` since
/// lamina's GGX uses `alpha = roughness²`. `Ns` 0 → 1, 10 → 0.64, 100 → 0.375,
/// 1000 → 0.21.
pub fn phong_exponent_to_roughness(ns: f32) -> f32 {
    (2.0 / (ns.max(0.0) + 2.0)).sqrt().sqrt()
}

/// The MTL file of one material, for errors with lines.
struct Mtl<'a> {
    path: &'a Path,
    text: String,
    name: &'a str,
}

impl Mtl<'_> {
    /// The 1-based line of the last statement `key` (any of `keys`) in this material's
    /// `newmtl` block, as tobj keeps the last one.
    fn line(&self, keys: &[&str]) -> Option<usize> {
        let mut inside = false;
        let mut found = None;
        for (i, l) in self.text.lines().enumerate() {
            let l = l.trim();
            let tag = l.split_whitespace().next().unwrap_or("");
            if tag == "newmtl" {
                inside = l["newmtl".len()..].trim() == self.name;
            } else if inside && keys.contains(&tag) {
                found = Some(i + 1);
            }
        }
        found
    }

    /// An error at statement `key` (the line of any of `keys`).
    fn err(&self, key: &str, keys: &[&str], msg: impl Into<String>) -> SceneError {
        SceneError::new(
            self.path,
            self.line(keys),
            format!("newmtl {}: {key}", self.name),
            msg,
        )
    }
}

/// One MTL material being converted: where its statements are (for errors with lines),
/// the maps read so far (for the shared texture-coordinate transform) and the warnings.
struct Converter<'a> {
    m: &'a tobj::Material,
    file: Mtl<'a>,
    /// The MTL file's folder: map paths start here.
    dir: &'a Path,
    /// Every map used, with its options.
    used: Vec<(&'static str, MapSpec)>,
    warnings: &'a mut Vec<String>,
}

/// `Kd`, `map_Kd` and the alpha matte of a material.
type AlbedoAlpha = (Option<Vec3>, Option<Texture>, Option<AlphaMask>);

/// tobj merges `bump` into `map_Bump`.
const BUMP: &[&str] = &["map_Bump", "map_bump", "bump"];

/// The gloss statements: a specular colour or the PBR extension's roughness / metallic,
/// with their scalar maps (and the channel `-imfchan` picks).
struct Gloss {
    ks: Option<Vec3>,
    pr: Option<f32>,
    pm: Option<f32>,
    map_pr: Option<(Texture, Option<char>)>,
    map_pm: Option<(Texture, Option<char>)>,
}

impl Gloss {
    /// Whether the material is glossy (and so becomes `pbr`).
    fn any(&self) -> bool {
        self.ks.is_some_and(|k| k.max_element() > 0.0)
            || self.pr.is_some()
            || self.pm.is_some()
            || self.map_pr.is_some()
            || self.map_pm.is_some()
    }
}

impl Converter<'_> {
    /// An error at statement `k` of this material.
    fn err(&self, k: &str, msg: String) -> SceneError {
        let keys: &[&str] = if k == "map_Bump" { BUMP } else { &[k] };
        self.file.err(k, keys, msg)
    }

    /// Loads the map of statement `k` (its options in `s`).
    fn texture(&self, k: &str, s: &MapSpec, enc: Encoding) -> Result<Texture, SceneError> {
        let p = self.dir.join(&s.file);
        let mut t = Texture::load(&p, enc)
            .map_err(|e| self.err(k, format!("cannot load texture '{}': {e}", p.display())))?;
        if s.clamp {
            t.wrap = Wrap::Clamp;
        }
        Ok(t)
    }

    /// The options and file of statement `k`'s value `v`.
    fn spec(&self, k: &str, v: &str) -> Result<MapSpec, SceneError> {
        parse_map(v).map_err(|e| self.err(k, e))
    }

    /// A colour statement, finite, clamped to [0, 1].
    fn finite3(&self, k: &str, v: [f32; 3]) -> Result<Vec3, SceneError> {
        let v = Vec3::from(v);
        if !v.is_finite() {
            return Err(self.err(k, format!("must be finite, got {:?}", v.to_array())));
        }
        Ok(v.clamp(Vec3::ZERO, Vec3::ONE))
    }

    /// A scalar statement of the PBR extension (`Pr 0.4`), in [0, 1].
    fn unit(&self, k: &str) -> Result<Option<f32>, SceneError> {
        let Some(v) = self.m.unknown_param.get(k) else {
            return Ok(None);
        };
        let x = v
            .trim()
            .parse::<f32>()
            .map_err(|_| self.err(k, format!("not a number: '{}'", v.trim())))?;
        if !(0.0..=1.0).contains(&x) {
            return Err(self.err(k, format!("must be in [0, 1], got {x}")));
        }
        Ok(Some(x))
    }

    /// `Kd`, `map_Kd` and the alpha matte (`map_d`, `map_Kd`'s alpha, or `d`/`Tr` without a
    /// map).
    fn albedo_and_alpha(&mut self) -> Result<AlbedoAlpha, SceneError> {
        let m = self.m;
        let kd = m.diffuse.map(|d| self.finite3("Kd", d)).transpose()?;
        let map_kd = match m.diffuse_texture.as_deref() {
            Some(v) => {
                let s = self.spec("map_Kd", v)?;
                let t = self.texture("map_Kd", &s, Encoding::Srgb)?;
                self.used.push(("map_Kd", s));
                Some(t)
            }
            None => None,
        };
        let has_alpha = |t: &Texture| t.texels().iter().any(|x| x.w < 1.0);
        let mut alpha = match &m.dissolve_texture {
            Some(v) => {
                let s = self.spec("map_d", v)?;
                let t = self.texture("map_d", &s, Encoding::Linear)?;
                self.used.push(("map_d", s));
                Some(AlphaMask {
                    use_alpha_channel: has_alpha(&t),
                    map: t,
                    cutoff: 0.5,
                })
            }
            None => map_kd.as_ref().filter(|t| has_alpha(t)).map(|t| AlphaMask {
                map: t.clone(),
                use_alpha_channel: true,
                cutoff: 0.5,
            }),
        };
        let d = m
            .dissolve
            .or_else(|| {
                m.unknown_param
                    .get("Tr")
                    .and_then(|v| v.trim().parse::<f32>().ok())
                    .map(|tr| 1.0 - tr)
            })
            .unwrap_or(1.0);
        if alpha.is_none() && d.is_finite() && d < 0.5 {
            self.warnings.push(format!(
                "material '{}': d = {d} (dissolve) without a map: rendered invisible",
                m.name
            ));
            alpha = Some(AlphaMask {
                map: Texture::constant(Vec4::ZERO),
                use_alpha_channel: false,
                cutoff: 0.5,
            });
        }
        Ok((kd, map_kd, alpha))
    }

    /// `Tf`, the transmission filter, when it is not black and not the exporters' `1 1 1`.
    fn transmission_filter(&self) -> Result<Option<Vec3>, SceneError> {
        let Some(v) = self.m.unknown_param.get("Tf") else {
            return Ok(None);
        };
        let n: Vec<f32> = v
            .split_whitespace()
            .map(|x| x.parse::<f32>())
            .collect::<Result<_, _>>()
            .map_err(|_| self.err("Tf", format!("not numbers: '{v}'")))?;
        let c = match n[..] {
            [g] => [g; 3],
            [r, g, b, ..] => [r, g, b],
            _ => return Err(self.err("Tf", format!("not an RGB colour: '{v}'"))),
        };
        let c = self.finite3("Tf", c)?;
        Ok((c.max_element() > 0.0 && c != Vec3::ONE).then_some(c))
    }

    /// A scalar map statement (`map_Pr`, `map_Pm`) with its channel.
    fn scalar_map(
        &mut self,
        k: &'static str,
    ) -> Result<Option<(Texture, Option<char>)>, SceneError> {
        let Some(v) = self.m.unknown_param.get(k) else {
            return Ok(None);
        };
        let s = self.spec(k, v)?;
        let t = self.texture(k, &s, Encoding::Linear)?;
        let c = s.channel;
        self.used.push((k, s));
        Ok(Some((t, c)))
    }

    /// The gloss statements.
    fn gloss(&mut self) -> Result<Gloss, SceneError> {
        let ks = self.m.specular.map(|v| self.finite3("Ks", v)).transpose()?;
        let pr = self.unit("Pr")?;
        let pm = self.unit("Pm")?;
        let map_pr = self.scalar_map("map_Pr")?;
        let map_pm = self.scalar_map("map_Pm")?;
        Ok(Gloss {
            ks,
            pr,
            pm,
            map_pr,
            map_pm,
        })
    }

    /// The normal map's strength `-bm`, in [0, 10].
    fn normal_scale(&self, k: &str, s: &MapSpec) -> Result<f32, SceneError> {
        let bm = s.bm.unwrap_or(1.0);
        if !(0.0..=10.0).contains(&bm) {
            return Err(self.err(k, format!("-bm must be in [0, 10], got {bm}")));
        }
        Ok(bm)
    }

    /// Relief: `norm` is a tangent-space normal map; `map_Bump` / `bump` is read as one
    /// when it is coloured (Blender writes its normal maps there), and ignored when it is
    /// grey (a classic height map).
    fn relief(&mut self) -> Result<Option<NormalMap>, SceneError> {
        let m = self.m;
        let mut normal_map = None;
        if let Some(v) = m.unknown_param.get("norm") {
            let s = self.spec("norm", v)?;
            normal_map = Some(NormalMap {
                map: self.texture("norm", &s, Encoding::Linear)?,
                scale: self.normal_scale("norm", &s)?,
            });
            self.used.push(("norm", s));
        }
        let Some(v) = &m.normal_texture else {
            return Ok(normal_map);
        };
        let s = self.spec("map_Bump", v)?;
        if normal_map.is_some() {
            self.warnings.push(format!(
                "material '{}': both norm and map_Bump/bump: norm is the normal map, map_Bump ignored",
                m.name
            ));
            return Ok(normal_map);
        }
        let t = self.texture("map_Bump", &s, Encoding::Linear)?;
        let grey = t
            .texels()
            .iter()
            .all(|x| (x.x - x.y).abs() < 1.5 / 255.0 && (x.y - x.z).abs() < 1.5 / 255.0);
        if grey {
            self.warnings.push(format!(
                "material '{}': map_Bump/bump '{}' is a grey height map; height maps are not supported, ignored",
                m.name, s.file
            ));
            return Ok(None);
        }
        self.warnings.push(format!(
            "material '{}': map_Bump/bump '{}' is read as a tangent-space normal map (OpenGL convention, strength -bm)",
            m.name, s.file
        ));
        let normal_map = NormalMap {
            scale: self.normal_scale("map_Bump", &s)?,
            map: t,
        };
        self.used.push(("map_Bump", s));
        Ok(Some(normal_map))
    }

    /// The one texture-coordinate transform of the material's maps (lamina maps have none
    /// of their own), with warnings for options ignored.
    fn uv_transform(&mut self) -> Option<(Vec2, Vec2)> {
        let name = &self.m.name;
        for (k, s) in &self.used {
            if !s.ignored.is_empty() {
                self.warnings.push(format!(
                    "material '{name}': {k}: texture options {} ignored",
                    s.ignored.join(", ")
                ));
            }
        }
        let first = self.used.first()?.1.uv_transform();
        if self.used.iter().all(|(_, s)| s.uv_transform() == first) {
            return Some(first).filter(|t| *t != (Vec2::ONE, Vec2::ZERO));
        }
        self.warnings.push(format!(
            "material '{name}': its maps have different -s/-o options ({}); all ignored",
            self.used
                .iter()
                .map(|(k, s)| {
                    let (sc, o) = s.uv_transform();
                    format!("{k}: -s {} {} -o {} {}", sc.x, sc.y, o.x, o.y)
                })
                .collect::<Vec<_>>()
                .join("; ")
        ));
        None
    }
}

/// MTL material to lamina material and the texture-coordinate transform (`uv * scale +
/// offset`) its maps ask for; see the module docs for the mapping.
pub(crate) fn convert_material(
    mtl: &Path,
    m: &tobj::Material,
    warnings: &mut Vec<String>,
) -> Result<(Material, Option<(Vec2, Vec2)>), SceneError> {
    let mut c = Converter {
        m,
        file: Mtl {
            path: mtl,
            text: std::fs::read_to_string(mtl).unwrap_or_default(),
            name: &m.name,
        },
        dir: mtl.parent().unwrap_or(Path::new("")),
        used: Vec::new(),
        warnings,
    };
    let (kd, map_kd, alpha) = c.albedo_and_alpha()?;
    let tf = c.transmission_filter()?;
    let gloss = c.gloss()?;
    let normal_map = c.relief()?;
    let uv = c.uv_transform();
    let factor = kd.unwrap_or(if map_kd.is_some() {
        Vec3::ONE
    } else {
        Vec3::splat(0.5)
    });
    // Energy: reflectance + transmittance <= 1 per channel.
    let factor = match tf {
        Some(t) => factor.min(Vec3::ONE - t),
        None => factor,
    };
    let name = m.name.clone();
    if !gloss.any() && normal_map.is_none() {
        let reflectance = match map_kd {
            Some(map) => ColorInput::Texture { map, factor },
            None => ColorInput::Constant(factor),
        };
        let mat = match tf {
            Some(t) => Material::DiffuseTransmission {
                name,
                reflectance,
                transmittance: ColorInput::Constant(t),
                alpha,
            },
            None => Material::Diffuse {
                name,
                reflectance,
                alpha,
            },
        };
        return Ok((mat, uv));
    }
    let pbr = PbrParts {
        name,
        factor,
        map_kd,
        alpha,
        tf,
        gloss,
        normal_map,
    };
    Ok((Material::Pbr(Box::new(pbr.build(&c)?)), uv))
}

/// What a glossy or relief-mapped MTL material becomes `pbr` from.
struct PbrParts {
    name: String,
    /// The base colour factor (Kd, lowered where Kd + Tf > 1).
    factor: Vec3,
    map_kd: Option<Texture>,
    alpha: Option<AlphaMask>,
    tf: Option<Vec3>,
    gloss: Gloss,
    normal_map: Option<NormalMap>,
}

impl PbrParts {
    fn build(self, c: &Converter) -> Result<PbrMaterial, SceneError> {
        let Gloss {
            pr,
            pm,
            map_pr,
            map_pm,
            ..
        } = self.gloss;
        // Roughness: Pr, else from Ns (only with a specular colour), else 0.5; a map
        // multiplies its factor, which is 1 when only the map is given (glTF semantics).
        let roughness = match (pr, c.m.shininess) {
            (Some(r), _) => r,
            (None, _) if map_pr.is_some() => 1.0,
            (None, Some(ns)) => {
                if !ns.is_finite() || ns < 0.0 {
                    return Err(c.err("Ns", format!("must be finite and >= 0, got {ns}")));
                }
                phong_exponent_to_roughness(ns)
            }
            (None, None) => 0.5,
        };
        let metallic = pm.unwrap_or(if map_pm.is_some() { 1.0 } else { 0.0 });
        let metallic_roughness = (map_pr.is_some() || map_pm.is_some())
            .then(|| metallic_roughness_texture(map_pr.as_ref(), map_pm.as_ref()));
        // Ni is the index of refraction; exporters write 1 (or nonsense) when unset.
        let ior = match c.m.optical_density {
            Some(n) if n > 1.0 && n <= 3.0 => n,
            _ => 1.5,
        };
        // Tf as diffuse transmission: (1 - t) base reflected, t colour transmitted, with
        // t = max(Tf), colour Tf / t and base Kd / (1 - t) (clamped to 1).
        let (transmission, transmission_color, factor) = match self.tf {
            Some(t) => {
                let tr = t.max_element().min(1.0);
                let base = if tr < 1.0 {
                    (self.factor / (1.0 - tr)).min(Vec3::ONE)
                } else {
                    self.factor
                };
                (tr, t / tr, base)
            }
            None => (0.0, Vec3::ONE, self.factor),
        };
        let base_color = match self.map_kd {
            Some(map) => ColorInput::Texture { map, factor },
            None => ColorInput::Constant(factor),
        };
        Ok(PbrMaterial {
            name: self.name,
            base_color,
            metallic,
            roughness,
            metallic_roughness,
            ior,
            transmission,
            transmission_map: None,
            transmission_color: ColorInput::Constant(transmission_color),
            normal_map: self.normal_map,
            alpha: self.alpha,
        })
    }
}

/// One channel of a scalar map texel (`-imfchan`; default the first channel).
fn channel(t: Vec4, c: Option<char>) -> f32 {
    match c {
        Some('g') => t.y,
        Some('b') => t.z,
        Some('m') => t.w,
        Some('l') => (t.x + t.y + t.z) / 3.0,
        _ => t.x,
    }
}

/// glTF's packed metallic-roughness texture (green = roughness, blue = metallic) from
/// MTL's separate `map_Pr` and `map_Pm`, at the larger of their resolutions (the other
/// sampled bilinearly); a missing one reads 1.
fn metallic_roughness_texture(
    pr: Option<&(Texture, Option<char>)>,
    pm: Option<&(Texture, Option<char>)>,
) -> Texture {
    let (w, h) = [pr, pm]
        .into_iter()
        .flatten()
        .max_by_key(|(t, _)| t.width() * t.height())
        .map_or((1, 1), |(t, _)| (t.width(), t.height()));
    let read = |m: Option<&(Texture, Option<char>)>, uv: Vec2| {
        m.map_or(1.0, |(t, c)| channel(t.sample(uv), *c))
    };
    let mut texels = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        for x in 0..w {
            // Texel centre, `v` up (top row first).
            let uv = Vec2::new(
                (x as f32 + 0.5) / w as f32,
                1.0 - (y as f32 + 0.5) / h as f32,
            );
            texels.push(Vec4::new(0.0, read(pr, uv), read(pm, uv), 1.0));
        }
    }
    let clamp = [pr, pm]
        .into_iter()
        .flatten()
        .all(|(t, _)| t.wrap == Wrap::Clamp);
    Texture::from_texels(w, h, texels, if clamp { Wrap::Clamp } else { Wrap::Repeat })
}
