//! The real `lamina` binary on good and bad input: clear messages, non-zero exits, no
//! panics, no partial output files.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn lamina() -> Command {
    Command::new(env!("CARGO_BIN_EXE_lamina"))
}

/// A fresh scratch directory for one test.
fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("lamina-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Asserts a clean failure: exit code 1, the expected words, no panic, no files left in `dir`
/// other than the inputs.
fn assert_fails(o: &Output, words: &[&str], dir: &Path, inputs: &[&str]) {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(1), "exit status for:\n{err}");
    assert!(!err.contains("panicked"), "panic:\n{err}");
    for w in words {
        assert!(err.contains(w), "expected '{w}' in:\n{err}");
    }
    let mut left: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| !inputs.contains(&n.as_str()))
        .collect();
    left.sort();
    assert!(left.is_empty(), "partial output left behind: {left:?}");
}

const GOOD: &str = r#"
[camera]
position = [0, 0, 1]
look_at = [0, 0, 0]
fov = 60

[film]
width = 24
height = 16
spp = 4

[sky]
type = "constant"
radiance = 0.5

[[light]]
type = "sun"
direction = [0.3, 0.5, 1]
irradiance = 2

[[material]]
name = "m"
type = "diffuse_transmission"
reflectance = 0.3
transmittance = 0.2

[[object]]
type = "quad"
material = "m"
corner = [-0.5, -0.5, 0]
edge_u = [1, 0, 0]
edge_v = [0, 1, 0]
"#;

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn render(dir: &Path, scene: &Path, extra: &[&str]) -> Output {
    let mut c = lamina();
    c.arg("render")
        .arg(scene)
        .arg("-o")
        .arg(dir.join("out.png"))
        .arg("--quiet")
        .args(extra);
    c.output().unwrap()
}

#[test]
fn good_scene_writes_png_and_exr_and_nothing_else() {
    let d = scratch("good");
    let s = write(&d, "s.toml", GOOD);
    let o = lamina()
        .args(["render", "--quiet", "--threads", "2", "--seed", "3"])
        .arg(&s)
        .arg("-o")
        .arg(d.join("a.png"))
        .arg("-o")
        .arg(d.join("a.exr"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("rays/s"),
        "summary line: {}",
        stderr(&o)
    );
    let png = image::open(d.join("a.png")).unwrap();
    assert_eq!((png.width(), png.height()), (24, 16));
    let exr = image::open(d.join("a.exr")).unwrap().into_rgb32f();
    assert!(
        exr.pixels()
            .all(|p| p.0.iter().all(|c| c.is_finite() && *c >= 0.0))
    );
    let mut names: Vec<_> = std::fs::read_dir(&d)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    names.sort();
    assert_eq!(
        names,
        ["a.exr", "a.png", "s.toml"].map(std::ffi::OsString::from)
    );
}

#[test]
fn same_seed_same_image() {
    let d = scratch("seed");
    let s = write(&d, "s.toml", GOOD);
    for name in ["1.exr", "2.exr"] {
        let o = lamina()
            .args(["render", "--quiet", "--seed", "9"])
            .arg(&s)
            .arg("-o")
            .arg(d.join(name))
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
    }
    assert_eq!(
        std::fs::read(d.join("1.exr")).unwrap(),
        std::fs::read(d.join("2.exr")).unwrap()
    );
}

/// `--accel`: a name that is no engine is refused by the parser (exit 2); `embree` renders
/// the same image as lamina's engine in a build with the `embree` feature, and is refused
/// with the feature named (exit 1, nothing written) in one without.
#[test]
fn accel_engine_is_checked() {
    let d = scratch("accel");
    let s = write(&d, "s.toml", GOOD);
    let o = render(&d, &s, &["--accel", "optix"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("lamina or embree"), "{}", stderr(&o));
    let o = render(&d, &s, &["--accel", "embree", "--seed", "4"]);
    if cfg!(feature = "embree") {
        assert!(o.status.success(), "{}", stderr(&o));
        std::fs::rename(d.join("out.png"), d.join("embree.png")).unwrap();
        let o = render(&d, &s, &["--accel", "lamina", "--seed", "4"]);
        assert!(o.status.success(), "{}", stderr(&o));
        let (a, b) = (
            image::open(d.join("out.png")),
            image::open(d.join("embree.png")),
        );
        assert_eq!(a.unwrap().to_rgb8(), b.unwrap().to_rgb8());
    } else {
        assert_fails(&o, &["accel embree", "`embree` feature"], &d, &["s.toml"]);
    }
}

#[test]
fn missing_scene_file() {
    let d = scratch("missing");
    let o = render(&d, &d.join("nope.toml"), &[]);
    assert_fails(&o, &["nope.toml", "cannot read scene file"], &d, &[]);
}

#[test]
fn toml_syntax_error() {
    let d = scratch("syntax");
    let s = write(&d, "s.toml", "[camera\nposition = [0,0,1]\n");
    let o = render(&d, &s, &[]);
    assert_fails(&o, &["s.toml:1"], &d, &["s.toml"]);
}

#[test]
fn unknown_key() {
    let d = scratch("unknown");
    let s = write(
        &d,
        "s.toml",
        &GOOD.replace("spp = 4", "spp = 4\nsamples = 3"),
    );
    let o = render(&d, &s, &[]);
    assert_fails(
        &o,
        &["s.toml:11", "unknown field `samples`"],
        &d,
        &["s.toml"],
    );
}

#[test]
fn missing_texture() {
    let d = scratch("tex");
    let s = write(
        &d,
        "s.toml",
        &GOOD.replace("reflectance = 0.3", "reflectance_map = \"leaf.png\""),
    );
    let o = render(&d, &s, &[]);
    assert_fails(
        &o,
        &["s.toml:24", "material[0].reflectance_map", "leaf.png"],
        &d,
        &["s.toml"],
    );
}

#[test]
fn corrupt_texture() {
    let d = scratch("corrupt");
    write(&d, "leaf.png", "this is not a png");
    let s = write(
        &d,
        "s.toml",
        &GOOD.replace("reflectance = 0.3", "reflectance_map = \"leaf.png\""),
    );
    let o = render(&d, &s, &[]);
    assert_fails(
        &o,
        &["leaf.png", "cannot read image"],
        &d,
        &["s.toml", "leaf.png"],
    );
}

#[test]
fn leaf_card_file_with_bad_row() {
    let d = scratch("cards");
    write(
        &d,
        "c.csv",
        "cx,cy,cz,nx,ny,nz,ux,uy,uz,width,height\n0,0,0,0,0,1,0,1,0,0.1,0.1\n0,0,0,0,0,1,0,1,0,-2,0.1\n",
    );
    let scene = GOOD.replace(
        "type = \"quad\"\nmaterial = \"m\"\ncorner = [-0.5, -0.5, 0]\nedge_u = [1, 0, 0]\nedge_v = [0, 1, 0]",
        "type = \"leaf_cards\"\nmaterial = \"m\"\nfile = \"c.csv\"",
    );
    let s = write(&d, "s.toml", &scene);
    let o = render(&d, &s, &[]);
    assert_fails(
        &o,
        &["c.csv:3", "width and height must be > 0"],
        &d,
        &["s.toml", "c.csv"],
    );
}

#[test]
fn zero_and_negative_sizes_and_counts() {
    let d = scratch("sizes");
    for (from, to, words) in [
        ("width = 24", "width = 0", vec!["film.width", "got 0"]),
        ("height = 16", "height = -3", vec!["film.height", "got -3"]),
        ("spp = 4", "spp = -1", vec!["film.spp"]),
        (
            "irradiance = 2",
            "irradiance = -2",
            vec!["light[0].irradiance"],
        ),
    ] {
        let s = write(&d, "s.toml", &GOOD.replace(from, to));
        let o = render(&d, &s, &[]);
        assert_fails(&o, &words, &d, &["s.toml"]);
    }
    let s = write(&d, "s.toml", GOOD);
    let o = render(&d, &s, &["--spp", "0"]);
    assert_eq!(o.status.code(), Some(2), "usage error: {}", stderr(&o));
    assert!(!d.join("out.png").exists());
}

#[test]
fn nan_and_degenerate_vectors() {
    let d = scratch("nan");
    for (from, to, words) in [
        (
            "look_at = [0, 0, 0]",
            "look_at = [0, 0, 1]",
            vec!["camera.look_at", "must differ"],
        ),
        (
            "direction = [0.3, 0.5, 1]",
            "direction = [nan, 0.5, 1]",
            vec!["light[0].direction", "finite"],
        ),
        (
            "direction = [0.3, 0.5, 1]",
            "direction = [0, 0, 0]",
            vec!["light[0].direction", "non-zero"],
        ),
    ] {
        let s = write(&d, "s.toml", &GOOD.replace(from, to));
        let o = render(&d, &s, &[]);
        assert_fails(&o, &words, &d, &["s.toml"]);
    }
}

#[test]
fn unwritable_output() {
    let d = scratch("out");
    let s = write(&d, "s.toml", GOOD);
    write(&d, "file", "");
    // A "directory" that is a file: nobody can write there, not even root.
    let o = lamina()
        .args(["render", "--quiet"])
        .arg(&s)
        .arg("-o")
        .arg(d.join("file/out.png"))
        .output()
        .unwrap();
    assert_fails(&o, &["file/out.png"], &d, &["s.toml", "file"]);
    let o = lamina()
        .args(["render", "--quiet"])
        .arg(&s)
        .arg("-o")
        .arg(d.join("out.jpg"))
        .output()
        .unwrap();
    assert_fails(&o, &["out.jpg", ".png or .exr"], &d, &["s.toml", "file"]);
}

/// A one-triangle glTF whose buffer is the external file `t.bin` (36 bytes: 3 f32 vec3s).
fn gltf_with_bin(extra: &str) -> String {
    format!(
        r#"{{"asset": {{"version": "2.0"}}, {extra}
  "scene": 0, "scenes": [{{"nodes": [0]}}], "nodes": [{{"mesh": 0}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}}}]}}],
  "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                  "min": [-1, -1, -1], "max": [1, 1, 1]}}],
  "bufferViews": [{{"buffer": 0, "byteLength": 36}}],
  "buffers": [{{"byteLength": 36, "uri": "t.bin"}}]}}"#
    )
}

fn triangle_bin(first_x: f32) -> Vec<u8> {
    [first_x, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect()
}

/// GOOD plus one more object (lines 30 onward are `extra`).
fn good_with(extra: &str) -> String {
    format!("{GOOD}\n{extra}\n")
}

/// A bad-glTF case: name, the .gltf text, the .bin bytes (if any), what the message names.
type GltfCase<'a> = (&'a str, String, Option<Vec<u8>>, Vec<&'a str>);

#[test]
fn bad_gltf_files() {
    let gltf_object = "[[object]]\ntype = \"gltf\"\nfile = \"t.gltf\"\n";
    let cases: Vec<GltfCase> = vec![
        (
            "missing buffer",
            gltf_with_bin(""),
            None,
            vec!["t.gltf", "buffers[0]", "cannot read buffer 't.bin'"],
        ),
        (
            "NaN vertex",
            gltf_with_bin(""),
            Some(triangle_bin(f32::NAN)),
            vec![
                "t.gltf",
                "meshes[0].primitives[0]",
                "vertex 0 is not finite",
            ],
        ),
        (
            "required extension",
            gltf_with_bin(
                r#""extensionsUsed": ["KHR_draco_mesh_compression"], "extensionsRequired": ["KHR_draco_mesh_compression"],"#,
            ),
            Some(triangle_bin(0.0)),
            vec![
                "t.gltf",
                "extensionsRequired",
                "KHR_draco_mesh_compression",
                "upported", // the gltf crate's "Unsupported extension" or ours
            ],
        ),
        (
            "empty mesh",
            gltf_with_bin("").replace(r#""nodes": [{"mesh": 0}]"#, r#""nodes": [{}]"#),
            Some(triangle_bin(0.0)),
            vec!["t.gltf", "no triangles"],
        ),
        (
            "absurd node scale",
            gltf_with_bin("").replace(
                r#"{"mesh": 0}"#,
                r#"{"mesh": 0, "scale": [1e30, 1e30, 1e30]}"#,
            ),
            Some(triangle_bin(0.0)),
            vec!["s.toml:", "object[1]", "beyond"],
        ),
    ];
    for (what, gltf, bin, words) in cases {
        let d = scratch(&format!("gltf-{}", what.replace(' ', "-")));
        write(&d, "t.gltf", &gltf);
        let mut inputs = vec!["s.toml", "t.gltf"];
        if let Some(b) = bin {
            std::fs::write(d.join("t.bin"), b).unwrap();
            inputs.push("t.bin");
        }
        let s = write(&d, "s.toml", &good_with(gltf_object));
        let o = render(&d, &s, &[]);
        eprintln!("{what}: {}", stderr(&o).trim());
        assert_fails(&o, &words, &d, &inputs);
    }
}

#[test]
fn bad_obj_files() {
    let obj_object = "[[object]]\ntype = \"obj\"\nfile = \"t.obj\"\n";
    for (what, obj, words) in [
        (
            "missing MTL",
            "mtllib gone.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
            vec!["t.obj:1: mtllib", "gone.mtl"],
        ),
        (
            "NaN vertex",
            "v 0 0 0\nv 1 NaN 0\nv 0 1 0\nf 1 2 3\n",
            vec!["t.obj:2: v", "'NaN' is not a finite number"],
        ),
        (
            "index out of range",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n",
            vec!["t.obj:4: f", "vertex index '4' is out of range"],
        ),
    ] {
        let d = scratch(&format!("obj-{}", what.replace(' ', "-")));
        write(&d, "t.obj", obj);
        let s = write(&d, "s.toml", &good_with(obj_object));
        let o = render(&d, &s, &[]);
        eprintln!("{what}: {}", stderr(&o).trim());
        assert_fails(&o, &words, &d, &["s.toml", "t.obj"]);
    }
    // A texture the MTL names but that is not there.
    let d = scratch("obj-missing-texture");
    write(
        &d,
        "t.obj",
        "mtllib t.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl leaf\nf 1 2 3\n",
    );
    write(&d, "t.mtl", "newmtl leaf\nmap_Kd maps/leaf.png\n");
    let s = write(&d, "s.toml", &good_with(obj_object));
    let o = render(&d, &s, &[]);
    assert_fails(
        &o,
        &["t.mtl", "newmtl leaf: map_Kd", "maps/leaf.png"],
        &d,
        &["s.toml", "t.obj", "t.mtl"],
    );
}

#[test]
fn bad_plant_parameters_and_absurd_sizes() {
    let d = scratch("plant-bad");
    let plant = |keys: &str| {
        good_with(&format!(
            "[[object]]\ntype = \"plant\"\n[object.plant]\nleaf_resolution = 16\n{keys}\n"
        ))
    };
    let line = GOOD.lines().count() + 6; // the line after leaf_resolution
    let at = format!("s.toml:{line}: object[1].plant");
    for (keys, words) in [
        (
            "leaf_count = 0",
            vec![
                at.clone() + ".leaf_count",
                "must be in [1, 20000000], got 0".into(),
            ],
        ),
        (
            "height_m = -1",
            vec![at.clone() + ".height_m", "got -1".into()],
        ),
        (
            "species = \"palm\"",
            vec![at.clone() + ".species", "palm".into()],
        ),
        (
            "petals = 10",
            vec![at.clone() + ".petals", "unknown field".into()],
        ),
    ] {
        let s = write(&d, "s.toml", &plant(keys));
        let o = render(&d, &s, &[]);
        let words: Vec<&str> = words.iter().map(String::as_str).collect();
        assert_fails(&o, &words, &d, &["s.toml"]);
    }
    for (extra, words) in [
        ("scale = 1e30", vec!["object[0].scale", "1e30"]),
        (
            "instances = [{ translate = [1, 0, 0] }, { scale = 0 }]",
            vec!["object[0].instances[1].scale", "singular"],
        ),
    ] {
        let s = write(
            &d,
            "s.toml",
            &GOOD.replace(
                "edge_v = [0, 1, 0]",
                &format!("edge_v = [0, 1, 0]\n{extra}"),
            ),
        );
        let o = render(&d, &s, &[]);
        assert_fails(&o, &words, &d, &["s.toml"]);
    }
    // A mesh of 1e9 m.
    let s = write(
        &d,
        "s.toml",
        &GOOD.replace("edge_u = [1, 0, 0]", "edge_u = [1e9, 0, 0]"),
    );
    let o = render(&d, &s, &[]);
    assert_fails(&o, &["object[0]", "beyond"], &d, &["s.toml"]);
}

#[test]
fn instanced_plant_renders() {
    let d = scratch("plant-instances");
    let s = write(
        &d,
        "s.toml",
        &good_with(
            "[[object]]\ntype = \"plant\"\nscale = 0.3\ninstances = [{ translate = [-0.2, -0.3, -0.5] }, { translate = [0.2, -0.3, -0.5], rotate_y = 90 }]\n\
             [object.plant]\nleaf_count = 60\nleaf_resolution = 16\nleaf_variants = 1\nattraction_points = 50\n",
        ),
    );
    let o = render(&d, &s, &[]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(d.join("out.png").exists());
}

/// The crafted files that crashed a loader on the old main (kept as the fuzz regression
/// inputs of lamina-scene), each named by a scene given to the real binary: a clear error
/// naming the file, exit 1, no panic, no output.
#[test]
fn crafted_files_that_crashed_loaders_are_errors() {
    let regr = Path::new(env!("CARGO_MANIFEST_DIR")).join("../lamina-scene/tests/fuzz_regressions");
    let cases = [
        ("gltf/byte-stride-4.gltf", "gltf", "byteStride 4"),
        ("gltf/glb-short-length.glb", "gltf", "glb-short-length.glb"),
        (
            "gltf/fuzz-position-accessor-missing.gltf",
            "gltf",
            "accessor 0 does not exist",
        ),
        ("obj_mtl/mtl-kd-one-number.obj", "obj", ""),
    ];
    for (i, (file, kind, words)) in cases.iter().enumerate() {
        let d = scratch(&format!("crafted-{i}"));
        let src = regr.join(file);
        let name = src.file_name().unwrap().to_string_lossy().into_owned();
        let bytes = std::fs::read(&src).unwrap();
        if *kind == "obj" {
            // The OBJ target's input carries its MTL after a `#MTL` line.
            let text = String::from_utf8(bytes).unwrap();
            let (obj, mtl) = text.split_once("#MTL\n").unwrap();
            std::fs::write(d.join(&name), obj).unwrap();
            std::fs::write(d.join("m.mtl"), mtl).unwrap();
        } else {
            std::fs::write(d.join(&name), bytes).unwrap();
        }
        let scene = write(
            &d,
            "s.toml",
            &good_with(&format!(
                "[[object]]\ntype = \"{kind}\"\nfile = \"{name}\"\n{}",
                if *kind == "obj" {
                    "material = \"m\"\n"
                } else {
                    ""
                }
            )),
        );
        let o = render(&d, &scene, &[]);
        let err = stderr(&o);
        assert!(!err.contains("panicked"), "{file}: panic:\n{err}");
        if *kind == "obj" {
            // `Kd 0.5` is valid MTL (grey): it now loads and renders.
            assert!(o.status.success(), "{file}:\n{err}");
            continue;
        }
        let mut inputs = vec!["s.toml", name.as_str()];
        inputs.push("m.mtl");
        assert_fails(&o, &[name.as_str(), words], &d, &inputs);
    }
}
