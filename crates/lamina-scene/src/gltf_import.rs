//! glTF 2.0 import (`.gltf` with its buffers, or `.glb`), via the `gltf` crate.
//!
//! What is read: the default scene's node hierarchy with its transforms; triangle
//! primitives with positions, normals, tangents and the first texture-coordinate set (with
//! the base colour's `KHR_texture_transform` applied); metallic-roughness materials mapped
//! onto lamina's materials:
//!
//! | glTF | lamina |
//! |---|---|
//! | `pbrMetallicRoughness` (base colour factor × texture, metallic and roughness factors × `metallicRoughnessTexture` B and G) | [`PbrMaterial`] ([`Material::Pbr`], evaluated as `lamina_leaf::PbrBsdf`) |
//! | `normalTexture` + `scale`, vertex `TANGENT` | [`NormalMap`]; without tangents the tangent frame comes from the UVs per triangle |
//! | `alphaMode` `MASK` + `alphaCutoff` | alpha test on the base colour's alpha channel |
//! | `alphaMode` `BLEND` | alpha test at 0.5 (a path tracer has no order-dependent blending) |
//! | `doubleSided` | every lamina material is two-sided |
//! | `KHR_materials_diffuse_transmission` (factor × texture alpha, colour × texture) | the Pbr material's diffuse transmission (the extension's own mix) |
//! | `KHR_materials_ior` | the dielectric's index (F0) |
//! | `KHR_materials_volume` `thicknessFactor` with diffuse transmission | a lamina `leaf`: front map = base colour, alpha = its alpha, blade thickness from the thickness (mesh units, taken as metres); its normal map is ignored (leaves take bump maps) |
//!
//! Every map is read with the first UV set after the base colour's transform; a map asking
//! for another set or transform gets a warning. glTF is `+y` up in metres, as lamina is;
//! texture `v` is flipped to lamina's `v`-up convention. A mesh that one node uses becomes
//! world-space
//! triangles; a mesh that several nodes use becomes one [`Prototype`] (in the mesh's own
//! space) with one [`Instance`] per node, unless the caller asks for everything flattened.

use crate::error::{SceneError, guarded, read_bytes};
use crate::gltf_accessor::{self as acc, check_accessor, read_f32};
use crate::limits::{MAX_GLTF_ELEMENTS, MAX_GLTF_FILE_BYTES, MAX_GLTF_NODES};
use crate::scene::{
    AlphaMask, ColorInput, Instance, Material, Mesh, NormalMap, PbrMaterial, Prototype,
};
use crate::transform::Transform;
use glam::{Mat3, Mat4, Vec2, Vec3, Vec4};
use lamina_leaf::{Encoding, Texture, Wrap};
use std::collections::HashMap;
use std::path::Path;
use std::sync::Arc;

/// Extensions whose absence changes nothing we render, so a file may require them.
const UNDERSTOOD: &[&str] = &[
    "KHR_texture_transform",
    "KHR_materials_ior",
    "KHR_materials_diffuse_transmission",
    "KHR_materials_volume",
    "KHR_mesh_quantization",
];

/// Vertices and triangles read so far from one file (every flattened use of a mesh
/// counted), against [`MAX_GLTF_ELEMENTS`] each.
#[derive(Default)]
struct Budget {
    vertices: usize,
    triangles: usize,
}

/// A glTF file converted to lamina meshes and materials.
#[derive(Debug, Default)]
pub struct GltfScene {
    /// World-space meshes; `material` indexes [`GltfScene::materials`].
    pub meshes: Vec<Mesh>,
    /// glTF meshes used by more than one node, in the mesh's own space (one [`Mesh`] per
    /// triangle primitive); `material` indexes [`GltfScene::materials`].
    pub prototypes: Vec<Prototype>,
    /// One per node using a prototype; `prototype` indexes [`GltfScene::prototypes`],
    /// `transform` is the node's world transform (after the caller's transform).
    pub instances: Vec<Instance>,
    /// Materials in glTF order, then one default material (grey diffuse) at the end.
    pub materials: Vec<Material>,
    /// glTF material names, parallel to `materials` (the default one is `"default"`).
    pub material_names: Vec<String>,
    /// Things that were approximated or ignored, for the user.
    pub warnings: Vec<String>,
}

/// Loads a glTF or GLB file and applies `xf` after the file's own node transforms; meshes
/// used by several nodes become prototypes with instances.
pub fn load_gltf(path: &Path, xf: &Transform) -> Result<GltfScene, SceneError> {
    load_gltf_with(path, xf, true)
}

/// [`load_gltf`]; with `instance_repeated` false every mesh use becomes world-space
/// triangles (no prototypes), as when the whole file is itself one prototype.
///
/// The file (and each external buffer) may have at most [`MAX_GLTF_FILE_BYTES`]; every
/// accessor is checked before it is read (by the crate's own checked accessor reader); a panic inside the
/// gltf crate or an image decoder is an error naming the file.
pub fn load_gltf_with(
    path: &Path,
    xf: &Transform,
    instance_repeated: bool,
) -> Result<GltfScene, SceneError> {
    guarded(path, || {
        let bytes = read_bytes(path, "glTF", MAX_GLTF_FILE_BYTES)?;
        parse_gltf_with(&bytes, path, xf, instance_repeated)
    })
}

/// [`load_gltf`] for a file already in memory, `.gltf` (JSON) or `.glb` (binary): `path`
/// names it in errors and anchors its relative buffer and image URIs. The entry point for
/// fuzzing.
pub fn parse_gltf(bytes: &[u8], path: &Path, xf: &Transform) -> Result<GltfScene, SceneError> {
    guarded(path, || parse_gltf_with(bytes, path, xf, true))
}

/// The gltf crate's validation (every index in range, required fields present, ...),
/// except that it rejects the extensions it does not implement itself even where lamina
/// reads them ([`UNDERSTOOD`]): required extensions are checked by the caller instead.
fn validate(doc: &gltf::Document) -> Result<(), String> {
    use gltf::json::validation::{Error, Validate};
    let root = doc.as_json();
    // gltf-json's own validation indexes `accessors` with a primitive's POSITION index
    // before checking that index (a panic found by fuzzing): check every accessor index a
    // primitive names first.
    let n = root.accessors.len();
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            let targets = prim.targets.iter().flatten().flat_map(|t| {
                [&t.positions, &t.normals, &t.tangents]
                    .into_iter()
                    .flatten()
                    .map(|i| ("targets", i.value()))
            });
            let named = prim
                .attributes
                .values()
                .map(|i| ("attributes", i.value()))
                .chain(prim.indices.iter().map(|i| ("indices", i.value())))
                .chain(targets);
            for (what, i) in named {
                if i >= n {
                    return Err(format!(
                        "meshes[{m}].primitives[{p}].{what}: accessor {i} does not exist \
                         (the file has {n})"
                    ));
                }
            }
        }
    }
    let mut errors = Vec::new();
    root.validate(root, gltf::json::Path::new, &mut |path, error| {
        let path = path().to_string();
        if !(error == Error::Unsupported && path.starts_with("extensionsRequired")) {
            errors.push(format!("{path}: {error}"));
        }
    });
    if errors.is_empty() {
        Ok(())
    } else {
        Err(format!("invalid glTF: {}", errors.join("; ")))
    }
}

/// A relative URI's path: percent-decoded, and valid UTF-8 (the gltf crate panics on one
/// that is not).
fn uri_path(uri: &str) -> Result<String, String> {
    let b = uri.as_bytes();
    let hex = |c: u8| (c as char).to_digit(16).map(|d| d as u8);
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        match (
            b[i],
            b.get(i + 1).copied().and_then(hex),
            b.get(i + 2).copied().and_then(hex),
        ) {
            (b'%', Some(h), Some(l)) => {
                out.push(h << 4 | l);
                i += 3;
            }
            (c, _, _) => {
                out.push(c);
                i += 1;
            }
        }
    }
    String::from_utf8(out).map_err(|_| format!("URI '{uri}' is not UTF-8 once percent-decoded"))
}

/// The file an external buffer URI refers to, as the gltf crate resolves it (`file:` URIs
/// as given, other URIs without a scheme relative to `base`); `None` for `data:` URIs and
/// other schemes (which the crate decodes or rejects itself).
fn buffer_file(base: &Path, uri: &str) -> Result<Option<std::path::PathBuf>, String> {
    if uri.contains(':') {
        return Ok(uri
            .strip_prefix("file://")
            .or_else(|| uri.strip_prefix("file:"))
            .map(std::path::PathBuf::from));
    }
    Ok(Some(base.join(uri_path(uri)?)))
}

fn parse_gltf_with(
    bytes: &[u8],
    path: &Path,
    xf: &Transform,
    instance_repeated: bool,
) -> Result<GltfScene, SceneError> {
    crate::error::fault_point("gltf");
    let fail = |key: &str, msg: String| SceneError::new(path, None, key, msg);
    let gltf = gltf::Gltf::from_slice_without_validation(bytes)
        .map_err(|e| fail("", format!("cannot read glTF: {e}")))?;
    validate(&gltf.document).map_err(|e| fail("", format!("cannot read glTF: {e}")))?;
    for ext in gltf.extensions_required() {
        if !UNDERSTOOD.contains(&ext) {
            return Err(fail(
                "extensionsRequired",
                format!("extension '{ext}' is required by the file but not supported"),
            ));
        }
    }
    let base = path.parent().unwrap_or(Path::new(""));
    let doc = gltf.document;
    // Name the missing buffer file (the gltf crate only says "No such file"), and check
    // each file's size before the crate reads it whole.
    for b in doc.buffers() {
        let key = format!("buffers[{}]", b.index());
        if b.length() as u64 > MAX_GLTF_FILE_BYTES {
            return Err(fail(
                &key,
                format!(
                    "byteLength {} is more than the {MAX_GLTF_FILE_BYTES} supported",
                    b.length()
                ),
            ));
        }
        if let gltf::buffer::Source::Uri(uri) = b.source() {
            let Some(file) = buffer_file(base, uri).map_err(|e| fail(&key, e))? else {
                continue;
            };
            match std::fs::metadata(&file) {
                Err(e) => {
                    return Err(fail(
                        &key,
                        format!("cannot read buffer '{uri}' ({}): {e}", file.display()),
                    ));
                }
                Ok(m) if !m.is_file() => {
                    return Err(fail(
                        &key,
                        format!("buffer '{uri}' ({}) is not a regular file", file.display()),
                    ));
                }
                Ok(m) if m.len() > MAX_GLTF_FILE_BYTES => {
                    return Err(fail(
                        &key,
                        format!(
                            "buffer '{uri}' ({}) is {} bytes, more than the {MAX_GLTF_FILE_BYTES} supported",
                            file.display(),
                            m.len()
                        ),
                    ));
                }
                Ok(_) => {}
            }
        }
    }
    let buffers = gltf::import_buffers(&doc, Some(base), gltf.blob)
        .map_err(|e| fail("buffers", format!("cannot load buffers: {e}")))?;
    let mut out = GltfScene::default();
    let mut images: HashMap<(usize, bool), Texture> = HashMap::new();
    for (i, m) in doc.materials().enumerate() {
        let name = m
            .name()
            .map_or_else(|| format!("material{i}"), str::to_owned);
        let mat = convert_material(
            path,
            &doc,
            &buffers,
            &m,
            &name,
            &mut images,
            &mut out.warnings,
        )?;
        out.materials.push(mat);
        out.material_names.push(name);
    }
    let default_material = out.materials.len() as u32;
    out.materials.push(Material::Diffuse {
        name: "default".into(),
        reflectance: ColorInput::Constant(Vec3::splat(0.5)),
        alpha: None,
    });
    out.material_names.push("default".into());
    let scene = doc
        .default_scene()
        .or_else(|| doc.scenes().next())
        .ok_or_else(|| fail("scenes", "the file has no scene".into()))?;
    let mut stack: Vec<(gltf::Node, Mat4)> = scene.nodes().map(|n| (n, xf.m)).collect();
    // Nodes put on the stack so far: a node hierarchy that is not a tree (a cycle, a node
    // with several parents) could otherwise grow it without bound.
    let mut visited = stack.len();
    let too_many = || {
        fail(
            "nodes",
            format!(
                "the node hierarchy is too deep or cyclic (more than {MAX_GLTF_NODES} node visits)"
            ),
        )
    };
    if visited > MAX_GLTF_NODES {
        return Err(too_many());
    }
    // glTF node hierarchies are trees: a node reached twice (a cycle, or a node with two
    // parents) would be visited without end, or once per path to it.
    let mut reached = vec![false; doc.nodes().len()];
    // (mesh, world transform) for every node with a mesh, in traversal order.
    let mut uses: Vec<(gltf::Mesh, Mat4)> = Vec::new();
    while let Some((node, parent)) = stack.pop() {
        match reached.get_mut(node.index()) {
            Some(r) if !*r => *r = true,
            _ => {
                return Err(fail(
                    &format!("nodes[{}]", node.index()),
                    "is reached twice: the node hierarchy must be a tree (a node in a cycle, with two parents, or listed twice as a root)".into(),
                ));
            }
        }
        let local = Mat4::from_cols_array_2d(&node.transform().matrix());
        let world = parent * local;
        if !world.is_finite() {
            return Err(fail(
                &format!("nodes[{}]", node.index()),
                "transform is not finite".into(),
            ));
        }
        if let Some(mesh) = node.mesh() {
            uses.push((mesh, world));
        }
        visited = visited.saturating_add(node.children().len());
        if visited > MAX_GLTF_NODES {
            return Err(too_many());
        }
        stack.extend(node.children().map(|c| (c, world)));
    }
    let mut budget = Budget::default();
    let mut count: HashMap<usize, usize> = HashMap::new();
    for (m, _) in &uses {
        *count.entry(m.index()).or_default() += 1;
    }
    // glTF mesh index -> prototype index.
    let mut proto_of: HashMap<usize, u32> = HashMap::new();
    for (mesh, world) in &uses {
        let repeated = instance_repeated && count[&mesh.index()] > 1;
        if !repeated {
            let meshes = read_mesh(
                path,
                mesh,
                &buffers,
                Transform::from_matrix(*world),
                default_material,
                &mut out.warnings,
                &mut budget,
            )?;
            out.meshes.extend(meshes);
            continue;
        }
        if Mat3::from_mat4(*world).determinant().abs() < 1e-30 {
            out.warnings.push(format!(
                "a node using mesh {} has a singular (zero-scale) transform; skipped",
                mesh.index()
            ));
            continue;
        }
        let proto = match proto_of.get(&mesh.index()) {
            Some(&p) => p,
            None => {
                let meshes = read_mesh(
                    path,
                    mesh,
                    &buffers,
                    Transform::default(),
                    default_material,
                    &mut out.warnings,
                    &mut budget,
                )?;
                if meshes.is_empty() {
                    continue;
                }
                out.prototypes.push(Prototype {
                    name: mesh
                        .name()
                        .map_or_else(|| format!("mesh{}", mesh.index()), str::to_owned),
                    meshes,
                });
                let p = out.prototypes.len() as u32 - 1;
                proto_of.insert(mesh.index(), p);
                p
            }
        };
        out.instances.push(Instance {
            prototype: proto,
            transform: glam::Affine3A::from_mat4(*world),
        });
    }
    if out.meshes.is_empty() && out.prototypes.is_empty() {
        return Err(fail("meshes", "the file has no triangles to render".into()));
    }
    Ok(out)
}

/// The triangle primitives of `mesh` transformed by `xf`, one [`Mesh`] each.
fn read_mesh(
    path: &Path,
    mesh: &gltf::Mesh,
    buffers: &[gltf::buffer::Data],
    xf: Transform,
    default_material: u32,
    warnings: &mut Vec<String>,
    budget: &mut Budget,
) -> Result<Vec<Mesh>, SceneError> {
    let mut out = Vec::new();
    for (pi, prim) in mesh.primitives().enumerate() {
        let key = format!("meshes[{}].primitives[{pi}]", mesh.index());
        if prim.mode() != gltf::mesh::Mode::Triangles {
            warnings.push(format!(
                "{key}: mode {:?} skipped (only triangles are rendered)",
                prim.mode()
            ));
            continue;
        }
        let material = prim
            .material()
            .index()
            .map_or(default_material, |i| i as u32);
        let uv_xf = prim
            .material()
            .pbr_metallic_roughness()
            .base_color_texture()
            .and_then(|t| t.texture_transform())
            .map(uv_transform);
        if let Some(m) = read_primitive(path, &key, &prim, buffers, xf, material, uv_xf, budget)? {
            out.push(m);
        }
    }
    Ok(out)
}

/// `KHR_texture_transform` as a matrix on `(u, v, 1)` in glTF's `v`-down convention.
fn uv_transform(t: gltf::texture::TextureTransform) -> Mat3 {
    let [ox, oy] = t.offset();
    let [sx, sy] = t.scale();
    let r = t.rotation();
    let translation = Mat3::from_cols(Vec3::X, Vec3::Y, Vec3::new(ox, oy, 1.0));
    let rotation = Mat3::from_cols(
        Vec3::new(r.cos(), -r.sin(), 0.0),
        Vec3::new(r.sin(), r.cos(), 0.0),
        Vec3::Z,
    );
    let scale = Mat3::from_diagonal(Vec3::new(sx, sy, 1.0));
    translation * rotation * scale
}

#[allow(clippy::too_many_arguments)]
fn read_primitive(
    path: &Path,
    key: &str,
    prim: &gltf::Primitive,
    buffers: &[gltf::buffer::Data],
    xf: Transform,
    material: u32,
    uv_xf: Option<Mat3>,
    budget: &mut Budget,
) -> Result<Option<Mesh>, SceneError> {
    use gltf::accessor::Dimensions;
    use gltf::mesh::Semantic;
    let fail = |msg: String| SceneError::new(path, None, key, msg);
    // Types, counts and sizes first, before anything is read or allocated.
    let pos = prim
        .get(&Semantic::Positions)
        .ok_or_else(|| fail("has no POSITION attribute".into()))?;
    check_accessor(&pos, Dimensions::Vec3, acc::POSITION, "POSITION").map_err(fail)?;
    let n = pos.count();
    let normal = prim.get(&Semantic::Normals);
    let tangent = prim.get(&Semantic::Tangents);
    let texcoord = prim.get(&Semantic::TexCoords(0));
    for (a, what) in [
        (&normal, "NORMAL"),
        (&tangent, "TANGENT"),
        (&texcoord, "TEXCOORD_0"),
    ] {
        if let Some(a) = a
            && a.count() != n
        {
            return Err(fail(format!(
                "{what} (accessor {}): count {} differs from the POSITION count {n}",
                a.index(),
                a.count()
            )));
        }
    }
    let index = prim.indices();
    let triangles = index.as_ref().map_or(n, |a| a.count()) / 3;
    budget.vertices = budget.vertices.saturating_add(n);
    budget.triangles = budget.triangles.saturating_add(triangles);
    if budget.vertices > MAX_GLTF_ELEMENTS || budget.triangles > MAX_GLTF_ELEMENTS {
        return Err(fail(format!(
            "the file's meshes make {} vertices and {} triangles so far (every use of a mesh that is flattened counts), more than the {MAX_GLTF_ELEMENTS} supported",
            budget.vertices, budget.triangles
        )));
    }
    let positions: Vec<Vec3> =
        read_f32::<3>(&pos, buffers, Dimensions::Vec3, acc::POSITION, "POSITION")
            .map_err(fail)?
            .into_iter()
            .map(Vec3::from)
            .collect();
    if let Some(bad) = positions
        .iter()
        .position(|p| !p.is_finite() || p.abs().max_element() > 1e12)
    {
        return Err(fail(format!(
            "vertex {bad} is not finite or absurdly large: {:?}",
            positions[bad]
        )));
    }
    let normals: Vec<Vec3> = match &normal {
        Some(a) => read_f32::<3>(a, buffers, Dimensions::Vec3, acc::DIRECTION, "NORMAL")
            .map_err(fail)?
            .into_iter()
            .map(Vec3::from)
            .collect(),
        None => Vec::new(),
    };
    let tangents: Vec<Vec4> = match &tangent {
        Some(a) => read_f32::<4>(a, buffers, Dimensions::Vec4, acc::DIRECTION, "TANGENT")
            .map_err(fail)?
            .into_iter()
            .map(Vec4::from)
            .collect(),
        None => Vec::new(),
    };
    let uvs: Vec<Vec2> = match &texcoord {
        Some(a) => read_f32::<2>(a, buffers, Dimensions::Vec2, acc::TEXCOORD, "TEXCOORD_0")
            .map_err(fail)?
            .into_iter()
            .map(|[u, v]| {
                let p = uv_xf.map_or(Vec3::new(u, v, 1.0), |m| m * Vec3::new(u, v, 1.0));
                Vec2::new(p.x, 1.0 - p.y)
            })
            .collect(),
        None => Vec::new(),
    };
    if let Some(bad) = normals.iter().position(|v| !v.is_finite()) {
        return Err(fail(format!(
            "normal {bad} is not finite: {:?}",
            normals[bad]
        )));
    }
    if let Some(bad) = tangents.iter().position(|v| !v.is_finite()) {
        return Err(fail(format!(
            "tangent {bad} is not finite: {:?}",
            tangents[bad]
        )));
    }
    if let Some(bad) = uvs.iter().position(|v| !v.is_finite()) {
        return Err(fail(format!(
            "texture coordinate {bad} is not finite: {:?}",
            uvs[bad]
        )));
    }
    let flat: Vec<u32> = match &index {
        Some(a) => acc::read_indices(a, buffers).map_err(fail)?,
        None => (0..n as u32).collect(),
    };
    if let Some((k, bad)) = flat.iter().enumerate().find(|&(_, &i)| i as usize >= n) {
        return Err(fail(format!(
            "indices: index {bad} (entry {k}) is out of range ({n} vertices)"
        )));
    }
    let flips = xf.flips();
    let indices: Vec<[u32; 3]> = flat
        .chunks_exact(3)
        .map(|t| {
            if flips {
                [t[0], t[2], t[1]]
            } else {
                [t[0], t[1], t[2]]
            }
        })
        // Degenerate triangles (repeated index or zero area) can never be hit.
        .filter(|t| {
            let [a, b, c] = t.map(|i| positions[i as usize]);
            t[0] != t[1] && t[1] != t[2] && t[0] != t[2] && (b - a).cross(c - a) != Vec3::ZERO
        })
        .collect();
    if indices.is_empty() {
        return Ok(None);
    }
    Ok(Some(Mesh {
        positions: positions.iter().map(|&p| xf.point(p)).collect(),
        normals: normals.iter().map(|&v| xf.normal(v)).collect(),
        // glTF: bitangent = w · (normal × tangent); a mirroring transform flips it.
        tangents: tangents
            .iter()
            .map(|t| {
                let w = if t.w < 0.0 { -1.0 } else { 1.0 };
                xf.vector(t.truncate())
                    .normalize_or_zero()
                    .extend(if flips { -w } else { w })
            })
            .collect(),
        uvs,
        indices,
        material,
    }))
}

/// Decodes glTF image `index` to a texture (sRGB-decoded when `srgb`), cached.
fn image(
    path: &Path,
    doc: &gltf::Document,
    buffers: &[gltf::buffer::Data],
    tex: gltf::Texture,
    srgb: bool,
    cache: &mut HashMap<(usize, bool), Texture>,
) -> Result<Texture, SceneError> {
    let img = tex.source();
    let key = (img.index(), srgb);
    if let Some(t) = cache.get(&key) {
        return Ok(t.clone());
    }
    let fail = |msg: String| SceneError::new(path, None, format!("images[{}]", img.index()), msg);
    let encoding = if srgb {
        Encoding::Srgb
    } else {
        Encoding::Linear
    };
    // Decoded with the size checked from the header first (lamina_leaf::texture).
    let mut t = match img.source() {
        gltf::image::Source::View { view, .. } => {
            let data = buffers
                .get(view.buffer().index())
                .ok_or_else(|| fail("its buffer is missing".into()))?;
            let (start, len) = (view.offset(), view.length());
            let bytes = start
                .checked_add(len)
                .and_then(|end| data.0.get(start..end))
                .ok_or_else(|| {
                    fail(format!(
                        "bufferView {} (byteOffset {start}, byteLength {len}) is beyond its buffer ({} bytes)",
                        view.index(),
                        data.0.len()
                    ))
                })?;
            Texture::decode(bytes, encoding, path).map_err(|e| fail(e.to_string()))?
        }
        gltf::image::Source::Uri { uri, .. } => {
            if uri.starts_with("data:") {
                return Err(fail(
                    "data-URI images are not supported; use a .glb or an image file".into(),
                ));
            }
            let file = path
                .parent()
                .unwrap_or(Path::new(""))
                .join(uri_path(uri).map_err(fail)?);
            Texture::load(&file, encoding).map_err(|e| fail(e.to_string()))?
        }
    };
    t.wrap = match tex.sampler().wrap_s() {
        gltf::texture::WrappingMode::ClampToEdge => Wrap::Clamp,
        _ => Wrap::Repeat,
    };
    let _ = doc;
    cache.insert(key, t.clone());
    Ok(t)
}

fn ext_f32(v: Option<&serde_json::Value>, name: &str, default: f32) -> f32 {
    v.and_then(|v| v.get(name))
        .and_then(|x| x.as_f64())
        .map_or(default, |x| x as f32)
}

/// The texture that a `KHR_materials_diffuse_transmission` texture-info object refers to.
fn ext_texture<'a>(
    path: &Path,
    doc: &'a gltf::Document,
    info: Option<&serde_json::Value>,
    key: &str,
) -> Result<Option<gltf::Texture<'a>>, SceneError> {
    let Some(info) = info else { return Ok(None) };
    let index = info.get("index").and_then(|i| i.as_u64());
    let tex = index.and_then(|i| doc.textures().nth(i as usize));
    match tex {
        Some(t) => Ok(Some(t)),
        None => Err(SceneError::new(
            path,
            None,
            key,
            format!("texture index {index:?} does not exist"),
        )),
    }
}

/// `(texCoord, KHR_texture_transform)` of a texture reference, for checking that all of a
/// material's maps read the coordinates the mesh carries.
fn tex_coord_and_transform(t: &gltf::texture::Info) -> (u32, Option<[f32; 5]>) {
    let xf = t.texture_transform().map(|x| {
        let [ox, oy] = x.offset();
        let [sx, sy] = x.scale();
        [ox, oy, sx, sy, x.rotation()]
    });
    (t.tex_coord(), xf)
}

#[allow(clippy::too_many_arguments)]
fn convert_material(
    path: &Path,
    doc: &gltf::Document,
    buffers: &[gltf::buffer::Data],
    m: &gltf::Material,
    name: &str,
    cache: &mut HashMap<(usize, bool), Texture>,
    warnings: &mut Vec<String>,
) -> Result<Material, SceneError> {
    let pbr = m.pbr_metallic_roughness();
    let factor = Vec4::from(pbr.base_color_factor());
    let base_tex = pbr
        .base_color_texture()
        .map(|t| image(path, doc, buffers, t.texture(), true, cache))
        .transpose()?;
    // Every map is read with the mesh's first UV set after the base colour's transform
    // (see `read_mesh`): say so where a map asks for something else.
    let base_coords = pbr
        .base_color_texture()
        .map(|t| tex_coord_and_transform(&t));
    let mut check_coords = |what: &str, coords: (u32, Option<[f32; 5]>)| {
        let expected = base_coords.unwrap_or((0, coords.1));
        if coords.0 != 0 || coords != expected {
            warnings.push(format!(
                "material '{name}': the {what} map uses other texture coordinates or another \
                 KHR_texture_transform than the base colour; it is read with the base colour's"
            ));
        }
    };
    let mr_tex = match pbr.metallic_roughness_texture() {
        Some(t) => {
            check_coords("metallic-roughness", tex_coord_and_transform(&t));
            Some(image(path, doc, buffers, t.texture(), false, cache)?)
        }
        None => None,
    };
    let normal_map = match m.normal_texture() {
        Some(t) => {
            // (the gltf crate does not expose a normal texture's KHR_texture_transform)
            check_coords("normal", (t.tex_coord(), base_coords.and_then(|b| b.1)));
            let scale = t.scale();
            if !scale.is_finite() || scale.abs() > 100.0 {
                return Err(SceneError::new(
                    path,
                    None,
                    format!("materials[{}].normalTexture.scale", m.index().unwrap_or(0)),
                    format!("must be finite and within ±100, got {scale}"),
                ));
            }
            Some(NormalMap {
                map: image(path, doc, buffers, t.texture(), false, cache)?,
                scale,
            })
        }
        None => None,
    };
    let alpha = match m.alpha_mode() {
        gltf::material::AlphaMode::Opaque => None,
        mode => {
            let cutoff = if mode == gltf::material::AlphaMode::Mask {
                m.alpha_cutoff().unwrap_or(0.5)
            } else {
                0.5
            };
            if mode == gltf::material::AlphaMode::Blend {
                warnings.push(format!(
                    "material '{name}': alphaMode BLEND rendered as a cut-out at 0.5"
                ));
            }
            match &base_tex {
                // The cut-out compares texture alpha times the factor's alpha with the cutoff.
                Some(t) => Some(AlphaMask {
                    map: t.clone(),
                    use_alpha_channel: true,
                    cutoff: (cutoff / factor.w.max(1e-6)).min(1.0),
                }),
                None if factor.w < cutoff => Some(AlphaMask {
                    map: Texture::constant(Vec4::ZERO),
                    use_alpha_channel: true,
                    cutoff: 0.5,
                }),
                None => None,
            }
        }
    };
    let base = match &base_tex {
        Some(t) => ColorInput::Texture {
            map: t.clone(),
            factor: factor.truncate(),
        },
        None => ColorInput::Constant(factor.truncate()),
    };
    let ext = m.extensions();
    let dt = ext.and_then(|e| e.get("KHR_materials_diffuse_transmission"));
    let volume = ext.and_then(|e| e.get("KHR_materials_volume"));
    if ext.is_some_and(|e| e.contains_key("KHR_materials_translucency")) {
        warnings.push(format!(
            "material '{name}': KHR_materials_translucency (not a ratified extension) ignored"
        ));
    }
    let mut out = PbrMaterial {
        name: name.into(),
        base_color: base,
        metallic: pbr.metallic_factor().clamp(0.0, 1.0),
        roughness: pbr.roughness_factor().clamp(0.0, 1.0),
        metallic_roughness: mr_tex,
        ior: 1.5,
        transmission: 0.0,
        transmission_map: None,
        transmission_color: ColorInput::Constant(Vec3::ONE),
        normal_map,
        alpha,
    };
    if let Some(ior) = ext.and_then(|e| e.get("KHR_materials_ior")) {
        let v = ext_f32(Some(ior), "ior", 1.5);
        if (1.0..=3.0).contains(&v) {
            out.ior = v;
        } else {
            warnings.push(format!(
                "material '{name}': KHR_materials_ior {v} outside [1, 3]; 1.5 used"
            ));
        }
    }
    let Some(dt) = dt else {
        return Ok(Material::Pbr(Box::new(out)));
    };
    let key = |k: &str| {
        format!(
            "materials[{}].extensions.KHR_materials_diffuse_transmission.{k}",
            m.index().unwrap_or(0)
        )
    };
    out.transmission = ext_f32(Some(dt), "diffuseTransmissionFactor", 0.0).clamp(0.0, 1.0);
    let c = dt
        .get("diffuseTransmissionColorFactor")
        .and_then(|v| serde_json::from_value::<[f32; 3]>(v.clone()).ok())
        .map_or(Vec3::ONE, Vec3::from)
        .clamp(Vec3::ZERO, Vec3::ONE);
    let t_tex = ext_texture(
        path,
        doc,
        dt.get("diffuseTransmissionTexture"),
        &key("diffuseTransmissionTexture"),
    )?;
    let c_tex = ext_texture(
        path,
        doc,
        dt.get("diffuseTransmissionColorTexture"),
        &key("diffuseTransmissionColorTexture"),
    )?;
    out.transmission_map = t_tex
        .map(|t| image(path, doc, buffers, t, false, cache))
        .transpose()?;
    out.transmission_color = match c_tex {
        Some(t) => ColorInput::Texture {
            map: image(path, doc, buffers, t, true, cache)?,
            factor: c,
        },
        None => ColorInput::Constant(c),
    };
    if let Some(v) = volume {
        let thickness_m = ext_f32(Some(v), "thicknessFactor", 0.0);
        if thickness_m > 0.0 {
            let params = lamina_leaf::LeafParams {
                thickness_mm: (thickness_m * 1000.0).clamp(0.01, 5.0),
                ..Default::default()
            };
            let maps = lamina_leaf::LeafMaps {
                front: base_tex.clone(),
                alpha: out.alpha.as_ref().map(|a| a.map.clone()),
                ..Default::default()
            };
            if out.normal_map.is_some() {
                warnings.push(format!(
                    "material '{name}': rendered as a lamina leaf, whose relief comes from a \
                     bump (height) map; the normal map is ignored"
                ));
            }
            let leaf = lamina_leaf::LeafMaterial::new(maps, params).map_err(|e| {
                SceneError::new(path, None, format!("material '{name}'"), e.to_string())
            })?;
            return Ok(Material::Leaf {
                name: name.into(),
                leaf: Arc::new(leaf),
            });
        }
    }
    Ok(Material::Pbr(Box::new(out)))
}
