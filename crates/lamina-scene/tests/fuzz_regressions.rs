//! Every input the fuzz campaign (`scripts/fuzz.sh`, targets in `fuzz/fuzz_targets/`) found
//! to crash a loader, and the crashing inputs found by hand while hardening the loaders (a
//! glTF accessor on a view with `byteStride: 4`, MTL `Kd 0.5`, a GLB header length under 12,
//! ...), run through the same calls as their target, on stable. The panic guard is
//! switched off (as in the targets), so an input must be handled by the loaders' own checks:
//! an error is fine, a panic fails the test.
//!
//! Inputs live in `tests/fuzz_regressions/<target>/`, one file each, named after the crash.

use lamina_leaf::texture::{Encoding, Texture};
use std::path::{Path, PathBuf};

fn inputs(target: &str) -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fuzz_regressions")
        .join(target);
    let mut v: Vec<PathBuf> = match std::fs::read_dir(&dir) {
        Ok(rd) => rd.map(|e| e.unwrap().path()).collect(),
        Err(_) => Vec::new(),
    };
    v.sort();
    v
}

/// Runs `f` on every input of `target`; returns how many there were.
fn each(target: &str, f: impl Fn(&[u8])) -> usize {
    lamina_leaf::guard::propagate_panics(true);
    let files = inputs(target);
    for p in &files {
        let data = std::fs::read(p).unwrap();
        let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| f(&data)));
        assert!(r.is_ok(), "{} panicked", p.display());
    }
    files.len()
}

#[test]
fn the_known_crashes_are_here() {
    let n: usize = ["gltf", "obj_mtl", "image_maps"]
        .iter()
        .map(|t| inputs(t).len())
        .sum();
    assert!(n >= 8, "only {n} regression inputs found");
}

fn text(data: &[u8]) -> Option<&str> {
    std::str::from_utf8(data).ok()
}

#[test]
fn scene_toml() {
    each("scene_toml", |d| {
        if let Some(t) = text(d) {
            let _ = lamina_scene::parse_scene(t, Path::new("/nonexistent-lamina-fuzz/s.toml"));
        }
    });
}

#[test]
fn gltf() {
    each("gltf", |d| {
        let _ = lamina_scene::gltf_import::parse_gltf(
            d,
            Path::new("/nonexistent-lamina-fuzz/model.gltf"),
            &Default::default(),
        );
    });
}

#[test]
fn obj_mtl() {
    let dir = std::env::temp_dir().join(format!("lamina-fuzz-regr-obj-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    each("obj_mtl", |d| {
        let (obj, mtl) = match d.windows(5).position(|w| w == b"#MTL\n") {
            Some(i) => (&d[..i], &d[i + 5..]),
            None => (d, &b""[..]),
        };
        std::fs::write(dir.join("m.obj"), obj).unwrap();
        std::fs::write(dir.join("m.mtl"), mtl).unwrap();
        let _ = lamina_scene::obj::load_obj(&dir.join("m.obj"));
    });
}

#[test]
fn cards() {
    each("cards", |d| {
        if let Some(t) = text(d) {
            let _ = lamina_scene::cards::parse_csv(Path::new("cards.csv"), t);
            let _ = lamina_scene::cards::parse_json(Path::new("cards.json"), t);
        }
    });
}

#[test]
fn placements() {
    each("placements", |d| {
        if let Some(t) = text(d) {
            let _ = lamina_scene::instances::parse_instances_csv(t, Path::new("p.csv"));
        }
    });
}

#[test]
fn leaf_toml() {
    each("leaf_toml", |d| {
        if let Some(t) = text(d)
            && let Ok(desc) = lamina_leaf::LeafDescription::from_toml_str(t, Path::new("leaf.toml"))
        {
            let _ = desc.params.validate();
        }
    });
}

#[test]
fn plant_params() {
    each("plant_params", |d| {
        if let Some(t) = text(d)
            && let Ok(p) = lamina_plant::PlantParams::from_toml(t)
            && p.validate().is_ok()
        {
            let _ = p.resolve();
        }
    });
}

#[test]
fn image_maps() {
    each("image_maps", |d| {
        for enc in [Encoding::Srgb, Encoding::Linear] {
            if let Ok(t) = Texture::decode(d, enc, Path::new("map.png")) {
                let _ = t.sample(glam::Vec2::new(0.3, 0.7));
            }
        }
    });
}
