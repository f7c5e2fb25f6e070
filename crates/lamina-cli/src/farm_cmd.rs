//! `lamina farm`: renders and sweeps as Slurm job arrays (`slurm`, `submit`/`retry`,
//! `status`, `merge`; `task` is what each array task runs). The folder layout, the
//! scripts and what the cluster must provide: `lamina_farm::slurm`.

use crate::render_cmd::{RenderArgs, RenderFlags};
use anyhow::{Context, Result, bail};
use lamina_farm::slurm::{self, FarmPlan, RenderSpec, TaskState};
use lamina_scene::Override;
use std::path::{Path, PathBuf};

/// `lamina farm ...`.
#[derive(clap::Subcommand, Debug)]
pub enum FarmCommand {
    /// Write a farm folder that renders SCENES (and a parameter grid) as a Slurm job array
    /// of parts plus a merge job; with --submit, submit it.
    Slurm(SlurmArgs),
    /// Submit the farm's tasks that are neither done nor queued (all of them the first time,
    /// the failed or lost ones later), with a new merge job that waits for them.
    #[command(visible_alias = "retry")]
    Submit {
        /// The farm folder.
        dir: PathBuf,
    },
    /// Parts done, queued, running and failed, and the merges, of a farm.
    Status {
        /// The farm folder.
        dir: PathBuf,
        /// List every task, not only those that are not done.
        #[arg(long)]
        all: bool,
    },
    /// Merge each render's parts into out/NAME.exr and out/NAME.png (the merge job runs
    /// this).
    Merge {
        /// The farm folder.
        dir: PathBuf,
        /// Merge the parts present when some are missing (the images say so).
        #[arg(long)]
        allow_missing: bool,
    },
    /// Render array task INDEX of a farm (what render.sbatch runs on a node).
    #[command(hide = true)]
    Task {
        /// The farm folder.
        dir: PathBuf,
        /// The array task index.
        index: u32,
    },
}

/// `lamina farm slurm`.
#[derive(clap::Args, Debug)]
pub struct SlurmArgs {
    /// Scene files (TOML); every one is rendered (for every point of the grid).
    #[arg(required = true)]
    pub scenes: Vec<PathBuf>,
    /// Parts of the samples: each array task renders 1/N of the samples (`--part K/N`) of
    /// its tile.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1001))]
    pub parts: u32,
    /// Also split each image into COLSxROWS tiles (`--crop` regions), each rendered by its
    /// own tasks: for frames too large for one node's time, and smaller files per task.
    #[arg(long, value_name = "COLSxROWS", value_parser = parse_tiles, default_value = "1x1")]
    pub tiles: [u32; 2],
    /// Samples per pixel (default: each scene's film.spp).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    pub spp: Option<u32>,
    /// Seed of every render.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Threads per task (default: SLURM_CPUS_PER_TASK where Slurm sets it, else all cores
    /// of the node; ask Slurm for cores with --sbatch-args "--cpus-per-task=N").
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub threads: Option<u32>,
    /// A parameter of the sweep: KEY=V1|V2|... (repeatable; the renders are every
    /// combination): e.g. --grid 'light[0].irradiance=1|2|4'. Keys and values as `lamina
    /// render --set`.
    #[arg(long, value_name = "KEY=V1|V2")]
    pub grid: Vec<String>,
    /// Extra arguments for every sbatch call, split at spaces: "--partition=short
    /// --time=01:00:00 --cpus-per-task=8".
    #[arg(long, value_name = "ARGS", allow_hyphen_values = true)]
    pub sbatch_args: Option<String>,
    /// Times a failed task is tried again inside its job before it counts as failed.
    #[arg(long, default_value_t = 2)]
    pub retries: u32,
    /// The farm folder (new or empty), on a file system every node sees.
    #[arg(long, default_value = "farm")]
    pub out: PathBuf,
    /// The lamina binary the nodes run (default: this one).
    #[arg(long)]
    pub lamina: Option<PathBuf>,
    /// Submit the job array and the merge job now (needs `sbatch`).
    #[arg(long)]
    pub submit: bool,
}

/// `--tiles COLSxROWS`.
fn parse_tiles(s: &str) -> std::result::Result<[u32; 2], String> {
    let (c, r) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("'{s}' is not COLSxROWS (e.g. 4x2)"))?;
    let n = |t: &str| match t.trim().parse::<u32>() {
        Ok(v) if v >= 1 => Ok(v),
        _ => Err(format!(
            "'{s}': '{t}' is not a whole number of tiles (at least 1)"
        )),
    };
    Ok([n(c)?, n(r)?])
}

/// Runs a `lamina farm` command.
pub fn run(cmd: FarmCommand) -> Result<()> {
    match cmd {
        FarmCommand::Slurm(args) => run_slurm(&args),
        FarmCommand::Submit { dir } => submit(&absolute(&dir)?),
        FarmCommand::Status { dir, all } => print_status(&absolute(&dir)?, all),
        FarmCommand::Merge { dir, allow_missing } => merge(&absolute(&dir)?, allow_missing),
        FarmCommand::Task { dir, index } => task(&absolute(&dir)?, index),
    }
}

fn absolute(p: &Path) -> Result<PathBuf> {
    std::path::absolute(p).with_context(|| format!("'{}'", p.display()))
}

/// `--grid KEY=V1|V2` as the overrides of each value.
fn grid_axis(g: &str) -> Result<Vec<Override>> {
    let (key, values) = g
        .split_once('=')
        .with_context(|| format!("--grid '{g}': not KEY=V1|V2|..."))?;
    values
        .split('|')
        .map(|v| {
            format!("{}={}", key.trim(), v.trim())
                .parse::<Override>()
                .map_err(|e| anyhow::anyhow!("--grid '{g}': {e}"))
        })
        .collect()
}

/// Letters, digits and `._=-+,` kept, anything else `_`, at most 40 characters.
fn safe_name(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "._=-+,".contains(c) {
                c
            } else {
                '_'
            }
        })
        .take(40)
        .collect()
}

fn run_slurm(args: &SlurmArgs) -> Result<()> {
    let dir = absolute(&args.out)?;
    let lamina = match &args.lamina {
        Some(p) => absolute(p)?,
        None => std::env::current_exe().context("finding the lamina binary")?,
    };
    let axes: Vec<Vec<Override>> = args
        .grid
        .iter()
        .map(|g| grid_axis(g))
        .collect::<Result<_>>()?;
    // Every combination of the axes' values.
    let mut points: Vec<Vec<Override>> = vec![Vec::new()];
    for axis in &axes {
        points = points
            .iter()
            .flat_map(|p| {
                axis.iter().map(move |o| {
                    let mut q = p.clone();
                    q.push(o.clone());
                    q
                })
            })
            .collect();
    }
    let mut renders = Vec::new();
    for scene in &args.scenes {
        let abs =
            std::fs::canonicalize(scene).with_context(|| format!("scene '{}'", scene.display()))?;
        let stem = safe_name(&scene.file_stem().unwrap_or_default().to_string_lossy());
        for point in &points {
            let i = renders.len();
            let mut name = if args.scenes.len() == 1 && points.len() == 1 {
                stem.clone()
            } else {
                format!("{i:03}-{stem}")
            };
            for o in point {
                let last = o.key.rsplit('.').next().unwrap_or(&o.key);
                name.push('-');
                name.push_str(&safe_name(&format!("{last}={}", o.value)));
            }
            // Load it now: a bad scene or override fails here, not on the cluster.
            let (s, _) = lamina_scene::load_scene_with_overrides(&abs, point)?;
            let spp = args.spp.unwrap_or(s.film.spp);
            if args.parts > spp {
                bail!(
                    "--parts {}: '{}' has {spp} samples per pixel; a render splits into at most \
                     that many parts (or raise --spp)",
                    args.parts,
                    scene.display()
                );
            }
            if args.tiles[0] > s.film.width || args.tiles[1] > s.film.height {
                bail!(
                    "--tiles {}x{}: more tiles than pixels in the {}x{} image of '{}'",
                    args.tiles[0],
                    args.tiles[1],
                    s.film.width,
                    s.film.height,
                    scene.display()
                );
            }
            renders.push(RenderSpec {
                name,
                scene: abs.clone(),
                set: point.iter().map(|o| o.to_string()).collect(),
                width: s.film.width,
                height: s.film.height,
            });
        }
    }
    let plan = FarmPlan {
        generator: lamina_io::GENERATOR.into(),
        lamina,
        parts: args.parts,
        tiles: args.tiles,
        spp: args.spp,
        seed: args.seed,
        threads: args.threads,
        attempts: args.retries.saturating_add(1),
        sbatch_args: args
            .sbatch_args
            .as_deref()
            .unwrap_or("")
            .split_whitespace()
            .map(String::from)
            .collect(),
        renders,
    };
    slurm::create_farm(&dir, &plan)?;
    eprintln!(
        "wrote farm {}: {} render(s) x {} tile(s) x {} parts = {} array tasks, then a merge job",
        dir.display(),
        plan.renders.len(),
        plan.tile_count(),
        plan.parts,
        plan.tasks()
    );
    if args.submit {
        submit(&dir)
    } else {
        eprintln!("submit it with: lamina farm submit {}", dir.display());
        Ok(())
    }
}

fn submit(dir: &Path) -> Result<()> {
    let plan = slurm::read_farm(dir)?;
    let st = slurm::status(dir, &plan)?;
    let tasks = st.to_retry();
    if tasks.is_empty() {
        eprintln!(
            "nothing to submit: {} tasks done, {} queued (`lamina farm status {}`)",
            st.count(|t| *t == TaskState::Done),
            st.count(|t| matches!(t, TaskState::Queued(_))),
            dir.display()
        );
        return Ok(());
    }
    for &i in &tasks {
        let _ = std::fs::remove_file(dir.join("status").join(format!("task-{i}.failed")));
    }
    let sub = slurm::submit(dir, &plan, &tasks)?;
    println!("{} {}", sub.array, sub.merge);
    eprintln!(
        "submitted array job {} (tasks {}) and merge job {} (after all of them succeed)",
        sub.array, sub.tasks, sub.merge
    );
    Ok(())
}

fn print_status(dir: &Path, all: bool) -> Result<()> {
    let plan = slurm::read_farm(dir)?;
    let st = slurm::status(dir, &plan)?;
    let jobs = slurm::read_jobs(dir)?;
    let done = st.count(|t| *t == TaskState::Done);
    let queued = st.count(|t| matches!(t, TaskState::Queued(_)));
    let running = st.count(|t| matches!(t, TaskState::Queued(s) if s == "RUNNING"));
    let failed = st.count(|t| matches!(t, TaskState::Failed(_)));
    let bad = st.count(|t| matches!(t, TaskState::Bad(_)));
    let missing = st.count(|t| *t == TaskState::Missing);
    println!(
        "farm {}: {} render(s) x {} tile(s) x {} parts = {} tasks",
        dir.display(),
        plan.renders.len(),
        plan.tile_count(),
        plan.parts,
        plan.tasks()
    );
    println!(
        "tasks: {done} done, {queued} queued ({running} running), {failed} failed, {bad} unusable, {missing} not done{}",
        if st.squeue {
            ""
        } else {
            " (squeue not available: queued tasks count as not done)"
        }
    );
    for (i, t) in st.tasks.iter().enumerate() {
        if *t == TaskState::Done && !all {
            continue;
        }
        let task = plan.task(i as u32).expect("task in range");
        let what = match t {
            TaskState::Done => "done".to_string(),
            TaskState::Queued(s) => s.clone(),
            TaskState::Failed(code) => format!("FAILED (exit {code}), log: logs/render-{i}.log"),
            TaskState::Bad(why) => format!("unusable part: {why}"),
            TaskState::Missing => "not done (never submitted, cancelled or lost)".into(),
        };
        println!("  task {i:>4}  {}  {what}", plan.describe(&task));
    }
    for (r, m) in plan.renders.iter().zip(&st.merged) {
        println!(
            "  merged {}: {}",
            r.name,
            if *m { "yes (out/)" } else { "no" }
        );
    }
    match (jobs.submission.last(), &st.merge_job) {
        (None, _) => println!("not submitted: lamina farm submit {}", dir.display()),
        (Some(s), Some(state)) => println!("merge job {}: {state}", s.merge),
        (Some(s), None) if st.merged.iter().all(|m| *m) => {
            println!("merge job {}: finished, every render merged", s.merge)
        }
        (Some(s), None) => println!(
            "merge job {}: not queued (it ran and failed, or was cancelled because a task \
             failed): resubmit what is missing with `lamina farm retry {}`, or merge the \
             parts present with `lamina farm merge {} --allow-missing`",
            s.merge,
            dir.display(),
            dir.display()
        ),
    }
    Ok(())
}

fn merge(dir: &Path, allow_missing: bool) -> Result<()> {
    let plan = slurm::read_farm(dir)?;
    let mut failures = Vec::new();
    let mut any_missing = false;
    for (ri, r) in plan.renders.iter().enumerate() {
        let mut parts = Vec::new();
        let mut missing = Vec::new();
        let first = ri as u32 * plan.tasks_per_render();
        for i in first..first + plan.tasks_per_render() {
            let task = plan.task(i).expect("task in range");
            let p = plan.part_path(dir, &task);
            if p.is_file() {
                parts.push(p);
            } else {
                let what = plan.describe(&task);
                let what = what.strip_prefix(&format!("{} ", r.name)).unwrap_or(&what);
                missing.push(format!("{what} (task {i}, logs/render-{i}.log)"));
            }
        }
        if !missing.is_empty() && !allow_missing {
            any_missing = true;
            failures.push(format!(
                "{}: {} of {} parts missing: {}",
                r.name,
                missing.len(),
                plan.tasks_per_render(),
                missing.join(", ")
            ));
            continue;
        }
        if parts.is_empty() {
            any_missing = true;
            failures.push(format!("{}: no part rendered", r.name));
            continue;
        }
        let [exr, png] = plan.outputs(dir, r);
        let args = crate::parts_cmd::MergeArgs {
            parts,
            output: vec![exr, png],
            allow_missing,
            force: false,
        };
        if let Err(e) = crate::parts_cmd::run_merge(&args) {
            failures.push(format!("{}: {e:#}", r.name));
        }
    }
    if !failures.is_empty() {
        let hint = if any_missing {
            format!(
                "\n(`lamina farm retry {}` resubmits missing parts; --allow-missing merges the \
                 parts present)",
                dir.display()
            )
        } else {
            String::new()
        };
        bail!(
            "{} of {} render(s) not merged:\n  {}{hint}",
            failures.len(),
            plan.renders.len(),
            failures.join("\n  "),
        );
    }
    Ok(())
}

fn task(dir: &Path, index: u32) -> Result<()> {
    let plan = slurm::read_farm(dir)?;
    let Some(t) = plan.task(index) else {
        bail!(
            "task {index}: the farm {} has tasks 0 to {}",
            dir.display(),
            plan.tasks().saturating_sub(1)
        );
    };
    let render = t.render;
    let set = render
        .set
        .iter()
        .map(|s| {
            s.parse::<Override>()
                .map_err(|e| anyhow::anyhow!("farm.toml: {e}"))
        })
        .collect::<Result<Vec<_>>>()?;
    let threads = plan.threads.or_else(|| {
        std::env::var("SLURM_CPUS_PER_TASK")
            .ok()
            .and_then(|v| v.parse().ok())
    });
    eprintln!(
        "lamina farm: task {index} = {} on {} thread(s)",
        plan.describe(&t),
        threads.map_or("all".to_string(), |t| t.to_string())
    );
    let [x0, y0, x1, y1] = plan.tile_crop(render, t.tile);
    crate::render_cmd::run(RenderArgs {
        scene: render.scene.clone(),
        output: vec![plan.part_path(dir, &t)],
        gpu: false,
        lod: None,
        force: false,
        part: Some((t.part, plan.parts)),
        no_sensors: true,
        sensor_scale: None,
        crop: (plan.tile_count() > 1).then_some(lamina_render::Crop { x0, y0, x1, y1 }),
        set,
        flags: RenderFlags {
            spp: plan.spp,
            threads,
            seed: plan.seed,
            time_limit: None,
            quiet: false,
            // Workers trace with the default engine, the one every build has.
            accel: Default::default(),
            one_path_at_a_time: false,
        },
    })
}
