//! Farm folders and Slurm job arrays: one array task per part of every render of a sweep,
//! and a merge job that runs when the whole array has succeeded.
//!
//! A farm folder (`lamina farm slurm ... --out DIR`) holds:
//!
//! | path | what |
//! |---|---|
//! | `farm.toml` | the [`FarmPlan`]: the lamina binary, the renders (scene + `--set` overrides), tiles, parts, spp, seed, retries, `sbatch` arguments |
//! | `render.sbatch` | the job array: task `i` renders one part of the samples of one tile of one render ([`FarmPlan::task`]; `lamina farm task DIR i`), retried in place up to `retries` times, `--requeue` so that a preempted or failed node's task runs again |
//! | `merge.sbatch` | the merge job (`lamina farm merge DIR`), submitted with `--dependency=afterok:<array>` and `--kill-on-invalid-dep=yes`: it runs once every task succeeded, and is cancelled (not left pending) when one failed for good |
//! | `parts/<render>/part-K-of-N.exr` | the part files (`tile-T-part-K-of-N.exr` with tiles) |
//! | `out/<render>.exr`, `.png` | the merged images |
//! | `logs/` | one log per task (`render-<i>.log`, all attempts) and `merge.log` |
//! | `status/task-<i>.failed` | the last exit code of a task whose attempts all failed |
//! | `jobs.toml` | the job ids of each submission (for `lamina farm status`) |
//!
//! **What the cluster must provide**: the farm folder, the scene and every file it refers
//! to on a file system shared by all nodes, at the same path (the plan stores absolute
//! paths); the lamina binary at the path in `farm.toml` on every node (`--lamina PATH`
//! when it differs from the one that wrote the plan); Slurm's `sbatch` (and `squeue` for
//! status) on the machine that submits. Nodes need no network beyond Slurm's own.

use crate::error::FarmError;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::process::Command;

/// The plan file's name in a farm folder.
pub const PLAN_FILE: &str = "farm.toml";
/// The job-id record's name in a farm folder.
pub const JOBS_FILE: &str = "jobs.toml";

/// One render of a farm: a scene file and the `--set` overrides of this point of a sweep.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RenderSpec {
    /// Its name: the folder of its parts and the stem of its outputs.
    pub name: String,
    /// The scene file (absolute).
    pub scene: PathBuf,
    /// `KEY=VALUE` overrides (`lamina render --set`).
    #[serde(default)]
    pub set: Vec<String>,
    /// The image's width in pixels (with the overrides), for the tiles' crops.
    pub width: u32,
    /// The image's height in pixels.
    pub height: u32,
}

/// One array task: part `part` of the samples of tile `tile` of a render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TaskRef<'a> {
    /// The render.
    pub render: &'a RenderSpec,
    /// Its index in the plan.
    pub render_index: usize,
    /// The tile, row-major over the `tiles` grid (0 without tiles).
    pub tile: u32,
    /// The part of the samples (`--part part/parts`).
    pub part: u32,
}

/// What a farm renders and how; stored as `farm.toml`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FarmPlan {
    /// The lamina that wrote the plan (the folder is lamina's).
    pub generator: String,
    /// The lamina binary the nodes run (absolute).
    pub lamina: PathBuf,
    /// Parts per tile (sample ranges `--part K/N`).
    pub parts: u32,
    /// Tiles per render, `[columns, rows]` (`--crop` regions; `[1, 1]`: the whole image).
    #[serde(default = "one_tile")]
    pub tiles: [u32; 2],
    /// Samples per pixel (`--spp`); `None`: each scene's `film.spp`.
    pub spp: Option<u32>,
    /// The seed of every render.
    pub seed: u64,
    /// Threads per task; `None`: `SLURM_CPUS_PER_TASK` where Slurm sets it, else all cores.
    pub threads: Option<u32>,
    /// Attempts per task inside its job before it counts as failed (at least 1).
    pub attempts: u32,
    /// Extra `sbatch` arguments for every job (`--partition=...`, `--time=...`).
    #[serde(default)]
    pub sbatch_args: Vec<String>,
    /// The renders.
    pub renders: Vec<RenderSpec>,
}

fn one_tile() -> [u32; 2] {
    [1, 1]
}

/// Slurm's default `MaxArraySize` is 1001: array indices 0..=1000.
pub const MAX_ARRAY_TASKS: u32 = 1001;

impl FarmPlan {
    /// Tiles per render.
    pub fn tile_count(&self) -> u32 {
        self.tiles[0] * self.tiles[1]
    }

    /// Array tasks per render: one per part of every tile.
    pub fn tasks_per_render(&self) -> u32 {
        self.tile_count() * self.parts
    }

    /// Array tasks: one per part of every tile of every render.
    pub fn tasks(&self) -> u32 {
        self.renders.len() as u32 * self.tasks_per_render()
    }

    /// Array task `i`: render `i div (tiles·parts)`, then tile, then part.
    pub fn task(&self, i: u32) -> Option<TaskRef<'_>> {
        let per = self.tasks_per_render().max(1);
        let render_index = (i / per) as usize;
        let render = self.renders.get(render_index)?;
        let rem = i % per;
        Some(TaskRef {
            render,
            render_index,
            tile: rem / self.parts.max(1),
            part: rem % self.parts.max(1),
        })
    }

    /// The array task index of `task`.
    pub fn index(&self, task: &TaskRef) -> u32 {
        task.render_index as u32 * self.tasks_per_render() + task.tile * self.parts + task.part
    }

    /// The pixels `[x0, y0, x1, y1]` of tile `tile` of `render`: the image cut into
    /// `columns x rows` rectangles whose edges are at `⌊c·width/columns⌋`.
    pub fn tile_crop(&self, render: &RenderSpec, tile: u32) -> [u32; 4] {
        let [cols, rows] = self.tiles;
        let (cx, cy) = (tile % cols, tile / cols);
        let at = |i: u32, n: u32, size: u32| (i as u64 * size as u64 / n as u64) as u32;
        [
            at(cx, cols, render.width),
            at(cy, rows, render.height),
            at(cx + 1, cols, render.width),
            at(cy + 1, rows, render.height),
        ]
    }

    /// The part file of `task`, in farm folder `dir`.
    pub fn part_path(&self, dir: &Path, task: &TaskRef) -> PathBuf {
        let name = if self.tile_count() == 1 {
            format!("part-{}-of-{}.exr", task.part, self.parts)
        } else {
            format!(
                "tile-{}-part-{}-of-{}.exr",
                task.tile, task.part, self.parts
            )
        };
        dir.join("parts").join(&task.render.name).join(name)
    }

    /// What `task` is, in words: `render part 1/4` or `render tile 3 part 1/4`.
    pub fn describe(&self, task: &TaskRef) -> String {
        if self.tile_count() == 1 {
            format!("{} part {}/{}", task.render.name, task.part, self.parts)
        } else {
            format!(
                "{} tile {} part {}/{}",
                task.render.name, task.tile, task.part, self.parts
            )
        }
    }

    /// The merged outputs of `render`: `out/<name>.exr` and `.png`.
    pub fn outputs(&self, dir: &Path, render: &RenderSpec) -> [PathBuf; 2] {
        let out = dir.join("out");
        [
            out.join(format!("{}.exr", render.name)),
            out.join(format!("{}.png", render.name)),
        ]
    }

    /// Checks the plan: parts, attempts, renders named uniquely and safely, the array
    /// within Slurm's default size.
    pub fn validate(&self) -> Result<(), String> {
        if self.parts == 0 {
            return Err("parts must be at least 1".into());
        }
        if self.tiles[0] == 0 || self.tiles[1] == 0 {
            return Err("tiles must be at least 1x1".into());
        }
        for r in &self.renders {
            if self.tiles[0] > r.width || self.tiles[1] > r.height {
                return Err(format!(
                    "{}x{} tiles do not fit the {}x{} image of '{}'",
                    self.tiles[0], self.tiles[1], r.width, r.height, r.name
                ));
            }
        }
        if self.attempts == 0 {
            return Err("attempts must be at least 1".into());
        }
        if self.renders.is_empty() {
            return Err("no scenes to render".into());
        }
        if self.tasks() > MAX_ARRAY_TASKS {
            return Err(format!(
                "{} renders x {} tiles x {} parts = {} array tasks, more than Slurm's default \
                 MaxArraySize allows ({MAX_ARRAY_TASKS}); use fewer parts or tiles, or split \
                 the sweep",
                self.renders.len(),
                self.tile_count(),
                self.parts,
                self.tasks()
            ));
        }
        let mut names: Vec<&str> = self.renders.iter().map(|r| r.name.as_str()).collect();
        for n in &names {
            let ok = !n.is_empty()
                && !n.starts_with('.')
                && n.chars()
                    .all(|c| c.is_ascii_alphanumeric() || "._=-+,".contains(c));
            if !ok {
                return Err(format!("render name '{n}' is not a safe file name"));
            }
        }
        names.sort_unstable();
        if let Some(w) = names.windows(2).find(|w| w[0] == w[1]) {
            return Err(format!("two renders are named '{}'", w[0]));
        }
        Ok(())
    }

    /// The job array script (see the module docs).
    pub fn render_script(&self, dir: &Path) -> String {
        let d = quote(&dir.to_string_lossy());
        let lamina = quote(&self.lamina.to_string_lossy());
        let last = self.tasks().saturating_sub(1);
        format!(
            "#!/bin/bash\n\
             # Written by {gen} (`lamina farm slurm`): task i renders one of the {n} parts\n\
             # of the samples of one tile of one render of {dir_text}/farm.toml; each task\n\
             # tries {a} time(s) in place, and --requeue lets Slurm run it again after a\n\
             # preemption or a node failure.\n\
             #SBATCH --job-name=lamina-render\n\
             #SBATCH --array=0-{last}\n\
             #SBATCH --requeue\n\
             #SBATCH --open-mode=append\n\
             #SBATCH --output={dir_text}/logs/render-%a.log\n\
             set -u\n\
             task=${{SLURM_ARRAY_TASK_ID:?submit with sbatch: lamina farm submit DIR}}\n\
             rm -f {d}/status/task-\"$task\".failed\n\
             rc=1\n\
             for attempt in $(seq 1 {a}); do\n\
             \x20   echo \"lamina farm: task $task attempt $attempt/{a} on $(hostname) at $(date -u +%FT%TZ)\" >&2\n\
             \x20   {lamina} farm task {d} \"$task\" && exit 0\n\
             \x20   rc=$?\n\
             \x20   echo \"lamina farm: task $task attempt $attempt/{a} failed with exit code $rc\" >&2\n\
             \x20   if [ \"$attempt\" -lt {a} ]; then sleep 2; fi\n\
             done\n\
             echo \"$rc\" > {d}/status/task-\"$task\".failed\n\
             exit \"$rc\"\n",
            gen = self.generator,
            n = self.parts,
            a = self.attempts,
            dir_text = dir.to_string_lossy(),
        )
    }

    /// The merge job's script.
    pub fn merge_script(&self, dir: &Path) -> String {
        format!(
            "#!/bin/bash\n\
             # Written by {gen} (`lamina farm slurm`): merges every render's parts into\n\
             # out/; submitted to run after the whole render array succeeded.\n\
             #SBATCH --job-name=lamina-merge\n\
             #SBATCH --open-mode=append\n\
             #SBATCH --output={dir_text}/logs/merge.log\n\
             exec {lamina} farm merge {d}\n",
            gen = self.generator,
            dir_text = dir.to_string_lossy(),
            lamina = quote(&self.lamina.to_string_lossy()),
            d = quote(&dir.to_string_lossy()),
        )
    }
}

/// `s` as one word for bash, single-quoted.
pub fn quote(s: &str) -> String {
    format!("'{}'", s.replace('\'', "'\\''"))
}

/// Creates farm folder `dir` (absent or empty; never one with anything in it) with the
/// plan, the scripts and the empty folders. `dir` must be absolute.
pub fn create_farm(dir: &Path, plan: &FarmPlan) -> Result<(), FarmError> {
    plan.validate().map_err(FarmError::Farm)?;
    let farm = |m: String| FarmError::Farm(m);
    // `#SBATCH --output=DIR/...` lines end at white space, and Slurm expands `%` in them.
    let text = dir.to_string_lossy();
    if dir.to_str().is_none() || text.contains(|c: char| c.is_whitespace() || c == '%') {
        return Err(farm(format!(
            "--out '{text}': a farm folder's path must have no spaces, '%' or non-UTF-8 \
             characters (Slurm reads it from #SBATCH lines); choose another folder"
        )));
    }
    if dir.exists() {
        if !dir.is_dir() {
            return Err(farm(format!(
                "--out {}: is a file, not a folder",
                dir.display()
            )));
        }
        let entries = std::fs::read_dir(dir)
            .map_err(|e| farm(format!("--out {}: {e}", dir.display())))?
            .count();
        if entries > 0 {
            let what = if dir.join(PLAN_FILE).is_file() {
                "holds a farm already: see `lamina farm status`, `retry` and `merge`, or choose another --out"
            } else {
                "is not empty: lamina writes a farm only into a new or empty folder"
            };
            return Err(farm(format!("--out {}: {what}", dir.display())));
        }
    }
    for sub in ["parts", "out", "logs", "status"] {
        std::fs::create_dir_all(dir.join(sub))
            .map_err(|e| farm(format!("cannot create {}: {e}", dir.join(sub).display())))?;
    }
    for r in &plan.renders {
        let p = dir.join("parts").join(&r.name);
        std::fs::create_dir_all(&p)
            .map_err(|e| farm(format!("cannot create {}: {e}", p.display())))?;
    }
    let text = format!(
        "# {} farm plan: `lamina farm status|submit|retry|merge` read it\n{}",
        lamina_io::GENERATOR,
        toml::to_string(plan).map_err(|e| farm(e.to_string()))?
    );
    write_text(&dir.join(PLAN_FILE), &text, false)?;
    write_text(&dir.join("render.sbatch"), &plan.render_script(dir), true)?;
    write_text(&dir.join("merge.sbatch"), &plan.merge_script(dir), true)?;
    Ok(())
}

/// Writes `text` to `path` atomically, executable when `exec`.
fn write_text(path: &Path, text: &str, exec: bool) -> Result<(), FarmError> {
    use std::io::Write;
    lamina_io::write_file(path, |w| w.write_all(text.as_bytes())).map_err(|e| {
        FarmError::Write {
            path: path.to_owned(),
            cause: e,
        }
    })?;
    #[cfg(unix)]
    if exec {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o755)).map_err(|e| {
            FarmError::Farm(format!("cannot make {} executable: {e}", path.display()))
        })?;
    }
    #[cfg(not(unix))]
    let _ = exec;
    Ok(())
}

/// Reads `dir/farm.toml`; errors name the file.
pub fn read_farm(dir: &Path) -> Result<FarmPlan, FarmError> {
    let path = dir.join(PLAN_FILE);
    let text = std::fs::read_to_string(&path).map_err(|e| {
        FarmError::Farm(format!(
            "{}: {e} (is {} a folder written by `lamina farm slurm`?)",
            path.display(),
            dir.display()
        ))
    })?;
    let plan: FarmPlan = toml::from_str(&text)
        .map_err(|e| FarmError::Farm(format!("{}: {}", path.display(), e.message())))?;
    plan.validate()
        .map_err(|e| FarmError::Farm(format!("{}: {e}", path.display())))?;
    Ok(plan)
}

/// One submission: the render array and its merge job.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Submission {
    /// The array job's id.
    pub array: String,
    /// The array tasks submitted (`0-7`, or `2,5` for a retry).
    pub tasks: String,
    /// The merge job's id.
    pub merge: String,
    /// When (UTC, seconds since 1970).
    pub at: u64,
}

/// The submissions of a farm, oldest first (`jobs.toml`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Jobs {
    /// Every submission.
    #[serde(default)]
    pub submission: Vec<Submission>,
}

/// Reads `dir/jobs.toml` (empty when the farm was never submitted).
pub fn read_jobs(dir: &Path) -> Result<Jobs, FarmError> {
    let path = dir.join(JOBS_FILE);
    match std::fs::read_to_string(&path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(Jobs::default()),
        Err(e) => Err(FarmError::Farm(format!("{}: {e}", path.display()))),
        Ok(text) => toml::from_str(&text)
            .map_err(|e| FarmError::Farm(format!("{}: {}", path.display(), e.message()))),
    }
}

/// `1,2,3,7,9,10` → `1-3,7,9-10`.
pub fn array_spec(tasks: &[u32]) -> String {
    let mut out: Vec<String> = Vec::new();
    let mut i = 0;
    while i < tasks.len() {
        let mut j = i;
        while j + 1 < tasks.len() && tasks[j + 1] == tasks[j] + 1 {
            j += 1;
        }
        out.push(if i == j {
            tasks[i].to_string()
        } else {
            format!("{}-{}", tasks[i], tasks[j])
        });
        i = j + 1;
    }
    out.join(",")
}

/// Runs `sbatch --parsable ARGS... SCRIPT` in `dir`; returns the job id.
fn sbatch(dir: &Path, args: &[String], script: &str) -> Result<String, FarmError> {
    let out = Command::new("sbatch")
        .arg("--parsable")
        .args(args)
        .arg(script)
        .current_dir(dir)
        .output()
        .map_err(|e| {
            FarmError::Farm(if e.kind() == std::io::ErrorKind::NotFound {
                format!(
                    "`sbatch` is not on PATH: submit from a machine with Slurm's client, \
                     with `lamina farm submit {}`",
                    dir.display()
                )
            } else {
                format!("cannot run sbatch: {e}")
            })
        })?;
    if !out.status.success() {
        return Err(FarmError::Farm(format!(
            "sbatch {} {script} failed ({}): {}",
            args.join(" "),
            out.status,
            String::from_utf8_lossy(&out.stderr).trim()
        )));
    }
    let text = String::from_utf8_lossy(&out.stdout);
    // `--parsable` prints `id` or `id;cluster`.
    let id = text.trim().split(';').next().unwrap_or("").to_string();
    if id.is_empty() || !id.chars().all(|c| c.is_ascii_digit()) {
        return Err(FarmError::Farm(format!(
            "sbatch printed no job id: '{}'",
            text.trim()
        )));
    }
    Ok(id)
}

/// Submits array tasks `tasks` of the farm in `dir` and a merge job that depends on them
/// (`afterok`, cancelled if they fail for good); records both in `jobs.toml`.
pub fn submit(dir: &Path, plan: &FarmPlan, tasks: &[u32]) -> Result<Submission, FarmError> {
    if tasks.is_empty() {
        return Err(FarmError::Farm("no tasks to submit".into()));
    }
    let spec = array_spec(tasks);
    let mut args = plan.sbatch_args.clone();
    args.push(format!("--array={spec}"));
    let array = sbatch(dir, &args, "render.sbatch")?;
    let mut args = plan.sbatch_args.clone();
    args.push(format!("--dependency=afterok:{array}"));
    args.push("--kill-on-invalid-dep=yes".into());
    let merge = sbatch(dir, &args, "merge.sbatch")?;
    let sub = Submission {
        array,
        tasks: spec,
        merge,
        at: std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_secs()),
    };
    let mut jobs = read_jobs(dir)?;
    jobs.submission.push(sub.clone());
    let text = format!(
        "# {} farm jobs\n{}",
        lamina_io::GENERATOR,
        toml::to_string(&jobs).map_err(|e| FarmError::Farm(e.to_string()))?
    );
    write_text(&dir.join(JOBS_FILE), &text, false)?;
    Ok(sub)
}

/// Where one array task stands.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum TaskState {
    /// Its part file holds every sample it should.
    Done,
    /// Slurm has it queued or running (its state word: `PENDING`, `RUNNING`, ...).
    Queued(String),
    /// Its attempts all failed (the last exit code).
    Failed(String),
    /// Its part file exists but is unusable or stopped early (why).
    Bad(String),
    /// Nothing yet: not submitted, cancelled, or lost.
    Missing,
}

/// The state of every task of a farm and of its merges.
#[derive(Clone, Debug)]
pub struct FarmStatus {
    /// Per array task, in order.
    pub tasks: Vec<TaskState>,
    /// Per render, whether its merged EXR is there and complete.
    pub merged: Vec<bool>,
    /// The last merge job's Slurm state, if squeue knows it.
    pub merge_job: Option<String>,
    /// Whether squeue could be asked.
    pub squeue: bool,
}

impl FarmStatus {
    /// Tasks in `state`'s kind.
    pub fn count(&self, f: impl Fn(&TaskState) -> bool) -> usize {
        self.tasks.iter().filter(|t| f(t)).count()
    }

    /// The tasks that are neither done nor queued: what `lamina farm retry` submits.
    pub fn to_retry(&self) -> Vec<u32> {
        self.tasks
            .iter()
            .enumerate()
            .filter(|(_, t)| !matches!(t, TaskState::Done | TaskState::Queued(_)))
            .map(|(i, _)| i as u32)
            .collect()
    }
}

/// Asks `squeue` for the states of the jobs `ids` (array tasks expanded): `id_task` or
/// `id` → state. One call per job, so that a purged id (finished jobs are forgotten after
/// `MinJobAge`) can never hide the others: Slurm 22.05 answers a list that mixes them but
/// fails with "Invalid job id" on a purged one alone, and a refused list would make a
/// retry's queued tasks look lost. `None` when squeue cannot be run or cannot reach the
/// controller.
fn squeue(ids: &[&str]) -> Option<Vec<(String, String)>> {
    let mut states = Vec::new();
    for id in ids {
        let out = Command::new("squeue")
            .args(["-h", "-r", "-o", "%i %T", "-j", id])
            .output()
            .ok()?;
        if !out.status.success() {
            // A purged job: nothing of it is queued. Anything else: the queue is unknown.
            if String::from_utf8_lossy(&out.stderr).contains("Invalid job id") {
                continue;
            }
            return None;
        }
        states.extend(
            String::from_utf8_lossy(&out.stdout)
                .lines()
                .filter_map(|l| {
                    let (a, b) = l.trim().split_once(' ')?;
                    Some((a.to_string(), b.trim().to_string()))
                }),
        );
    }
    Some(states)
}

/// The state of the farm in `dir`: part files on disk, failure records, and Slurm's queue.
pub fn status(dir: &Path, plan: &FarmPlan) -> Result<FarmStatus, FarmError> {
    let jobs = read_jobs(dir)?;
    let mut ids: Vec<&str> = Vec::new();
    for s in &jobs.submission {
        ids.push(&s.array);
        ids.push(&s.merge);
    }
    let queue = squeue(&ids);
    let queued = |id: &str| -> Option<String> {
        queue
            .as_ref()?
            .iter()
            .find(|(j, _)| j == id)
            .map(|(_, s)| s.clone())
    };
    let mut tasks = Vec::new();
    for i in 0..plan.tasks() {
        let task = plan.task(i).expect("task in range");
        let path = plan.part_path(dir, &task);
        let state = if path.is_file() {
            // The header says what the part holds; a corrupt body shows at the merge.
            match crate::read_part_info(&path) {
                Ok(p) if p.samples == p.samples_requested => TaskState::Done,
                Ok(p) => TaskState::Bad(format!(
                    "stopped early at sample {} of {}",
                    p.samples[1], p.samples_requested[1]
                )),
                Err(e) => TaskState::Bad(e.to_string()),
            }
        } else {
            TaskState::Missing
        };
        let state = match state {
            TaskState::Done => TaskState::Done,
            other => {
                // The newest submission that holds the task decides whether it is queued.
                let q = jobs
                    .submission
                    .iter()
                    .rev()
                    .find_map(|s| queued(&format!("{}_{i}", s.array)));
                let failed =
                    std::fs::read_to_string(dir.join("status").join(format!("task-{i}.failed")));
                match (q, failed) {
                    (Some(q), _) => TaskState::Queued(q),
                    (None, Ok(code)) => TaskState::Failed(code.trim().to_string()),
                    (None, Err(_)) => other,
                }
            }
        };
        tasks.push(state);
    }
    let merged = plan
        .renders
        .iter()
        .map(|r| {
            let [exr, _] = plan.outputs(dir, r);
            crate::merge::read_merge_summary(&exr).is_some_and(|m| m.complete)
        })
        .collect();
    let merge_job = jobs.submission.last().and_then(|s| queued(&s.merge));
    Ok(FarmStatus {
        tasks,
        merged,
        merge_job,
        squeue: queue.is_some(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan() -> FarmPlan {
        FarmPlan {
            generator: lamina_io::GENERATOR.into(),
            lamina: "/opt/lamina it's/lamina".into(),
            parts: 4,
            tiles: [1, 1],
            spp: Some(64),
            seed: 1,
            threads: None,
            attempts: 2,
            sbatch_args: vec!["--partition=short".into()],
            renders: vec![
                RenderSpec {
                    name: "000-leaf".into(),
                    scene: "/data/leaf.toml".into(),
                    set: vec![],
                    width: 64,
                    height: 48,
                },
                RenderSpec {
                    name: "001-leaf".into(),
                    scene: "/data/leaf.toml".into(),
                    set: vec!["light[0].irradiance=3".into()],
                    width: 64,
                    height: 48,
                },
            ],
        }
    }

    #[test]
    fn tasks_map_to_renders_and_parts() {
        let p = plan();
        assert_eq!(p.tasks(), 8);
        let t = p.task(5).unwrap();
        assert_eq!((t.render.name.as_str(), t.tile, t.part), ("001-leaf", 0, 1));
        assert_eq!(p.index(&t), 5);
        assert!(p.task(8).is_none());
        assert_eq!(
            p.part_path(Path::new("/f"), &p.task(7).unwrap()),
            Path::new("/f/parts/001-leaf/part-3-of-4.exr")
        );
        // 3x2 tiles of 2 parts: task 9 of 24 is render 0, tile 4, part 1.
        let mut p = plan();
        p.tiles = [3, 2];
        p.parts = 2;
        assert_eq!(p.tasks(), 24);
        let t = p.task(9).unwrap();
        assert_eq!((t.render_index, t.tile, t.part), (0, 4, 1));
        assert_eq!(p.index(&t), 9);
        assert_eq!(p.tile_crop(t.render, 4), [21, 24, 42, 48]);
        assert_eq!(
            p.part_path(Path::new("/f"), &t),
            Path::new("/f/parts/000-leaf/tile-4-part-1-of-2.exr")
        );
        // The tiles cover the image exactly.
        let area: u32 = (0..6)
            .map(|i| {
                let [x0, y0, x1, y1] = p.tile_crop(&p.renders[0], i);
                (x1 - x0) * (y1 - y0)
            })
            .sum();
        assert_eq!(area, 64 * 48);
        p.tiles = [65, 1];
        assert!(p.validate().unwrap_err().contains("do not fit"));
        assert_eq!(array_spec(&[0, 1, 2, 5, 7, 8]), "0-2,5,7-8");
        assert_eq!(array_spec(&[3]), "3");
    }

    #[test]
    fn scripts_quote_paths_and_name_the_array() {
        let p = plan();
        let s = p.render_script(Path::new("/farm dir"));
        assert!(s.contains("#SBATCH --array=0-7"), "{s}");
        assert!(s.contains("#SBATCH --requeue"), "{s}");
        assert!(
            s.contains("'/opt/lamina it'\\''s/lamina' farm task '/farm dir' \"$task\""),
            "{s}"
        );
        assert!(s.contains("seq 1 2"), "{s}");
        let m = p.merge_script(Path::new("/farm dir"));
        assert!(m.contains("farm merge '/farm dir'"), "{m}");
    }

    #[test]
    fn plans_are_checked_and_folders_kept() {
        let mut p = plan();
        p.renders[1].name = "000-leaf".into();
        assert!(p.validate().unwrap_err().contains("two renders"));
        let mut p = plan();
        p.parts = 600;
        assert!(p.validate().unwrap_err().contains("MaxArraySize"));
        let mut p = plan();
        p.renders[0].name = "../x".into();
        assert!(p.validate().unwrap_err().contains("safe file name"));

        let dir = std::env::temp_dir().join(format!("lamina-farm-plan-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        create_farm(&dir, &plan()).unwrap();
        assert_eq!(read_farm(&dir).unwrap(), plan());
        let e = create_farm(&dir, &plan()).unwrap_err().to_string();
        assert!(e.contains("holds a farm already"), "{e}");
        let e = create_farm(&dir.join("a b"), &plan())
            .unwrap_err()
            .to_string();
        assert!(e.contains("no spaces"), "{e}");
        assert!(!dir.join("a b").exists());
        let other = dir.join("parts").join("000-leaf");
        std::fs::write(other.join("notes.txt"), "mine").unwrap();
        let e = create_farm(&other, &plan()).unwrap_err().to_string();
        assert!(e.contains("not empty"), "{e}");
        assert_eq!(
            std::fs::read_to_string(other.join("notes.txt")).unwrap(),
            "mine"
        );
        std::fs::write(dir.join(PLAN_FILE), "parts = \"x\"\n").unwrap();
        let e = read_farm(&dir).unwrap_err().to_string();
        assert!(e.contains("farm.toml"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
