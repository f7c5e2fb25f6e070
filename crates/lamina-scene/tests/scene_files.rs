//! Scene files: what parses, and that every kind of mistake names file, line and key.

use lamina_scene::{
    Integrator, Light, LightSampling, Material, Scene, SceneError, Sky, SkySampling, parse_scene,
};
use std::path::{Path, PathBuf};

const MINIMAL: &str = r#"
[camera]
position = [0, 1, 3]
look_at = [0, 0, 0]
"#;

fn parse(text: &str) -> Result<Scene, SceneError> {
    parse_scene(text, Path::new("test.toml"))
}

fn err(text: &str) -> SceneError {
    match parse(text) {
        Ok(_) => panic!("expected an error for:\n{text}"),
        Err(e) => e,
    }
}

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples")
}

#[test]
fn minimal_scene_gets_documented_defaults() {
    let s = parse(MINIMAL).unwrap();
    assert_eq!((s.film.width, s.film.height, s.film.spp), (640, 480, 64));
    assert_eq!(s.camera.fov_deg, 40.0);
    assert_eq!(
        s.integrator,
        Integrator::Path {
            max_depth: 8,
            rr_depth: 3,
            light_sampling: Default::default(),
            sky_sampling: Default::default(),
        }
    );
    assert!(s.sky.is_none() && s.lights.is_empty() && s.meshes.is_empty());
}

#[test]
fn example_scene_loads_with_its_card_file() {
    let s = lamina_scene::load_scene(&examples().join("leaf_cards.toml")).unwrap();
    assert_eq!(s.materials.len(), 2);
    assert!(matches!(
        s.materials[0],
        Material::DiffuseTransmission { .. }
    ));
    let cards = &s.meshes[0];
    assert_eq!(cards.indices.len(), 2 * 40, "40 cards of two triangles");
    assert!(matches!(s.sky, Some(Sky::Constant(_))));
    match &s.lights[0] {
        Light::Sun {
            direction,
            irradiance,
            angular_diameter_deg,
        } => {
            assert!((direction.length() - 1.0).abs() < 1e-6);
            assert_eq!(irradiance.x, 3.0);
            assert_eq!(*angular_diameter_deg, 0.53);
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn every_light_and_object_type_parses() {
    let text = format!(
        r#"{MINIMAL}
[integrator]
type = "paper"
ambient = 0.2
[sky]
type = "constant"
radiance = [0.1, 0.2, 0.3]
[[light]]
type = "point"
position = [0, 2, 0]
intensity = 5
[[light]]
type = "quad"
corner = [0, 2, 0]
edge_u = [1, 0, 0]
edge_v = [0, 0, 1]
radiance = 4
two_sided = true
[[light]]
type = "sphere"
center = [0, 3, 0]
radius = 0.5
radiance = [1, 1, 1]
[[material]]
name = "m"
type = "diffuse"
[[object]]
type = "quad"
material = "m"
corner = [0, 0, 0]
edge_u = [1, 0, 0]
edge_v = [0, 1, 0]
transform = {{ scale = -1, rotate_y = 90, translate = [1, 2, 3] }}
[[object]]
type = "leaf_cards"
material = "m"
cards = [{{ center = [0, 0, 0], normal = [0, 0, 1], up = [0, 1, 0], width = 0.1, height = 0.2 }}]
"#
    );
    let s = parse(&text).unwrap();
    assert_eq!(s.lights.len(), 3);
    assert_eq!(s.meshes.len(), 2);
    assert!(matches!(
        s.integrator,
        Integrator::Paper { ambient: Some(_) }
    ));
    // The mirrored quad keeps its front face: scale -1 flips winding back.
    let m = &s.meshes[0];
    let [a, b, c] = m.indices[0].map(|i| m.positions[i as usize]);
    let n = (b - a).cross(c - a).normalize();
    // Front was +z; scale(-1) maps it to -z, then rotate_y 90° maps -z to -x.
    assert!((n - glam::Vec3::new(-1.0, 0.0, 0.0)).length() < 1e-5, "{n}");
}

/// `max_depth = 0` is a valid depth: only what camera rays see directly.
#[test]
fn max_depth_zero_loads() {
    let s = parse(&format!("{MINIMAL}\n[integrator]\nmax_depth = 0\n")).unwrap();
    assert!(
        matches!(s.integrator, Integrator::Path { max_depth: 0, .. }),
        "{:?}",
        s.integrator
    );
}

#[test]
fn light_sampling_reads_all_and_one() {
    for (value, want) in [("all", LightSampling::All), ("one", LightSampling::One)] {
        let s = parse(&format!(
            "{MINIMAL}\n[integrator]\nmax_depth = 5\nlight_sampling = \"{value}\"\n"
        ))
        .unwrap();
        assert_eq!(
            s.integrator,
            Integrator::Path {
                max_depth: 5,
                rr_depth: 3,
                light_sampling: want,
                sky_sampling: Default::default(),
            }
        );
    }
    let e = err(&format!(
        "{MINIMAL}\n[integrator]\nlight_sampling = \"power\"\n"
    ));
    assert!(
        e.to_string()
            .contains("unknown light sampling 'power' (all, one)"),
        "{e}"
    );
}

#[test]
fn sky_sampling_reads_auto_light_and_bsdf() {
    for (value, want) in [
        ("auto", SkySampling::Auto),
        ("light", SkySampling::Light),
        ("bsdf", SkySampling::Bsdf),
    ] {
        let s = parse(&format!(
            "{MINIMAL}\n[integrator]\nsky_sampling = \"{value}\"\n"
        ))
        .unwrap();
        let Integrator::Path { sky_sampling, .. } = s.integrator else {
            panic!("{:?}", s.integrator)
        };
        assert_eq!(sky_sampling, want);
    }
    let e = err(&format!(
        "{MINIMAL}\n[integrator]\nsky_sampling = \"never\"\n"
    ));
    assert_eq!(
        (e.key.as_str(), e.line),
        ("integrator.sky_sampling", Some(7)),
        "{e}"
    );
    assert!(
        e.to_string()
            .contains("unknown sky sampling 'never' (auto, light, bsdf)"),
        "{e}"
    );
    let e = err(&format!("{MINIMAL}\n[integrator]\nsky_sampling = true\n"));
    assert!(e.to_string().contains("must be a string"), "{e}");
    let e = err(&format!(
        "{MINIMAL}\n[integrator]\ntype = \"paper\"\nsky_sampling = \"bsdf\"\n"
    ));
    assert_eq!(e.key, "integrator.sky_sampling", "{e}");
    // Auto: BSDF samples for a constant sky, light samples for an image sky.
    assert!(!SkySampling::Auto.light_samples(&Sky::Constant(glam::Vec3::ONE)));
    assert!(SkySampling::Light.light_samples(&Sky::Constant(glam::Vec3::ONE)));
}

#[test]
fn toml_syntax_error_names_line() {
    let e = err("[camera]\nposition = [0, 1, 3\nlook_at = [0,0,0]\n");
    assert_eq!(e.file, Path::new("test.toml"));
    assert!(e.line.is_some(), "{e}");
}

#[test]
fn unknown_key_names_line_and_key() {
    let e = err(&format!("{MINIMAL}\n[film]\nwidth = 10\nsamples = 4\n"));
    assert_eq!(e.line, Some(8), "{e}");
    assert_eq!(e.key, "film.samples", "{e}");
    assert!(e.to_string().contains("unknown field `samples`"), "{e}");
}

#[test]
fn wrong_type_names_line() {
    let e = err(&format!("{MINIMAL}\n[film]\nwidth = \"wide\"\n"));
    assert_eq!(e.line, Some(7), "{e}");
    assert_eq!(e.key, "film.width", "{e}");
    let e = err(&format!(
        "{MINIMAL}\n[[light]]\ntype = \"sun\"\n[[light]]\ntype = \"point\"\nposition = \"here\"\n"
    ));
    assert_eq!(
        (e.key.as_str(), e.line),
        ("light[1].position", Some(10)),
        "{e}"
    );
}

#[test]
fn bad_values_name_key_and_range() {
    for (snippet, key, line) in [
        ("[film]\nspp = 0\n", "film.spp", 7),
        ("[film]\nwidth = -5\n", "film.width", 7),
        ("[integrator]\nmax_depth = -1\n", "integrator.max_depth", 7),
        (
            "[integrator]\nmax_depth = 1025\n",
            "integrator.max_depth",
            7,
        ),
        (
            "[integrator]\nlight_sampling = \"some\"\n",
            "integrator.light_sampling",
            7,
        ),
        (
            "[integrator]\ntype = \"paper\"\nlight_sampling = \"one\"\n",
            "integrator.light_sampling",
            6,
        ),
        (
            "[[light]]\ntype = \"sun\"\ndirection = [0, 0, 0]\nirradiance = 1\n",
            "light[0].direction",
            8,
        ),
        (
            "[[light]]\ntype = \"sun\"\ndirection = [0, 1, 0]\nirradiance = -1\n",
            "light[0].irradiance",
            9,
        ),
        (
            "[[light]]\ntype = \"sun\"\ndirection = [0, nan, 0]\nirradiance = 1\n",
            "light[0].direction",
            8,
        ),
        (
            "[[light]]\ntype = \"sun\"\nirradiance = 1\n",
            "light[0].direction",
            6,
        ),
        (
            "[[light]]\ntype = \"sun\"\ndirection = [0, 1, 0]\nirradiance = 1\nradius = 2\n",
            "light[0].radius",
            6,
        ),
        ("[[light]]\ntype = \"laser\"\n", "light[0].type", 7),
        (
            "[[material]]\nname = \"a\"\ntype = \"diffuse\"\nreflectance = 1.5\n",
            "material[0].reflectance",
            9,
        ),
        (
            "[[material]]\nname = \"a\"\ntype = \"diffuse_transmission\"\nreflectance = 0.6\ntransmittance = 0.6\n",
            "material[0].transmittance",
            10,
        ),
        (
            "[[material]]\nname = \"a\"\ntype = \"diffuse\"\n[[object]]\ntype = \"quad\"\nmaterial = \"b\"\ncorner = [0,0,0]\nedge_u = [1,0,0]\nedge_v = [0,1,0]\n",
            "object[0].material",
            11,
        ),
        (
            "[[material]]\nname = \"a\"\ntype = \"diffuse\"\n[[object]]\ntype = \"leaf_cards\"\nmaterial = \"a\"\ncards = [{ center = [0,0,0], normal = [0,0,1], up = [0,0,1], width = 0.1, height = 0.1 }]\n",
            "object[0].cards[0]",
            12,
        ),
    ] {
        let e = err(&format!("{MINIMAL}\n{snippet}"));
        assert_eq!(e.key, key, "{e}");
        assert_eq!(e.line, Some(line), "{e}");
    }
}

#[test]
fn degenerate_camera_is_rejected() {
    let e = err("[camera]\nposition = [1, 1, 1]\nlook_at = [1, 1, 1]\n");
    assert_eq!(e.key, "camera.look_at");
    assert_eq!(e.line, Some(3));
    let e = err("[camera]\nposition = [0, 0, 0]\nlook_at = [0, 1, 0]\n");
    assert_eq!(e.key, "camera.up");
}

#[test]
fn missing_referenced_files_name_the_file() {
    let dir = examples();
    let text = format!(
        "{MINIMAL}\n[[material]]\nname = \"m\"\ntype = \"diffuse\"\nreflectance_map = \"no_such.png\"\n"
    );
    let e = parse_scene(&text, &dir.join("x.toml")).unwrap_err();
    assert!(e.to_string().contains("no_such.png"), "{e}");
    assert_eq!(e.line, Some(9));
    let text = format!(
        "{MINIMAL}\n[[material]]\nname = \"m\"\ntype = \"diffuse\"\n[[object]]\ntype = \"obj\"\nmaterial = \"m\"\nfile = \"missing.obj\"\n"
    );
    let e = parse_scene(&text, &dir.join("x.toml")).unwrap_err();
    assert!(e.to_string().contains("missing.obj"), "{e}");
}

#[test]
fn leaf_material_inline_params_are_validated() {
    let ok = format!("{MINIMAL}\n[[material]]\nname = \"l\"\ntype = \"leaf\"\n");
    let s = parse(&ok).unwrap();
    assert!(matches!(s.materials[0], Material::Leaf { .. }));
    let bad = format!(
        "{MINIMAL}\n[[material]]\nname = \"l\"\ntype = \"leaf\"\nparams = {{ no_such_param = 1 }}\n"
    );
    let e = err(&bad);
    assert_eq!(e.line, Some(9), "{e}");
    assert!(e.to_string().contains("no_such_param"), "{e}");
}

#[test]
fn procedural_species_leaf_material() {
    let ok = format!(
        "{MINIMAL}\n[[material]]\nname = \"l\"\ntype = \"leaf\"\nspecies = \"maple\"\nseed = 3\nresolution = 64\nparams = {{ thickness_mm = 0.3 }}\n"
    );
    let s = parse(&ok).unwrap();
    let Material::Leaf { leaf, .. } = &s.materials[0] else {
        panic!()
    };
    assert_eq!(
        leaf.params().thickness_mm,
        0.3,
        "scene params override the preset's"
    );
    assert!(leaf.maps().alpha.is_some(), "the generated maps are used");
    let e = err(&format!(
        "{MINIMAL}\n[[material]]\nname = \"l\"\ntype = \"leaf\"\nspecies = \"banana\"\n"
    ));
    assert_eq!(
        (e.key.as_str(), e.line),
        ("material[0].species", Some(9)),
        "{e}"
    );
    assert!(e.to_string().contains("beech"), "lists the species: {e}");
    let e = err(&format!(
        "{MINIMAL}\n[[material]]\nname = \"l\"\ntype = \"leaf\"\nseed = 3\n"
    ));
    assert_eq!(e.key, "material[0].seed", "{e}");
}

#[test]
fn a_misspelt_key_names_its_line_the_keys_the_type_takes_and_the_near_miss() {
    for (snippet, key, line, near, takes) in [
        (
            "[film]\nwidht = 10\n",
            "film.widht",
            7,
            "width",
            "`tonemap`",
        ),
        (
            "[[light]]\ntype = \"sun\"\ndirektion = [0, 1, 0]\nirradiance = 1\n",
            "light[0].direktion",
            8,
            "direction",
            "`angular_diameter`",
        ),
        (
            "[[material]]\nname = \"m\"\ntype = \"pbr\"\nroughnes = 0.4\n",
            "material[0].roughnes",
            9,
            "roughness",
            "`normal_scale`",
        ),
        (
            "[[material]]\nname = \"m\"\ntype = \"diffuse\"\n[[object]]\ntype = \"quad\"\nmaterial = \"m\"\ncorner = [0, 0, 0]\nedge_u = [1, 0, 0]\nedge_v = [0, 1, 0]\ntranslat = [0, 1, 0]\n",
            "object[0].translat",
            15,
            "translate",
            "`instances_file`",
        ),
    ] {
        let e = err(&format!("{MINIMAL}\n{snippet}"));
        let text = e.to_string();
        assert_eq!(e.key, key, "{text}");
        assert_eq!(e.line, Some(line), "{text}");
        assert!(text.contains(&format!("did you mean `{near}`?")), "{text}");
        assert!(text.contains(takes), "{text}");
    }
    // No near miss: no suggestion, still the list.
    let e = err(&format!("{MINIMAL}\n[film]\nsamples = 4\n"));
    assert!(!e.to_string().contains("did you mean"), "{e}");
    assert!(e.to_string().contains("expected one of `width`"), "{e}");
}

#[test]
fn a_key_of_a_nested_table_is_checked_too() {
    // An inline transform and an inline card take only their own keys.
    let e = err(&format!(
        "{MINIMAL}\n[[material]]\nname = \"m\"\ntype = \"diffuse\"\n[[object]]\ntype = \"quad\"\nmaterial = \"m\"\ncorner = [0, 0, 0]\nedge_u = [1, 0, 0]\nedge_v = [0, 1, 0]\ninstances = [{{ translate = [0, 0, 0] }}, {{ rotate = 30 }}]\n"
    ));
    assert_eq!(e.key, "object[0].instances[1].rotate", "{e}");
    assert!(e.to_string().contains("did you mean `rotate_x`?"), "{e}");
}

#[test]
fn the_pigment_leaves_example_loads_with_its_sun_placed_by_time() {
    let s = lamina_scene::load_scene(&examples().join("pigment_leaves.toml")).unwrap();
    assert_eq!(s.materials.len(), 4);
    let Light::Sun { direction, .. } = s.lights[0] else {
        panic!("not a sun");
    };
    // Paris, 21 June 2024, 14:30 CEST: elevation 63.5°, azimuth 199.6° (south-south-west).
    let elevation = direction.y.asin().to_degrees();
    let azimuth = direction
        .x
        .atan2(-direction.z)
        .to_degrees()
        .rem_euclid(360.0);
    assert!(
        (elevation - 63.53).abs() < 0.02 && (azimuth - 199.58).abs() < 0.02,
        "{elevation} {azimuth}"
    );
}
