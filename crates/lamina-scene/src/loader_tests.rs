//! Tests of the loaders' last line of defence (a panic inside a loader becomes an error
//! naming the file) and of the scene-wide budgets, with small budgets so that nothing big
//! is built.

use crate::limits::Budgets;
use std::path::{Path, PathBuf};

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("lamina-guard-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

use lamina_leaf::guard::with_fault;

fn assert_names(e: crate::SceneError, file: &str) {
    let s = e.to_string();
    assert!(
        s.contains(file) && s.contains("injected fault") && s.contains("a bug"),
        "{s}"
    );
}

const SCENE: &str = "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n";

/// A one-triangle .gltf with its buffer as a data URI.
fn triangle_gltf() -> String {
    let bytes: Vec<u8> = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]
        .iter()
        .flat_map(|x| x.to_le_bytes())
        .collect();
    const T: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut b64 = String::new();
    for c in bytes.chunks(3) {
        let n = (c[0] as u32) << 16 | (c[1] as u32) << 8 | c[2] as u32;
        for i in 0..4 {
            b64.push(T[(n >> (18 - 6 * i) & 63) as usize] as char);
        }
    }
    format!(
        r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0]}}],
  "nodes": [{{"mesh": 0}}], "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}}}]}}],
  "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}}],
  "bufferViews": [{{"buffer": 0, "byteLength": 36}}],
  "buffers": [{{"byteLength": 36, "uri": "data:application/octet-stream;base64,{b64}"}}]}}"#
    )
}

#[test]
fn every_loader_entry_point_turns_a_panic_into_an_error_naming_the_file() {
    let d = scratch("entry");
    let scene = d.join("s.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let gltf = d.join("t.gltf");
    std::fs::write(&gltf, triangle_gltf()).unwrap();
    let obj = d.join("t.obj");
    std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let cards = d.join("c.csv");
    std::fs::write(
        &cards,
        "cx,cy,cz,nx,ny,nz,ux,uy,uz,width,height\n0,0,0,0,0,1,0,1,0,0.1,0.2\n",
    )
    .unwrap();
    let placements = d.join("p.csv");
    std::fs::write(&placements, "tx\n1\n").unwrap();
    let xf = crate::transform::Transform::default();

    // Without the fault, everything loads.
    assert!(crate::load_scene(&scene).is_ok());
    assert!(crate::gltf_import::load_gltf(&gltf, &xf).is_ok());
    assert!(crate::obj::load_obj(&obj).is_ok());
    assert!(crate::obj::load_obj_meshes(&obj, 0).is_ok());
    assert!(crate::cards::read_card_file(&cards).is_ok());
    assert!(crate::instances::read_instances_csv(&placements).is_ok());

    assert_names(
        with_fault("scene", || crate::load_scene(&scene)).unwrap_err(),
        "s.toml",
    );
    assert_names(
        with_fault("scene", || crate::parse_scene(SCENE, &scene)).unwrap_err(),
        "s.toml",
    );
    assert_names(
        with_fault("gltf", || crate::gltf_import::load_gltf(&gltf, &xf)).unwrap_err(),
        "t.gltf",
    );
    let bytes = std::fs::read(&gltf).unwrap();
    assert_names(
        with_fault("gltf", || {
            crate::gltf_import::parse_gltf(&bytes, &gltf, &xf)
        })
        .unwrap_err(),
        "t.gltf",
    );
    assert_names(
        with_fault("obj", || crate::obj::load_obj(&obj)).unwrap_err(),
        "t.obj",
    );
    assert_names(
        with_fault("obj_meshes", || crate::obj::load_obj_meshes(&obj, 0)).unwrap_err(),
        "t.obj",
    );
    assert_names(
        with_fault("cards", || crate::cards::read_card_file(&cards)).unwrap_err(),
        "c.csv",
    );
    assert_names(
        with_fault("instances", || {
            crate::instances::read_instances_csv(&placements)
        })
        .unwrap_err(),
        "p.csv",
    );
    // Inside a scene: the innermost guard names the file it was reading.
    let text = format!("{SCENE}[[object]]\ntype = \"gltf\"\nfile = \"t.gltf\"\n");
    assert_names(
        with_fault("gltf", || crate::parse_scene(&text, &scene)).unwrap_err(),
        "t.gltf",
    );
}

fn parse_small(text: &str, path: &Path, budgets: Budgets) -> Result<crate::Scene, String> {
    crate::loader::parse_with(text, path, budgets).map_err(|e| e.to_string())
}

const QUAD: &str = "[[material]]\nname = \"m\"\ntype = \"diffuse\"\n";

#[test]
fn the_instance_limit_is_over_all_objects() {
    let d = scratch("instances");
    let obj = |n: usize| {
        let placements = vec!["{ translate = [0, 0, 0] }"; n].join(", ");
        format!(
            "[[object]]\ntype = \"quad\"\nmaterial = \"m\"\ncorner = [0, 0, 0]\nedge_u = [1, 0, 0]\nedge_v = [0, 1, 0]\ninstances = [{placements}]\n"
        )
    };
    let budgets = Budgets {
        instances: 5,
        ..Budgets::default()
    };
    let ok = format!("{SCENE}{QUAD}{}{}", obj(3), obj(2));
    let s = parse_small(&ok, &d.join("s.toml"), budgets).unwrap();
    assert_eq!(s.instances.len(), 5);
    // Each object alone is within the limit; together they are not.
    let bad = format!("{SCENE}{QUAD}{}{}", obj(3), obj(3));
    let e = parse_small(&bad, &d.join("s.toml"), budgets).unwrap_err();
    assert!(
        e.contains("s.toml:14: object[1].instances")
            && e.contains("3 instances here and 3 in the objects before")
            && e.contains("more than the 5 supported in all"),
        "{e}"
    );
    // The placements file stops reading at the limit.
    std::fs::write(d.join("p.csv"), "tx\n1\n2\n3\n").unwrap();
    let file = "[[object]]\ntype = \"quad\"\nmaterial = \"m\"\ncorner = [0, 0, 0]\nedge_u = [1, 0, 0]\nedge_v = [0, 1, 0]\ninstances_file = \"p.csv\"\n";
    let bad = format!("{SCENE}{QUAD}{}{file}", obj(3));
    let e = parse_small(&bad, &d.join("s.toml"), budgets).unwrap_err();
    assert!(
        e.contains("p.csv:4") && e.contains("more than 2 instances"),
        "{e}"
    );
}

#[test]
fn the_leaf_and_leaf_map_limits_are_over_the_whole_scene() {
    let d = scratch("leaves");
    let budgets = Budgets {
        leaves: 5,
        leaf_texels: 100_000,
        ..Budgets::default()
    };
    let card =
        "{ center = [0, 0, 0], normal = [0, 0, 1], up = [0, 1, 0], width = 0.1, height = 0.1 }";
    let cards = |n: usize| {
        format!(
            "[[object]]\ntype = \"leaf_cards\"\nmaterial = \"m\"\ncards = [{}]\n",
            vec![card; n].join(", ")
        )
    };
    let ok = format!("{SCENE}{QUAD}{}{}", cards(3), cards(2));
    assert!(parse_small(&ok, &d.join("s.toml"), budgets).is_ok());
    let bad = format!("{SCENE}{QUAD}{}{}", cards(3), cards(3));
    let e = parse_small(&bad, &d.join("s.toml"), budgets).unwrap_err();
    assert!(
        e.contains("object[1].cards") && e.contains("more than the 5 supported in all"),
        "{e}"
    );
    // A card file stops at what is left.
    std::fs::write(
        d.join("c.csv"),
        "cx,cy,cz,nx,ny,nz,ux,uy,uz,width,height\n0,0,0,0,0,1,0,1,0,0.1,0.2\n0,0,0,0,0,1,0,1,0,0.1,0.2\n0,0,0,0,0,1,0,1,0,0.1,0.2\n",
    )
    .unwrap();
    let file = "[[object]]\ntype = \"leaf_cards\"\nmaterial = \"m\"\nfile = \"c.csv\"\n";
    let bad = format!("{SCENE}{QUAD}{}{file}", cards(3));
    let e = parse_small(&bad, &d.join("s.toml"), budgets).unwrap_err();
    assert!(
        e.contains("c.csv:4") && e.contains("more than 2 leaf cards"),
        "{e}"
    );
    // A plant's leaves count too, before it is grown.
    let plant = "[[object]]\ntype = \"plant\"\n[object.plant]\nleaf_count = 60\nleaf_resolution = 16\nleaf_variants = 1\n";
    let bad = format!("{SCENE}{plant}");
    let e = parse_small(&bad, &d.join("s.toml"), budgets).unwrap_err();
    assert!(
        e.contains("object[0].plant.leaf_count") && e.contains("more than the 5 supported"),
        "{e}"
    );
    // Procedural leaf maps: two species materials of 256 px (65536 texels each) exceed
    // 100,000 texels; the second is rejected before it is generated.
    let leaf = |i: usize| {
        format!(
            "[[material]]\nname = \"l{i}\"\ntype = \"leaf\"\nspecies = \"beech\"\nresolution = 256\n"
        )
    };
    let bad = format!("{SCENE}{}{}", leaf(0), leaf(1));
    let e = parse_small(&bad, &d.join("s.toml"), budgets).unwrap_err();
    assert!(
        e.contains("s.toml:13: material[1].resolution")
            && e.contains("more than the 100000 supported in all"),
        "{e}"
    );
}

#[test]
fn deeply_nested_input_is_an_error_not_a_stack_overflow() {
    let d = scratch("nested");
    let depth = 100_000;
    let toml = format!("{SCENE}x = {}{}\n", "[".repeat(depth), "]".repeat(depth));
    let e = crate::parse_scene(&toml, &d.join("s.toml"))
        .map(|_| ())
        .unwrap_err();
    assert!(e.to_string().contains("s.toml"), "{e}");
    let json = format!("{}{}", "[".repeat(depth), "]".repeat(depth));
    let e = crate::cards::parse_json(&d.join("c.json"), &json)
        .map(|_| ())
        .unwrap_err();
    assert!(e.to_string().contains("c.json"), "{e}");
}

#[test]
fn pigment_leaves_load_and_bad_pigments_name_the_key() {
    let scene = |pigments: &str, extra: &str| {
        format!(
            "{SCENE}[[material]]\nname = \"l\"\ntype = \"leaf\"\n{extra}pigments = {{ {pigments} }}\n"
        )
    };
    let path = Path::new("/tmp/pigments.toml");
    let ok = crate::loader::parse_scene(&scene("cab = 30, anth = 4", ""), path).unwrap();
    let crate::scene::Material::Leaf { leaf, .. } = &ok.materials[0] else {
        panic!("not a leaf");
    };
    // Colours from PROSPECT: a green leaf, green brighter than red and blue.
    let [front, _, trans] = leaf.map_colours(glam::Vec2::splat(0.5));
    assert!(front.y > front.x && front.y > front.z, "{front}");
    assert!(trans.y > trans.z, "{trans}");
    // A species keeps its shape maps and takes its colours from the pigments.
    crate::loader::parse_scene(
        &scene("cab = 30", "species = \"oak\"\nresolution = 32\n"),
        path,
    )
    .unwrap();
    for (pigments, words) in [
        ("cab = 300", &["pigments.cab", "300", "[0, 120]"][..]),
        ("chlorophyll = 3", &["chlorophyll"][..]),
        ("prot = 0.001, cm = 0.01", &["cm", "prot + cbc"][..]),
        ("n = \"two\"", &["n"][..]),
    ] {
        let e = crate::loader::parse_scene(&scene(pigments, ""), path)
            .unwrap_err()
            .to_string();
        assert!(e.contains("pigments.toml"), "{e}");
        for w in words {
            assert!(e.contains(w), "expected '{w}' in: {e}");
        }
    }
    let e = crate::loader::parse_scene(&scene("cab = 30", "maps = { front = \"f.png\" }\n"), path)
        .unwrap_err()
        .to_string();
    assert!(e.contains("f.png") || e.contains("maps.front"), "{e}");
}

#[test]
fn a_leaf_folder_with_its_wrap_mode_loads_from_a_scene() {
    // A folder as `lamina leaf generate` writes it: its leaf.toml says `wrap = "clamp"`,
    // which is a mode, not a map path to resolve against the folder.
    let d = scratch("wrap");
    let leaf = lamina_leafmaps::generate(&lamina_leafmaps::LeafSpec::new(
        lamina_leafmaps::Species::Oak,
        1,
        32,
    ));
    leaf.write_folder_with(&d.join("oak"), &lamina_leafmaps::FolderWrite::default())
        .unwrap();
    let text = std::fs::read_to_string(d.join("oak/leaf.toml")).unwrap();
    assert!(text.contains("wrap = \"clamp\""), "{text}");
    for extra in ["", "maps = { wrap = \"repeat\" }\n"] {
        let scene = format!(
            "{SCENE}[[material]]\nname = \"l\"\ntype = \"leaf\"\nfile = \"oak/leaf.toml\"\n{extra}"
        );
        crate::loader::parse_scene(&scene, &d.join("scene.toml")).unwrap();
    }
}

#[test]
fn a_sun_placed_by_latitude_longitude_and_time() {
    let path = Path::new("/tmp/sun.toml");
    let scene = |position: &str| {
        format!("{SCENE}[[light]]\ntype = \"sun\"\nirradiance = 3\nposition = {{ {position} }}\n")
    };
    // Golden, Colorado (the SPA paper's example): zenith 50.108°, azimuth 194.340°.
    let s = crate::loader::parse_scene(
        &scene("latitude = 39.742476, longitude = -105.1786, elevation = 1830.14, time = \"2003-10-17T12:30:30-07:00\""),
        path,
    )
    .unwrap();
    let crate::scene::Light::Sun { direction, .. } = s.lights[0] else {
        panic!("not a sun");
    };
    let zenith = direction.y.acos().to_degrees();
    // Azimuth clockwise from north (-z) toward east (+x).
    let azimuth = direction
        .x
        .atan2(-direction.z)
        .to_degrees()
        .rem_euclid(360.0);
    assert!(
        (zenith - 50.1078).abs() < 1e-3 && (azimuth - 194.3402).abs() < 1e-3,
        "{zenith} {azimuth}"
    );
    // North along +x turns the sun by 90 degrees about y.
    let s = crate::loader::parse_scene(
        &scene("latitude = 39.742476, longitude = -105.1786, elevation = 1830.14, time = \"2003-10-17T12:30:30-07:00\", north = [1, 0, 0]"),
        path,
    )
    .unwrap();
    let crate::scene::Light::Sun { direction: d2, .. } = s.lights[0] else {
        panic!("not a sun");
    };
    assert!(
        (d2 - glam::Vec3::new(-direction.z, direction.y, direction.x)).length() < 1e-5,
        "{d2} {direction}"
    );
    for (position, words) in [
        (
            "latitude = 52.5, longitude = 13.4, time = \"2024-06-21T23:30:00+02:00\"",
            &["time", "below the horizon"][..],
        ),
        (
            "latitude = 52.5, longitude = 13.4, time = \"2024-06-21T12:00\"",
            &["time", "UTC offset"][..],
        ),
        (
            "latitude = 95, longitude = 13.4, time = \"2024-06-21T12:00Z\"",
            &["latitude"][..],
        ),
        (
            "latitude = 52.5, longitude = 13.4, time = \"2024-02-30T12:00Z\"",
            &["day"][..],
        ),
        (
            "latitude = 52.5, longitude = 13.4, time = \"2024-06-21T12:00Z\", lat = 3",
            &["lat"][..],
        ),
        (
            "latitude = 52.5, longitude = 13.4, time = \"2024-06-21T12:00Z\", north = [0, 1, 0]",
            &["north", "horizontal"][..],
        ),
    ] {
        let e = crate::loader::parse_scene(&scene(position), path)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("sun.toml") && e.contains("light[0].position"),
            "{e}"
        );
        for w in words {
            assert!(e.contains(w), "expected '{w}' in: {e}");
        }
    }
    let both = format!(
        "{SCENE}[[light]]\ntype = \"sun\"\nirradiance = 3\ndirection = [0, 1, 0]\nposition = {{ latitude = 0, longitude = 0, time = \"2024-03-20T12:00Z\" }}\n"
    );
    let e = crate::loader::parse_scene(&both, path)
        .unwrap_err()
        .to_string();
    assert!(e.contains("not both"), "{e}");
}

#[test]
fn film_bands_parse_and_bad_bands_name_the_key() {
    let path = Path::new("/tmp/bands.toml");
    let scene = |film: &str| format!("{SCENE}[film]\n{film}\n");
    let (_, out) = crate::loader::parse_with_output(
        &scene("bands = [{ name = \"red\", center = 665, width = 30 }, { name = \"nir\", min = 785, max = 900 }]\nfalse_color = [\"nir\", \"red\", \"red\"]"),
        path,
        Budgets::default(),
    )
    .unwrap();
    let out = out.unwrap();
    assert_eq!(out.bands.len(), 2);
    assert_eq!((out.bands[0].lo_nm, out.bands[0].hi_nm), (650.0, 680.0));
    assert_eq!((out.bands[1].lo_nm, out.bands[1].hi_nm), (785.0, 900.0));
    assert_eq!(out.false_color, [1, 0, 0]);
    let (_, none) =
        crate::loader::parse_with_output(&scene("width = 8"), path, Budgets::default()).unwrap();
    assert!(none.is_none());
    for (film, words) in [
        ("bands = []", &["film.bands", "give 1 to 64"][..]),
        (
            "bands = [{ name = \"x\", center = 300, width = 10 }]",
            &["center", "300"][..],
        ),
        (
            "bands = [{ name = \"x\", center = 2490, width = 40 }]",
            &["360-2500"][..],
        ),
        ("bands = [{ name = \"x\", center = 500 }]", &["width"][..]),
        (
            "bands = [{ name = \"x\", min = 600, max = 500 }]",
            &["wider than 0"][..],
        ),
        (
            "bands = [{ name = \"a b\", center = 500, width = 10 }]",
            &["'a b'", "EXR channel"][..],
        ),
        (
            "bands = [{ name = \"x\", center = 500, width = 10 }, { name = \"x\", center = 600, width = 10 }]",
            &["names two bands"][..],
        ),
        (
            "bands = [{ name = \"x\", centre = 500, width = 10 }]",
            &["centre"][..],
        ),
        ("bands = [\"red\"]", &["each band is a table"][..]),
        (
            "bands = [{ name = \"x\", center = 500, width = 10 }]\nfalse_color = [\"x\", \"y\", \"x\"]",
            &["no band named 'y'", "x"][..],
        ),
        (
            "false_color = [\"a\", \"b\", \"c\"]",
            &["needs `bands`"][..],
        ),
    ] {
        let e = crate::loader::parse_scene(&scene(film), path)
            .unwrap_err()
            .to_string();
        assert!(e.contains("bands.toml") && e.contains("film"), "{e}");
        for w in words {
            assert!(e.contains(w), "expected '{w}' in: {e}");
        }
    }
}

/// A band given by a response file: read relative to the scene, weighted, its errors
/// naming the file, the line and the key.
#[test]
fn film_bands_from_response_files() {
    let dir = scratch("response");
    let path = dir.join("scene.toml");
    std::fs::write(
        dir.join("b8.csv"),
        "# a made-up NIR response\nwavelength_nm,response\n770,0\n790,0.5\n830,1\n870,0.5\n890,0\n",
    )
    .unwrap();
    let film = |bands: &str| format!("{SCENE}[film]\nbands = [{bands}]\n");
    let (_, out) = crate::loader::parse_with_output(
        &film("{ name = \"B8\", response = \"b8.csv\" }, { name = \"red\", min = 650, max = 680 }"),
        &path,
        Budgets::default(),
    )
    .unwrap();
    let b8 = &out.unwrap().bands[0];
    assert_eq!((b8.lo_nm, b8.hi_nm), (770.0, 890.0));
    assert!((b8.center() - 830.0).abs() < 0.5, "{}", b8.center());
    assert_eq!(b8.weight(810.0), 0.75);
    std::fs::write(dir.join("bad.csv"), "nm r\n700 1\n690 1\n").unwrap();
    for (bands, words) in [
        (
            "{ name = \"x\", response = \"bad.csv\" }",
            &[
                "bad.csv:3",
                "film.bands[0].response",
                "band 'x'",
                "increase",
            ][..],
        ),
        (
            "{ name = \"x\", response = \"missing.csv\" }",
            &["missing.csv", "film.bands[0].response", "cannot read"][..],
        ),
        (
            "{ name = \"x\", response = \"b8.csv\", center = 800 }",
            &["film.bands[0].center", "drop `center`"][..],
        ),
        (
            "{ name = \"x\", response = 3 }",
            &["film.bands[0].response"][..],
        ),
    ] {
        let e = crate::loader::parse_scene(&film(bands), &path)
            .unwrap_err()
            .to_string();
        for w in words {
            assert!(e.contains(w), "expected '{w}' in: {e}");
        }
    }
}

/// An edited scene re-reads its settings and changed materials, keeps its geometry, and
/// refuses edits of the geometry, renames and bad values without changing the scene.
#[test]
fn reload_settings_rereads_what_changed_and_keeps_the_geometry() {
    use crate::overrides::{Override, apply_overrides};
    let path = Path::new("/nonexistent/edit.toml");
    let old = format!(
        "{SCENE}[film]\nwidth = 8\nheight = 6\n\n[[light]]\ntype = \"sun\"\ndirection = [0, 0, 1]\nirradiance = [1, 1, 1]\n\n\
         [[material]]\nname = \"a\"\ntype = \"diffuse\"\nreflectance = [0.5, 0.5, 0.5]\n\n\
         [[material]]\nname = \"b\"\ntype = \"diffuse\"\n\n\
         [[object]]\ntype = \"quad\"\nmaterial = \"b\"\ncorner = [-1, -1, 0]\nedge_u = [2, 0, 0]\nedge_v = [0, 2, 0]\n"
    );
    let (mut scene, mut spectral) = crate::parse_scene_with_output(&old, path).unwrap();
    let set = |text: &str, kv: &[&str]| {
        let o: Vec<Override> = kv.iter().map(|s| s.parse().unwrap()).collect();
        apply_overrides(text, path, &o).unwrap()
    };
    let new = set(
        &old,
        &[
            "camera.fov=20",
            "film.width=16",
            "light[0].direction=[0, 1, 1]",
            "material[1].reflectance=[0.1, 0.2, 0.3]",
        ],
    );
    let meshes = format!("{:?}", scene.meshes);
    crate::reload_settings(&mut scene, &mut spectral, &old, &new, path).unwrap();
    assert_eq!(scene.camera.fov_deg, 20.0);
    assert_eq!(scene.film.width, 16);
    let crate::Light::Sun { direction, .. } = &scene.lights[0] else {
        panic!("a sun")
    };
    assert!((direction.y - direction.z).abs() < 1e-6 && direction.y > 0.7);
    let crate::Material::Diffuse { reflectance, .. } = &scene.materials[1] else {
        panic!("diffuse")
    };
    assert_eq!(
        reflectance.at(glam::Vec2::ZERO),
        glam::Vec3::new(0.1, 0.2, 0.3)
    );
    assert_eq!(format!("{:?}", scene.meshes), meshes);

    // Refused, and the scene unchanged.
    let before = format!("{scene:?}");
    for (kv, words) in [
        ("object[0].material=\"a\"", "[[object]] tables changed"),
        ("material[0].name=\"c\"", "cannot be renamed"),
        ("film.width=0", "film.width"),
        (
            "material[0].reflectance=[2, 0, 0]",
            "material[0].reflectance",
        ),
    ] {
        let e = crate::reload_settings(&mut scene, &mut spectral, &new, &set(&new, &[kv]), path)
            .unwrap_err()
            .to_string();
        assert!(e.contains(words), "{kv}: {e}");
        assert_eq!(format!("{scene:?}"), before, "{kv}");
    }
}
