//! Ctrl-C on the real `lamina` binary, with real SIGINTs sent at chosen moments (found by
//! reading the per-pass lines lamina prints when stderr is not a terminal):
//!
//! * during loading, during a render's first pass, during `leaf generate` and during the
//!   demo's first panels: the process ends at once with exit code 130, writes nothing and
//!   leaves an existing output untouched;
//! * during a later pass: the pass in progress is dropped, the image of the completed
//!   passes is written, the message says how many passes made it, exit code 130;
//! * a second Ctrl-C ends the process at once; no temporary file is ever left behind.
//!
//! The scenes are sized so that each moment lasts seconds on a slow, shared 2-core machine,
//! and each test asserts that the moment had not passed when the signal went out.
#![cfg(unix)]

mod common;
use common::names;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::mpsc::{Receiver, RecvTimeoutError, channel};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

fn scratch(name: &str) -> PathBuf {
    common::scratch("interrupt", name)
}

/// A running `lamina` whose stderr is read line by line.
struct Running {
    child: Child,
    lines: Receiver<String>,
    log: Arc<Mutex<String>>,
}

impl Running {
    fn start(args: &[&str], cwd: &Path) -> Running {
        let mut child = Command::new(env!("CARGO_BIN_EXE_lamina"))
            .args(args)
            .current_dir(cwd)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let err = child.stderr.take().unwrap();
        let (tx, lines) = channel();
        let log = Arc::new(Mutex::new(String::new()));
        let log2 = log.clone();
        std::thread::spawn(move || {
            for line in BufReader::new(err).lines().map_while(Result::ok) {
                log2.lock().unwrap().push_str(&format!("{line}\n"));
                let _ = tx.send(line);
            }
        });
        Running { child, lines, log }
    }

    /// Waits for a stderr line containing `needle`.
    fn wait_for(&self, needle: &str, timeout: Duration) {
        let end = Instant::now() + timeout;
        loop {
            match self
                .lines
                .recv_timeout(end.saturating_duration_since(Instant::now()))
            {
                Ok(l) if l.contains(needle) => return,
                Ok(_) => {}
                Err(RecvTimeoutError::Timeout | RecvTimeoutError::Disconnected) => {
                    panic!("no line with '{needle}' in:\n{}", self.log())
                }
            }
        }
    }

    fn sigint(&self) {
        // A real SIGINT, as a terminal's Ctrl-C sends it.
        rustix::process::kill_process(
            rustix::process::Pid::from_child(&self.child),
            rustix::process::Signal::INT,
        )
        .expect("SIGINT");
    }

    /// Waits for the exit (killing the process after `timeout`); the status, the time it
    /// took and stderr.
    fn finish(mut self, timeout: Duration) -> (ExitStatus, Duration, String) {
        let t = Instant::now();
        loop {
            if let Some(s) = self.child.try_wait().unwrap() {
                // Let the reader thread drain the pipe.
                std::thread::sleep(Duration::from_millis(50));
                return (s, t.elapsed(), self.log());
            }
            if t.elapsed() > timeout {
                let _ = self.child.kill();
                panic!("still running after {timeout:?}:\n{}", self.log());
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }

    fn log(&self) -> String {
        self.log.lock().unwrap().clone()
    }
}

/// The user's previous render: an image lamina wrote (so a new render may replace it).
fn old_png() -> Vec<u8> {
    let pixels = vec![90u8; 4 * 4 * 3];
    lamina_io::image_out::encode(
        Path::new("old.png"),
        &pixels,
        4,
        4,
        image::ExtendedColorType::Rgb8,
    )
    .unwrap()
}

fn camera_and_sky(width: u32, height: u32, spp: u32, depth: u32) -> String {
    format!(
        r#"
[camera]
position = [0, 1.2, 3.0]
look_at = [0, 0.6, 0]
fov = 50

[film]
width = {width}
height = {height}
spp = {spp}

[integrator]
type = "path"
max_depth = {depth}

[sky]
type = "constant"
radiance = [0.3, 0.35, 0.4]

[[light]]
type = "sun"
direction = [-0.4, 0.8, 0.3]
irradiance = 4

[[material]]
name = "ground"
type = "diffuse"
reflectance = 0.3

[[object]]
type = "quad"
material = "ground"
corner = [-5, 0, 5]
edge_u = [10, 0, 0]
edge_v = [0, 0, -10]
"#
    )
}

/// A bush whose loading (growing the plant, making its leaf maps) takes seconds.
fn slow_to_load(width: u32, height: u32, spp: u32) -> String {
    camera_and_sky(width, height, spp, 4)
        + r#"
[[object]]
type = "plant"
[object.plant]
kind = "tree"
seed = 5
height_m = 1.5
leaf_count = 600000
leaf_variants = 8
leaf_resolution = 1024
"#
}

/// A small bush that loads fast; its passes take a while at this size.
fn quick_to_load(width: u32, height: u32, spp: u32) -> String {
    camera_and_sky(width, height, spp, 8)
        + r#"
[[object]]
type = "plant"
[object.plant]
kind = "bush"
seed = 2
leaf_count = 2000
leaf_variants = 1
leaf_resolution = 64
"#
}

fn setup(name: &str, scene: &str) -> PathBuf {
    let d = scratch(name);
    std::fs::write(d.join("s.toml"), scene).unwrap();
    std::fs::write(d.join("out.png"), old_png()).unwrap();
    d
}

fn assert_interrupted_untouched(d: &Path, status: ExitStatus, log: &str) {
    assert_eq!(status.code(), Some(130), "exit code:\n{log}");
    assert!(!log.contains("panicked"), "{log}");
    assert!(log.contains("interrupted"), "{log}");
    assert_eq!(
        std::fs::read(d.join("out.png")).unwrap(),
        old_png(),
        "out.png changed:\n{log}"
    );
    assert_eq!(names(d), ["out.png", "s.toml"], "files left behind:\n{log}");
}

#[test]
fn ctrl_c_during_loading_stops_at_once_and_writes_nothing() {
    let d = setup("load", &slow_to_load(64, 64, 4));
    let r = Running::start(&["render", "s.toml", "-o", "out.png"], &d);
    r.wait_for("loading", Duration::from_secs(30));
    std::thread::sleep(Duration::from_millis(300));
    r.sigint();
    let (status, took, log) = r.finish(Duration::from_secs(30));
    assert!(
        !log.contains("loaded, rendering"),
        "loading had finished:\n{log}"
    );
    assert!(
        took < Duration::from_secs(2),
        "took {took:?} to stop:\n{log}"
    );
    assert_interrupted_untouched(&d, status, &log);
}

#[test]
fn ctrl_c_during_the_first_pass_writes_nothing() {
    // 1 spp over 4 Mpixel with depth 8: the first pass takes seconds.
    let d = setup("first-pass", &quick_to_load(2048, 2048, 64));
    let r = Running::start(&["render", "s.toml", "-o", "out.png"], &d);
    r.wait_for("loaded, rendering", Duration::from_secs(60));
    std::thread::sleep(Duration::from_millis(200));
    r.sigint();
    let (status, took, log) = r.finish(Duration::from_secs(30));
    assert!(
        !log.contains("pass 1/"),
        "the first pass had finished:\n{log}"
    );
    assert!(
        took < Duration::from_secs(2),
        "took {took:?} to stop:\n{log}"
    );
    assert_interrupted_untouched(&d, status, &log);
}

#[test]
fn ctrl_c_during_a_later_pass_keeps_the_completed_passes() {
    let d = setup("later-pass", &quick_to_load(256, 256, 4096));
    let r = Running::start(&["render", "s.toml", "-o", "out.png", "-o", "out.exr"], &d);
    r.wait_for("pass 3/", Duration::from_secs(120));
    r.sigint();
    let (status, _, log) = r.finish(Duration::from_secs(60));
    assert_eq!(status.code(), Some(130), "{log}");
    assert!(!log.contains("panicked"), "{log}");
    // "interrupted: K of N passes completed (S spp)", K >= 3 and < N.
    let line = log
        .lines()
        .find(|l| l.contains("passes completed"))
        .unwrap_or_else(|| panic!("no summary line:\n{log}"));
    let words: Vec<&str> = line.split_whitespace().collect();
    let k: u32 = words[1].parse().unwrap();
    let n: u32 = words[3].parse().unwrap();
    assert!(k >= 3 && k < n, "{line}");
    let spp: u32 = words[6].trim_start_matches('(').parse().unwrap();
    let last_pass_line = format!("pass {k}/{n} done, {spp}/4096 spp");
    assert!(
        log.contains(&last_pass_line),
        "'{last_pass_line}' not in:\n{log}"
    );
    // The image of those passes was written, whole, over the old file.
    let img = image::open(d.join("out.png")).unwrap().to_rgb8();
    assert_eq!(img.dimensions(), (256, 256));
    assert!(img.pixels().any(|p| p.0 != [0, 0, 0]), "black image");
    let exr = image::open(d.join("out.exr")).unwrap().to_rgb32f();
    assert_eq!(exr.dimensions(), (256, 256));
    assert_eq!(names(&d), ["out.exr", "out.png", "s.toml"], "{log}");
}

#[test]
fn a_second_ctrl_c_quits_at_once() {
    let d = setup("twice", &quick_to_load(256, 256, 4096));
    let r = Running::start(&["render", "s.toml", "-o", "out.png"], &d);
    r.wait_for("pass 2/", Duration::from_secs(120));
    r.sigint();
    r.sigint();
    let (status, took, log) = r.finish(Duration::from_secs(30));
    assert_eq!(status.code(), Some(130), "{log}");
    assert!(took < Duration::from_secs(5), "took {took:?}:\n{log}");
    // Whichever press ended it, out.png is the old file or a whole new image, and no
    // temporary file is left.
    let bytes = std::fs::read(d.join("out.png")).unwrap();
    assert!(
        bytes == old_png() || image::load_from_memory(&bytes).is_ok(),
        "{log}"
    );
    assert_eq!(names(&d), ["out.png", "s.toml"], "{log}");
}

#[test]
fn ctrl_c_during_leaf_generate_leaves_no_folder() {
    let d = scratch("leaf-generate");
    let r = Running::start(&["leaf", "generate", "-r", "4096", "-o", "leaf"], &d);
    std::thread::sleep(Duration::from_millis(700));
    r.sigint();
    let (status, took, log) = r.finish(Duration::from_secs(30));
    assert!(!log.contains("wrote"), "it had finished:\n{log}");
    assert_eq!(status.code(), Some(130), "{log}");
    assert!(took < Duration::from_secs(2), "took {took:?}:\n{log}");
    assert!(names(&d).is_empty(), "left behind: {:?}", names(&d));
}

#[test]
fn ctrl_c_during_the_demo_first_panels_writes_nothing() {
    let d = scratch("demo");
    std::fs::write(d.join("demo.png"), old_png()).unwrap();
    let r = Running::start(&["demo", "--size", "96", "--spp", "1024"], &d);
    // The second panel: panel 1's handler problem of old would make this one unstoppable.
    r.wait_for("back-lit leaf: pass 2/", Duration::from_secs(120));
    r.sigint();
    let (status, took, log) = r.finish(Duration::from_secs(30));
    assert_eq!(status.code(), Some(130), "{log}");
    assert!(took < Duration::from_secs(2), "took {took:?}:\n{log}");
    assert_eq!(std::fs::read(d.join("demo.png")).unwrap(), old_png());
    assert_eq!(names(&d), ["demo.png"]);
}
