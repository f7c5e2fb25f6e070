//! Helpers shared by the CLI test files.

use std::path::{Path, PathBuf};

/// A fresh scratch folder for one test (`kind` names the test file, `name` the test).
pub fn scratch(kind: &str, name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("lamina-{kind}-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The names in folder `d`, sorted.
#[allow(dead_code)]
pub fn names(d: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// Runs the `lamina` binary in `cwd`.
#[allow(dead_code)]
pub fn lamina(args: &[&str], cwd: &Path) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_lamina"))
        .args(args)
        .current_dir(cwd)
        .output()
        .unwrap()
}

/// The command's standard error, asserting that it succeeded.
#[allow(dead_code)]
pub fn ok(o: &std::process::Output) -> String {
    let e = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "failed:\n{e}");
    e
}

/// Asserts that the command failed cleanly (exit 1, no panic) with each of `words` in its
/// message.
#[allow(dead_code)]
pub fn fails(o: &std::process::Output, words: &[&str]) {
    let e = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(!o.status.success(), "should fail:\n{e}");
    assert!(!e.contains("panicked"), "panic:\n{e}");
    for w in words {
        assert!(e.contains(w), "expected '{w}' in:\n{e}");
    }
}

/// A small scene with a leaf, a sun and a sky, a wide Gaussian filter.
#[allow(dead_code)]
pub const SCENE: &str = "[camera]\nposition = [0, -1.2, 1.6]\nlook_at = [0, 0, 0]\nfov = 40\n\
    [film]\nwidth = 40\nheight = 30\nspp = 12\nfilter = \"gaussian\"\nfilter_radius = 2.0\nfilter_sigma = 0.7\n\
    [sky]\ntype = \"constant\"\nradiance = [0.3, 0.4, 0.6]\n\
    [[light]]\ntype = \"sun\"\ndirection = [0.3, -0.4, 1]\nirradiance = 3\n\
    [[material]]\nname = \"leaf\"\ntype = \"leaf\"\nspecies = \"beech\"\n\
    [[material]]\nname = \"soil\"\ntype = \"diffuse\"\nreflectance = 0.2\n\
    [[object]]\ntype = \"quad\"\nmaterial = \"soil\"\ncorner = [-3, -3, -0.3]\nedge_u = [6, 0, 0]\nedge_v = [0, 6, 0]\n\
    [[object]]\ntype = \"quad\"\nmaterial = \"leaf\"\ncorner = [-0.5, -0.4, 0]\nedge_u = [1, 0, 0.2]\nedge_v = [0, 0.8, 0]\n";

/// Every channel of an EXR's first layer, by name.
#[allow(dead_code)]
pub fn channels(path: &Path) -> std::collections::BTreeMap<String, Vec<f32>> {
    use exr::prelude::{FlatSamples, ReadChannels, ReadLayers, read};
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .unwrap();
    image
        .layer_data
        .channel_data
        .list
        .iter()
        .map(|c| {
            let v = match &c.sample_data {
                FlatSamples::F32(v) => v.clone(),
                _ => panic!("not f32"),
            };
            (c.name.to_string(), v)
        })
        .collect()
}

/// The image channels (not the parts' remainders).
#[allow(dead_code)]
pub fn image_channels(path: &Path) -> std::collections::BTreeMap<String, Vec<u32>> {
    channels(path)
        .into_iter()
        .filter(|(n, _)| !n.contains('.'))
        .map(|(n, v)| (n, v.iter().map(|x| x.to_bits()).collect()))
        .collect()
}

/// Asserts that two EXRs hold the same image channels bit for bit, saying how many values
/// differ and by how many units in the last place when they do not.
#[allow(dead_code)]
pub fn assert_same(a: &Path, b: &Path) {
    let (x, y) = (image_channels(a), image_channels(b));
    assert_eq!(x.keys().collect::<Vec<_>>(), y.keys().collect::<Vec<_>>());
    for (name, va) in &x {
        let vb = &y[name];
        assert_eq!(va.len(), vb.len());
        let diffs: Vec<i64> = va
            .iter()
            .zip(vb)
            .map(|(&p, &q)| p as i64 - q as i64)
            .filter(|d| *d != 0)
            .collect();
        let max = diffs.iter().map(|d| d.abs()).max().unwrap_or(0);
        assert!(
            diffs.is_empty(),
            "{} vs {}, channel {name}: {} of {} values differ, by up to {max} ulp",
            a.display(),
            b.display(),
            diffs.len(),
            va.len()
        );
    }
}
