//! Ray throughput of lamina-accel against Embree 3 on the same scenes and rays.
//!
//! `cargo run --release -p lamina-bench --bin rays -- [--embree] [--json FILE]
//! [--threads 1,2] [--quick] [--builder lamina|embree]` (`--embree` and `--builder embree`
//! need `--features embree` and libembree-dev).
//!
//! Scenes ([`lamina_bench::rays`]): `cards` (100k leaf cards with a leaf matte and a
//! ground, as `lamina-render`'s ray bench), `cards_opaque` (the same cards without the
//! matte) and `tree` (1M instances of a curved 64-triangle leaf in a crown, a trunk).
//! Cases, each on every `--threads` count (rayon pools), best wall clock of `--repeat`
//! runs, the same rays (fixed seeds) for both engines:
//!
//! | case | scene | rays | query |
//! |---|---|---|---|
//! | `camera_closest` | cards | 1024² pinhole camera rays | closest hit, matte |
//! | `random_closest` | cards_opaque | 2²⁰ random (origins in the box, uniform directions) | closest hit |
//! | `random_closest_alpha` | cards | the same random rays | closest hit, matte |
//! | `shadow_any_alpha` | cards | 2²⁰ between two random points of the box | any hit, matte |
//! | `sun_any_alpha` | cards | 2²⁰ from random points of the box toward the sun ([`SUN`]); lamina with its grid along the sun (`Accel::index_direction`), as the renderer builds for a `sun` | any hit, matte |
//! | `pixels_closest_alpha` | cards | 8 jittered camera rays per pixel of a 362² picture (2²⁰ in all), pixel after pixel; lamina with its grid from the eye (`Accel::index_view`), as the renderer builds for a pinhole, one ray at a time | closest hit, matte |
//! | `pixels_many_alpha` | cards | the same rays; lamina eight at a time (`Accel::intersect_many`, as the renderer finds a pixel's camera hits), Embree one at a time | closest hit, matte |
//! | `tree_camera_closest` | tree | 1024² camera rays | closest hit |
//! | `tree_random_closest` | tree | 2²⁰ random rays in the tree's box | closest hit |
//! | `tree_shadow_any` | tree | 2²⁰ shadow rays in the tree's box | any hit |
//!
//! Both engines use the opacity mask first and ask the bilinear matte only in unknown
//! cells. Printed: build time and memory per engine and scene, one row per case and thread
//! count (`ratio` = lamina / Embree, above 1 when lamina is faster), lamina's traversal
//! counters over the first 65536 rays of each case, and, with `--embree`, how many of those
//! rays the engines answer differently: `hit/miss` and `primitive` (real disagreements,
//! printed with their rays), and the ones rounding decides: `tie` (two primitives at the
//! same `t`), `edge` (the nearer answer within 1e-4 of its primitive's boundary) and
//! `matte edge` (the nearer answer where the matte is within 5e-3 of its cutoff).

use anyhow::{Context, Result, bail};
use clap::Parser;
use glam::Vec2;
use lamina_accel::{Accel, Kernel, PrimRef, Ray, SceneDesc, TraversalStats};
use lamina_bench::rays::{
    CARDS_BOX, CARDS_VIEW, LeafMatte, MATTE_SIZE, SUN, Scale, TREE_BOX, TREE_VIEW, View,
    camera_rays, cards_scene, pixel_rays, random_rays, shadow_rays, sun_rays, tree_scene,
};
use rayon::prelude::*;
use serde::Serialize;
use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

#[cfg(feature = "embree")]
use lamina_accel::embree::{EmbreeAccel, EmbreeOptions};

#[derive(Parser, Debug)]
#[command(
    about = "Ray throughput: lamina-accel against Embree 3 on leaf cards and an instanced tree"
)]
struct Args {
    /// Also measure Embree 3 (needs the `embree` cargo feature).
    #[arg(long)]
    embree: bool,
    /// With --embree: Embree without RTC_SCENE_FLAG_ROBUST (its fastest, non-watertight
    /// path; lamina's traversal is always conservative).
    #[arg(long)]
    embree_fast: bool,
    /// Write the results as JSON to FILE (atomically: a temporary file, then a rename).
    /// An existing FILE is replaced only when it is an earlier report of this benchmark.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
    /// Replace the `--json` file even when it is not an earlier report of this benchmark.
    #[arg(long)]
    force: bool,
    /// Thread counts to run every case on, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "1,2")]
    threads: Vec<usize>,
    /// 10x fewer cards, leaves and rays (a smoke test).
    #[arg(long)]
    quick: bool,
    /// Leaf cards of the cards scene instead of the scale's (100k; 10k with --quick): a
    /// few thousand shows the per-ray cost on a scene that fits in the caches.
    #[arg(long, value_name = "N")]
    cards: Option<u32>,
    /// Runs per measurement (the best one counts).
    #[arg(long, default_value_t = 3)]
    repeat: usize,
    /// Scenes to run, comma-separated: cards (also builds cards_opaque), tree.
    #[arg(long, value_delimiter = ',', default_value = "cards,tree")]
    scenes: Vec<String>,
    /// Cases to run, comma-separated (e.g. `tree_camera_closest`, for a profile of one);
    /// all of the chosen scenes' cases by default.
    #[arg(long, value_delimiter = ',')]
    cases: Vec<String>,
    /// The builder of lamina's bottom-level trees: `lamina` (its binned SAH) or `embree`
    /// (Embree 3's high-quality builder with spatial splits, through `rtcBuildBVH`; needs
    /// the `embree` cargo feature): lamina's traversal over either tree, to compare the
    /// builders with the traversal held fixed.
    #[arg(long, default_value = "lamina", value_parser = ["lamina", "embree"])]
    builder: String,
    /// lamina's boxes and grids over whole masked primitives rather than over the part
    /// their opacity masks do not call transparent (`BuildOptions::trim_masked`, on by
    /// default; the same answers): to measure what the trimming gains.
    #[arg(long)]
    whole_boxes: bool,
}

/// Rays of the counters and the cross-check.
const SUBSET: usize = 65536;

/// One built scene: its description and each engine's structure.
struct Built {
    name: &'static str,
    /// For the cross-check's edge test.
    #[cfg_attr(not(feature = "embree"), allow(dead_code))]
    desc: SceneDesc,
    lamina: Accel,
    #[cfg(feature = "embree")]
    embree: Option<EmbreeAccel>,
}

#[derive(Serialize, Debug)]
struct BuildRow {
    scene: &'static str,
    engine: &'static str,
    seconds: f64,
    memory_mb: Option<f64>,
    primitives: usize,
    instances: usize,
    /// lamina only: [`Accel::world_sah_cost`].
    world_sah_cost: Option<f64>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Query {
    Closest,
    /// Closest hits eight rays at a time (`Accel::intersect_many`; Embree one by one).
    ClosestMany,
    Occluded,
}

struct Case<'a> {
    name: &'static str,
    scene: &'a Built,
    /// lamina's structure for the case: the scene's, or a copy with a grid added.
    lamina: &'a Accel,
    rays: &'a [Ray],
    query: Query,
    alpha: bool,
}

/// lamina's traversal counters per ray over [`SUBSET`] rays.
#[derive(Serialize, Debug, Clone, Copy)]
struct Counters {
    nodes_per_ray: f64,
    packs_per_ray: f64,
    instances_per_ray: f64,
    alpha_candidates_per_ray: f64,
    /// Share of alpha candidates the masks decided: `(opaque + transparent) / (those +
    /// lookups)`; `None` in opaque cases.
    mask_share: Option<f64>,
}

/// How the engines' answers differ over [`SUBSET`] rays.
#[derive(Serialize, Debug, Clone, Copy, Default)]
struct Mismatches {
    rays: usize,
    /// One hits, the other does not (any hit: the boolean differs).
    hit_miss: usize,
    /// Different primitives at different `t`.
    primitive: usize,
    /// Different primitives at the same `t` (within 2e-6 of `max(t, |origin|)`, ~20 ulp
    /// of the coordinates): ties rounding decides.
    ties: usize,
    /// Closest hit: the nearer answer lies within 1e-4 (barycentric) of its primitive's
    /// boundary, where rounding decides between hitting it and passing it (a small
    /// instanced triangle far from the origin has a barycentric resolution of ~1e-5).
    edge: usize,
    /// Closest hit: the nearer answer is on a matte where the bilinear alpha is within
    /// 5e-3 of the 0.5 cutoff; the engines' barycentrics differ by ~1e-5 (the rounding of
    /// coordinates ~10 m from the origin on a 0.1 m card), which moves the alpha by up to
    /// ~3e-3 on this 256-texel matte.
    matte_edge: usize,
}

/// Whether `h` is on an alpha-tested primitive where the matte is within 5e-3 of its
/// cutoff.
#[cfg(feature = "embree")]
fn near_cutoff(desc: &SceneDesc, h: &lamina_accel::Hit, matte: &LeafMatte) -> bool {
    let prim = if h.prim.inst == lamina_accel::NO_INSTANCE {
        desc.world.prims.get(h.prim.prim as usize)
    } else {
        desc.instances.get(h.prim.inst as usize).and_then(|i| {
            desc.prototypes[i.prototype as usize]
                .prims
                .get(h.prim.prim as usize)
        })
    };
    let Some(alpha) = prim.and_then(|p| p.alpha) else {
        return false;
    };
    let (b1, b2) = (h.bary.x, h.bary.y);
    let uv = alpha.uv[0] * (1.0 - b1 - b2) + alpha.uv[1] * b1 + alpha.uv[2] * b2;
    (matte.alpha(uv) - 0.5).abs() < 5e-3
}

/// How far `h` lies inside its primitive's boundary, in barycentric units.
#[cfg(feature = "embree")]
fn edge_distance(desc: &SceneDesc, h: &lamina_accel::Hit) -> f32 {
    let prims = if h.prim.inst == lamina_accel::NO_INSTANCE {
        &desc.world.prims
    } else if let Some(i) = desc.instances.get(h.prim.inst as usize) {
        &desc.prototypes[i.prototype as usize].prims
    } else {
        return f32::INFINITY; // a sphere
    };
    let (b1, b2) = (h.bary.x, h.bary.y);
    if prims[h.prim.prim as usize].quad {
        b1.min(b2).min(1.0 - b1).min(1.0 - b2)
    } else {
        b1.min(b2).min(1.0 - b1 - b2)
    }
}

#[derive(Serialize, Debug)]
struct CaseRow {
    name: &'static str,
    scene: &'static str,
    threads: usize,
    rays: usize,
    lamina_mrays: f64,
    embree_mrays: Option<f64>,
    /// lamina / Embree.
    ratio: Option<f64>,
    /// Share of rays that hit (lamina).
    hit_share: f64,
    nodes_per_ray: f64,
    packs_per_ray: f64,
    instances_per_ray: f64,
    alpha_candidates_per_ray: f64,
    mask_share: Option<f64>,
    world_sah_cost: f64,
    mismatches: Option<Mismatches>,
}

#[derive(Serialize, Debug)]
struct Machine {
    cpu: String,
    logical_cpus: usize,
    os: String,
    load_average_at_start: String,
    lamina_kernel: String,
    /// `--builder`: who built lamina's bottom-level trees.
    lamina_builder: String,
    embree: Option<String>,
    quick: bool,
    repeat: usize,
    unix_time: u64,
}

/// `Report::generator`: what marks a JSON file as this benchmark's, so that a rerun may
/// replace it.
const REPORT_GENERATOR: &str = "lamina-bench rays";

#[derive(Serialize, Debug)]
struct Report {
    generator: &'static str,
    machine: Machine,
    cases: Vec<CaseRow>,
    builds: Vec<BuildRow>,
}

fn read_trim(path: &str) -> String {
    std::fs::read_to_string(path)
        .map(|s| s.trim().to_string())
        .unwrap_or_default()
}

fn machine(args: &Args) -> Machine {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|m| m.trim().to_string())
        })
        .unwrap_or_else(|| std::env::consts::ARCH.to_string());
    Machine {
        cpu,
        logical_cpus: std::thread::available_parallelism().map_or(1, |n| n.get()),
        os: format!(
            "{} {}",
            std::env::consts::OS,
            read_trim("/proc/sys/kernel/osrelease")
        ),
        load_average_at_start: read_trim("/proc/loadavg"),
        lamina_kernel: format!("{:?}", Kernel::best()),
        lamina_builder: args.builder.clone(),
        embree: args.embree.then(|| {
            format!(
                "Embree 3 (libembree3), {}",
                if args.embree_fast {
                    "fast (no RTC_SCENE_FLAG_ROBUST)"
                } else {
                    "RTC_SCENE_FLAG_ROBUST"
                }
            )
        }),
        quick: args.quick,
        repeat: args.repeat,
        unix_time: std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_secs()),
    }
}

/// Best of `repeat` runs of `f` over `rays` on `pool`: (Mrays/s wall clock, hits).
fn throughput(
    pool: &rayon::ThreadPool,
    rays: &[Ray],
    repeat: usize,
    f: impl Fn(&Ray) -> bool + Sync,
) -> (f64, usize) {
    throughput_chunks(pool, rays, repeat, |c| c.iter().filter(|r| f(r)).count())
}

/// [`throughput`] of `lamina.intersect_many` over the rays eight at a time.
fn throughput_many(
    pool: &rayon::ThreadPool,
    rays: &[Ray],
    repeat: usize,
    lamina: &Accel,
    f: &(impl lamina_accel::AlphaFilter + Sync),
) -> (f64, usize) {
    throughput_chunks(pool, rays, repeat, |c| {
        let mut out = [None; 8];
        c.chunks(8)
            .map(|rays| {
                let out = &mut out[..rays.len()];
                lamina.intersect_many(rays, f, out);
                out.iter().filter(|h| h.is_some()).count()
            })
            .sum::<usize>()
    })
}

/// Best of `repeat` runs of `hits` over `rays` in chunks of 1024 on `pool`: (Mrays/s wall
/// clock, hits).
fn throughput_chunks(
    pool: &rayon::ThreadPool,
    rays: &[Ray],
    repeat: usize,
    hits: impl Fn(&[Ray]) -> usize + Sync,
) -> (f64, usize) {
    let (mut best, mut found) = (f64::INFINITY, 0);
    for _ in 0..repeat.max(1) {
        let t = Instant::now();
        found = pool.install(|| rays.par_chunks(1024).map(&hits).sum::<usize>());
        best = best.min(t.elapsed().as_secs_f64());
    }
    (rays.len() as f64 / 1e6 / best.max(1e-9), found)
}

fn build(
    name: &'static str,
    desc: SceneDesc,
    args: &Args,
    builds: &mut Vec<BuildRow>,
) -> Result<Built> {
    let prims =
        desc.world.prims.len() + desc.prototypes.iter().map(|g| g.prims.len()).sum::<usize>();
    let instances = desc.instances.len();
    let t = Instant::now();
    let opts = lamina_accel::BuildOptions {
        builder: builder(&args.builder)?,
        trim_masked: !args.whole_boxes,
        ..Default::default()
    };
    let lamina =
        Accel::build_with(&desc, opts).with_context(|| format!("lamina build of {name}"))?;
    builds.push(BuildRow {
        scene: name,
        engine: "lamina",
        seconds: t.elapsed().as_secs_f64(),
        memory_mb: Some(lamina.memory().total() as f64 / 1e6),
        primitives: prims,
        instances,
        world_sah_cost: Some(lamina.world_sah_cost()),
    });
    #[cfg(feature = "embree")]
    let embree = if args.embree {
        let t = Instant::now();
        let e = EmbreeAccel::build_with(
            &desc,
            EmbreeOptions {
                robust: !args.embree_fast,
            },
        )
        .with_context(|| format!("Embree build of {name}"))?;
        builds.push(BuildRow {
            scene: name,
            engine: "embree",
            seconds: t.elapsed().as_secs_f64(),
            memory_mb: e.memory_bytes().map(|b| b as f64 / 1e6),
            primitives: prims,
            instances,
            world_sah_cost: None,
        });
        Some(e)
    } else {
        None
    };
    #[cfg(not(feature = "embree"))]
    let _ = args;
    Ok(Built {
        name,
        desc,
        lamina,
        #[cfg(feature = "embree")]
        embree,
    })
}

/// The `--builder` named `name`.
fn builder(name: &str) -> Result<lamina_accel::Builder> {
    Ok(match name {
        "lamina" => lamina_accel::Builder::Lamina,
        #[cfg(feature = "embree")]
        "embree" => lamina_accel::Builder::EmbreeHigh,
        _ => bail!("--builder {name}: this build has no Embree (build with --features embree)"),
    })
}

/// lamina's counters over the first [`SUBSET`] rays of `case`.
fn counters(case: &Case, matte: &LeafMatte) -> Counters {
    let f = |_: u32, uv: Vec2| matte.opaque(uv);
    let stats = TraversalStats::default();
    let rays = &case.rays[..case.rays.len().min(SUBSET)];
    for r in rays {
        match case.query {
            Query::Closest => {
                case.lamina.intersect_counted(r, PrimRef::NONE, &f, &stats);
            }
            Query::ClosestMany => {} // below, eight at a time
            Query::Occluded => {
                case.lamina.occluded_counted(r, PrimRef::NONE, &f, &stats);
            }
        }
    }
    if case.query == Query::ClosestMany {
        let mut out = [None; 8];
        for chunk in rays.chunks(8) {
            let out = &mut out[..chunk.len()];
            case.lamina.intersect_many_counted(chunk, &f, &stats, out);
        }
    }
    let n = rays.len().max(1) as f64;
    let decided = stats.mask_opaque.get() + stats.mask_transparent.get();
    let candidates = decided + stats.alpha_lookups.get();
    Counters {
        nodes_per_ray: stats.nodes.get() as f64 / n,
        packs_per_ray: stats.packs.get() as f64 / n,
        instances_per_ray: stats.instances.get() as f64 / n,
        alpha_candidates_per_ray: candidates as f64 / n,
        mask_share: (case.alpha && candidates > 0).then(|| decided as f64 / candidates as f64),
    }
}

/// The engines' answers compared over the first [`SUBSET`] rays; prints the first rays
/// that differ.
#[cfg(feature = "embree")]
fn cross_check(case: &Case, e: &EmbreeAccel, matte: &LeafMatte) -> Mismatches {
    let f = |_: u32, uv: Vec2| matte.opaque(uv);
    let rays = &case.rays[..case.rays.len().min(SUBSET)];
    let mut m = Mismatches {
        rays: rays.len(),
        ..Default::default()
    };
    // lamina names instances in its top level's order, Embree by scene index.
    let order = case.lamina.scene_instances(&case.scene.desc);
    let to_scene = |h: lamina_accel::Hit| match h.prim.inst {
        lamina_accel::NO_INSTANCE | lamina_accel::SPHERE => h,
        k => lamina_accel::Hit {
            prim: PrimRef {
                inst: order[k as usize],
                prim: h.prim.prim,
            },
            ..h
        },
    };
    let mut shown = 0;
    let mut show = |what: &str, r: &Ray, a: String, b: String| {
        if shown < 5 {
            println!(
                "  {}: {what}: {r:?}\n    lamina {a}\n    embree {b}",
                case.name
            );
            shown += 1;
        }
    };
    for r in rays {
        match case.query {
            Query::Closest | Query::ClosestMany => {
                let a = case
                    .scene
                    .lamina
                    .intersect(r, PrimRef::NONE, &f)
                    .map(to_scene);
                let b = e.intersect(r, PrimRef::NONE, &f);
                if a.map(|h| h.prim) == b.map(|h| h.prim) {
                    continue;
                }
                let near = match (a, b) {
                    (Some(x), Some(y)) => {
                        if (x.t - y.t).abs() <= 2e-6 * x.t.max(r.origin.abs().max_element()) {
                            m.ties += 1;
                            continue;
                        }
                        if x.t < y.t { x } else { y }
                    }
                    (Some(x), None) | (None, Some(x)) => x,
                    (None, None) => unreachable!(),
                };
                if edge_distance(&case.scene.desc, &near) < 1e-4 {
                    m.edge += 1;
                } else if near_cutoff(&case.scene.desc, &near, matte) {
                    m.matte_edge += 1;
                } else if a.is_some() && b.is_some() {
                    m.primitive += 1;
                    show("different primitive", r, format!("{a:?}"), format!("{b:?}"));
                } else {
                    m.hit_miss += 1;
                    show("hit against miss", r, format!("{a:?}"), format!("{b:?}"));
                }
            }
            Query::Occluded => {
                let a = case.lamina.occluded(r, PrimRef::NONE, &f);
                let b = e.occluded(r, PrimRef::NONE, &f);
                if a != b {
                    m.hit_miss += 1;
                    show("occluded differs", r, a.to_string(), b.to_string());
                }
            }
        }
    }
    m
}

/// Writes `bytes` to `path` atomically: a temporary file beside it, then a rename (the
/// folder is created if missing).
fn run_cases(
    cases: &[Case],
    args: &Args,
    matte: &LeafMatte,
    pools: &[(usize, rayon::ThreadPool)],
    rows: &mut Vec<CaseRow>,
) {
    let f = |_: u32, uv: Vec2| matte.opaque(uv);
    for case in cases {
        if !args.cases.is_empty() && !args.cases.iter().any(|c| c == case.name) {
            continue;
        }
        let c = counters(case, matte);
        #[cfg(feature = "embree")]
        let mismatches = case
            .scene
            .embree
            .as_ref()
            .map(|e| cross_check(case, e, matte));
        #[cfg(not(feature = "embree"))]
        let mismatches: Option<Mismatches> = None;
        for (threads, pool) in pools {
            let lamina = case.lamina;
            let (lamina_mrays, hits) = match case.query {
                Query::Closest => throughput(pool, case.rays, args.repeat, |r| {
                    lamina.intersect(r, PrimRef::NONE, &f).is_some()
                }),
                Query::ClosestMany => throughput_many(pool, case.rays, args.repeat, lamina, &f),
                Query::Occluded => throughput(pool, case.rays, args.repeat, |r| {
                    lamina.occluded(r, PrimRef::NONE, &f)
                }),
            };
            #[cfg(feature = "embree")]
            let embree_mrays = case.scene.embree.as_ref().map(|e| {
                match case.query {
                    Query::Closest | Query::ClosestMany => {
                        throughput(pool, case.rays, args.repeat, |r| {
                            e.intersect(r, PrimRef::NONE, &f).is_some()
                        })
                    }
                    Query::Occluded => throughput(pool, case.rays, args.repeat, |r| {
                        e.occluded(r, PrimRef::NONE, &f)
                    }),
                }
                .0
            });
            #[cfg(not(feature = "embree"))]
            let embree_mrays: Option<f64> = None;
            let ratio = embree_mrays.map(|e| lamina_mrays / e);
            println!(
                "{:22} {:>7} {:>13.3} {:>13} {:>7} {:>6.1}",
                case.name,
                threads,
                lamina_mrays,
                embree_mrays.map_or("-".into(), |e| format!("{e:.3}")),
                ratio.map_or("-".into(), |r| format!("{r:.2}")),
                100.0 * hits as f64 / case.rays.len().max(1) as f64,
            );
            rows.push(CaseRow {
                name: case.name,
                scene: case.scene.name,
                threads: *threads,
                rays: case.rays.len(),
                lamina_mrays,
                embree_mrays,
                ratio,
                hit_share: hits as f64 / case.rays.len().max(1) as f64,
                nodes_per_ray: c.nodes_per_ray,
                packs_per_ray: c.packs_per_ray,
                instances_per_ray: c.instances_per_ray,
                alpha_candidates_per_ray: c.alpha_candidates_per_ray,
                mask_share: c.mask_share,
                world_sah_cost: case.lamina.world_sah_cost(),
                mismatches,
            });
        }
    }
}

fn print_builds(builds: &[BuildRow]) {
    println!(
        "{:14} {:7} {:>9} {:>10} {:>10} {:>10} {:>9}",
        "scene", "engine", "build_s", "memory_MB", "prims", "instances", "sah_cost"
    );
    for b in builds {
        println!(
            "{:14} {:7} {:>9.3} {:>10} {:>10} {:>10} {:>9}",
            b.scene,
            b.engine,
            b.seconds,
            b.memory_mb.map_or("-".into(), |m| format!("{m:.1}")),
            b.primitives,
            b.instances,
            b.world_sah_cost.map_or("-".into(), |c| format!("{c:.1}")),
        );
    }
}

/// Every case's name, for `--cases`.
const CASES: [&str; 10] = [
    "camera_closest",
    "random_closest",
    "random_closest_alpha",
    "shadow_any_alpha",
    "sun_any_alpha",
    "pixels_closest_alpha",
    "pixels_many_alpha",
    "tree_camera_closest",
    "tree_random_closest",
    "tree_shadow_any",
];

fn main() -> Result<()> {
    let args = Args::parse();
    if let Some(bad) = args.cases.iter().find(|c| !CASES.contains(&c.as_str())) {
        bail!("--cases: no case '{bad}' (cases: {})", CASES.join(", "));
    }
    if let Some(path) = &args.json {
        lamina_bench::report::check_json_target(path, REPORT_GENERATOR, args.force, "--json")?;
    }
    if args.embree && !cfg!(feature = "embree") {
        eprintln!(
            "error: --embree needs lamina-bench built with the `embree` feature (and libembree-dev):\n  \
             cargo run --release -p lamina-bench --features embree --bin rays -- --embree"
        );
        std::process::exit(1);
    }
    let mut scale = if args.quick {
        Scale::QUICK
    } else {
        Scale::FULL
    };
    if let Some(n) = args.cards {
        if n == 0 {
            bail!("--cards: must be at least 1");
        }
        scale.cards = n;
    }
    // A builder this build lacks: refused before any output.
    builder(&args.builder)?;
    let machine = machine(&args);
    println!(
        "{} ({} logical CPUs), load {}; lamina kernel {}, {} builder; {}",
        machine.cpu,
        machine.logical_cpus,
        machine.load_average_at_start,
        machine.lamina_kernel,
        machine.lamina_builder,
        machine.embree.as_deref().unwrap_or("no Embree (--embree)")
    );
    println!(
        "{} cards, {} tree leaves, {}x{} camera rays, {} random rays{}; best of {}",
        scale.cards,
        scale.leaves,
        scale.camera,
        scale.camera,
        scale.rays,
        if args.quick { " (--quick)" } else { "" },
        args.repeat
    );
    let pools = args
        .threads
        .iter()
        .map(|&n| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .map(|p| (n, p))
                .with_context(|| format!("a pool of {n} threads"))
        })
        .collect::<Result<Vec<_>>>()?;
    let matte = LeafMatte::new(MATTE_SIZE);
    let (mut builds, mut rows) = (Vec::new(), Vec::new());
    let header = || {
        println!(
            "{:22} {:>7} {:>13} {:>13} {:>7} {:>6}",
            "case", "threads", "lamina_mrays", "embree_mrays", "ratio", "hit%"
        )
    };
    let print_counters = |rows: &[CaseRow], from: usize| {
        println!("lamina counters over the first {SUBSET} rays of each case:");
        for r in rows[from..]
            .iter()
            .filter(|r| r.threads == rows[from].threads)
        {
            println!(
                "  {:22} nodes/ray {:6.1}  packs/ray {:6.1}  instances/ray {:5.1}  alpha candidates/ray {:5.2}  mask-decided {}  world SAH cost {:.1}{}",
                r.name,
                r.nodes_per_ray,
                r.packs_per_ray,
                r.instances_per_ray,
                r.alpha_candidates_per_ray,
                r.mask_share
                    .map_or("-".into(), |s| format!("{:.1} %", 100.0 * s)),
                r.world_sah_cost,
                r.mismatches.map_or(String::new(), |m| format!(
                    "; vs Embree: {} hit/miss, {} primitive, {} tie, {} edge, {} matte edge of {}",
                    m.hit_miss, m.primitive, m.ties, m.edge, m.matte_edge, m.rays
                )),
            );
        }
    };

    if args.scenes.iter().any(|s| s == "cards") {
        let cards = build(
            "cards",
            cards_scene(scale.cards, 1, Some(&matte)),
            &args,
            &mut builds,
        )?;
        let opaque = build(
            "cards_opaque",
            cards_scene(scale.cards, 1, None),
            &args,
            &mut builds,
        )?;
        print_builds(&builds);
        let camera = camera_rays(&CARDS_VIEW, scale.camera, scale.camera);
        let random = random_rays(CARDS_BOX, scale.rays, 11);
        let shadow = shadow_rays(CARDS_BOX, scale.rays, 12);
        let sun = sun_rays(CARDS_BOX, scale.rays, 13, SUN);
        // lamina with its grid along the sun, as the renderer builds for a `sun` light.
        let mut with_sun = cards.lamina.clone();
        let t = Instant::now();
        let grid = with_sun
            .index_direction(SUN)
            .context("a grid along the sun over the cards scene")?;
        println!(
            "cards          lamina sun grid: {:.3} s, {}x{} cells, {} entries, {:.1} MB",
            t.elapsed().as_secs_f64(),
            grid.cells.0,
            grid.cells.1,
            grid.entries,
            grid.bytes as f64 / 1e6
        );
        // A pixel's camera rays together, lamina with its grid from the eye, as the
        // renderer builds for a pinhole.
        let side = ((scale.rays / 8) as f64).sqrt() as u32;
        let (pixels, (eye, fwd, up, window)) = pixel_rays(&CARDS_VIEW, side, side, 8, 14);
        let mut with_eye = cards.lamina.clone();
        let t = Instant::now();
        let grid = with_eye
            .index_view(eye, fwd, up, window)
            .context("a grid from the eye over the cards scene")?;
        println!(
            "cards          lamina eye grid: {:.3} s, {}x{} cells, {} entries, {:.1} MB",
            t.elapsed().as_secs_f64(),
            grid.cells.0,
            grid.cells.1,
            grid.entries,
            grid.bytes as f64 / 1e6
        );
        let cases = [
            Case {
                name: "camera_closest",
                scene: &cards,
                lamina: &cards.lamina,
                rays: &camera,
                query: Query::Closest,
                alpha: true,
            },
            Case {
                name: "random_closest",
                scene: &opaque,
                lamina: &opaque.lamina,
                rays: &random,
                query: Query::Closest,
                alpha: false,
            },
            Case {
                name: "random_closest_alpha",
                scene: &cards,
                lamina: &cards.lamina,
                rays: &random,
                query: Query::Closest,
                alpha: true,
            },
            Case {
                name: "shadow_any_alpha",
                scene: &cards,
                lamina: &cards.lamina,
                rays: &shadow,
                query: Query::Occluded,
                alpha: true,
            },
            Case {
                name: "sun_any_alpha",
                scene: &cards,
                lamina: &with_sun,
                rays: &sun,
                query: Query::Occluded,
                alpha: true,
            },
            Case {
                name: "pixels_closest_alpha",
                scene: &cards,
                lamina: &with_eye,
                rays: &pixels,
                query: Query::Closest,
                alpha: true,
            },
            Case {
                name: "pixels_many_alpha",
                scene: &cards,
                lamina: &with_eye,
                rays: &pixels,
                query: Query::ClosestMany,
                alpha: true,
            },
        ];
        header();
        let from = rows.len();
        run_cases(&cases, &args, &matte, &pools, &mut rows);
        print_counters(&rows, from);
    }
    if args.scenes.iter().any(|s| s == "tree") {
        let from_builds = builds.len();
        let tree = build("tree", tree_scene(scale.leaves, 2), &args, &mut builds)?;
        print_builds(&builds[from_builds..]);
        let view: &View = &TREE_VIEW;
        let camera = camera_rays(view, scale.camera, scale.camera);
        let random = random_rays(TREE_BOX, scale.rays, 21);
        let shadow = shadow_rays(TREE_BOX, scale.rays, 22);
        let cases = [
            Case {
                name: "tree_camera_closest",
                scene: &tree,
                lamina: &tree.lamina,
                rays: &camera,
                query: Query::Closest,
                alpha: false,
            },
            Case {
                name: "tree_random_closest",
                scene: &tree,
                lamina: &tree.lamina,
                rays: &random,
                query: Query::Closest,
                alpha: false,
            },
            Case {
                name: "tree_shadow_any",
                scene: &tree,
                lamina: &tree.lamina,
                rays: &shadow,
                query: Query::Occluded,
                alpha: false,
            },
        ];
        header();
        let from = rows.len();
        run_cases(&cases, &args, &matte, &pools, &mut rows);
        print_counters(&rows, from);
    }
    if let Some(path) = &args.json {
        let report = Report {
            generator: REPORT_GENERATOR,
            machine,
            cases: rows,
            builds,
        };
        let json = serde_json::to_vec_pretty(&report)?;
        lamina_bench::report::check_json_target(path, REPORT_GENERATOR, args.force, "--json")?;
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        }
        lamina_io::write_file(path, |w| w.write_all(&json))?;
        println!("wrote {}", path.display());
    }
    Ok(())
}
