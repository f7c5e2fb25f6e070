//! OBJ with MTL materials in scene files: usemtl groups, Kd/map_Kd/d/map_d/Tf, overrides by
//! name, and bad files (missing MTL or texture, NaN vertices, indices out of range).

mod common;
use glam::{Vec2, Vec3};
use lamina_scene::{ColorInput, Material, Scene, parse_scene};
use std::path::{Path, PathBuf};

fn scratch(name: &str) -> PathBuf {
    common::scratch("objmtl", name)
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

/// Four quads, one per material of [`PBR_MTL`].
const PBR_OBJ: &str = "mtllib plant.mtl
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
vt 0 0
vt 1 0
vt 1 1
vt 0 1
o a
usemtl glossy
f 1/1 2/2 3/3 4/4
o b
usemtl rough
f 1/1 2/2 3/3 4/4
o c
usemtl blender
f 1/1 2/2 3/3 4/4
o d
usemtl height
f 1/1 2/2 3/3 4/4
";

const PBR_MTL: &str = "newmtl glossy
Kd 0.6 0.5 0.4
Ks 0.5 0.5 0.5
Ns 98
Ni 1.33
Pm 0.25
norm -bm 0.5 -s 2 2 1 -o 0.5 0.25 0 normals.png
map_Kd -s 2 2 -o 0.5 0.25 leaf.png
newmtl rough
Kd 0.3 0.2 0.1
Pr 0.7
map_Pr -imfchan g rough.png
map_Pm metal.png
newmtl blender
Kd 0.5 0.5 0.5
map_Bump -bm 2 normals.png
newmtl height
Kd 0.2 0.2 0.2
bump -bm 0.1 height.png
";

fn setup_pbr(name: &str, mtl: &str) -> PathBuf {
    let d = scratch(name);
    std::fs::write(d.join("plant.obj"), PBR_OBJ).unwrap();
    std::fs::write(d.join("plant.mtl"), mtl).unwrap();
    write_png(&d, "leaf.png", 255);
    image::RgbImage::from_pixel(2, 2, image::Rgb([128, 200, 255]))
        .save(d.join("normals.png"))
        .unwrap();
    // Roughness in green (read with -imfchan g), metallic in red.
    image::RgbImage::from_fn(4, 1, |x, _| {
        image::Rgb([0, if x < 2 { 51 } else { 255 }, 0])
    })
    .save(d.join("rough.png"))
    .unwrap();
    image::GrayImage::from_fn(4, 1, |x, _| image::Luma([if x < 2 { 0 } else { 255 }]))
        .save(d.join("metal.png"))
        .unwrap();
    image::GrayImage::from_pixel(2, 2, image::Luma([90]))
        .save(d.join("height.png"))
        .unwrap();
    d
}

fn pbr_of(s: &Scene, mesh: usize) -> &lamina_scene::PbrMaterial {
    match &s.materials[s.meshes[mesh].material as usize] {
        Material::Pbr(p) => p,
        other => panic!("mesh {mesh}: {other:?}"),
    }
}

#[test]
fn glossy_and_relief_mtl_materials_become_pbr() {
    let d = setup_pbr("pbr", PBR_MTL);
    let s = scene(&d, "").unwrap();
    assert_eq!(s.meshes.len(), 4);

    // Ks + Ns: roughness (2 / (Ns + 2))^(1/4) = 0.02^0.25; Pm; Ni; norm -bm.
    let g = pbr_of(&s, 0);
    assert_eq!(g.name, "glossy");
    assert!(
        (g.roughness - 0.02f32.powf(0.25)).abs() < 1e-6,
        "{}",
        g.roughness
    );
    assert!((lamina_scene::obj::phong_exponent_to_roughness(98.0) - 0.376_06).abs() < 1e-4);
    assert_eq!((g.metallic, g.ior, g.transmission), (0.25, 1.33, 0.0));
    assert!(g.metallic_roughness.is_none());
    match &g.base_color {
        ColorInput::Texture { factor, .. } => assert_eq!(*factor, Vec3::new(0.6, 0.5, 0.4)),
        other => panic!("{other:?}"),
    }
    let n = g.normal_map.as_ref().expect("norm");
    assert_eq!(n.scale, 0.5);
    let texel = n.map.rgb(Vec2::new(0.5, 0.5));
    assert!(
        (texel - Vec3::new(128.0, 200.0, 255.0) / 255.0).length() < 1e-5,
        "linear"
    );
    assert!(g.alpha.is_none());
    // Both maps say -s 2 2 -o 0.5 0.25: the quad's uvs are transformed.
    let uvs = &s.meshes[0].uvs;
    let want = [(0.5, 0.25), (2.5, 0.25), (2.5, 2.25), (0.5, 2.25)];
    for w in want {
        assert!(
            uvs.iter()
                .any(|u| (*u - Vec2::new(w.0, w.1)).length() < 1e-6),
            "{w:?} not in {uvs:?}"
        );
    }
    // Other materials' meshes keep their uvs.
    assert!(s.meshes[1].uvs.iter().all(|u| u.x <= 1.0 && u.y <= 1.0));

    // Pr with map_Pr (green channel) and map_Pm alone (factor 1), packed G / B.
    let r = pbr_of(&s, 1);
    assert_eq!((r.roughness, r.metallic), (0.7, 1.0));
    assert!(r.normal_map.is_none());
    let mr = r.metallic_roughness.as_ref().expect("packed map");
    assert_eq!((mr.width(), mr.height()), (4, 1));
    let left = mr.texel(0, 0);
    let right = mr.texel(3, 0);
    assert!((left.y - 0.2).abs() < 1e-2 && left.z == 0.0, "{left}");
    assert!((right.y - 1.0).abs() < 1e-6 && right.z == 1.0, "{right}");
    let b = r.bsdf(Vec2::new(0.8, 0.5));
    assert!((b.roughness - 0.7).abs() < 1e-5 && (b.metallic - 1.0).abs() < 1e-6);

    // A coloured map_Bump is read as a normal map with -bm; no Ks/Ns: roughness 0.5.
    let bl = pbr_of(&s, 2);
    assert_eq!(bl.normal_map.as_ref().expect("map_Bump").scale, 2.0);
    assert_eq!((bl.roughness, bl.metallic), (0.5, 0.0));

    // A grey bump (height map) is ignored: the material stays diffuse.
    match &s.materials[s.meshes[3].material as usize] {
        Material::Diffuse { name, .. } => assert_eq!(name, "height"),
        other => panic!("{other:?}"),
    }
    // ... with warnings for both bump maps.
    let obj = lamina_scene::obj::load_obj(&d.join("plant.obj")).unwrap();
    let w = obj.warnings.join("\n");
    assert!(
        w.contains("'blender'") && w.contains("tangent-space normal map"),
        "{w}"
    );
    assert!(w.contains("'height'") && w.contains("height map"), "{w}");
}

#[test]
fn pbr_with_tf_keeps_the_transmission() {
    let d = setup_pbr(
        "pbr_tf",
        "newmtl glossy\nKd 0.4 0.4 0.4\nKs 1 1 1\nTf 0.5 0.25 0.5\nnewmtl rough\nnewmtl blender\nnewmtl height\n",
    );
    let s = scene(&d, "").unwrap();
    let g = pbr_of(&s, 0);
    assert_eq!(g.transmission, 0.5);
    assert_eq!(
        g.transmission_color.at(Vec2::ZERO),
        Vec3::new(1.0, 0.5, 1.0)
    );
    // Kd 0.4 reflected of (1 - 0.5): base 0.8.
    assert!((g.base_color.at(Vec2::ZERO) - Vec3::splat(0.8)).length() < 1e-6);
    // Neither Ns nor Pr: roughness 0.5; no Ni: ior 1.5.
    assert_eq!((g.roughness, g.ior), (0.5, 1.5));
    // Materials without gloss or relief stay as before.
    assert!(matches!(
        s.materials[s.meshes[1].material as usize],
        Material::Diffuse { .. }
    ));
}

#[test]
fn maps_with_different_uv_options_are_warned_about_and_ignored() {
    let d = setup_pbr(
        "pbr_mixed",
        "newmtl glossy\nKs 1 1 1\nmap_Kd -s 2 2 leaf.png\nnorm normals.png\n\
         newmtl rough\nnewmtl blender\nnewmtl height\n",
    );
    let obj = lamina_scene::obj::load_obj(&d.join("plant.obj")).unwrap();
    let w = obj.warnings.join("\n");
    assert!(w.contains("different -s/-o"), "{w}");
    let m0 = obj.meshes.iter().find(|m| m.material == 0).unwrap();
    assert!(m0.uvs.iter().all(|u| u.x <= 1.0 && u.y <= 1.0), "unchanged");
}

#[test]
fn bad_pbr_mtl_values_name_file_line_and_statement() {
    let tail = "newmtl rough\nnewmtl blender\nnewmtl height\n";
    let cases: &[(&str, &str, &[&str])] = &[
        (
            "pr",
            "Kd 1 1 1\nPr 2\n",
            &["plant.mtl:3: newmtl glossy: Pr", "must be in [0, 1], got 2"],
        ),
        (
            "pm",
            "Pm -1\n",
            &[
                "plant.mtl:2: newmtl glossy: Pm",
                "must be in [0, 1], got -1",
            ],
        ),
        (
            "pr_nan",
            "Pr x\n",
            &["plant.mtl:2: newmtl glossy: Pr", "not a number: 'x'"],
        ),
        (
            "norm_missing",
            "Kd 1 1 1\n\nnorm -bm 0.5 gone.png\n",
            &[
                "plant.mtl:4: newmtl glossy: norm",
                "cannot load texture",
                "gone.png",
            ],
        ),
        (
            "bm",
            "norm -bm x normals.png\n",
            &[
                "plant.mtl:2: newmtl glossy: norm",
                "-bm: 'x' is not a finite number",
            ],
        ),
        (
            "bm_range",
            "bump -bm 50 normals.png\n",
            &[
                "plant.mtl:2: newmtl glossy: map_Bump",
                "-bm must be in [0, 10], got 50",
            ],
        ),
        (
            "s",
            "map_Kd -s leaf.png\n",
            &[
                "plant.mtl:2: newmtl glossy: map_Kd",
                "-s: needs numbers, got 'leaf.png'",
            ],
        ),
        (
            "option",
            "map_Pr -foo 1 rough.png\n",
            &[
                "plant.mtl:2: newmtl glossy: map_Pr",
                "unknown texture option '-foo'",
            ],
        ),
        (
            "no_file",
            "norm -bm 1\n",
            &[
                "plant.mtl:2: newmtl glossy: norm",
                "no texture file after the options",
            ],
        ),
        (
            "ns",
            "Ks 1 1 1\nNs -4\n",
            &[
                "plant.mtl:3: newmtl glossy: Ns",
                "must be finite and >= 0, got -4",
            ],
        ),
    ];
    for (name, body, want) in cases {
        let d = setup_pbr(
            &format!("bad_{name}"),
            &format!("newmtl glossy\n{body}{tail}"),
        );
        let e = scene(&d, "").map(|_| ()).unwrap_err();
        for w in *want {
            assert!(e.contains(w), "{name}: '{w}' not in: {e}");
        }
    }
}
