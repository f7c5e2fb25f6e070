//! The scale benchmark: trees of 10k, 100k and 1M leaves rendered at 1920x1080, 16 spp,
//! with flat leaf cards and with instanced curved leaves.
//!
//! `cargo run --release -p lamina-bench --bin scale` (all levels; minutes), or quicker:
//! `... --bin scale -- --levels 10000 --width 480 --height 270 --spp 4`.
//!
//! Every (level, representation) runs in a child process (this binary re-executed with
//! `--child`), so the peak memory (VmHWM) is that level's alone. Prints the table and
//! writes `scale.csv`, `scale.json`, one PNG frame per run and, through
//! `crates/lamina-bench/plot_scale.py` (matplotlib), the scaling plot `scale.png` into `--out`
//! (default `out/scale`, ignored by git: a quick or partial run never touches the published
//! table; `--out crates/lamina-bench/results` publishes). It replaces only files an earlier run wrote
//! (`scale.json`'s `"generator"`, lamina's mark on the CSV and the PNGs; `--force` to
//! replace others), checked before the first run.

use anyhow::{Context, Result, bail};
use clap::Parser;
use lamina_bench::{Measurement, Representation, peak_rss_bytes, tree_scene, triangle_counts};
use lamina_plant::{PlantParams, generate_plant};
use lamina_render::{RenderOptions, render, write_image};
use std::path::PathBuf;
use std::process::Command;
use std::time::Instant;

#[derive(Parser, Debug, Clone)]
#[command(about = "Render trees of growing leaf counts; print build time, memory and speed")]
struct Args {
    /// Leaf counts of the trees, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "10000,100000,1000000")]
    levels: Vec<u32>,
    /// Representations to measure, comma-separated: flat, instanced, instanced-cards (flat
    /// cards as instances: the two-level BVH's own cost).
    #[arg(long, value_delimiter = ',', default_value = "flat,instanced")]
    reps: Vec<String>,
    /// Forest rows: numbers of copies of the first level's tree, placed as instances of
    /// one tree prototype, comma-separated (empty: none).
    #[arg(long, value_delimiter = ',', default_value = "")]
    forest: Vec<String>,
    /// Also measure each forest with curved leaves (every leaf instance composed with
    /// every tree placement).
    #[arg(long)]
    forest_curved: bool,
    /// Image width (pixels).
    #[arg(long, default_value_t = 1920)]
    width: u32,
    /// Image height (pixels).
    #[arg(long, default_value_t = 1080)]
    height: u32,
    /// Samples per pixel.
    #[arg(long, default_value_t = 16)]
    spp: u32,
    /// Render threads.
    #[arg(long, default_value_t = 2)]
    threads: usize,
    /// The path integrator's light sampling: `all` (a shadow ray to every light NEE samples
    /// at every vertex) or `one` (one of them, drawn by power).
    #[arg(long, default_value = "all", value_parser = ["all", "one"])]
    light_sampling: String,
    /// The path integrator's sky sampling: `auto` (the default: the constant sky is left to
    /// BSDF samples), `light` (NEE samples it too: a shadow ray to the sun and one to the
    /// sky at every vertex with `--light-sampling all`) or `bsdf`.
    #[arg(long, default_value = "auto", value_parser = ["auto", "light", "bsdf"])]
    sky_sampling: String,
    /// Seed of the tree.
    #[arg(long, default_value_t = 11)]
    seed: u64,
    /// Output folder for the table, the frames and the plot. The default is ignored by git;
    /// `crates/lamina-bench/results` holds the published table (README) and is written only
    /// when named.
    #[arg(long, default_value = "out/scale")]
    out: PathBuf,
    /// Skip the plot (no Python needed).
    #[arg(long)]
    no_plot: bool,
    /// Replace output files in `--out` that this benchmark did not write (without it such
    /// files are kept and the benchmark refuses to start).
    #[arg(long)]
    force: bool,
    /// Internal: measure one level in this process and print it as a `RESULT` JSON line.
    #[arg(long, hide = true)]
    child: Option<String>,
    /// Internal: forest copies for `--child forest`.
    #[arg(long, hide = true, default_value_t = 1)]
    copies: u32,
}

fn parse_rep(s: &str) -> Result<Representation> {
    Ok(match s {
        "flat" => Representation::Flat,
        "instanced" => Representation::Instanced,
        "instanced-cards" => Representation::InstancedCards,
        "forest" => Representation::Forest,
        "forest-curved" => Representation::ForestCurved,
        _ => bail!("unknown representation '{s}' (flat, instanced, instanced-cards)"),
    })
}

/// Measures one level in this process.
fn child(args: &Args, rep: Representation) -> Result<Measurement> {
    let leaves = *args
        .levels
        .first()
        .context("--child needs one --levels value")?;
    let t = Instant::now();
    let mut params = PlantParams::tree(args.seed, leaves);
    params.light_direction = [0.5, 0.8, 0.6];
    let plant = generate_plant(&params)?;
    let generate_s = t.elapsed().as_secs_f64();
    let leaves_placed = plant.leaf_count() as u64;
    let copies = if rep.is_forest() { args.copies } else { 1 };
    let mut scene = tree_scene(plant, rep, copies, args.width, args.height, args.spp);
    if let lamina_core::Integrator::Path {
        light_sampling,
        sky_sampling,
        ..
    } = &mut scene.integrator
    {
        *light_sampling = if args.light_sampling == "one" {
            lamina_core::LightSampling::One
        } else {
            lamina_core::LightSampling::All
        };
        *sky_sampling = match args.sky_sampling.as_str() {
            "light" => lamina_core::SkySampling::Light,
            "bsdf" => lamina_core::SkySampling::Bsdf,
            _ => lamina_core::SkySampling::Auto,
        };
    }
    let (triangles, unique_triangles) = triangle_counts(&scene);
    eprintln!(
        "  {rep} {leaves} leaves x{copies}: generated in {generate_s:.1} s, {triangles} triangles ({unique_triangles} unique); rendering {}x{} {} spp",
        args.width, args.height, args.spp
    );
    let out = render(
        &scene,
        &RenderOptions {
            spp: Some(args.spp),
            threads: Some(args.threads),
            seed: 1,
            ..Default::default()
        },
    )?;
    let s = out.stats;
    let render_s = (s.elapsed - s.accel_build).as_secs_f64();
    std::fs::create_dir_all(&args.out)?;
    write_image(
        &args.out.join(frame_file(rep, leaves, copies)),
        &out.image,
        &scene.film,
    )?;
    let scene_leaves = leaves_placed * copies as u64;
    let mem = s.accel_memory;
    Ok(Measurement {
        leaves: leaves as u64 * copies as u64,
        representation: rep,
        trees: copies as u64,
        triangles,
        unique_triangles,
        primitives: s.primitives as u64,
        instances: s.instances as u64,
        generate_s,
        bvh_build_s: s.accel_build.as_secs_f64(),
        bvh_bytes: mem.total() as u64,
        bvh_world_bytes: mem.world as u64,
        bvh_prototype_bytes: mem.prototypes as u64,
        bvh_instance_bytes: mem.instances as u64,
        bvh_bytes_per_leaf: mem.total() as f64 / scene_leaves.max(1) as f64,
        bytes_per_instance: mem.bytes_per_instance(),
        peak_rss_bytes: peak_rss_bytes(),
        mrays_per_s: s.rays as f64 / render_s / 1e6,
        render_s,
        spp: s.spp_done,
        resolution: [args.width, args.height],
        threads: args.threads,
    })
}

/// Runs one level in a child process and reads its `RESULT` line.
fn spawn(args: &Args, rep: &str, leaves: u32, copies: u32) -> Result<Measurement> {
    let exe = std::env::current_exe()?;
    let output = Command::new(exe)
        .args(["--child", rep, "--levels", &leaves.to_string()])
        .args(["--copies", &copies.to_string()])
        .args(["--width", &args.width.to_string()])
        .args(["--height", &args.height.to_string()])
        .args(["--spp", &args.spp.to_string()])
        .args(["--threads", &args.threads.to_string()])
        .args(["--light-sampling", &args.light_sampling])
        .args(["--sky-sampling", &args.sky_sampling])
        .args(["--seed", &args.seed.to_string()])
        .arg("--out")
        .arg(&args.out)
        .stderr(std::process::Stdio::inherit())
        .output()?;
    if !output.status.success() {
        bail!(
            "the {rep} run of {leaves} leaves failed ({})",
            output.status
        );
    }
    let stdout = String::from_utf8_lossy(&output.stdout);
    let line = stdout
        .lines()
        .find_map(|l| l.strip_prefix("RESULT "))
        .context("the child printed no RESULT line")?;
    Ok(serde_json::from_str(line)?)
}

fn mib(b: u64) -> f64 {
    b as f64 / (1024.0 * 1024.0)
}

fn print_table(rows: &[Measurement]) {
    println!(
        "\n{:>9} {:>15} {:>5} {:>12} {:>10} {:>8} {:>10} {:>9} {:>9} {:>9} {:>7} {:>8}",
        "leaves",
        "repr",
        "trees",
        "triangles",
        "unique",
        "build s",
        "BVH MiB",
        "B/leaf",
        "B/inst",
        "peak MiB",
        "Mrays/s",
        "s/frame"
    );
    for r in rows {
        println!(
            "{:>9} {:>15} {:>5} {:>12} {:>10} {:>8.2} {:>10.1} {:>9.1} {:>9.1} {:>9.0} {:>7.3} {:>8.1}",
            r.leaves,
            r.representation.to_string(),
            r.trees,
            r.triangles,
            r.unique_triangles,
            r.bvh_build_s,
            mib(r.bvh_bytes),
            r.bvh_bytes_per_leaf,
            r.bytes_per_instance,
            mib(r.peak_rss_bytes),
            r.mrays_per_s,
            r.render_s
        );
    }
}

/// `"generator"` of `scale.json` and the detail of `scale.csv`'s mark line.
const GENERATOR: &str = "lamina-bench scale";

/// The frame a run writes (`plot_scale.py`'s `frame_name` reads the same names).
fn frame_file(rep: Representation, leaves: u32, copies: u32) -> String {
    if rep.is_forest() {
        format!("frame_{rep}_{copies}x{leaves}.png")
    } else {
        format!("frame_{rep}_{leaves}.png")
    }
}

/// Refuses to start when a file the benchmark would write in `--out` (the table, the
/// report, a frame, a plot) exists and an earlier run did not write it, unless `--force`.
fn check_outputs(args: &Args, forest: &[u32]) -> Result<()> {
    use lamina_bench::report::{check_json_target, check_marked_target};
    let out = &args.out;
    check_json_target(&out.join("scale.json"), GENERATOR, args.force, "--out")?;
    let mut marked = vec![out.join("scale.csv")];
    for &leaves in &args.levels {
        for rep in &args.reps {
            marked.push(out.join(frame_file(parse_rep(rep)?, leaves, 1)));
        }
    }
    for &copies in forest {
        marked.push(out.join(frame_file(Representation::Forest, args.levels[0], copies)));
        if args.forest_curved {
            marked.push(out.join(frame_file(
                Representation::ForestCurved,
                args.levels[0],
                copies,
            )));
        }
    }
    if !args.no_plot {
        marked.extend([out.join("scale.png"), out.join("frames.png")]);
    }
    for path in &marked {
        check_marked_target(path, args.force)?;
    }
    Ok(())
}

fn write_csv(path: &std::path::Path, rows: &[Measurement]) -> Result<()> {
    let mut s = lamina_io::text_mark_line(GENERATOR) + "\n";
    s.push_str(
        "leaves,representation,trees,triangles,unique_triangles,primitives,instances,generate_s,bvh_build_s,bvh_bytes,bvh_world_bytes,bvh_prototype_bytes,bvh_instance_bytes,bvh_bytes_per_leaf,bytes_per_instance,peak_rss_bytes,mrays_per_s,render_s,spp,width,height,threads\n",
    );
    for r in rows {
        s += &format!(
            "{},{},{},{},{},{},{},{:.3},{:.3},{},{},{},{},{:.2},{:.2},{},{:.4},{:.2},{},{},{},{}\n",
            r.leaves,
            r.representation,
            r.trees,
            r.triangles,
            r.unique_triangles,
            r.primitives,
            r.instances,
            r.generate_s,
            r.bvh_build_s,
            r.bvh_bytes,
            r.bvh_world_bytes,
            r.bvh_prototype_bytes,
            r.bvh_instance_bytes,
            r.bvh_bytes_per_leaf,
            r.bytes_per_instance,
            r.peak_rss_bytes,
            r.mrays_per_s,
            r.render_s,
            r.spp,
            r.resolution[0],
            r.resolution[1],
            r.threads
        );
    }
    lamina_io::write_bytes(path, s.as_bytes())?;
    Ok(())
}

fn main() -> Result<()> {
    let args = Args::parse();
    if let Some(rep) = &args.child {
        let m = child(&args, parse_rep(rep)?)?;
        println!("RESULT {}", serde_json::to_string(&m)?);
        return Ok(());
    }
    if args.levels.is_empty() {
        bail!("--levels needs at least one leaf count");
    }
    for r in &args.reps {
        parse_rep(r)?;
    }
    let forest: Vec<u32> = args
        .forest
        .iter()
        .filter(|s| !s.is_empty())
        .map(|s| s.parse().context("--forest takes copy counts"))
        .collect::<Result<_>>()?;
    check_outputs(&args, &forest)?;
    std::fs::create_dir_all(&args.out)?;
    let (csv, json) = (args.out.join("scale.csv"), args.out.join("scale.json"));
    let mut rows = Vec::new();
    // The table is rewritten after every run, so an interrupted benchmark keeps its rows.
    let mut record = |m: Measurement| -> Result<()> {
        rows.push(m);
        write_csv(&csv, &rows)?;
        let report = serde_json::json!({ "generator": GENERATOR, "runs": &rows });
        lamina_io::write_bytes(&json, serde_json::to_string_pretty(&report)?.as_bytes())?;
        Ok(())
    };
    for &leaves in &args.levels {
        for rep in &args.reps {
            eprintln!("{rep}, {leaves} leaves:");
            record(spawn(&args, rep, leaves, 1)?)?;
        }
    }
    for &copies in &forest {
        eprintln!("forest of {copies} trees of {} leaves:", args.levels[0]);
        record(spawn(&args, "forest", args.levels[0], copies)?)?;
        if args.forest_curved {
            eprintln!(
                "forest of {copies} trees of {} curved leaves:",
                args.levels[0]
            );
            record(spawn(&args, "forest-curved", args.levels[0], copies)?)?;
        }
    }
    print_table(&rows);
    println!("\nwrote {} and {}", csv.display(), json.display());
    if !args.no_plot {
        let png = args.out.join("scale.png");
        let frames = args.out.join("frames.png");
        let script = concat!(env!("CARGO_MANIFEST_DIR"), "/plot_scale.py");
        let status = Command::new("python3")
            .arg(script)
            .arg(&json)
            .arg(&png)
            .arg(&frames)
            .status();
        match status {
            Ok(s) if s.success() => println!("wrote {} and {}", png.display(), frames.display()),
            _ => eprintln!(
                "no plot: run `python3 {script} {} {} {}` (needs matplotlib)",
                json.display(),
                png.display(),
                frames.display()
            ),
        }
    }
    Ok(())
}
