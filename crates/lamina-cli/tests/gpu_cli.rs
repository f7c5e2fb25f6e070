//! `lamina render --gpu` and `lamina view` from the command line. The GPU render needs a
//! Vulkan adapter (lavapipe in CI); without one it is skipped with a note unless `CI` is set.
//! No test here needs a display: `view` is only checked to fail cleanly without one.

use std::path::Path;
use std::process::Command;

fn lamina() -> Command {
    Command::new(env!("CARGO_BIN_EXE_lamina"))
}

fn tmp_dir(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("lamina-gpu-cli-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).expect("temp dir");
    d
}

#[test]
fn render_gpu_writes_the_film_sized_png() {
    let out = tmp_dir("render").join("cards.png");
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/leaf_cards.toml");
    let o = lamina()
        .args(["render", "--gpu"])
        .arg(&scene)
        .arg("-o")
        .arg(&out)
        .output()
        .expect("run lamina");
    let stderr = String::from_utf8_lossy(&o.stderr);
    if !o.status.success() && stderr.contains("no GPU adapter") && std::env::var_os("CI").is_none()
    {
        eprintln!("skipped: no Vulkan adapter (apt-get install -y mesa-vulkan-drivers)");
        assert!(stderr.contains("mesa-vulkan-drivers"), "{stderr}");
        return;
    }
    assert!(o.status.success(), "{stderr}");
    let img = image::open(&out).expect("a PNG").to_rgb8();
    assert_eq!(img.dimensions(), (480, 360));
    // Not blank: sky above, lit leaves and ground below give a spread of values.
    let lum: Vec<u32> = img
        .pixels()
        .map(|p| p.0.iter().map(|&c| c as u32).sum())
        .collect();
    let (lo, hi) = (lum.iter().min().unwrap(), lum.iter().max().unwrap());
    assert!(hi - lo > 100, "flat image: {lo}..{hi}");
}

#[test]
fn view_without_a_display_fails_with_a_hint() {
    let o = lamina()
        .args(["view", "demo:front", "--frames", "1"])
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .expect("run lamina");
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("xvfb-run") && stderr.contains("render --gpu"),
        "{stderr}"
    );
}

#[test]
fn view_rejects_an_unknown_builtin() {
    let o = lamina()
        .args(["view", "demo:nope"])
        .output()
        .expect("run lamina");
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("demo:bush"), "{stderr}");
}
