//! `lamina render --gpu` and `lamina view` from the command line. The GPU render needs a
//! Vulkan adapter (lavapipe in CI); without one it is skipped with a note unless `CI` is set.
//! `view` is checked to fail cleanly without a display, and (where `xvfb-run` exists) to
//! close on Ctrl-C without writing its screenshot.

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

/// `lamina render --gpu EXTRA... examples/leaf_cards.toml -o OUT`: its stderr, or `None`
/// (with a note) when the machine has no Vulkan adapter and `CI` is not set. Panics if the
/// render fails otherwise.
fn render_cards_gpu(extra: &[&str], out: &Path) -> Option<String> {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/leaf_cards.toml");
    let o = lamina()
        .args(["render", "--gpu"])
        .args(extra)
        .arg(&scene)
        .arg("-o")
        .arg(out)
        .output()
        .expect("run lamina");
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    if !o.status.success() && stderr.contains("no GPU adapter") && std::env::var_os("CI").is_none()
    {
        eprintln!("skipped: no Vulkan adapter (apt-get install -y mesa-vulkan-drivers)");
        assert!(stderr.contains("mesa-vulkan-drivers"), "{stderr}");
        return None;
    }
    assert!(o.status.success(), "{stderr}");
    Some(stderr)
}

#[test]
fn render_gpu_writes_the_film_sized_png() {
    let out = tmp_dir("render").join("cards.png");
    if render_cards_gpu(&[], &out).is_none() {
        return;
    }
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

/// The pid of the descendant of `root` whose command name is `name` (from `/proc`).
#[cfg(target_os = "linux")]
fn descendant_named(root: u32, name: &str) -> Option<u32> {
    let mut parent = std::collections::HashMap::new();
    let mut comm = std::collections::HashMap::new();
    for e in std::fs::read_dir("/proc").ok()?.flatten() {
        let Ok(pid) = e.file_name().to_string_lossy().parse::<u32>() else {
            continue;
        };
        let Ok(stat) = std::fs::read_to_string(e.path().join("stat")) else {
            continue;
        };
        // "pid (comm) state ppid ...": comm may hold spaces, so split at the last ')'.
        let (Some(open), Some(close)) = (stat.find('('), stat.rfind(')')) else {
            continue;
        };
        let ppid = stat[close + 1..]
            .split_whitespace()
            .nth(1)?
            .parse::<u32>()
            .ok()?;
        parent.insert(pid, ppid);
        comm.insert(pid, stat[open + 1..close].to_string());
    }
    comm.iter()
        .filter(|(_, c)| c.as_str() == name)
        .map(|(p, _)| *p)
        .find(|&p| {
            let mut q = p;
            while let Some(&pp) = parent.get(&q) {
                if pp == root {
                    return true;
                }
                if pp <= 1 {
                    break;
                }
                q = pp;
            }
            false
        })
}

/// Ctrl-C in `lamina view` (under Xvfb) closes the window at the next frame, writes no
/// screenshot and exits with 130. Skipped with a note where `xvfb-run` is missing (`.ci/run`
/// installs it).
#[cfg(target_os = "linux")]
#[test]
fn ctrl_c_closes_the_view_without_a_screenshot() {
    use std::io::BufRead;
    if Command::new("xvfb-run").arg("--help").output().is_err() {
        eprintln!("skipped: no xvfb-run (apt-get install xvfb xauth)");
        return;
    }
    let d = tmp_dir("view-ctrl-c");
    let _ = std::fs::remove_file(d.join("shot.png"));
    let mut child = Command::new("xvfb-run")
        .args(["-a", env!("CARGO_BIN_EXE_lamina"), "view", "demo:front"])
        .args([
            "--width",
            "160",
            "--height",
            "120",
            "--screenshot",
            "shot.png",
        ])
        .current_dir(&d)
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("xvfb-run");
    let err = std::io::BufReader::new(child.stderr.take().unwrap());
    let mut log = String::new();
    let mut lines = err.lines().map_while(Result::ok);
    for line in lines.by_ref() {
        log.push_str(&line);
        log.push('\n');
        if line.starts_with("lamina view:") {
            break;
        }
    }
    if !log.contains("lamina view:") {
        let _ = child.wait();
        if std::env::var_os("CI").is_none() {
            eprintln!("skipped: the view did not start (no Vulkan adapter?):\n{log}");
            return;
        }
        panic!("the view did not start:\n{log}");
    }
    std::thread::sleep(std::time::Duration::from_millis(500));
    let pid = descendant_named(child.id(), "lamina").expect("lamina under xvfb-run");
    let ok = rustix::process::kill_process(
        rustix::process::Pid::from_raw(pid as i32).expect("pid"),
        rustix::process::Signal::INT,
    );
    ok.expect("SIGINT");
    for line in lines {
        log.push_str(&line);
        log.push('\n');
    }
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(130), "{log}");
    assert!(log.contains("no screenshot written"), "{log}");
    assert!(!d.join("shot.png").exists(), "{log}");
}

/// Runs `lamina ARGS examples/leaf_cards.toml -o DIR/x.png`, which must fail without
/// writing the image; returns its stderr.
fn refused(dir: &Path, args: &[&str]) -> String {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/leaf_cards.toml");
    let out = dir.join("x.png");
    let o = lamina()
        .args(args)
        .arg(&scene)
        .arg("-o")
        .arg(&out)
        .output()
        .expect("run lamina");
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(!o.status.success(), "{args:?}: {stderr}");
    assert!(!out.exists(), "{args:?}");
    stderr
}

#[test]
fn render_gpu_refuses_flags_that_do_not_apply() {
    let d = tmp_dir("flags");
    for (flag, value, words) in [
        ("--seed", "3", "no random numbers"),
        ("--threads", "2", "CPU threads"),
        ("--time-limit", "1", "progressive"),
        ("--accel", "embree", "ray-casting engine"),
    ] {
        let stderr = refused(&d, &["render", "--gpu", flag, value]);
        assert!(
            stderr.contains(flag)
                && stderr.contains("does not apply to --gpu")
                && stderr.contains(words),
            "{flag}: {stderr}"
        );
    }
}

/// `--lod` is the GPU path's: refused without `--gpu`, and out-of-range values are named.
#[test]
fn lod_is_checked() {
    let d = tmp_dir("lod");
    for (args, words) in [
        (&["render", "--lod", "2"][..], "always traces every leaf"),
        (
            &["render", "--gpu", "--lod", "-1"][..],
            "-1 is not a leaf area",
        ),
        (
            &["render", "--gpu", "--lod", "many"][..],
            "'many' is not a number",
        ),
    ] {
        let stderr = refused(&d, args);
        assert!(stderr.contains(words), "{args:?}: {stderr}");
    }
}

#[test]
fn render_gpu_spp_is_supersampling() {
    let d = tmp_dir("spp");
    let mut images = Vec::new();
    for spp in ["1", "10"] {
        let out = d.join(format!("spp{spp}.png"));
        let Some(stderr) = render_cards_gpu(&["--spp", spp], &out) else {
            return;
        };
        if spp == "1" {
            assert!(stderr.contains("1 samples per pixel (1x1"), "{stderr}");
        } else {
            // 10 is not a square: the nearest grid, said so.
            assert!(stderr.contains("3x3 = 9 samples per pixel"), "{stderr}");
        }
        images.push(image::open(&out).expect("a PNG").to_rgb8());
    }
    // The same picture, smoother edges: close on average, not identical.
    let diff: f64 = images[0]
        .pixels()
        .zip(images[1].pixels())
        .map(|(a, b)| {
            (0..3)
                .map(|k| (a.0[k] as f64 - b.0[k] as f64).abs())
                .sum::<f64>()
        })
        .sum::<f64>()
        / (3.0 * images[0].pixels().len() as f64);
    assert!(diff > 0.0 && diff < 6.0, "mean |difference| {diff}");
}
