//! glTF 2.0 import (`.gltf` with its buffers, or `.glb`), via the `gltf` crate.
//!
//! What is read: the default scene's node hierarchy with its transforms; triangle
//! primitives with positions, normals, tangents and the first texture-coordinate set (with
//! the base colour's `KHR_texture_transform` applied); metallic-roughness materials mapped
//! onto lamina's materials:
//!
//! | glTF | lamina |
//! |---|---|
//! | `pbrMetallicRoughness` (base colour factor × texture, metallic and roughness factors × `metallicRoughnessTexture` B and G) | [`PbrMaterial`](crate::scene::PbrMaterial) ([`Material::Pbr`], evaluated as `lamina_leaf::PbrBsdf`) |
//! | `normalTexture` + `scale`, vertex `TANGENT` | [`NormalMap`](crate::scene::NormalMap); without tangents the tangent frame comes from the UVs per triangle |
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
use crate::scene::{ColorInput, Instance, Material, Mesh, Prototype};
use crate::transform::Transform;
use glam::{Mat3, Mat4, Vec2, Vec3, Vec4};
use lamina_leaf::Texture;
use std::collections::HashMap;
use std::path::Path;

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
pub(crate) fn uri_path(uri: &str) -> Result<String, String> {
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
    check_buffer_files(&doc, base, &fail)?;
    let buffers = gltf::import_buffers(&doc, Some(base), gltf.blob)
        .map_err(|e| fail("buffers", format!("cannot load buffers: {e}")))?;
    let mut out = GltfScene::default();
    read_materials(path, &doc, &buffers, &mut out)?;
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
    let uses = mesh_uses(&doc, &scene, xf, &fail)?;
    let meshes = MeshReader {
        path,
        buffers: &buffers,
        default_material,
    };
    place_meshes(&meshes, &uses, instance_repeated, &mut out)?;
    if out.meshes.is_empty() && out.prototypes.is_empty() {
        return Err(fail("meshes", "the file has no triangles to render".into()));
    }
    Ok(out)
}

/// Names a missing buffer file (the gltf crate only says "No such file"), and checks each
/// file's size before the crate reads it whole.
fn check_buffer_files(
    doc: &gltf::Document,
    base: &Path,
    fail: &dyn Fn(&str, String) -> SceneError,
) -> Result<(), SceneError> {
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
        let gltf::buffer::Source::Uri(uri) = b.source() else {
            continue;
        };
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
    Ok(())
}

/// Every glTF material as a lamina material, in file order (images decoded once).
fn read_materials(
    path: &Path,
    doc: &gltf::Document,
    buffers: &[gltf::buffer::Data],
    out: &mut GltfScene,
) -> Result<(), SceneError> {
    let mut images: HashMap<(usize, bool), Texture> = HashMap::new();
    for (i, m) in doc.materials().enumerate() {
        let name = m
            .name()
            .map_or_else(|| format!("material{i}"), str::to_owned);
        let mat = crate::gltf_material::convert_material(
            path,
            doc,
            buffers,
            &m,
            &name,
            &mut images,
            &mut out.warnings,
        )?;
        out.materials.push(mat);
        out.material_names.push(name);
    }
    Ok(())
}

/// (mesh, world transform) for every node of `scene` with a mesh, in traversal order;
/// the node hierarchy must be a tree of at most [`MAX_GLTF_NODES`] visits.
fn mesh_uses<'a>(
    doc: &gltf::Document,
    scene: &gltf::Scene<'a>,
    xf: &Transform,
    fail: &dyn Fn(&str, String) -> SceneError,
) -> Result<Vec<(gltf::Mesh<'a>, Mat4)>, SceneError> {
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
    let mut uses = Vec::new();
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
    Ok(uses)
}

/// What reading a glTF mesh needs besides the mesh.
struct MeshReader<'a> {
    path: &'a Path,
    buffers: &'a [gltf::buffer::Data],
    default_material: u32,
}

/// Puts every mesh use into `out`: in world space, or (with `instance_repeated`, for a
/// mesh used by several nodes) as one prototype with an instance per node.
fn place_meshes(
    r: &MeshReader,
    uses: &[(gltf::Mesh, Mat4)],
    instance_repeated: bool,
    out: &mut GltfScene,
) -> Result<(), SceneError> {
    let mut budget = Budget::default();
    let mut count: HashMap<usize, usize> = HashMap::new();
    for (m, _) in uses {
        *count.entry(m.index()).or_default() += 1;
    }
    // glTF mesh index -> prototype index.
    let mut proto_of: HashMap<usize, u32> = HashMap::new();
    for (mesh, world) in uses {
        let repeated = instance_repeated && count[&mesh.index()] > 1;
        if !repeated {
            let meshes = read_mesh(
                r.path,
                mesh,
                r.buffers,
                Transform::from_matrix(*world),
                r.default_material,
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
                    r.path,
                    mesh,
                    r.buffers,
                    Transform::default(),
                    r.default_material,
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
    Ok(())
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
