//! Instancing in scene files (`instances`, `instances_file`) and the size limits on
//! transforms and placed geometry.

mod common;
use glam::Vec3;
use lamina_scene::{Scene, parse_scene};
use std::path::{Path, PathBuf};

const HEAD: &str = "[camera]\nposition = [0, 1, 3]\nlook_at = [0, 0, 0]\n\
                    [[material]]\nname = \"m\"\ntype = \"diffuse\"\n";

/// A unit quad object (lines 7-12 of the scene) followed by `extra` lines.
fn quad(extra: &str) -> String {
    format!(
        "{HEAD}[[object]]\ntype = \"quad\"\nmaterial = \"m\"\ncorner = [0, 0, 0]\n\
         edge_u = [1, 0, 0]\nedge_v = [0, 1, 0]\n{extra}\n"
    )
}

fn scratch(name: &str) -> PathBuf {
    common::scratch("inst", name)
}

fn parse_in(dir: &Path, text: &str) -> Result<Scene, String> {
    parse_scene(text, &dir.join("s.toml")).map_err(|e| e.to_string())
}

fn parse(text: &str) -> Result<Scene, String> {
    parse_scene(text, Path::new("s.toml")).map_err(|e| e.to_string())
}

fn world(s: &Scene, inst: usize, p: Vec3) -> Vec3 {
    s.instances[inst].transform.transform_point3(p)
}

#[test]
fn inline_instances_make_one_prototype() {
    let s = parse(&quad(
        "translate = [0, 0, 5]\nname = \"tile\"\n\
         instances = [{ translate = [10, 0, 0] }, { rotate_y = 90, scale = 2 }, {}]",
    ))
    .unwrap();
    assert!(s.meshes.is_empty());
    assert_eq!(s.prototypes.len(), 1);
    assert_eq!(s.prototypes[0].name, "tile");
    assert_eq!(s.instances.len(), 3);
    assert!(s.instances.iter().all(|i| i.prototype == 0));
    // The object's own transform is applied first (in the prototype), then the instance's.
    let corner = s.prototypes[0].meshes[0].positions[0];
    assert_eq!(corner, Vec3::new(0.0, 0.0, 5.0));
    assert!((world(&s, 0, corner) - Vec3::new(10.0, 0.0, 5.0)).length() < 1e-5);
    assert!((world(&s, 1, corner) - Vec3::new(10.0, 0.0, 0.0)).length() < 1e-4);
    assert_eq!(world(&s, 2, corner), corner);
}

#[test]
fn instances_file_csv_with_a_subset_of_columns() {
    let d = scratch("csv");
    std::fs::write(
        d.join("placements.csv"),
        "# x, z and uniform scale\ntx, tz, s, ry\n1, 2, 1, 0\n-3, 0, 0.5, 180\n",
    )
    .unwrap();
    let s = parse_in(
        &d,
        &quad("instances = [{ translate = [0, 7, 0] }]\ninstances_file = \"placements.csv\""),
    )
    .unwrap();
    assert_eq!(s.instances.len(), 3, "inline first, then the file");
    assert!((world(&s, 0, Vec3::ZERO) - Vec3::new(0.0, 7.0, 0.0)).length() < 1e-6);
    assert!((world(&s, 1, Vec3::X) - Vec3::new(2.0, 0.0, 2.0)).length() < 1e-6);
    let p = world(&s, 2, Vec3::X);
    assert!((p - Vec3::new(-3.5, 0.0, 0.0)).length() < 1e-5, "{p}");
}

#[test]
fn bad_instances_name_the_row() {
    let d = scratch("bad");
    let cases: &[(&str, &str, &[&str])] = &[
        (
            "instances = [{ translate = [1, 0, 0] }, { scale = 1e30 }]",
            "",
            &[
                "s.toml:13: object[0].instances[1].scale",
                "1e-6, 1e6",
                "1e30",
            ],
        ),
        (
            "instances = [{ scale = 0 }]",
            "",
            &["object[0].instances[0].scale", "singular"],
        ),
        (
            "instances = [{ scale = [1, 0, 1] }]",
            "",
            &["object[0].instances[0].scale"],
        ),
        (
            "instances = [{ translate = [1e9, 0, 0] }]",
            "",
            &["object[0].instances[0].translate", "1e7"],
        ),
        (
            "instances = [{ translate = [0, 0, 0], spin = 3 }]",
            "",
            &["s.toml:13", "spin"],
        ),
        (
            "instances = []",
            "",
            &["object[0].instances", "no placements"],
        ),
        (
            "instances_file = \"p.csv\"",
            "tx,ty,tz\n0,0,0\n1,nan,0\n",
            &["p.csv:3: translate", "NaN"],
        ),
        (
            "instances_file = \"p.csv\"",
            "tx,s\n0,1\n1,abc\n",
            &["p.csv:3: s", "not a number: 'abc'"],
        ),
        (
            "instances_file = \"p.csv\"",
            "tx,sx\n0,1\n\n1,0\n",
            &["p.csv:4: scale", "singular"],
        ),
        (
            "instances_file = \"p.csv\"",
            "tx,height\n0,1\n",
            &["p.csv:1: height", "unknown column"],
        ),
        (
            "instances_file = \"p.csv\"",
            "tx,s,sx\n0,1,1\n",
            &["p.csv:1: s", "not both"],
        ),
        (
            "instances_file = \"p.csv\"",
            "tx,ty\n0,1\n1\n",
            &["p.csv:3", "bad CSV row"],
        ),
        (
            "instances_file = \"gone.csv\"",
            "",
            &["gone.csv", "cannot read"],
        ),
        // A placed vertex beyond 1e7 m (within limits one by one, not together).
        (
            "scale = 1e5\ninstances = [{ scale = 1e5 }]",
            "",
            &["object[0].instances[0]", "beyond"],
        ),
    ];
    for (extra, csv, want) in cases {
        std::fs::write(d.join("p.csv"), csv).unwrap();
        let e = parse_in(&d, &quad(extra)).map(|_| ()).unwrap_err();
        for w in *want {
            assert!(e.contains(w), "{extra}: '{w}' not in: {e}");
        }
    }
}

#[test]
fn absurd_object_sizes_are_rejected() {
    let cases: &[(&str, &[&str])] = &[
        ("scale = 1e30", &["s.toml:13: object[0].scale", "1e30"]),
        ("scale = 0", &["object[0].scale", "singular"]),
        (
            "transform = { scale = [1, 1, 1e-9] }",
            &["object[0].transform.scale"],
        ),
        ("translate = [0, 1e12, 0]", &["object[0].translate", "1e7"]),
        (
            "rotate_y = 10\ntransform = { rotate_y = 10 }",
            &["object[0].transform", "not both"],
        ),
    ];
    for (extra, want) in cases {
        let e = parse(&quad(extra)).map(|_| ()).unwrap_err();
        for w in *want {
            assert!(e.contains(w), "{extra}: '{w}' not in: {e}");
        }
    }
    // A mesh of 1e9 m: each key is fine on its own, the geometry is not.
    let e = parse(&format!(
        "{HEAD}[[object]]\ntype = \"quad\"\nmaterial = \"m\"\ncorner = [0, 0, 0]\n\
         edge_u = [1e9, 0, 0]\nedge_v = [0, 1, 0]\n"
    ))
    .map(|_| ())
    .unwrap_err();
    assert!(e.contains("object[0]") && e.contains("beyond"), "{e}");
}

#[test]
fn an_instanced_plant_is_one_prototype() {
    let s = parse(&format!(
        "{HEAD}[[object]]\ntype = \"plant\"\nname = \"shrub\"\n\
         instances = [{{ translate = [0, 0, 0] }}, {{ translate = [3, 0, 0], rotate_y = 120 }}]\n\
         [object.plant]\nleaf_count = 100\nleaf_resolution = 32\nleaf_variants = 1\nattraction_points = 60\n"
    ))
    .unwrap();
    assert!(s.meshes.is_empty());
    assert_eq!(s.prototypes.len(), 1);
    assert_eq!(s.prototypes[0].name, "shrub");
    assert!(s.prototypes[0].meshes.len() >= 2, "branches and leaves");
    assert_eq!(s.instances.len(), 2);
    // scene material m, then bark and one leaf
    assert_eq!(s.materials.len(), 3);
}
