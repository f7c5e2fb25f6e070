//! glTF import: a small hand-made file, bad files, and the real plant when ../shared exists.

use lamina_scene::gltf_import::load_gltf;
use lamina_scene::transform::Transform;
use lamina_scene::{Material, parse_scene};
mod common;
use common::b64;
use std::path::{Path, PathBuf};

fn scratch(name: &str) -> PathBuf {
    common::scratch("gltf", name)
}

/// A one-triangle glTF with two nodes instancing the same mesh, the second translated by
/// +2 in x, and a diffuse-transmission material.
fn triangle_gltf(positions: [[f32; 3]; 3], extra: &str) -> String {
    let mut bytes = Vec::new();
    for p in positions {
        for c in p {
            bytes.extend(c.to_le_bytes());
        }
    }
    let uri = format!("data:application/octet-stream;base64,{}", b64(&bytes));
    format!(
        r#"{{
  "asset": {{"version": "2.0"}},
  {extra}
  "scene": 0,
  "scenes": [{{"nodes": [0, 1]}}],
  "nodes": [{{"mesh": 0}}, {{"mesh": 0, "translation": [2, 0, 0]}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "material": 0}}]}}],
  "materials": [{{"name": "leafy", "pbrMetallicRoughness": {{"baseColorFactor": [0.2, 0.4, 0.1, 1], "metallicFactor": 0}},
                 "extensions": {{"KHR_materials_diffuse_transmission": {{"diffuseTransmissionFactor": 0.5,
                   "diffuseTransmissionColorFactor": [0.5, 1.0, 0.2]}}}}}}],
  "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                  "min": [-10, -10, -10], "max": [10, 10, 10]}}],
  "bufferViews": [{{"buffer": 0, "byteLength": 36}}],
  "buffers": [{{"byteLength": 36, "uri": "{uri}"}}]
}}"#
    )
}

const TRI: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

#[test]
fn hierarchy_instances_and_diffuse_transmission() {
    let d = scratch("ok");
    let p = d.join("t.gltf");
    std::fs::write(&p, triangle_gltf(TRI, "")).unwrap();
    // The mesh is used by two nodes: one prototype, two instances.
    let g = load_gltf(&p, &Transform::default()).unwrap();
    assert!(g.meshes.is_empty());
    assert_eq!(g.prototypes.len(), 1);
    assert_eq!(
        g.prototypes[0].meshes[0].positions[1].x, 1.0,
        "object space"
    );
    assert_eq!(g.instances.len(), 2);
    let xs: Vec<f32> = g
        .instances
        .iter()
        .map(|i| i.transform.transform_point3(glam::Vec3::X).x)
        .collect();
    assert!(xs.contains(&1.0) && xs.contains(&3.0), "{xs:?}");
    // Flattened on request (an object that is itself instanced).
    let flat = lamina_scene::gltf_import::load_gltf_with(&p, &Transform::default(), false).unwrap();
    assert_eq!(flat.meshes.len(), 2);
    assert!(flat.prototypes.is_empty() && flat.instances.is_empty());
    let xs: Vec<f32> = flat.meshes.iter().map(|m| m.positions[1].x).collect();
    assert!(xs.contains(&1.0) && xs.contains(&3.0), "{xs:?}");
    match &g.materials[0] {
        Material::Pbr(p) => {
            let b = p.bsdf(glam::Vec2::ZERO);
            assert!((b.base_color - glam::Vec3::new(0.2, 0.4, 0.1)).length() < 1e-6);
            assert_eq!((b.metallic, b.roughness, b.ior), (0.0, 1.0, 1.5));
            assert_eq!(b.transmission, 0.5);
            assert!((b.transmission_color - glam::Vec3::new(0.5, 1.0, 0.2)).length() < 1e-6);
            assert!(p.normal_map.is_none() && p.metallic_roughness.is_none());
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn scene_file_overrides_gltf_material_by_name() {
    let d = scratch("override");
    std::fs::write(d.join("t.gltf"), triangle_gltf(TRI, "")).unwrap();
    let text = r#"
[camera]
position = [0, 0, 5]
look_at = [0, 0, 0]
[[material]]
name = "mine"
type = "leaf"
[[object]]
type = "gltf"
file = "t.gltf"
materials = { leafy = "mine" }
transform = { translate = [0, 1, 0] }
"#;
    let s = parse_scene(text, &d.join("s.toml")).unwrap();
    assert!(s.meshes.is_empty());
    assert_eq!((s.prototypes.len(), s.instances.len()), (1, 2));
    assert!(s.prototypes[0].meshes.iter().all(|m| m.material == 0));
    assert_eq!(
        s.materials.len(),
        1,
        "the overridden glTF material is not added"
    );
    // The object's transform is part of each instance's.
    let y = s.instances[0]
        .transform
        .transform_point3(s.prototypes[0].meshes[0].positions[0])
        .y;
    assert!((y - 1.0).abs() < 1e-6, "{y}");
    // Placed three times, the file's repeated mesh stays one prototype: 3 placements x 2
    // nodes = 6 instances, each the placement composed with its node.
    let placed = text.replace(
        "transform = { translate = [0, 1, 0] }",
        "transform = { translate = [0, 1, 0] }\ninstances = [{}, { translate = [10, 0, 0] }, \
         { translate = [20, 0, 0] }]",
    );
    let s = parse_scene(&placed, &d.join("s.toml")).unwrap();
    assert_eq!((s.prototypes.len(), s.instances.len()), (1, 6));
    let mut xs: Vec<i32> = s
        .instances
        .iter()
        .map(|i| i.transform.transform_point3(glam::Vec3::ZERO).x.round() as i32)
        .collect();
    xs.sort();
    assert_eq!(xs, vec![0, 2, 10, 12, 20, 22]);
    let bad = text.replace("leafy = ", "nosuch = ");
    let e = parse_scene(&bad, &d.join("s.toml")).unwrap_err();
    assert!(
        e.to_string().contains("no material 'nosuch'") && e.to_string().contains("leafy"),
        "{e}"
    );
}

#[test]
fn bad_gltf_files_give_clear_errors() {
    let d = scratch("bad");
    let cases = [
        (
            "nan.gltf",
            triangle_gltf([[f32::NAN, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], ""),
            "not finite",
        ),
        (
            "huge.gltf",
            triangle_gltf([[1e30, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], ""),
            "absurdly large",
        ),
        (
            "req.gltf",
            triangle_gltf(
                TRI,
                r#""extensionsRequired": ["EXT_meshopt_compression"], "extensionsUsed": ["EXT_meshopt_compression"],"#,
            ),
            "EXT_meshopt_compression",
        ),
        (
            "missing.gltf",
            triangle_gltf(TRI, "")
                .replace(&format!("data:application/octet-stream;base64,{}", ""), "")
                .replacen("\"uri\": \"data:", "\"uri\": \"nothere.bin\", \"x\": \"", 1),
            "buffers",
        ),
        (
            "empty.gltf",
            r#"{"asset": {"version": "2.0"}, "scenes": [{"nodes": []}], "scene": 0}"#.to_string(),
            "no triangles",
        ),
        ("garbage.gltf", "not json".to_string(), "cannot read glTF"),
    ];
    for (name, text, words) in cases {
        let p = d.join(name);
        std::fs::write(&p, text).unwrap();
        let e = load_gltf(&p, &Transform::default())
            .map(|_| ())
            .unwrap_err()
            .to_string();
        assert!(e.contains(name), "{name}: {e}");
        assert!(e.contains(words), "{name}: expected '{words}' in: {e}");
    }
}

#[test]
fn real_plant_when_shared_data_exists() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data/plants/potted_plant_02/potted_plant_02.glb");
    if !path.exists() {
        eprintln!("skipped: {} not present", path.display());
        return;
    }
    let g = load_gltf(&path, &Transform::default()).unwrap();
    let tris: usize = g.meshes.iter().map(|m| m.indices.len()).sum();
    assert!(tris > 60_000, "{tris} triangles");
    let leaves = g
        .material_names
        .iter()
        .position(|n| n == "potted_plant_02_leaves")
        .expect("leaf material");
    // Every material keeps its maps: base colour, metallic-roughness, normal.
    for m in &g.materials[..2] {
        let Material::Pbr(p) = m else {
            panic!("glTF materials are Pbr: {m:?}");
        };
        assert!(
            p.metallic_roughness.is_some() && p.normal_map.is_some(),
            "{}",
            p.name
        );
        assert_eq!(p.metallic, 0.0);
    }
    match &g.materials[leaves] {
        Material::Pbr(p) => assert_eq!(p.alpha.as_ref().map(|a| a.cutoff), Some(0.5)),
        other => panic!("leaves should be a cut-out material: {other:?}"),
    }
    let (lo, hi) = g
        .meshes
        .iter()
        .flat_map(|m| &m.positions)
        .fold((glam::Vec3::MAX, glam::Vec3::MIN), |(lo, hi), p| {
            (lo.min(*p), hi.max(*p))
        });
    let size = hi - lo;
    assert!(
        size.y > 0.6 && size.y < 1.0 && size.x > 0.4 && size.x < 1.0,
        "plant size {size} m"
    );
    assert!(
        g.warnings
            .iter()
            .any(|w| w.contains("KHR_materials_translucency"))
    );
}

/// A scene file with one glTF object `t.gltf` in `d`.
fn gltf_scene(d: &Path, gltf: &str, object_extra: &str) -> Result<lamina_scene::Scene, String> {
    std::fs::write(d.join("t.gltf"), gltf).unwrap();
    let text = format!(
        "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n[[object]]\ntype = \"gltf\"\nfile = \"t.gltf\"\n{object_extra}\n"
    );
    parse_scene(&text, &d.join("s.toml")).map_err(|e| e.to_string())
}

#[test]
fn bad_gltf_in_a_scene_file_missing_texture_absurd_scale() {
    let d = scratch("bad-scene");
    // A base-colour texture whose image file does not exist.
    let tex = triangle_gltf(
        TRI,
        r#""images": [{"uri": "textures/gone.png"}], "textures": [{"source": 0}],"#,
    )
    .replace(
        r#""baseColorFactor": [0.2, 0.4, 0.1, 1]"#,
        r#""baseColorFactor": [0.2, 0.4, 0.1, 1], "baseColorTexture": {"index": 0}"#,
    );
    let e = gltf_scene(&d, &tex, "").unwrap_err();
    assert!(
        e.contains("t.gltf") && e.contains("images[0]") && e.contains("textures/gone.png"),
        "{e}"
    );
    // A node scaled by 1e30: each vertex is small, the placed mesh is absurd. The mesh is
    // used by two nodes, so this is an instance.
    let huge = triangle_gltf(TRI, "").replace(
        r#"{"mesh": 0, "translation": [2, 0, 0]}"#,
        r#"{"mesh": 0, "scale": [1e30, 1e30, 1e30]}"#,
    );
    let e = gltf_scene(&d, &huge, "").unwrap_err();
    assert!(
        e.contains("s.toml:4: object[0]: a node using mesh 'mesh0' places") && e.contains("beyond"),
        "{e}"
    );
    // The same file placed by the object's own instances: flattened, still caught.
    let e = gltf_scene(&d, &huge, "instances = [{}]").unwrap_err();
    assert!(e.contains("object[0]") && e.contains("beyond"), "{e}");
    // The object's scale is checked before anything is loaded.
    let e = gltf_scene(&d, &triangle_gltf(TRI, ""), "scale = 1e30").unwrap_err();
    assert!(e.contains("object[0].scale") && e.contains("1e30"), "{e}");
    // An accessor that reads past the end of its buffer.
    let short = triangle_gltf(TRI, "").replace(r#""count": 3"#, r#""count": 300"#);
    let e = gltf_scene(&d, &short, "").unwrap_err();
    assert!(e.contains("t.gltf"), "{e}");
    // A primitive whose triangles are all degenerate: no triangles to render.
    let degenerate = triangle_gltf([[0.0; 3], [0.0; 3], [0.0; 3]], "").replace(
        r#""min": [-10, -10, -10], "max": [10, 10, 10]"#,
        r#""min": [0, 0, 0], "max": [0, 0, 0]"#,
    );
    let e = gltf_scene(&d, &degenerate, "").unwrap_err();
    assert!(e.contains("t.gltf") && e.contains("no triangles"), "{e}");
}

#[test]
fn nan_normals_are_rejected() {
    let d = scratch("nan-normal");
    let mut bytes = Vec::new();
    for v in TRI.iter().flatten() {
        bytes.extend(v.to_le_bytes());
    }
    for v in [0.0, 0.0, 1.0, f32::NAN, 0.0, 1.0, 0.0, 0.0, 1.0] {
        bytes.extend(f32::to_le_bytes(v));
    }
    let text = format!(
        r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0]}}],
  "nodes": [{{"mesh": 0}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0, "NORMAL": 1}}}}]}}],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}},
    {{"bufferView": 0, "byteOffset": 36, "componentType": 5126, "count": 3, "type": "VEC3"}}],
  "bufferViews": [{{"buffer": 0, "byteLength": 72}}],
  "buffers": [{{"byteLength": 72, "uri": "data:application/octet-stream;base64,{}"}}]}}"#,
        b64(&bytes)
    );
    let p = d.join("n.gltf");
    std::fs::write(&p, text).unwrap();
    let e = load_gltf(&p, &Transform::default())
        .map(|_| ())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("n.gltf")
            && e.contains("meshes[0].primitives[0]")
            && e.contains("normal 1 is not finite"),
        "{e}"
    );
}

/// A unit quad in `z = 0` (normals `+z`, UVs, tangents `+x` with `w = tangent_w`) under a
/// node with scale `node_scale`; material 0 has a metallic-roughness and a normal texture
/// (`mr.png`, `n.png` beside the file), material 1 has no `pbrMetallicRoughness` block.
fn mapped_quad_gltf(node_scale: [f32; 3], tangent_w: f32) -> String {
    let mut bytes = Vec::new();
    let pos = [
        [0.0f32, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ];
    for p in pos {
        p.iter().for_each(|c| bytes.extend(c.to_le_bytes()));
    }
    for _ in 0..4 {
        [0.0f32, 0.0, 1.0]
            .iter()
            .for_each(|c| bytes.extend(c.to_le_bytes()));
    }
    for _ in 0..4 {
        [1.0f32, 0.0, 0.0, tangent_w]
            .iter()
            .for_each(|c| bytes.extend(c.to_le_bytes()));
    }
    for uv in [[0.0f32, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]] {
        uv.iter().for_each(|c| bytes.extend(c.to_le_bytes()));
    }
    for i in [0u16, 1, 2, 0, 2, 3] {
        bytes.extend(i.to_le_bytes());
    }
    let n = bytes.len();
    let uri = format!("data:application/octet-stream;base64,{}", b64(&bytes));
    format!(
        r#"{{
  "asset": {{"version": "2.0"}},
  "scene": 0,
  "scenes": [{{"nodes": [0]}}],
  "nodes": [{{"mesh": 0, "scale": {node_scale:?}}}],
  "meshes": [{{"primitives": [
     {{"attributes": {{"POSITION": 0, "NORMAL": 1, "TANGENT": 2, "TEXCOORD_0": 3}}, "indices": 4, "material": 0}},
     {{"attributes": {{"POSITION": 0}}, "indices": 4, "material": 1}}]}}],
  "materials": [
    {{"name": "glossy", "pbrMetallicRoughness": {{"metallicFactor": 0.5, "roughnessFactor": 0.8,
        "metallicRoughnessTexture": {{"index": 0}}}},
      "normalTexture": {{"index": 1, "scale": 0.7}}}},
    {{"name": "plain"}}],
  "textures": [{{"source": 0}}, {{"source": 1}}],
  "images": [{{"uri": "mr.png"}}, {{"uri": "n.png"}}],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}},
    {{"bufferView": 0, "byteOffset": 48, "componentType": 5126, "count": 4, "type": "VEC3"}},
    {{"bufferView": 0, "byteOffset": 96, "componentType": 5126, "count": 4, "type": "VEC4"}},
    {{"bufferView": 0, "byteOffset": 160, "componentType": 5126, "count": 4, "type": "VEC2"}},
    {{"bufferView": 0, "byteOffset": 192, "componentType": 5123, "count": 6, "type": "SCALAR"}}],
  "bufferViews": [{{"buffer": 0, "byteLength": {n}}}],
  "buffers": [{{"byteLength": {n}, "uri": "{uri}"}}]
}}"#
    )
}

/// Writes the textures `mapped_quad_gltf` refers to: metallic-roughness with G = 0.5,
/// B = 0.25; a normal map tilted towards `+x`.
fn write_quad_textures(d: &Path) {
    let mr = image::RgbaImage::from_pixel(2, 2, image::Rgba([0, 128, 64, 255]));
    mr.save(d.join("mr.png")).unwrap();
    let n = image::RgbaImage::from_pixel(2, 2, image::Rgba([200, 128, 230, 255]));
    n.save(d.join("n.png")).unwrap();
}

#[test]
fn metallic_roughness_normal_maps_and_tangents() {
    let d = scratch("pbr");
    write_quad_textures(&d);
    let p = d.join("q.gltf");
    std::fs::write(&p, mapped_quad_gltf([1.0, 1.0, 1.0], 1.0)).unwrap();
    let g = load_gltf(&p, &Transform::default()).unwrap();
    let Material::Pbr(m) = &g.materials[0] else {
        panic!("{:?}", g.materials[0]);
    };
    assert_eq!(m.name, "glossy");
    // Factors times the map (linear: G = 128/255, B = 64/255).
    let b = m.bsdf(glam::Vec2::splat(0.5));
    assert!(
        (b.roughness - 0.8 * 128.0 / 255.0).abs() < 1e-3,
        "{}",
        b.roughness
    );
    assert!(
        (b.metallic - 0.5 * 64.0 / 255.0).abs() < 1e-3,
        "{}",
        b.metallic
    );
    let nm = m.normal_map.as_ref().expect("normal map");
    assert_eq!(nm.scale, 0.7);
    // Decoded linearly (not sRGB): x = 2·200/255 − 1 = 0.569, scaled by 0.7.
    let v = nm.at(glam::Vec2::splat(0.5));
    let raw = glam::Vec3::new(
        2.0 * 200.0 / 255.0 - 1.0,
        2.0 * 128.0 / 255.0 - 1.0,
        2.0 * 230.0 / 255.0 - 1.0,
    );
    let want = glam::Vec3::new(raw.x * 0.7, raw.y * 0.7, raw.z).normalize();
    assert!((v - want).length() < 1e-3, "{v} vs {want}");
    // glTF defaults for a material without pbrMetallicRoughness: white, metallic 1,
    // roughness 1.
    let Material::Pbr(plain) = &g.materials[1] else {
        panic!("{:?}", g.materials[1]);
    };
    let b = plain.bsdf(glam::Vec2::ZERO);
    assert_eq!(
        (b.base_color, b.metallic, b.roughness),
        (glam::Vec3::ONE, 1.0, 1.0)
    );
    // Tangents are read; v is flipped to lamina's convention.
    let mesh = &g.meshes[0];
    assert_eq!(mesh.tangents, vec![glam::Vec4::new(1.0, 0.0, 0.0, 1.0); 4]);
    assert_eq!(mesh.uvs[0], glam::Vec2::new(0.0, 0.0));
    assert_eq!(mesh.uvs[3], glam::Vec2::new(0.0, 1.0));
    assert!(g.meshes[1].tangents.is_empty());

    // A mirroring node: tangents follow the mirror and their handedness flips.
    std::fs::write(&p, mapped_quad_gltf([-1.0, 1.0, 1.0], 1.0)).unwrap();
    let g = load_gltf(&p, &Transform::default()).unwrap();
    assert_eq!(
        g.meshes[0].tangents[0],
        glam::Vec4::new(-1.0, 0.0, 0.0, -1.0)
    );

    // Bad tangents and bad normal-map strength are errors naming the file and the key.
    std::fs::write(&p, mapped_quad_gltf([1.0, 1.0, 1.0], f32::NAN)).unwrap();
    let e = load_gltf(&p, &Transform::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("q.gltf") && e.contains("tangent"), "{e}");
    std::fs::write(
        &p,
        mapped_quad_gltf([1.0, 1.0, 1.0], 1.0).replace("\"scale\": 0.7", "\"scale\": 1e9"),
    )
    .unwrap();
    let e = load_gltf(&p, &Transform::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("q.gltf") && e.contains("normalTexture.scale"),
        "{e}"
    );
    // A missing normal map names the image.
    std::fs::write(&p, mapped_quad_gltf([1.0, 1.0, 1.0], 1.0)).unwrap();
    std::fs::remove_file(d.join("n.png")).unwrap();
    let e = load_gltf(&p, &Transform::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("q.gltf") && e.contains("n.png"), "{e}");
}

/// `KHR_materials_diffuse_transmission` with both textures: the factor times the
/// transmission texture's alpha, the colour factor times the (sRGB) colour texture.
#[test]
fn diffuse_transmission_textures() {
    let d = scratch("dtt");
    write_quad_textures(&d);
    image::RgbaImage::from_pixel(2, 2, image::Rgba([0, 0, 0, 128]))
        .save(d.join("t.png"))
        .unwrap();
    image::RgbaImage::from_pixel(2, 2, image::Rgba([255, 188, 0, 255]))
        .save(d.join("c.png"))
        .unwrap();
    let with_ext = |t_index: u32| {
        mapped_quad_gltf([1.0, 1.0, 1.0], 1.0)
            .replace(
                "\"normalTexture\": {\"index\": 1, \"scale\": 0.7}}",
                &format!(
                    "\"normalTexture\": {{\"index\": 1, \"scale\": 0.7}}, \"extensions\": \
                     {{\"KHR_materials_diffuse_transmission\": {{\"diffuseTransmissionFactor\": \
                     0.8, \"diffuseTransmissionTexture\": {{\"index\": {t_index}}}, \
                     \"diffuseTransmissionColorFactor\": [1, 0.5, 0.5], \
                     \"diffuseTransmissionColorTexture\": {{\"index\": 3}}}}}}}}"
                ),
            )
            .replace(
                "\"textures\": [{\"source\": 0}, {\"source\": 1}]",
                "\"textures\": [{\"source\": 0}, {\"source\": 1}, {\"source\": 2}, {\"source\": 3}]",
            )
            .replace(
                "\"images\": [{\"uri\": \"mr.png\"}, {\"uri\": \"n.png\"}]",
                "\"images\": [{\"uri\": \"mr.png\"}, {\"uri\": \"n.png\"}, {\"uri\": \"t.png\"}, {\"uri\": \"c.png\"}]",
            )
    };
    let p = d.join("q.gltf");
    std::fs::write(&p, with_ext(2)).unwrap();
    let g = load_gltf(&p, &Transform::default()).unwrap();
    let Material::Pbr(m) = &g.materials[0] else {
        panic!("{:?}", g.materials[0]);
    };
    let b = m.bsdf(glam::Vec2::splat(0.5));
    assert!(
        (b.transmission - 0.8 * 128.0 / 255.0).abs() < 1e-3,
        "{}",
        b.transmission
    );
    let lin = lamina_leaf::texture::srgb_to_linear(188.0 / 255.0);
    let want = glam::Vec3::new(1.0, 0.5 * lin, 0.0);
    assert!(
        (b.transmission_color - want).length() < 1e-3,
        "{}",
        b.transmission_color
    );
    // A texture index that does not exist names the key.
    std::fs::write(&p, with_ext(9)).unwrap();
    let e = load_gltf(&p, &Transform::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("q.gltf") && e.contains("diffuseTransmissionTexture"),
        "{e}"
    );
}
