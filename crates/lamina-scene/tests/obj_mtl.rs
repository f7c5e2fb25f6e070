//! OBJ with MTL materials in scene files: usemtl groups, Kd/map_Kd/d/map_d/Tf, overrides by
//! name, and bad files (missing MTL or texture, NaN vertices, indices out of range).

use glam::{Vec2, Vec3};
use lamina_scene::{ColorInput, Material, Scene, parse_scene};
use std::path::{Path, PathBuf};

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("lamina-objmtl-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Two quads: the first with `usemtl bark`, the second with `usemtl leaf`.
const OBJ: &str = "mtllib plant.mtl
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 0 0 1
v 1 0 1
v 1 1 1
v 0 1 1
vt 0 0
vt 1 0
vt 1 1
vt 0 1
o stem
usemtl bark
f 1/1 2/2 3/3 4/4
o blade
usemtl leaf
f 5/1 6/2 7/3 8/4
";

const MTL: &str = "newmtl bark
Kd 0.3 0.2 0.1
newmtl leaf
Kd 0.9 0.9 0.9
map_Kd leaf.png
Tf 0.3 0.5 0.1
";

fn write_png(dir: &Path, name: &str, alpha: u8) {
    let img = image::RgbaImage::from_fn(4, 4, |x, _| {
        image::Rgba([255, 128, 0, if x < 2 { alpha } else { 255 }])
    });
    img.save(dir.join(name)).unwrap();
}

fn scene(dir: &Path, object_extra: &str) -> Result<Scene, String> {
    let text = format!(
        "[camera]\nposition = [0, 1, 3]\nlook_at = [0, 0, 0]\n\
         [[material]]\nname = \"my_leaf\"\ntype = \"leaf\"\n\
         [[object]]\ntype = \"obj\"\nfile = \"plant.obj\"\n{object_extra}\n"
    );
    parse_scene(&text, &dir.join("s.toml")).map_err(|e| e.to_string())
}

fn setup(name: &str) -> PathBuf {
    let d = scratch(name);
    std::fs::write(d.join("plant.obj"), OBJ).unwrap();
    std::fs::write(d.join("plant.mtl"), MTL).unwrap();
    write_png(&d, "leaf.png", 0);
    d
}

#[test]
fn usemtl_groups_become_meshes_with_mtl_materials() {
    let d = setup("ok");
    let s = scene(&d, "").unwrap();
    // my_leaf (scene), bark, leaf; the unused default is not added.
    assert_eq!(s.materials.len(), 3);
    assert_eq!(s.meshes.len(), 2);
    let bark = &s.materials[s.meshes[0].material as usize];
    match bark {
        Material::Diffuse {
            name,
            reflectance: ColorInput::Constant(c),
            alpha: None,
        } => {
            assert_eq!(name, "bark");
            assert!((*c - Vec3::new(0.3, 0.2, 0.1)).length() < 1e-6);
        }
        other => panic!("{other:?}"),
    }
    match &s.materials[s.meshes[1].material as usize] {
        Material::DiffuseTransmission {
            name,
            reflectance,
            transmittance,
            alpha,
        } => {
            assert_eq!(name, "leaf");
            // Kd lowered to keep Kd + Tf <= 1; texture sRGB-decoded (128 -> 0.216).
            let r = reflectance.at(Vec2::new(0.9, 0.5));
            assert!(
                (r - Vec3::new(0.7, 0.5 * 0.2158, 0.0)).length() < 1e-2,
                "{r}"
            );
            assert_eq!(transmittance.at(Vec2::ZERO), Vec3::new(0.3, 0.5, 0.1));
            let a = alpha.as_ref().expect("map_Kd alpha becomes a cut-out");
            assert!(a.use_alpha_channel);
            assert!(!a.opaque(Vec2::new(0.1, 0.5)) && a.opaque(Vec2::new(0.9, 0.5)));
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn mtl_materials_are_overridden_by_name_or_all_at_once() {
    let d = setup("override");
    let s = scene(&d, "materials = { leaf = \"my_leaf\" }").unwrap();
    assert_eq!(s.meshes[1].material, 0);
    assert_eq!(s.materials.len(), 2, "my_leaf and bark");
    let s = scene(&d, "material = \"my_leaf\"").unwrap();
    assert!(s.meshes.iter().all(|m| m.material == 0));
    assert_eq!(s.materials.len(), 1);
    let e = scene(&d, "materials = { petal = \"my_leaf\" }").unwrap_err();
    assert!(
        e.contains("object[0].materials.petal") && e.contains("bark, leaf"),
        "{e}"
    );
}

#[test]
fn map_d_and_dissolve() {
    let d = setup("dissolve");
    std::fs::write(
        d.join("plant.mtl"),
        "newmtl bark\nd 0.2\nnewmtl leaf\nKd 0.5 0.5 0.5\nmap_d matte.png\n",
    )
    .unwrap();
    image::GrayImage::from_fn(2, 1, |x, _| image::Luma([if x == 0 { 0 } else { 255 }]))
        .save(d.join("matte.png"))
        .unwrap();
    let s = scene(&d, "").unwrap();
    let alpha = |i: usize| match &s.materials[s.meshes[i].material as usize] {
        Material::Diffuse { alpha, .. } => alpha.clone().expect("cut-out"),
        other => panic!("{other:?}"),
    };
    assert!(!alpha(0).opaque(Vec2::new(0.5, 0.5)), "d 0.2: invisible");
    let leaf = alpha(1);
    assert!(!leaf.use_alpha_channel);
    assert!(!leaf.opaque(Vec2::new(0.25, 0.5)) && leaf.opaque(Vec2::new(0.75, 0.5)));
}

#[test]
fn obj_without_mtl_gets_the_grey_default() {
    let d = scratch("plain");
    std::fs::write(d.join("plant.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let s = scene(&d, "").unwrap();
    assert_eq!(s.meshes.len(), 1);
    match &s.materials[s.meshes[0].material as usize] {
        Material::Diffuse { name, .. } => assert_eq!(name, "default"),
        other => panic!("{other:?}"),
    }
}

#[test]
fn bad_obj_and_mtl_files_name_file_line_and_what() {
    let cases: &[(&str, &str, Option<&str>, &[&str])] = &[
        // (name, obj text, mtl text, expected words)
        (
            "missing_mtl",
            "mtllib nothere.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
            None,
            &["plant.obj:1: mtllib", "nothere.mtl"],
        ),
        (
            "missing_texture",
            OBJ,
            Some("newmtl bark\nKd 1 1 1\nnewmtl leaf\nmap_Kd textures/gone.png\n"),
            &["plant.mtl", "newmtl leaf: map_Kd", "textures/gone.png"],
        ),
        (
            "nan",
            "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n",
            None,
            &["plant.obj:2: v", "'nan' is not a finite number"],
        ),
        (
            "inf",
            "v 0 0 0\nv 1 inf 0\nv 0 1 0\nf 1 2 3\n",
            None,
            &["plant.obj:2: v", "'inf'"],
        ),
        (
            "index",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n",
            None,
            &["plant.obj:4: f", "vertex index '7' is out of range"],
        ),
        (
            "negative_index",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -9\n",
            None,
            &["plant.obj:4: f", "'-9' is out of range"],
        ),
        (
            "uv_index",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/2 3/1\n",
            None,
            &["plant.obj:5: f", "texture coordinate index '2'"],
        ),
        ("empty", "# nothing\n", None, &["plant.obj", "no triangles"]),
        (
            "bad_tf",
            "mtllib plant.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl leaf\nf 1 2 3\n",
            Some("newmtl leaf\nTf 0.2 x 0.1\n"),
            &["plant.mtl", "newmtl leaf: Tf", "not numbers"],
        ),
    ];
    for (name, obj, mtl, want) in cases {
        let d = scratch(name);
        std::fs::write(d.join("plant.obj"), obj).unwrap();
        if let Some(m) = mtl {
            std::fs::write(d.join("plant.mtl"), m).unwrap();
        }
        let e = scene(&d, "").map(|_| ()).unwrap_err();
        for w in *want {
            assert!(e.contains(w), "{name}: '{w}' not in: {e}");
        }
    }
}
