//! Loaders validate before they read: crafted glTF, OBJ/MTL, card, placement and scene
//! files that used to panic inside a dependency, read out of bounds, or allocate without
//! bound give an error naming the file, the key or line, and what was wrong.

use lamina_scene::gltf_import::{load_gltf, parse_gltf};
use lamina_scene::transform::Transform;
use lamina_scene::{ColorInput, Material, parse_scene};
mod common;
use common::b64;
use std::path::{Path, PathBuf};

fn scratch(name: &str) -> PathBuf {
    common::scratch("limits", name)
}

fn f32_bytes(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

const TRI: [f32; 9] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];

/// A one-mesh glTF whose buffer 0 holds `bytes` (as a data URI); `accessors`,
/// `views` and `attributes` are the JSON of those parts, `extra` more top-level keys.
fn gltf_json(bytes: &[u8], accessors: &str, views: &str, prim: &str, extra: &str) -> String {
    format!(
        r#"{{"asset": {{"version": "2.0"}}, {extra}
  "scene": 0, "scenes": [{{"nodes": [0]}}], "nodes": [{{"mesh": 0}}],
  "meshes": [{{"primitives": [{prim}]}}],
  "accessors": [{accessors}],
  "bufferViews": [{views}],
  "buffers": [{{"byteLength": {}, "uri": "data:application/octet-stream;base64,{}"}}]}}"#,
        bytes.len(),
        b64(bytes)
    )
}

fn gltf_error(d: &Path, name: &str, text: &str) -> String {
    let p = d.join(name);
    std::fs::write(&p, text).unwrap();
    load_gltf(&p, &Transform::default())
        .map(|_| ())
        .unwrap_err()
        .to_string()
}

const POS0: &str = r#"{"attributes": {"POSITION": 0}}"#;

#[test]
fn gltf_short_byte_stride_is_an_error_not_a_panic() {
    let d = scratch("stride");
    // A VEC3 float accessor (12-byte elements) on a view with byteStride 4: the gltf
    // crate's iterator panics on it.
    let text = gltf_json(
        &f32_bytes(&TRI),
        r#"{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}"#,
        r#"{"buffer": 0, "byteLength": 36, "byteStride": 4}"#,
        POS0,
        "",
    );
    let e = gltf_error(&d, "stride.gltf", &text);
    assert!(
        e.contains("stride.gltf")
            && e.contains("meshes[0].primitives[0]")
            && e.contains("POSITION (accessor 0)")
            && e.contains("byteStride 4, less than the element size 12"),
        "{e}"
    );
    // The same in a .glb (binary chunk instead of a data URI), read from memory too.
    let json = r#"{"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
      "nodes": [{"mesh": 0}], "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
      "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}],
      "bufferViews": [{"buffer": 0, "byteLength": 36, "byteStride": 4}],
      "buffers": [{"byteLength": 36}]}"#;
    let glb = glb(json, &f32_bytes(&TRI));
    let p = d.join("stride.glb");
    std::fs::write(&p, &glb).unwrap();
    let e = load_gltf(&p, &Transform::default())
        .map(|_| ())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("stride.glb") && e.contains("byteStride 4"),
        "{e}"
    );
    let e = parse_gltf(&glb, &p, &Transform::default())
        .map(|_| ())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("stride.glb") && e.contains("byteStride 4"),
        "{e}"
    );
    // With a good stride the .glb loads.
    let ok = glb_with_stride(12);
    assert!(parse_gltf(&ok, &p, &Transform::default()).is_ok());
}

fn glb_with_stride(stride: u32) -> Vec<u8> {
    let json = format!(
        r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0]}}],
      "nodes": [{{"mesh": 0}}], "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}}}]}}],
      "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}}],
      "bufferViews": [{{"buffer": 0, "byteLength": 36, "byteStride": {stride}}}],
      "buffers": [{{"byteLength": 36}}]}}"#
    );
    glb(&json, &f32_bytes(&TRI))
}

/// A binary glTF: header, JSON chunk, BIN chunk (both padded to 4 bytes).
fn glb(json: &str, bin: &[u8]) -> Vec<u8> {
    let mut j = json.as_bytes().to_vec();
    while !j.len().is_multiple_of(4) {
        j.push(b' ');
    }
    let mut b = bin.to_vec();
    while !b.len().is_multiple_of(4) {
        b.push(0);
    }
    let total = 12 + 8 + j.len() + 8 + b.len();
    let mut out = Vec::new();
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((j.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(&j);
    out.extend((b.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(&b);
    out
}

#[test]
fn gltf_views_accessors_and_types_are_checked_before_reading() {
    let d = scratch("views");
    let bytes = f32_bytes(&TRI);
    let cases = [
        (
            // The view is longer than its buffer.
            gltf_json(
                &bytes,
                r#"{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}"#,
                r#"{"buffer": 0, "byteLength": 72}"#,
                POS0,
                "",
            ),
            "bufferView 0 (byteOffset 0, byteLength 72) ends at byte 72, beyond buffer 0 (36 bytes)",
        ),
        (
            // The accessor's elements run past the end of the view.
            gltf_json(
                &bytes,
                r#"{"bufferView": 0, "byteOffset": 4, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}"#,
                r#"{"buffer": 0, "byteLength": 36}"#,
                POS0,
                "",
            ),
            "end at byte 40, beyond bufferView 0 (36 bytes)",
        ),
        (
            // Positions as unsigned ints.
            gltf_json(
                &bytes,
                r#"{"bufferView": 0, "componentType": 5125, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}"#,
                r#"{"buffer": 0, "byteLength": 36}"#,
                POS0,
                "",
            ),
            "component type UNSIGNED_INT (5125) is not allowed",
        ),
        (
            // Texture coordinates as VEC3.
            gltf_json(
                &bytes,
                r#"{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}"#,
                r#"{"buffer": 0, "byteLength": 36}"#,
                r#"{"attributes": {"POSITION": 0, "TEXCOORD_0": 0}}"#,
                "",
            ),
            "TEXCOORD_0 (accessor 0): type VEC3 where VEC2 is required",
        ),
        (
            // Float indices.
            gltf_json(
                &bytes,
                r#"{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
                   {"bufferView": 0, "componentType": 5126, "count": 3, "type": "SCALAR"}"#,
                r#"{"buffer": 0, "byteLength": 36}"#,
                r#"{"attributes": {"POSITION": 0}, "indices": 1}"#,
                "",
            ),
            "indices (accessor 1): component type FLOAT (5126) is not allowed",
        ),
        (
            // A huge count with no data behind it: sparse, no bufferView.
            gltf_json(
                &bytes,
                r#"{"componentType": 5126, "count": 100000000, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0],
                    "sparse": {"count": 1, "indices": {"bufferView": 0, "componentType": 5121},
                               "values": {"bufferView": 0}}}"#,
                r#"{"buffer": 0, "byteLength": 36}"#,
                POS0,
                "",
            ),
            "count 100000000 must be in [1, 67108864]",
        ),
        (
            // A NORMAL accessor with fewer elements than POSITION.
            gltf_json(
                &bytes,
                r#"{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
                   {"bufferView": 0, "componentType": 5126, "count": 2, "type": "VEC3"}"#,
                r#"{"buffer": 0, "byteLength": 36}"#,
                r#"{"attributes": {"POSITION": 0, "NORMAL": 1}}"#,
                "",
            ),
            "NORMAL (accessor 1): count 2 differs from the POSITION count 3",
        ),
    ];
    for (i, (text, words)) in cases.iter().enumerate() {
        let name = format!("v{i}.gltf");
        let e = gltf_error(&d, &name, text);
        assert!(
            e.contains(&name) && e.contains("meshes[0].primitives[0]") && e.contains(words),
            "case {i}: expected '{words}' in: {e}"
        );
    }
}

#[test]
fn gltf_sparse_accessors_are_read_and_checked() {
    let d = scratch("sparse");
    // Base positions TRI, then a sparse override of vertex 2 to (0, 2, 0): indices (u8 at
    // byte 36, padded to 40) and values (floats at 40).
    let mut bytes = f32_bytes(&TRI);
    bytes.extend([2, 0, 0, 0]);
    bytes.extend(f32_bytes(&[0.0, 2.0, 0.0]));
    let sparse = |index_view: &str, count: u32| {
        format!(
            r#"{{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 2, 0],
                "sparse": {{"count": {count}, "indices": {{"bufferView": {index_view}, "componentType": 5121}},
                           "values": {{"bufferView": 2}}}}}}"#
        )
    };
    let views = r#"{"buffer": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 1},
                   {"buffer": 0, "byteOffset": 40, "byteLength": 12}"#;
    let p = d.join("ok.gltf");
    std::fs::write(&p, gltf_json(&bytes, &sparse("1", 1), views, POS0, "")).unwrap();
    let g = load_gltf(&p, &Transform::default()).unwrap();
    assert_eq!(g.meshes[0].positions[2], glam::Vec3::new(0.0, 2.0, 0.0));
    assert_eq!(g.meshes[0].positions[1], glam::Vec3::new(1.0, 0.0, 0.0));
    // Two sparse entries where the views hold one.
    let e = gltf_error(
        &d,
        "two.gltf",
        &gltf_json(&bytes, &sparse("1", 2), views, POS0, ""),
    );
    assert!(
        e.contains("two.gltf") && e.contains("sparse.indices") && e.contains("beyond bufferView 1"),
        "{e}"
    );
    // A sparse index beyond the accessor's count.
    let mut bad = bytes.clone();
    bad[36] = 7;
    let e = gltf_error(
        &d,
        "idx.gltf",
        &gltf_json(&bad, &sparse("1", 1), views, POS0, ""),
    );
    assert!(
        e.contains("idx.gltf") && e.contains("sparse index 7"),
        "{e}"
    );
}

#[test]
fn gltf_quantized_positions_are_dequantized() {
    let d = scratch("quant");
    // KHR_mesh_quantization: unsigned-byte positions, 4-byte aligned elements.
    let bytes = [0u8, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0];
    let text = gltf_json(
        &bytes,
        r#"{"bufferView": 0, "componentType": 5121, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}"#,
        r#"{"buffer": 0, "byteLength": 12, "byteStride": 4}"#,
        POS0,
        r#""extensionsUsed": ["KHR_mesh_quantization"], "extensionsRequired": ["KHR_mesh_quantization"],"#,
    );
    let p = d.join("q.gltf");
    std::fs::write(&p, text).unwrap();
    let g = load_gltf(&p, &Transform::default()).unwrap();
    let pos = &g.meshes[0].positions;
    assert_eq!(pos[1], glam::Vec3::X);
    assert_eq!(pos[2], glam::Vec3::Y);
}

#[test]
fn gltf_node_cycles_and_bad_uris_are_errors() {
    let d = scratch("nodes");
    let bytes = f32_bytes(&TRI);
    let acc = r#"{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}"#;
    let view = r#"{"buffer": 0, "byteLength": 36}"#;
    let cyclic = gltf_json(&bytes, acc, view, POS0, "").replace(
        r#""nodes": [{"mesh": 0}]"#,
        r#""nodes": [{"mesh": 0, "children": [1]}, {"children": [0]}]"#,
    );
    let e = gltf_error(&d, "cycle.gltf", &cyclic);
    assert!(
        e.contains("cycle.gltf") && e.contains("nodes[0]") && e.contains("reached twice"),
        "{e}"
    );
    // A buffer URI that is not UTF-8 once percent-decoded (the gltf crate panics on it);
    // the file exists under its literal name.
    std::fs::write(d.join("%FF.bin"), &bytes).unwrap();
    let text = gltf_json(&bytes, acc, view, POS0, "").replace(
        &format!("data:application/octet-stream;base64,{}", b64(&bytes)),
        "%FF.bin",
    );
    let e = gltf_error(&d, "uri.gltf", &text);
    assert!(
        e.contains("uri.gltf") && e.contains("buffers[0]") && e.contains("UTF-8"),
        "{e}"
    );
    // Percent-encoded names of files that exist are found.
    std::fs::write(d.join("my tri.bin"), &bytes).unwrap();
    let text = gltf_json(&bytes, acc, view, POS0, "").replace(
        &format!("data:application/octet-stream;base64,{}", b64(&bytes)),
        "my%20tri.bin",
    );
    let p = d.join("spaced.gltf");
    std::fs::write(&p, text).unwrap();
    assert!(load_gltf(&p, &Transform::default()).is_ok());
}

#[test]
fn huge_images_are_rejected_before_decoding() {
    let d = scratch("images");
    // In a glTF buffer view: 16384 x 16384 grey (256 MiB stored, 4 GiB as a texture).
    let mut bytes = f32_bytes(&TRI);
    let png = lamina_leaf::testing::png_header_only(16384, 16384);
    bytes.extend(&png);
    let text = gltf_json(
        &bytes,
        r#"{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}"#,
        &format!(
            r#"{{"buffer": 0, "byteLength": 36}}, {{"buffer": 0, "byteOffset": 36, "byteLength": {}}}"#,
            png.len()
        ),
        r#"{"attributes": {"POSITION": 0}, "material": 0}"#,
        r#""images": [{"bufferView": 1, "mimeType": "image/png"}], "textures": [{"source": 0}],
           "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],"#,
    );
    let e = gltf_error(&d, "img.gltf", &text);
    assert!(
        e.contains("img.gltf") && e.contains("images[0]") && e.contains("67108864"),
        "{e}"
    );
    // As a scene material's map: the scene file, its line and the key.
    std::fs::write(d.join("huge.png"), &png).unwrap();
    let scene = "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n\
                 [[material]]\nname = \"m\"\ntype = \"diffuse\"\nreflectance_map = \"huge.png\"\n";
    let e = parse_scene(scene, &d.join("s.toml"))
        .map(|_| ())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("s.toml:7: material[0].reflectance_map")
            && e.contains("huge.png")
            && e.contains("too large"),
        "{e}"
    );
}

fn write(d: &Path, name: &str, text: &str) -> PathBuf {
    let p = d.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

const QUAD_OBJ: &str = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nusemtl grey\nf 1 2 3\n";

#[test]
fn mtl_colours_with_one_number_load_and_short_ones_are_errors() {
    let d = scratch("mtl");
    // `Kd 0.5` is valid MTL (grey); tobj panics on it.
    write(&d, "m.mtl", "newmtl grey\nKd 0.25\n");
    let p = write(&d, "q.obj", QUAD_OBJ);
    let obj = lamina_scene::obj::load_obj(&p).unwrap();
    match &obj.materials[0] {
        Material::Diffuse {
            reflectance: ColorInput::Constant(c),
            ..
        } => assert_eq!(*c, glam::Vec3::splat(0.25)),
        other => panic!("{other:?}"),
    }
    // Two numbers, or none: an error with the MTL file's line.
    for (mtl, words) in [
        (
            "newmtl grey\n\nKs 0.25 0.5\n",
            "m.mtl:3: Ks: needs one number",
        ),
        ("newmtl grey\nKa\n", "m.mtl:2: Ka: needs one number"),
        (
            "newmtl grey\nKd 1 x 1\n",
            "m.mtl:2: Kd: 'x' is not a number",
        ),
    ] {
        write(&d, "m.mtl", mtl);
        let e = lamina_scene::obj::load_obj(&p)
            .map(|_| ())
            .unwrap_err()
            .to_string();
        assert!(e.contains(words), "expected '{words}' in: {e}");
    }
}

#[test]
fn files_too_large_to_be_sane_are_not_read() {
    let d = scratch("sizes");
    let sparse = |name: &str, len: u64| {
        let p = d.join(name);
        std::fs::File::create(&p).unwrap().set_len(len).unwrap();
        p
    };
    let e = lamina_scene::load_scene(&sparse(
        "s.toml",
        lamina_scene::limits::MAX_SCENE_FILE_BYTES + 1,
    ))
    .map(|_| ())
    .unwrap_err()
    .to_string();
    assert!(e.contains("s.toml") && e.contains("67108864"), "{e}");
    let big = lamina_scene::limits::MAX_TEXT_FILE_BYTES + 1;
    let e = lamina_scene::obj::load_obj(&sparse("big.obj", big))
        .map(|_| ())
        .unwrap_err()
        .to_string();
    assert!(e.contains("big.obj") && e.contains("1073741824"), "{e}");
    let e = lamina_scene::cards::read_card_file(&sparse("big.csv", big))
        .map(|_| ())
        .unwrap_err()
        .to_string();
    assert!(e.contains("big.csv") && e.contains("1073741824"), "{e}");
    let e = lamina_scene::instances::read_instances_csv(&sparse("p.csv", big))
        .map(|_| ())
        .unwrap_err()
        .to_string();
    assert!(e.contains("p.csv") && e.contains("1073741824"), "{e}");
    // Devices report no length and never end: not read at all.
    if Path::new("/dev/zero").exists() {
        let zero = Path::new("/dev/zero");
        let e = lamina_scene::obj::load_obj(zero)
            .map(|_| ())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("/dev/zero") && e.contains("not a regular file"),
            "{e}"
        );
        let e = lamina_leaf::LeafDescription::from_toml_file(zero)
            .map(|_| ())
            .unwrap_err()
            .to_string();
        assert!(e.contains("not a regular file"), "{e}");
        let text = gltf_json(
            &f32_bytes(&TRI),
            r#"{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}"#,
            r#"{"buffer": 0, "byteLength": 36}"#,
            POS0,
            "",
        )
        .replace(
            &format!("data:application/octet-stream;base64,{}", b64(&f32_bytes(&TRI))),
            "file:/dev/zero",
        );
        let e = gltf_error(&d, "zero.gltf", &text);
        assert!(
            e.contains("zero.gltf") && e.contains("buffers[0]") && e.contains("not a regular file"),
            "{e}"
        );
    }
    // A plant parameter file named by a scene.
    sparse("bush.toml", lamina_plant::MAX_PARAM_FILE_BYTES + 1);
    let scene = "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n\
                 [[object]]\ntype = \"plant\"\nfile = \"bush.toml\"\n";
    let e = parse_scene(scene, &d.join("s.toml"))
        .map(|_| ())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("s.toml:6: object[0].file") && e.contains("bush.toml") && e.contains("1048576"),
        "{e}"
    );
}

#[test]
fn cards_with_huge_finite_vectors_get_unit_normals() {
    let d = scratch("cards");
    let p = write(
        &d,
        "c.json",
        r#"{"cards": [{"center": [0, 0, 0], "normal": [1e30, 1e30, 0], "up": [0, 0, 1e30],
                       "width": 0.1, "height": 0.2}]}"#,
    );
    let cards = lamina_scene::cards::read_card_file(&p).unwrap();
    let n = cards[0].normal;
    assert!((n.length() - 1.0).abs() < 1e-5, "{n:?}");
    assert!(
        (cards[0].up - glam::Vec3::Z).length() < 1e-5,
        "{:?}",
        cards[0].up
    );
}

#[test]
fn absurd_scene_values_are_rejected_naming_the_key() {
    let d = scratch("values");
    let head = "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n";
    // A procedural leaf of 8192 px maps (~10 GB while generating).
    let text = format!(
        "{head}[[material]]\nname = \"l\"\ntype = \"leaf\"\nspecies = \"beech\"\nresolution = 8192\n"
    );
    let e = parse_scene(&text, &d.join("s.toml"))
        .map(|_| ())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("s.toml:8: material[0].resolution") && e.contains("[16, 4096]"),
        "{e}"
    );
    // 16 leaf variants of 2048 px maps in one plant.
    let text = format!(
        "{head}[[object]]\ntype = \"plant\"\n[object.plant]\nleaf_variants = 16\nleaf_resolution = 2048\n"
    );
    let e = parse_scene(&text, &d.join("s.toml"))
        .map(|_| ())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("object[0].plant.leaf_resolution") && e.contains("16777216"),
        "{e}"
    );
}
