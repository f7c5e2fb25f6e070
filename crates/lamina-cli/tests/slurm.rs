//! `lamina farm` on a real Slurm: a one-node cluster on loopback
//! (`scripts/slurm/local-cluster.sh`, munged + slurmctld + slurmd in a network namespace of
//! their own), a 4-part job array plus its merge job, a part killed on purpose and retried,
//! a part that fails for good (merge cancelled, `--allow-missing`, then `lamina farm
//! retry`), each merged image checked against the single-process render of the same seed.
//!
//! It needs root and Slurm installed, so it runs only with `LAMINA_SLURM_TEST=1`:
//! `scripts/slurm/test-farm.sh` installs Slurm and munge (Debian packages) and runs it, and
//! `.ci/run` runs that script. Elsewhere it prints a note and passes.

mod common;

use common::{SCENE, assert_same, fails, lamina, ok, scratch};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A started cluster; stopped (every daemon it started) and removed when dropped, also
/// when the test fails.
struct Cluster {
    dir: PathBuf,
}

impl Cluster {
    fn start() -> Cluster {
        // Short: the munge and Slurm socket paths must fit in 108 bytes.
        let dir = PathBuf::from(format!("/tmp/lamina-slurm-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let script = repo().join("scripts/slurm/local-cluster.sh");
        let out = Command::new("bash")
            .arg(&script)
            .arg("start")
            .arg(&dir)
            .output()
            .unwrap();
        let cluster = Cluster { dir };
        assert!(
            out.status.success(),
            "cluster did not start:\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
        cluster
    }

    /// PATH with the cluster's client wrappers first.
    fn path(&self) -> String {
        format!(
            "{}:{}",
            self.dir.join("bin").display(),
            std::env::var("PATH").unwrap_or_default()
        )
    }

    /// `lamina ARGS` in `cwd` with the cluster's clients.
    fn lamina(&self, args: &[&str], cwd: &Path) -> Output {
        Command::new(env!("CARGO_BIN_EXE_lamina"))
            .args(args)
            .current_dir(cwd)
            .env("PATH", self.path())
            .env("SLURM_CONF", self.dir.join("slurm.conf"))
            .output()
            .unwrap()
    }

    /// `lamina farm status DIR` as text.
    fn status(&self, farm: &Path) -> String {
        let o = self.lamina(&["farm", "status", &farm.to_string_lossy()], farm);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8_lossy(&o.stdout).into_owned()
    }

    /// Polls `lamina farm status` until `done` says so (at most `limit`).
    fn wait(&self, farm: &Path, limit: Duration, done: impl Fn(&str) -> bool) -> String {
        let t0 = Instant::now();
        loop {
            let s = self.status(farm);
            if done(&s) {
                return s;
            }
            assert!(
                t0.elapsed() < limit,
                "timed out after {limit:?}; status:\n{s}"
            );
            std::thread::sleep(Duration::from_millis(500));
        }
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        let script = repo().join("scripts/slurm/local-cluster.sh");
        let _ = Command::new("bash")
            .arg(&script)
            .arg("stop")
            .arg(&self.dir)
            .status();
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// Kills, once it has started rendering, the `lamina farm task FARM TASK` process; returns
/// after the kill (panics after `limit`).
fn kill_task(farm: &Path, task: u32, limit: Duration) {
    let needle = format!("farm\0task\0{}\0{task}\0", farm.display());
    let t0 = Instant::now();
    loop {
        for e in std::fs::read_dir("/proc").unwrap().flatten() {
            let Ok(pid) = e.file_name().to_string_lossy().parse::<i32>() else {
                continue;
            };
            let Ok(cmd) = std::fs::read(e.path().join("cmdline")) else {
                continue;
            };
            if cmd.windows(needle.len()).any(|w| w == needle.as_bytes()) {
                // Let it load and start its passes, so the kill lands mid-render.
                std::thread::sleep(Duration::from_millis(400));
                let killed = Command::new("kill")
                    .args(["-KILL", &pid.to_string()])
                    .status()
                    .unwrap();
                if killed.success() {
                    return;
                }
            }
        }
        assert!(t0.elapsed() < limit, "task {task} never ran");
        std::thread::sleep(Duration::from_millis(50));
    }
}

#[test]
fn farm_runs_on_a_real_slurm_and_merges_to_the_single_render() {
    if std::env::var("LAMINA_SLURM_TEST").as_deref() != Ok("1") {
        eprintln!(
            "skipped: set LAMINA_SLURM_TEST=1 to run lamina farm on a local Slurm cluster \
             (scripts/slurm/test-farm.sh installs Slurm and does; it needs root)"
        );
        return;
    }
    let d = scratch("slurm", "farm");
    // Big enough that a part takes a few seconds: a kill lands mid-render.
    let scene = SCENE
        .replace("width = 40\nheight = 30", "width = 160\nheight = 120")
        .replace("spp = 12", "spp = 192");
    std::fs::write(d.join("s.toml"), scene).unwrap();
    let t = Instant::now();
    ok(&lamina(
        &[
            "render",
            "s.toml",
            "--seed",
            "5",
            "-q",
            "-o",
            "single.exr",
            "-o",
            "single.png",
        ],
        &d,
    ));
    eprintln!("single-process render: {:.1} s", t.elapsed().as_secs_f64());
    let cluster = Cluster::start();
    let limit = Duration::from_secs(240);

    // 1. Four parts and a merge job; part 2 is killed once mid-render and retried in place.
    let farm = d.join("farm");
    let t = Instant::now();
    // A 4-part farm of the scene with `retries`, submitted.
    let submit = |out: &str, retries: &str| {
        let args = [
            "farm",
            "slurm",
            "s.toml",
            "--parts",
            "4",
            "--seed",
            "5",
            "--threads",
            "1",
            "--retries",
            retries,
            "--out",
            out,
            "--submit",
        ];
        ok(&cluster.lamina(&args, &d));
    };
    submit("farm", "2");
    kill_task(&farm, 2, limit);
    let s = cluster.wait(&farm, limit, |s| s.contains("every render merged"));
    eprintln!(
        "farm of 4 parts with one killed and retried: {:.1} s\n{s}",
        t.elapsed().as_secs_f64()
    );
    assert!(s.contains("tasks: 4 done"), "{s}");
    let log = std::fs::read_to_string(farm.join("logs/render-2.log")).unwrap();
    assert!(
        log.contains("attempt 1/3 failed with exit code 137"),
        "{log}"
    );
    assert!(log.contains("attempt 2/3 on"), "{log}");
    assert_same(&farm.join("out/s.exr"), &d.join("single.exr"));
    assert_eq!(
        std::fs::read(farm.join("out/s.png")).unwrap(),
        std::fs::read(d.join("single.png")).unwrap()
    );

    // 2. No retries: part 1 killed fails for good, the merge job is cancelled, status says
    //    so; the parts present merge with --allow-missing; `farm retry` resubmits part 1
    //    and a new merge, and the image is whole again.
    let farm = d.join("farm2");
    submit("farm2", "0");
    kill_task(&farm, 1, limit);
    let s = cluster.wait(&farm, limit, |s| {
        s.contains("3 done") && s.contains("1 failed") && s.contains("not queued")
    });
    assert!(
        s.contains("task    1  s part 1/4  FAILED (exit 137)"),
        "{s}"
    );
    assert!(s.contains("lamina farm retry"), "{s}");
    assert!(!farm.join("out/s.exr").exists());
    fails(
        &cluster.lamina(&["farm", "merge", "farm2"], &d),
        &["s: 1 of 4 parts missing: part 1/4 (task 1, logs/render-1.log)"],
    );
    let e = ok(&cluster.lamina(&["farm", "merge", "farm2", "--allow-missing"], &d));
    assert!(
        e.contains("144-144 of 192 samples") && e.contains("INCOMPLETE"),
        "{e}"
    );
    ok(&cluster.lamina(&["farm", "retry", "farm2"], &d));
    let s = cluster.wait(&farm, limit, |s| s.contains("every render merged"));
    assert!(s.contains("tasks: 4 done"), "{s}");
    assert_same(&farm.join("out/s.exr"), &d.join("single.exr"));
    drop(cluster);
    std::fs::remove_dir_all(&d).unwrap();
}

/// Without sbatch, --submit is a clear error and the farm folder is still written (to be
/// submitted elsewhere); bad farm arguments fail before anything is written.
#[test]
fn farm_errors_are_clear() {
    let d = scratch("slurm", "errors");
    std::fs::write(d.join("s.toml"), SCENE).unwrap();
    let no_slurm = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_lamina"))
            .args(args)
            .current_dir(&d)
            .env("PATH", "/nonexistent")
            .output()
            .unwrap()
    };
    fails(
        &no_slurm(&[
            "farm", "slurm", "s.toml", "--parts", "2", "--out", "f", "--submit",
        ]),
        &["`sbatch` is not on PATH", "lamina farm submit"],
    );
    assert!(d.join("f/farm.toml").is_file() && d.join("f/render.sbatch").is_file());
    fails(
        &lamina(
            &["farm", "slurm", "s.toml", "--parts", "2", "--out", "f"],
            &d,
        ),
        &["holds a farm already"],
    );
    // Bad farms fail before anything is written: (arguments after `farm slurm`, words).
    let bad: [(&[&str], &[&str]); 4] = [
        (
            &["s.toml", "--parts", "20"],
            &["--parts 20", "12 samples per pixel"],
        ),
        (&["nope.toml", "--parts", "2"], &["nope.toml"]),
        (
            &[
                "s.toml",
                "--parts",
                "2",
                "--grid",
                "light[3].irradiance=1|2",
            ],
            &["light[3].irradiance", "1 [[light]] table(s)"],
        ),
        (
            &["s.toml", "--parts", "2", "--grid", "film.spp=4|x"],
            &["--grid", "not a TOML value"],
        ),
    ];
    for (args, words) in bad {
        let mut a = vec!["farm", "slurm", "--out", "g"];
        a.extend_from_slice(args);
        fails(&lamina(&a, &d), words);
    }
    assert!(!d.join("g").exists());
    fails(
        &lamina(&["farm", "status", "nowhere"], &d),
        &["nowhere", "farm.toml"],
    );
    fails(
        &lamina(&["farm", "task", "f", "9"], &d),
        &["task 9", "tasks 0 to 1"],
    );
    // A farm's own task renders its part exactly as `render --part` does.
    ok(&lamina(&["farm", "task", "f", "1"], &d));
    ok(&lamina(
        &["render", "s.toml", "--part", "1/2", "-o", "p1.exr"],
        &d,
    ));
    assert_same(&d.join("f/parts/s/part-1-of-2.exr"), &d.join("p1.exr"));
    std::fs::remove_dir_all(&d).unwrap();
}

/// A farm's tasks run anywhere (`lamina farm task` is all a node runs): tiles times parts,
/// run here one by one and merged by `lamina farm merge`, give the single render.
#[test]
fn farm_tasks_with_tiles_merge_to_the_single_render() {
    let d = scratch("slurm", "tiles");
    std::fs::write(d.join("s.toml"), SCENE).unwrap();
    ok(&lamina(
        &["render", "s.toml", "--seed", "4", "-q", "-o", "single.exr"],
        &d,
    ));
    let e = ok(&lamina(
        &[
            "farm", "slurm", "s.toml", "--parts", "2", "--tiles", "3x2", "--seed", "4", "--out",
            "t",
        ],
        &d,
    ));
    assert!(
        e.contains("1 render(s) x 6 tile(s) x 2 parts = 12 array tasks"),
        "{e}"
    );
    let script = std::fs::read_to_string(d.join("t/render.sbatch")).unwrap();
    assert!(script.contains("#SBATCH --array=0-11"), "{script}");
    for i in 0..11 {
        ok(&lamina(&["farm", "task", "t", &i.to_string()], &d));
    }
    let o = lamina(&["farm", "status", "t"], &d);
    let s = String::from_utf8_lossy(&o.stdout);
    assert!(
        s.contains("tasks: 11 done") && s.contains("task   11  s tile 5 part 1/2"),
        "{s}"
    );
    fails(
        &lamina(&["farm", "merge", "t"], &d),
        &["s: 1 of 12 parts missing: tile 5 part 1/2 (task 11"],
    );
    ok(&lamina(&["farm", "task", "t", "11"], &d));
    ok(&lamina(&["farm", "merge", "t"], &d));
    assert_same(&d.join("t/out/s.exr"), &d.join("single.exr"));
    assert!(d.join("t/out/s.png").is_file());
    fails(
        &lamina(
            &[
                "farm", "slurm", "s.toml", "--parts", "2", "--tiles", "41x1", "--out", "u",
            ],
            &d,
        ),
        &["--tiles 41x1", "40x30"],
    );
    fails(
        &lamina(
            &[
                "farm", "slurm", "s.toml", "--parts", "2", "--tiles", "3", "--out", "u",
            ],
            &d,
        ),
        &["--tiles", "COLSxROWS"],
    );
    std::fs::remove_dir_all(&d).unwrap();
}
