//! `[[material]] type = "pbr"` in scene files: defaults, every key loaded (maps included),
//! and every bad value named by file, line and key.

mod common;
use glam::{Vec2, Vec3};
use lamina_scene::{ColorInput, Material, PbrMaterial, Scene, SceneError, parse_scene};
use std::path::{Path, PathBuf};

const CAMERA: &str = "[camera]\nposition = [0, 1, 3]\nlook_at = [0, 0, 0]\n";

fn scratch(name: &str) -> PathBuf {
    common::scratch("pbr", name)
}

/// Lines 1-3 are the camera, line 4 `[[material]]`, line 5 `name`, line 6 `type`, then
/// `body` from line 7.
fn parse_in(dir: &Path, body: &str) -> Result<Scene, SceneError> {
    let text = format!("{CAMERA}[[material]]\nname = \"m\"\ntype = \"pbr\"\n{body}");
    parse_scene(&text, &dir.join("s.toml"))
}

fn pbr(s: &Scene) -> &PbrMaterial {
    match &s.materials[0] {
        Material::Pbr(p) => p,
        other => panic!("{other:?}"),
    }
}

/// Writes the maps the tests use: a 2x1 sRGB colour map, a 2x1 metallic-roughness map, a
/// flat-ish normal map, and a matte whose left half is transparent.
fn write_maps(d: &Path) {
    image::RgbImage::from_fn(2, 1, |x, _| {
        image::Rgb(if x == 0 { [255, 0, 0] } else { [0, 0, 255] })
    })
    .save(d.join("base.png"))
    .unwrap();
    image::RgbImage::from_pixel(2, 1, image::Rgb([0, 128, 255]))
        .save(d.join("mr.png"))
        .unwrap();
    image::RgbImage::from_pixel(2, 2, image::Rgb([255, 128, 255]))
        .save(d.join("normals.png"))
        .unwrap();
    image::GrayImage::from_fn(2, 1, |x, _| image::Luma([if x == 0 { 0 } else { 255 }]))
        .save(d.join("matte.png"))
        .unwrap();
}

#[test]
fn defaults() {
    let d = scratch("defaults");
    let s = parse_in(&d, "").unwrap();
    let p = pbr(&s);
    assert_eq!(p.name, "m");
    assert_eq!(s.materials[0].name(), "m");
    assert!(matches!(p.base_color, ColorInput::Constant(c) if c == Vec3::splat(0.8)));
    assert_eq!(
        (p.metallic, p.roughness, p.ior, p.transmission),
        (0.0, 0.5, 1.5, 0.0)
    );
    assert!(matches!(p.transmission_color, ColorInput::Constant(c) if c == Vec3::ONE));
    assert!(p.metallic_roughness.is_none() && p.transmission_map.is_none());
    assert!(p.normal_map.is_none() && p.alpha.is_none());
    assert!(s.materials[0].normal_map().is_none() && s.materials[0].alpha_mask().is_none());
}

#[test]
fn every_key_is_loaded() {
    let d = scratch("all");
    write_maps(&d);
    let s = parse_in(
        &d,
        "base_color = [0.5, 1, 1]\nbase_color_map = \"base.png\"\nmetallic = 0.75\n\
         roughness = 0.3\nmetallic_roughness_map = \"mr.png\"\nior = 1.33\ntransmission = 0.4\n\
         transmission_color = [0.2, 0.9, 0.1]\nnormal_map = \"normals.png\"\nnormal_scale = 0.5\n\
         alpha = \"matte.png\"\nalpha_cutoff = 0.25\n",
    )
    .unwrap();
    let p = pbr(&s);
    // The map (sRGB, red on the left) times the factor.
    match &p.base_color {
        ColorInput::Texture { factor, .. } => assert_eq!(*factor, Vec3::new(0.5, 1.0, 1.0)),
        other => panic!("{other:?}"),
    }
    let left = p.base_color.at(Vec2::new(0.25, 0.5));
    assert!((left - Vec3::new(0.5, 0.0, 0.0)).length() < 1e-5, "{left}");
    assert_eq!(
        (p.metallic, p.roughness, p.ior, p.transmission),
        (0.75, 0.3, 1.33, 0.4)
    );
    assert!(
        matches!(p.transmission_color, ColorInput::Constant(c) if c == Vec3::new(0.2, 0.9, 0.1))
    );
    // Linear: 128 / 255, not sRGB-decoded.
    let mr = p
        .metallic_roughness
        .as_ref()
        .expect("metallic-roughness map");
    let t = mr.sample(Vec2::new(0.5, 0.5));
    assert!(
        (t.y - 128.0 / 255.0).abs() < 1e-5 && (t.z - 1.0).abs() < 1e-6,
        "{t}"
    );
    let b = p.bsdf(Vec2::new(0.5, 0.5));
    assert!((b.roughness - 0.3 * 128.0 / 255.0).abs() < 1e-5);
    assert!((b.metallic - 0.75).abs() < 1e-6);
    let n = s.materials[0].normal_map().expect("normal map");
    assert_eq!(n.scale, 0.5);
    assert!((n.map.rgb(Vec2::new(0.5, 0.5)).y - 128.0 / 255.0).abs() < 1e-5);
    let a = s.materials[0].alpha_mask().expect("cut-out");
    assert_eq!(a.cutoff, 0.25);
    assert!(!a.use_alpha_channel);
    assert!(!a.opaque(Vec2::new(0.25, 0.5)) && a.opaque(Vec2::new(0.75, 0.5)));
}

#[test]
fn alpha_map_is_another_name_for_alpha() {
    let d = scratch("alpha_map");
    write_maps(&d);
    let s = parse_in(&d, "alpha_map = \"matte.png\"\n").unwrap();
    let a = pbr(&s).alpha.as_ref().expect("cut-out");
    assert_eq!(a.cutoff, 0.5);
    assert!(!a.opaque(Vec2::new(0.25, 0.5)) && a.opaque(Vec2::new(0.75, 0.5)));
    let e = parse_in(&d, "alpha = \"matte.png\"\nalpha_map = \"matte.png\"\n").unwrap_err();
    assert_eq!(
        (e.key.as_str(), e.line),
        ("material[0].alpha_map", Some(8)),
        "{e}"
    );
}

#[test]
fn bad_values_name_file_line_and_key() {
    let d = scratch("bad");
    write_maps(&d);
    let cases: &[(&str, &str, usize, &str)] = &[
        (
            "roughness = 1.5\n",
            "roughness",
            7,
            "must be in [0, 1], got 1.5",
        ),
        (
            "roughness = -0.1\n",
            "roughness",
            7,
            "must be in [0, 1], got -0.1",
        ),
        ("metallic = 2\n", "metallic", 7, "must be in [0, 1], got 2"),
        ("\nior = 0.5\n", "ior", 8, "must be in [1, 3], got 0.5"),
        ("ior = nan\n", "ior", 7, "got NaN"),
        (
            "transmission = 1.2\n",
            "transmission",
            7,
            "must be in [0, 1], got 1.2",
        ),
        (
            "base_color = [1.2, 0, 0]\n",
            "base_color",
            7,
            "must be in [0, 1]",
        ),
        (
            "base_color = -1\n",
            "base_color",
            7,
            "must be finite and >= 0",
        ),
        (
            "transmission_color = 2\n",
            "transmission_color",
            7,
            "must be in [0, 1]",
        ),
        (
            "normal_map = \"normals.png\"\nnormal_scale = 11\n",
            "normal_scale",
            8,
            "must be in [0, 10], got 11",
        ),
        (
            "normal_scale = 1\n",
            "normal_scale",
            7,
            "needs a normal map",
        ),
        (
            "alpha_cutoff = 0.5\n",
            "alpha_cutoff",
            7,
            "needs an alpha map",
        ),
        (
            "alpha = \"matte.png\"\nalpha_cutoff = 2\n",
            "alpha_cutoff",
            8,
            "must be in [0, 1], got 2",
        ),
        ("normal_map = \"gone.png\"\n", "normal_map", 7, "gone.png"),
        (
            "base_color_map = \"gone.png\"\n",
            "base_color_map",
            7,
            "gone.png",
        ),
        (
            "metallic_roughness_map = \"gone.png\"\n",
            "metallic_roughness_map",
            7,
            "gone.png",
        ),
        ("alpha_map = \"gone.png\"\n", "alpha_map", 7, "gone.png"),
        // Keys of other material types: the table's line.
        (
            "reflectance = 0.5\n",
            "reflectance",
            4,
            "is not a key of a material[0] of type 'pbr'",
        ),
        (
            "species = \"oak\"\n",
            "species",
            4,
            "it takes: type, name, base_color",
        ),
    ];
    for (body, key, line, msg) in cases {
        let e = parse_in(&d, body).map(|_| ()).unwrap_err();
        let text = e.to_string();
        assert_eq!(e.key, format!("material[0].{key}"), "{body}: {text}");
        assert_eq!(e.line, Some(*line), "{body}: {text}");
        assert!(text.contains(msg), "{body}: '{msg}' not in: {text}");
        assert!(
            text.starts_with(&format!(
                "{}:{line}: material[0].{key}: ",
                d.join("s.toml").display()
            )),
            "{text}"
        );
    }
}

#[test]
fn pbr_keys_are_rejected_on_other_types_and_unknown_type_lists_pbr() {
    let d = scratch("other");
    let text = format!("{CAMERA}[[material]]\nname = \"m\"\ntype = \"diffuse\"\nroughness = 0.5\n");
    let e = parse_scene(&text, &d.join("s.toml")).unwrap_err();
    assert_eq!(
        (e.key.as_str(), e.line),
        ("material[0].roughness", Some(4)),
        "{e}"
    );
    let text = format!("{CAMERA}[[material]]\nname = \"m\"\ntype = \"glossy\"\n");
    let e = parse_scene(&text, &d.join("s.toml")).unwrap_err();
    assert_eq!(
        (e.key.as_str(), e.line),
        ("material[0].type", Some(6)),
        "{e}"
    );
    assert!(e.to_string().contains("pbr"), "{e}");
}

#[test]
fn pbr_material_is_used_by_a_quad() {
    let d = scratch("quad");
    let s = parse_in(
        &d,
        "metallic = 1\nroughness = 0.2\n[[object]]\ntype = \"quad\"\nmaterial = \"m\"\n\
         corner = [0, 0, 0]\nedge_u = [1, 0, 0]\nedge_v = [0, 1, 0]\n",
    )
    .unwrap();
    assert_eq!(s.meshes.len(), 1);
    let p = pbr(&s);
    assert_eq!((p.metallic, p.roughness), (1.0, 0.2));
    assert_eq!(s.meshes[0].material, 0);
}
