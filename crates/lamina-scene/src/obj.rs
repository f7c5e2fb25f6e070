//! Wavefront OBJ meshes with their MTL materials (via `tobj`). Each shape is split by
//! `usemtl` into one [`Mesh`] per material; faces are triangulated. OBJ `vt` texture
//! coordinates have `v` up, as lamina's textures do.
//!
//! MTL to lamina (paths in an MTL file are relative to the MTL file):
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

use crate::error::{SceneError, guarded, read_text};
use crate::limits::MAX_TEXT_FILE_BYTES;
use crate::scene::{AlphaMask, ColorInput, Material, Mesh, NormalMap, PbrMaterial};
use glam::{Vec2, Vec3, Vec4};
use lamina_leaf::texture::Wrap;
use lamina_leaf::{Encoding, Texture};
use std::cell::RefCell;
use std::path::{Path, PathBuf};

/// An OBJ file as meshes (in the file's space) and materials.
#[derive(Debug, Default)]
pub struct ObjScene {
    /// One mesh per shape and material; `material` indexes [`ObjScene::materials`].
    pub meshes: Vec<Mesh>,
    /// The MTL materials (in the order of the `mtllib` files and their `newmtl`s), then
    /// one default material (grey diffuse 0.5) at the end.
    pub materials: Vec<Material>,
    /// Names parallel to `materials` (the default one is `"default"`).
    pub material_names: Vec<String>,
    /// Things that were approximated, for the user.
    pub warnings: Vec<String>,
}

/// Loads an OBJ file with its MTL materials. Errors (naming the .obj or .mtl file, the line
/// where known, and the texture path): unreadable files, a missing `mtllib` file, a
/// `usemtl` of an undefined material, missing or corrupt textures, non-finite vertices,
/// face indices out of range, no triangles.
///
/// The OBJ and each MTL file may have at most [`crate::limits::MAX_TEXT_FILE_BYTES`]; every
/// texture's size is checked before it is decoded; a panic inside tobj or a decoder is an
/// error naming the file.
pub fn load_obj(path: &Path) -> Result<ObjScene, SceneError> {
    guarded(path, || {
        let text = read_text(path, "OBJ", MAX_TEXT_FILE_BYTES)?;
        parse_obj_text(&text, path)
    })
}

/// [`load_obj`] for OBJ text in memory: `path` names it in errors and anchors its `mtllib`
/// files (read from disk). The entry point for fuzzing.
pub fn parse_obj(text: &str, path: &Path) -> Result<ObjScene, SceneError> {
    guarded(path, || parse_obj_text(text, path))
}

/// MTL text as tobj can read it: a colour statement with one number (`Kd 0.5`, which the
/// MTL format allows and means grey) written out as three, since tobj panics on it.
/// [`scan_mtl`] has rejected every other short colour statement.
fn normalise_mtl(text: &str) -> String {
    let mut out = String::with_capacity(text.len() + 64);
    for line in text.lines() {
        let mut words = line.split_whitespace();
        match (words.next(), words.next(), words.next()) {
            (Some(tag @ ("Ka" | "Kd" | "Ks" | "Ke")), Some(x), None) => {
                out.push_str(&format!("{tag} {x} {x} {x}"));
            }
            _ => out.push_str(line),
        }
        out.push('\n');
    }
    out
}

/// Checks an MTL file's size and its colour statements (`Ka`, `Kd`, `Ks`, `Ke`: one or
/// three numbers), which tobj would otherwise panic on or reject without a line.
fn scan_mtl(obj: &Path, obj_line: Option<usize>, file: &Path) -> Result<(), SceneError> {
    let text = read_text(file, "the MTL file", MAX_TEXT_FILE_BYTES)
        .map_err(|e| SceneError::new(obj, obj_line, "mtllib", e.message))?;
    for (i, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        let Some(tag @ ("Ka" | "Kd" | "Ks" | "Ke")) = words.next() else {
            continue;
        };
        let values: Vec<&str> = words.take(3).collect();
        let bad = |msg: String| SceneError::new(file, Some(i + 1), tag, msg);
        if values.len() != 1 && values.len() != 3 {
            return Err(bad(format!(
                "needs one number (grey) or three (r g b), got {}",
                values.len()
            )));
        }
        if let Some(v) = values.iter().find(|v| v.parse::<f32>().is_err()) {
            return Err(bad(format!(
                "'{v}' is not a number (spectral and xyz colours are not supported)"
            )));
        }
    }
    Ok(())
}

fn parse_obj_text(text: &str, path: &Path) -> Result<ObjScene, SceneError> {
    crate::error::fault_point("obj");
    let dir = path.parent().unwrap_or(Path::new("")).to_owned();
    prescan(path, text, &dir, true)?;
    // Every MTL file tobj asks for, with the materials it defined (in tobj's order).
    let loaded: RefCell<Vec<(PathBuf, Vec<String>)>> = RefCell::new(Vec::new());
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ..Default::default()
    };
    let (models, materials) =
        tobj::load_obj_buf(&mut std::io::Cursor::new(text.as_bytes()), &opts, |p| {
            let file = dir.join(p);
            // Checked by `prescan` (size and colour statements).
            let r = match std::fs::read_to_string(&file) {
                Ok(t) => tobj::load_mtl_buf(&mut std::io::Cursor::new(normalise_mtl(&t))),
                Err(_) => Err(tobj::LoadError::OpenFileFailed),
            };
            if let Ok((mats, _)) = &r {
                loaded
                    .borrow_mut()
                    .push((file, mats.iter().map(|m| m.name.clone()).collect()));
            }
            r
        })
        .map_err(|e| SceneError::new(path, None, "", format!("cannot load OBJ: {e}")))?;
    let materials = materials.map_err(|e| {
        SceneError::new(
            path,
            None,
            "mtllib",
            format!("cannot load the MTL file: {e}"),
        )
    })?;
    let mtl_of = |name: &str| -> PathBuf {
        loaded
            .borrow()
            .iter()
            .rev()
            .find(|(_, names)| names.iter().any(|n| n == name))
            .map_or_else(|| path.to_owned(), |(f, _)| f.clone())
    };
    let mut out = ObjScene::default();
    // Per material: the texture-coordinate transform of its maps (`-s`, `-o`).
    let mut uv_transforms = Vec::new();
    for m in &materials {
        let mtl = mtl_of(&m.name);
        let (mat, uv) = convert_material(&mtl, m, &mut out.warnings)?;
        out.materials.push(mat);
        out.material_names.push(m.name.clone());
        uv_transforms.push(uv);
    }
    for (i, line) in text.lines().enumerate() {
        if let Some(name) = line.trim().strip_prefix("usemtl") {
            let name = name.trim();
            if !out.material_names.iter().any(|n| n == name) {
                out.warnings.push(format!(
                    "line {}: usemtl '{name}' is not defined by any MTL file; grey default used",
                    i + 1
                ));
            }
        }
    }
    let default = out.materials.len() as u32;
    out.materials.push(Material::Diffuse {
        name: "default".into(),
        reflectance: ColorInput::Constant(Vec3::splat(0.5)),
        alpha: None,
    });
    out.material_names.push("default".into());
    out.meshes = meshes(path, models, |id| {
        id.map_or(default, |i| (i as u32).min(default))
    })?;
    for mesh in &mut out.meshes {
        if let Some(Some((scale, offset))) = uv_transforms.get(mesh.material as usize) {
            for uv in &mut mesh.uvs {
                *uv = *uv * *scale + *offset;
            }
        }
    }
    Ok(out)
}

/// Checks what tobj would accept silently or report without a line: `mtllib` files that
/// do not exist, vertices that are not finite, faces that refer to vertices not (yet)
/// defined.
fn prescan(path: &Path, text: &str, dir: &Path, mtl: bool) -> Result<(), SceneError> {
    let (mut nv, mut nvt, mut nvn) = (0i64, 0i64, 0i64);
    for (i, line) in text.lines().enumerate() {
        let ln = Some(i + 1);
        let line = line.trim();
        let mut words = line.split_whitespace();
        let Some(tag) = words.next() else { continue };
        match tag {
            "mtllib" if mtl => {
                let name = line["mtllib".len()..].trim();
                let file = dir.join(name);
                if let Err(e) = std::fs::metadata(&file) {
                    return Err(SceneError::new(
                        path,
                        ln,
                        "mtllib",
                        format!("cannot read the MTL file '{}': {e}", file.display()),
                    ));
                }
                scan_mtl(path, ln, &file)?;
            }
            "v" | "vt" | "vn" => {
                let count = if tag == "vt" { 2 } else { 3 };
                for w in words.take(count) {
                    if !w.parse::<f32>().is_ok_and(f32::is_finite) {
                        return Err(SceneError::new(
                            path,
                            ln,
                            tag,
                            format!("'{w}' is not a finite number"),
                        ));
                    }
                }
                match tag {
                    "v" => nv += 1,
                    "vt" => nvt += 1,
                    _ => nvn += 1,
                }
            }
            "f" => {
                for w in words {
                    for (j, part) in w.split('/').enumerate() {
                        if part.is_empty() {
                            continue;
                        }
                        let n = [nv, nvt, nvn].get(j).copied().unwrap_or(0);
                        let what = ["vertex", "texture coordinate", "normal"]
                            .get(j)
                            .copied()
                            .unwrap_or("index");
                        let ok = part
                            .parse::<i64>()
                            .is_ok_and(|k| (k > 0 && k <= n) || (k < 0 && -k <= n));
                        if !ok {
                            return Err(SceneError::new(
                                path,
                                ln,
                                "f",
                                format!(
                                    "{what} index '{part}' is out of range (1..{n} defined so far)"
                                ),
                            ));
                        }
                    }
                }
            }
            "usemtl" | "o" | "g" | "s" | "vp" | "l" | "p" | "#" => {}
            _ => {}
        }
    }
    Ok(())
}

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

/// MTL material to lamina material and the texture-coordinate transform (`uv * scale +
/// offset`) its maps ask for; see the module docs for the mapping.
fn convert_material(
    mtl: &Path,
    m: &tobj::Material,
    warnings: &mut Vec<String>,
) -> Result<(Material, Option<(Vec2, Vec2)>), SceneError> {
    let dir = mtl.parent().unwrap_or(Path::new(""));
    let f = Mtl {
        path: mtl,
        text: std::fs::read_to_string(mtl).unwrap_or_default(),
        name: &m.name,
    };
    const BUMP: &[&str] = &["map_Bump", "map_bump", "bump"];
    let err = |k: &str, msg: String| {
        // tobj merges `bump` into `map_Bump`.
        let keys: &[&str] = if k == "map_Bump" { BUMP } else { &[k] };
        f.err(k, keys, msg)
    };
    // Every map used, with its options, for the shared texture-coordinate transform.
    let mut used: Vec<(&str, MapSpec)> = Vec::new();
    let spec = |k: &str, v: &str| parse_map(v).map_err(|e| err(k, e));
    let texture = |k: &str, s: &MapSpec, enc: Encoding| -> Result<Texture, SceneError> {
        let p = dir.join(&s.file);
        let mut t = Texture::load(&p, enc)
            .map_err(|e| err(k, format!("cannot load texture '{}': {e}", p.display())))?;
        if s.clamp {
            t.wrap = Wrap::Clamp;
        }
        Ok(t)
    };
    let finite3 = |k: &str, v: [f32; 3]| -> Result<Vec3, SceneError> {
        let v = Vec3::from(v);
        if !v.is_finite() {
            return Err(err(k, format!("must be finite, got {:?}", v.to_array())));
        }
        Ok(v.clamp(Vec3::ZERO, Vec3::ONE))
    };
    // A scalar statement of the PBR extension (`Pr 0.4`), in [0, 1].
    let unit = |k: &str| -> Result<Option<f32>, SceneError> {
        let Some(v) = m.unknown_param.get(k) else {
            return Ok(None);
        };
        let x = v
            .trim()
            .parse::<f32>()
            .map_err(|_| err(k, format!("not a number: '{}'", v.trim())))?;
        if !(0.0..=1.0).contains(&x) {
            return Err(err(k, format!("must be in [0, 1], got {x}")));
        }
        Ok(Some(x))
    };
    let kd = m.diffuse.map(|d| finite3("Kd", d)).transpose()?;
    let map_kd = match m.diffuse_texture.as_deref() {
        Some(v) => {
            let s = spec("map_Kd", v)?;
            let t = texture("map_Kd", &s, Encoding::Srgb)?;
            used.push(("map_Kd", s));
            Some(t)
        }
        None => None,
    };
    let has_alpha = |t: &Texture| t.texels().iter().any(|x| x.w < 1.0);
    let mut alpha = match &m.dissolve_texture {
        Some(v) => {
            let s = spec("map_d", v)?;
            let t = texture("map_d", &s, Encoding::Linear)?;
            used.push(("map_d", s));
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
        warnings.push(format!(
            "material '{}': d = {d} (dissolve) without a map: rendered invisible",
            m.name
        ));
        alpha = Some(AlphaMask {
            map: Texture::constant(Vec4::ZERO),
            use_alpha_channel: false,
            cutoff: 0.5,
        });
    }
    let tf = match m.unknown_param.get("Tf") {
        Some(v) => {
            let n: Vec<f32> = v
                .split_whitespace()
                .map(|x| x.parse::<f32>())
                .collect::<Result<_, _>>()
                .map_err(|_| err("Tf", format!("not numbers: '{v}'")))?;
            let c = match n[..] {
                [g] => [g; 3],
                [r, g, b, ..] => [r, g, b],
                _ => return Err(err("Tf", format!("not an RGB colour: '{v}'"))),
            };
            let c = finite3("Tf", c)?;
            (c.max_element() > 0.0 && c != Vec3::ONE).then_some(c)
        }
        None => None,
    };

    // Gloss: a specular colour or the PBR extension's roughness / metallic.
    let ks = m.specular.map(|v| finite3("Ks", v)).transpose()?;
    let pr = unit("Pr")?;
    let pm = unit("Pm")?;
    let mut scalar_map = |k: &'static str| -> Result<Option<(Texture, Option<char>)>, SceneError> {
        match m.unknown_param.get(k) {
            Some(v) => {
                let s = spec(k, v)?;
                let t = texture(k, &s, Encoding::Linear)?;
                let c = s.channel;
                used.push((k, s));
                Ok(Some((t, c)))
            }
            None => Ok(None),
        }
    };
    let map_pr = scalar_map("map_Pr")?;
    let map_pm = scalar_map("map_Pm")?;
    // Relief: `norm` is a tangent-space normal map; `map_Bump` / `bump` is read as one
    // when it is coloured (Blender writes its normal maps there), and ignored when it is
    // grey (a classic height map).
    let normal_scale = |k: &str, s: &MapSpec| -> Result<f32, SceneError> {
        let bm = s.bm.unwrap_or(1.0);
        if !(0.0..=10.0).contains(&bm) {
            return Err(err(k, format!("-bm must be in [0, 10], got {bm}")));
        }
        Ok(bm)
    };
    let mut normal_map = None;
    if let Some(v) = m.unknown_param.get("norm") {
        let s = spec("norm", v)?;
        normal_map = Some(NormalMap {
            map: texture("norm", &s, Encoding::Linear)?,
            scale: normal_scale("norm", &s)?,
        });
        used.push(("norm", s));
    }
    if let Some(v) = &m.normal_texture {
        let s = spec("map_Bump", v)?;
        if normal_map.is_some() {
            warnings.push(format!(
                "material '{}': both norm and map_Bump/bump: norm is the normal map, map_Bump ignored",
                m.name
            ));
        } else {
            let t = texture("map_Bump", &s, Encoding::Linear)?;
            let grey = t
                .texels()
                .iter()
                .all(|x| (x.x - x.y).abs() < 1.5 / 255.0 && (x.y - x.z).abs() < 1.5 / 255.0);
            if grey {
                warnings.push(format!(
                    "material '{}': map_Bump/bump '{}' is a grey height map; height maps are not supported, ignored",
                    m.name, s.file
                ));
            } else {
                warnings.push(format!(
                    "material '{}': map_Bump/bump '{}' is read as a tangent-space normal map (OpenGL convention, strength -bm)",
                    m.name, s.file
                ));
                normal_map = Some(NormalMap {
                    scale: normal_scale("map_Bump", &s)?,
                    map: t,
                });
                used.push(("map_Bump", s));
            }
        }
    }

    for (k, s) in &used {
        if !s.ignored.is_empty() {
            warnings.push(format!(
                "material '{}': {k}: texture options {} ignored",
                m.name,
                s.ignored.join(", ")
            ));
        }
    }
    // One texture-coordinate transform per material (lamina maps have none of their own).
    let uv = match used.first() {
        Some((_, first))
            if used
                .iter()
                .all(|(_, s)| s.uv_transform() == first.uv_transform()) =>
        {
            Some(first.uv_transform()).filter(|t| *t != (Vec2::ONE, Vec2::ZERO))
        }
        Some(_) => {
            warnings.push(format!(
                "material '{}': its maps have different -s/-o options ({}); all ignored",
                m.name,
                used.iter()
                    .map(|(k, s)| {
                        let (sc, o) = s.uv_transform();
                        format!("{k}: -s {} {} -o {} {}", sc.x, sc.y, o.x, o.y)
                    })
                    .collect::<Vec<_>>()
                    .join("; ")
            ));
            None
        }
        None => None,
    };

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
    let gloss = ks.is_some_and(|k| k.max_element() > 0.0)
        || pr.is_some()
        || pm.is_some()
        || map_pr.is_some()
        || map_pm.is_some();
    if !gloss && normal_map.is_none() {
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

    // Pbr. Roughness: Pr, else from Ns (only with a specular colour), else 0.5; a map
    // multiplies its factor, which is 1 when only the map is given (glTF semantics).
    let roughness = match (pr, m.shininess) {
        (Some(r), _) => r,
        (None, _) if map_pr.is_some() => 1.0,
        (None, Some(ns)) => {
            if !ns.is_finite() || ns < 0.0 {
                return Err(err("Ns", format!("must be finite and >= 0, got {ns}")));
            }
            phong_exponent_to_roughness(ns)
        }
        (None, None) => 0.5,
    };
    let metallic = pm.unwrap_or(if map_pm.is_some() { 1.0 } else { 0.0 });
    let metallic_roughness = (map_pr.is_some() || map_pm.is_some())
        .then(|| metallic_roughness_texture(map_pr.as_ref(), map_pm.as_ref()));
    // Ni is the index of refraction; exporters write 1 (or nonsense) when unset.
    let ior = match m.optical_density {
        Some(n) if n > 1.0 && n <= 3.0 => n,
        _ => 1.5,
    };
    // Tf as diffuse transmission: (1 - t) base reflected, t colour transmitted, with
    // t = max(Tf), colour Tf / t and base Kd / (1 - t) (clamped to 1).
    let (transmission, transmission_color, factor) = match tf {
        Some(t) => {
            let tr = t.max_element().min(1.0);
            let base = if tr < 1.0 {
                (factor / (1.0 - tr)).min(Vec3::ONE)
            } else {
                factor
            };
            (tr, t / tr, base)
        }
        None => (0.0, Vec3::ONE, factor),
    };
    let base_color = match map_kd {
        Some(map) => ColorInput::Texture { map, factor },
        None => ColorInput::Constant(factor),
    };
    let pbr = PbrMaterial {
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
        alpha,
    };
    Ok((Material::Pbr(Box::new(pbr)), uv))
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

/// Geometry only: every shape with `material`, MTL files not read.
/// The same checks and limits as [`load_obj`].
pub fn load_obj_meshes(path: &Path, material: u32) -> Result<Vec<Mesh>, SceneError> {
    guarded(path, || {
        crate::error::fault_point("obj_meshes");
        let text = read_text(path, "OBJ", MAX_TEXT_FILE_BYTES)?;
        let dir = path.parent().unwrap_or(Path::new(""));
        prescan(path, &text, dir, false)?;
        let opts = tobj::LoadOptions {
            triangulate: true,
            single_index: true,
            ..Default::default()
        };
        let (models, _materials) =
            tobj::load_obj_buf(&mut std::io::Cursor::new(text.as_bytes()), &opts, |_| {
                Err(tobj::LoadError::OpenFileFailed)
            })
            .map_err(|e| SceneError::new(path, None, "", format!("cannot load OBJ: {e}")))?;
        meshes(path, models, |_| material)
    })
}

/// tobj models to meshes, checked; `material` maps tobj's material id.
fn meshes(
    path: &Path,
    models: Vec<tobj::Model>,
    material: impl Fn(Option<usize>) -> u32,
) -> Result<Vec<Mesh>, SceneError> {
    let mut meshes = Vec::new();
    for model in models {
        let m = &model.mesh;
        let positions: Vec<Vec3> = m
            .positions
            .chunks_exact(3)
            .map(|p| Vec3::new(p[0], p[1], p[2]))
            .collect();
        if positions.iter().any(|p| !p.is_finite()) {
            return Err(SceneError::new(
                path,
                None,
                &model.name,
                "a vertex position is not a finite number",
            ));
        }
        let normals: Vec<Vec3> = m
            .normals
            .chunks_exact(3)
            .map(|p| Vec3::new(p[0], p[1], p[2]).normalize_or_zero())
            .collect();
        let uvs: Vec<Vec2> = m
            .texcoords
            .chunks_exact(2)
            .map(|p| Vec2::new(p[0], p[1]))
            .collect();
        let n = positions.len();
        if (!normals.is_empty() && normals.len() != n) || (!uvs.is_empty() && uvs.len() != n) {
            return Err(SceneError::new(
                path,
                None,
                &model.name,
                "normal or texture-coordinate count differs from vertex count",
            ));
        }
        let mut indices = Vec::with_capacity(m.indices.len() / 3);
        for t in m.indices.chunks_exact(3) {
            if t.iter().any(|&i| i as usize >= n) {
                return Err(SceneError::new(
                    path,
                    None,
                    &model.name,
                    "a face refers to a vertex that does not exist",
                ));
            }
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| positions[i as usize]);
            // Zero-area triangles can never be hit.
            if (b - a).cross(c - a) != Vec3::ZERO {
                indices.push([t[0], t[1], t[2]]);
            }
        }
        if indices.is_empty() {
            continue;
        }
        meshes.push(Mesh {
            positions,
            normals,
            tangents: Vec::new(),
            uvs,
            indices,
            material: material(m.material_id),
        });
    }
    if meshes.is_empty() {
        return Err(SceneError::new(
            path,
            None,
            "",
            "the OBJ file has no triangles",
        ));
    }
    Ok(meshes)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(name: &str, text: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("lamina-obj-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn loads_a_quad_as_two_triangles() {
        let p = write(
            "q.obj",
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3 4/4\n",
        );
        let m = load_obj_meshes(&p, 7).unwrap();
        assert_eq!(m.len(), 1);
        assert_eq!(m[0].indices.len(), 2);
        assert_eq!(m[0].uvs.len(), 4);
        assert_eq!(m[0].material, 7);
    }

    #[test]
    fn rejects_empty_and_nan() {
        let p = write("e.obj", "# nothing\n");
        assert!(
            load_obj_meshes(&p, 0)
                .unwrap_err()
                .to_string()
                .contains("no triangles")
        );
        let p = write("n.obj", "v nan 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\n");
        let e = load_obj_meshes(&p, 0).map(|_| ()).unwrap_err().to_string();
        assert!(e.contains("finite") || e.contains("cannot load"), "{e}");
    }
}
