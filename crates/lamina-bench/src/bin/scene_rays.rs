//! A scene's own rays through the ray-casting engine alone: where a render's traversal
//! time goes, and how it compares with another engine's on the same kinds of rays.
//!
//! `cargo run --release -p lamina-bench --bin scene_rays -- SCENE.toml [--spp N]
//! [--threads 2] [--repeat 3] [--embree] [--counts] [--json FILE]` (`--embree` needs
//! `--features embree` and libembree-dev).
//!
//! The ray sets, made once (fixed seeds) and traced by each engine, each the best wall
//! clock of `--repeat` runs on a `--threads` pool:
//!
//! | set | rays | query |
//! |---|---|---|
//! | `camera` | the scene's camera, `--spp` rays per pixel (uniformly jittered in the pixel, the lens at its centre), pixel after pixel | closest hit, eight at a time (`Accel::intersect_many`, as the renderer) |
//! | `camera_one` | the same | closest hit, one at a time |
//! | `bounce` | from each camera ray's hit on a surface: a cosine-weighted direction about the geometric normal, on either side by a coin toss (what a diffuse leaf's BSDF samples), leaving that primitive; pixel after pixel | closest hit |
//! | `bounce_shuffled` | the same rays in a random order (no two neighbours from one pixel) | closest hit |
//! | `sun` | from each such hit toward the first `sun` light (a direction in its disc, drawn as the renderer draws it), leaving that primitive | any hit, eight at a time (`Accel::occluded_many`, as the renderer) |
//! | `sun_one` | the same | any hit, one at a time |
//! | `bounce2` | from each bounce ray's hit (a path's second vertex), a bounce ray made as at the first | closest hit, one at a time (as the renderer at deeper vertices) |
//! | `sun2_one` | from each such hit toward the sun, made as at the first | any hit, one at a time (as the renderer at deeper vertices) |
//!
//! Printed per set: rays, hits (or blocked), seconds and M rays/s; with `--embree` the
//! same on Embree 3 (lamina-render's Embree backend, one ray at a time) and the ratio
//! (Embree's time / lamina's: above 1 when lamina is faster). `--counts` adds what lamina's
//! engine does per ray of each set, counted in a separate, untimed run: wide nodes and
//! leaf packs tested, instances entered, alpha candidates the opacity masks decided
//! (opaque, transparent) and those that asked the exact matte. `--json` writes the rows.
//! `bench/mitsuba_rays.py` runs this on the Mitsuba comparison's scene and times Mitsuba
//! 3 (Embree packets inside) on rays made the same way.

use anyhow::{Result, bail};
use clap::Parser;
use glam::{Vec2, Vec3};
use lamina_accel::TraversalStats;
use lamina_core::{Light, Scene};
use lamina_leaf::frame::Frame;
use lamina_leaf::sampling::cosine_hemisphere;
use lamina_render::accel::{Accel, Backend, HitKind, PrimRef, Ray, spawn_origin};
use lamina_render::camera::CameraModel;
use lamina_render::lights::SunLight;
use lamina_render::sampler::hash_combine;
use rayon::prelude::*;
use serde::Serialize;
use std::path::PathBuf;
use std::time::Instant;

/// The `"generator"` of this benchmark's JSON reports.
const GENERATOR: &str = "lamina-bench scene_rays";

#[derive(Parser, Debug)]
#[command(about = "A scene's camera, bounce and sun rays through the ray-casting engine alone")]
struct Args {
    /// The lamina scene (TOML).
    scene: PathBuf,
    /// Camera rays per pixel (default: the scene's film spp).
    #[arg(long)]
    spp: Option<u32>,
    /// Threads of the pool the rays are traced on.
    #[arg(long, default_value_t = 2)]
    threads: usize,
    /// Runs per set (the best one counts).
    #[arg(long, default_value_t = 3)]
    repeat: usize,
    /// Also trace the sets on Embree 3 (needs the `embree` cargo feature).
    #[arg(long)]
    embree: bool,
    /// Write the rows as JSON to FILE (atomically). An existing FILE is replaced only
    /// when it is an earlier report of this benchmark.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
    /// Replace the `--json` file even when it is not an earlier report of this benchmark,
    /// and `--write-rays`' files when they exist.
    #[arg(long)]
    force: bool,
    /// Also count what lamina's engine does per ray of each set (an extra, untimed run).
    #[arg(long)]
    counts: bool,
    /// Also trace the rays of FILE (a ray file, see above), closest hit one at a time.
    #[arg(long, value_name = "FILE")]
    read_rays: Option<PathBuf>,
    /// Write the bounce and sun sets to DIR as ray files (see above).
    #[arg(long, value_name = "DIR")]
    write_rays: Option<PathBuf>,
}

/// The bytes of `rays` as a ray file: eight little-endian `f32` per ray.
fn ray_file_bytes<'a>(rays: impl Iterator<Item = &'a Ray>) -> Vec<u8> {
    let mut out = Vec::new();
    for r in rays {
        let v = [
            r.origin.x, r.origin.y, r.origin.z, 0.0, r.dir.x, r.dir.y, r.dir.z, r.tmax,
        ];
        for x in v {
            out.extend_from_slice(&x.to_le_bytes());
        }
    }
    out
}

/// The rays of a ray file (tnear ignored), with a clear error for a file that is not one.
fn read_ray_file(path: &std::path::Path) -> Result<Vec<Ray>> {
    let bytes =
        std::fs::read(path).map_err(|e| anyhow::anyhow!("--read-rays {}: {e}", path.display()))?;
    if bytes.is_empty() || bytes.len() % 32 != 0 {
        bail!(
            "--read-rays {}: {} bytes is not a whole number of 32-byte rays",
            path.display(),
            bytes.len()
        );
    }
    let f = |c: &[u8]| f32::from_le_bytes([c[0], c[1], c[2], c[3]]);
    let mut rays = Vec::with_capacity(bytes.len() / 32);
    for (i, c) in bytes.chunks_exact(32).enumerate() {
        let v: [f32; 8] = std::array::from_fn(|k| f(&c[4 * k..4 * k + 4]));
        let ray = Ray {
            origin: Vec3::new(v[0], v[1], v[2]),
            dir: Vec3::new(v[4], v[5], v[6]),
            tmax: v[7],
        };
        if !ray.origin.is_finite() || !ray.dir.is_finite() || ray.dir == Vec3::ZERO || v[7].is_nan()
        {
            bail!(
                "--read-rays {}: ray {i} has a non-finite origin or direction, a zero direction or a NaN tfar",
                path.display()
            );
        }
        rays.push(ray);
    }
    Ok(rays)
}

/// One set on one engine.
#[derive(Serialize, Debug)]
struct Row {
    set: &'static str,
    engine: &'static str,
    rays: usize,
    /// Rays that hit (closest-hit sets) or are blocked (`sun`).
    hits: usize,
    seconds: f64,
    mrays_per_s: f64,
    /// Per ray, with `--counts` (lamina's rows).
    #[serde(skip_serializing_if = "Option::is_none")]
    counts: Option<Counts>,
}

/// What lamina's engine did per ray of a set, on average.
#[derive(Serialize, Debug, Clone, Copy)]
struct Counts {
    /// Wide nodes tested.
    nodes: f64,
    /// Leaf packs (four primitives) tested.
    packs: f64,
    /// Instances entered.
    instances: f64,
    /// Alpha candidates the opacity masks decided opaque.
    mask_opaque: f64,
    /// Alpha candidates the opacity masks decided transparent.
    mask_transparent: f64,
    /// Alpha candidates that asked the exact matte.
    alpha_lookups: f64,
}

impl Counts {
    /// The counts of `stats` per ray of `rays`.
    fn per_ray(stats: [u64; 6], rays: usize) -> Counts {
        let per = |k: usize| stats[k] as f64 / rays.max(1) as f64;
        Counts {
            nodes: per(0),
            packs: per(1),
            instances: per(2),
            mask_opaque: per(3),
            mask_transparent: per(4),
            alpha_lookups: per(5),
        }
    }
}

/// `stats` as an array, in [`Counts`]' order.
fn stats_array(stats: &TraversalStats) -> [u64; 6] {
    [
        stats.nodes.get(),
        stats.packs.get(),
        stats.instances.get(),
        stats.mask_opaque.get(),
        stats.mask_transparent.get(),
        stats.alpha_lookups.get(),
    ]
}

/// Element-wise sum of two counter arrays.
fn add_stats(a: [u64; 6], b: [u64; 6]) -> [u64; 6] {
    std::array::from_fn(|k| a[k] + b[k])
}

#[derive(Serialize)]
struct Report<'a> {
    generator: &'static str,
    scene: String,
    width: u32,
    height: u32,
    spp: u32,
    threads: usize,
    rows: &'a [Row],
}

/// A hash to `[0, 1)` of a ray index and a dimension (the sets' only randomness).
fn unit(i: u64, dim: u32) -> f32 {
    let h = hash_combine(hash_combine(dim, i as u32), (i >> 32) as u32);
    (h >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// A set's tracing: the hits (or blocked rays) it counts.
type Tracer<'a> = Box<dyn Fn() -> usize + Sync + 'a>;

/// The camera rays, the vertices at their hits, and the vertices at those vertices'
/// bounce rays' hits.
type Sets = (Vec<Ray>, Vec<Secondary>, Vec<Secondary>);

/// Rays made at one camera ray's hit: the bounce ray and, with a sun, the shadow ray,
/// each leaving the primitive hit.
struct Secondary {
    bounce: Ray,
    sun: Option<Ray>,
    skip: PrimRef,
}

fn main() -> Result<()> {
    let args = Args::parse();
    if args.threads == 0 || args.repeat == 0 {
        bail!("--threads and --repeat must be at least 1");
    }
    if args.embree && !Backend::Embree.available() {
        bail!("--embree: this build has no Embree (build with --features embree)");
    }
    if let Some(json) = &args.json {
        lamina_bench::report::check_json_target(json, GENERATOR, args.force, "--json")?;
    }
    let scene = lamina_scene::load_scene(&args.scene)?;
    let spp = args.spp.unwrap_or(scene.film.spp);
    if spp == 0 {
        bail!("--spp must be at least 1");
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads)
        .build()?;
    let from_file = match &args.read_rays {
        Some(p) => read_ray_file(p)?,
        None => Vec::new(),
    };
    let lamina = Accel::build_on(&scene, Backend::Lamina)?;
    let (camera, secondary, deeper) = pool.install(|| make_sets(&scene, &lamina, spp))?;
    if let Some(dir) = &args.write_rays {
        std::fs::create_dir_all(dir)
            .map_err(|e| anyhow::anyhow!("--write-rays {}: {e}", dir.display()))?;
        for name in ["lamina_bounce.f32", "lamina_sun.f32"] {
            let f = dir.join(name);
            if f.exists() && !args.force {
                bail!(
                    "--write-rays: {} exists; nothing was written (pass --force to replace it, \
                     or name another folder)",
                    f.display()
                );
            }
        }
        let bounce = ray_file_bytes(secondary.iter().map(|s| &s.bounce));
        lamina_io::write_bytes(&dir.join("lamina_bounce.f32"), &bounce)?;
        let sun = ray_file_bytes(secondary.iter().filter_map(|s| s.sun.as_ref()));
        lamina_io::write_bytes(&dir.join("lamina_sun.f32"), &sun)?;
        println!(
            "wrote lamina_bounce.f32 and lamina_sun.f32 to {}",
            dir.display()
        );
    }
    // The bounce rays in a random order, moved (not indexed: reading them at random would
    // time the memory, not the engine).
    let mut shuffled: Vec<(Ray, PrimRef)> = secondary.iter().map(|s| (s.bounce, s.skip)).collect();
    for i in (1..shuffled.len()).rev() {
        let j = (unit(i as u64, 99) * (i + 1) as f32) as usize;
        shuffled.swap(i, j.min(i));
    }
    let (w, h) = (scene.film.width, scene.film.height);
    println!(
        "{}: {w}x{h}, {spp} camera rays per pixel: {} camera rays, {} hit a surface \
         ({} threads, best of {}); {} of their bounce rays hit a surface",
        args.scene.display(),
        camera.len(),
        secondary.len(),
        args.threads,
        args.repeat,
        deeper.len()
    );
    let mut engines = vec![("lamina", lamina)];
    if args.embree {
        engines.push(("embree", Accel::build_on(&scene, Backend::Embree)?));
    }
    let mut rows = Vec::new();
    for (engine, accel) in &engines {
        let time = |f: &(dyn Fn() -> usize + Sync)| -> (f64, usize) {
            let mut best = f64::INFINITY;
            let mut n = 0;
            for _ in 0..args.repeat {
                let t = Instant::now();
                n = pool.install(f);
                best = best.min(t.elapsed().as_secs_f64());
            }
            (best, n)
        };
        let suns = secondary.iter().filter(|s| s.sun.is_some()).count();
        let suns2 = deeper.iter().filter(|s| s.sun.is_some()).count();
        let sets: [(&'static str, usize, Tracer); 9] = [
            (
                "camera",
                camera.len(),
                Box::new(|| {
                    let count = |ch: &[Ray]| {
                        let mut out = [None; Accel::MANY];
                        let mut n = 0;
                        for g in ch.chunks(Accel::MANY) {
                            accel.intersect_many(g, &mut out[..g.len()]);
                            n += out[..g.len()].iter().filter(|h| h.is_some()).count();
                        }
                        n
                    };
                    camera.par_chunks(spp as usize * 16).map(count).sum()
                }),
            ),
            (
                "camera_one",
                camera.len(),
                Box::new(|| {
                    let count =
                        |ch: &[Ray]| ch.iter().filter(|r| accel.intersect(r).is_some()).count();
                    camera.par_chunks(spp as usize * 16).map(count).sum()
                }),
            ),
            (
                "bounce",
                secondary.len(),
                Box::new(|| bounce_hits(accel, &secondary)),
            ),
            (
                "bounce_shuffled",
                secondary.len(),
                Box::new(|| {
                    let hit =
                        |(r, skip): &&(Ray, PrimRef)| accel.intersect_skip(r, *skip).is_some();
                    shuffled
                        .par_chunks(1024)
                        .map(|ch| ch.iter().filter(|i| hit(i)).count())
                        .sum()
                }),
            ),
            (
                "sun",
                suns,
                Box::new(|| {
                    secondary
                        .par_chunks(1024)
                        .map(|ch| sun_many(accel, ch, None))
                        .sum()
                }),
            ),
            (
                "sun_one",
                suns,
                Box::new(|| suns_blocked(accel, &secondary)),
            ),
            (
                "bounce2",
                deeper.len(),
                Box::new(|| bounce_hits(accel, &deeper)),
            ),
            ("sun2_one", suns2, Box::new(|| suns_blocked(accel, &deeper))),
            (
                "file",
                from_file.len(),
                Box::new(|| {
                    let hit = |r: &Ray| accel.intersect(r).is_some();
                    from_file
                        .par_chunks(1024)
                        .map(|ch| ch.iter().filter(|r| hit(r)).count())
                        .sum()
                }),
            ),
        ];
        for (set, rays, f) in &sets {
            if *rays == 0 {
                continue;
            }
            let (seconds, hits) = time(f.as_ref());
            let counts = (args.counts && *engine == "lamina").then(|| {
                let stats = pool.install(|| {
                    count_set(set, accel, spp, &camera, &secondary, &deeper, &from_file)
                });
                Counts::per_ray(stats, *rays)
            });
            rows.push(Row {
                set,
                engine,
                rays: *rays,
                hits,
                seconds,
                mrays_per_s: *rays as f64 / seconds * 1e-6,
                counts,
            });
        }
    }
    println!(
        "{:<16} {:>10} {:>10} {:>10} {:>9} {:>10} {:>9} {:>8}",
        "set", "rays", "hits", "lamina s", "Mrays/s", "embree s", "Mrays/s", "ratio"
    );
    for r in rows.iter().filter(|r| r.engine == "lamina") {
        let e = rows.iter().find(|e| e.engine == "embree" && e.set == r.set);
        let (es, em, ratio) = match e {
            Some(e) => (
                format!("{:.3}", e.seconds),
                format!("{:.2}", e.mrays_per_s),
                format!("{:.2}x", e.seconds / r.seconds),
            ),
            None => ("-".into(), "-".into(), "-".into()),
        };
        println!(
            "{:<16} {:>10} {:>10} {:>10.3} {:>9.2} {:>10} {:>9} {:>8}",
            r.set, r.rays, r.hits, r.seconds, r.mrays_per_s, es, em, ratio
        );
    }
    if args.counts {
        println!(
            "\nper ray (lamina): {:<16} {:>7} {:>7} {:>9} {:>11} {:>13} {:>8}",
            "set", "nodes", "packs", "instances", "mask opaque", "mask transp.", "lookups"
        );
        for r in &rows {
            if let Some(c) = &r.counts {
                println!(
                    "                  {:<16} {:>7.2} {:>7.2} {:>9.2} {:>11.3} {:>13.3} {:>8.4}",
                    r.set,
                    c.nodes,
                    c.packs,
                    c.instances,
                    c.mask_opaque,
                    c.mask_transparent,
                    c.alpha_lookups
                );
            }
        }
    }
    if let Some(json) = &args.json {
        let report = Report {
            generator: GENERATOR,
            scene: args.scene.display().to_string(),
            width: w,
            height: h,
            spp,
            threads: args.threads,
            rows: &rows,
        };
        let bytes = serde_json::to_vec_pretty(&report)?;
        lamina_io::write_bytes(json, &bytes)?;
        println!("wrote {}", json.display());
    }
    Ok(())
}

/// How many of `set`'s bounce rays hit a surface, traced one at a time (in parallel
/// chunks).
fn bounce_hits(accel: &Accel, set: &[Secondary]) -> usize {
    let hit = |s: &Secondary| accel.intersect_skip(&s.bounce, s.skip).is_some();
    set.par_chunks(1024)
        .map(|ch| ch.iter().filter(|s| hit(s)).count())
        .sum()
}

/// How many of `set`'s sun rays are blocked, traced one at a time (in parallel chunks).
fn suns_blocked(accel: &Accel, set: &[Secondary]) -> usize {
    let blocked = |s: &Secondary| s.sun.is_some_and(|r| accel.occluded_skip(&r, s.skip));
    set.par_chunks(1024)
        .map(|ch| ch.iter().filter(|s| blocked(s)).count())
        .sum()
}

/// The sun rays of `ch` (of the hits that have one), eight at a time through
/// [`Accel::occluded_many`], as the renderer traces a pixel's samples' shadow rays: how
/// many are blocked; counted into `stats` when given.
fn sun_many(accel: &Accel, ch: &[Secondary], stats: Option<&TraversalStats>) -> usize {
    let mut rays = Vec::with_capacity(Accel::MANY);
    let mut skips = Vec::with_capacity(Accel::MANY);
    let mut out = [false; Accel::MANY];
    let mut blocked = 0;
    let mut flush = |rays: &mut Vec<Ray>, skips: &mut Vec<PrimRef>| {
        let n = rays.len();
        blocked += match stats {
            Some(st) => accel.occluded_many_counted(rays, skips, st),
            None => {
                accel.occluded_many(rays, skips, &mut out[..n]);
                out[..n].iter().filter(|&&b| b).count()
            }
        };
        rays.clear();
        skips.clear();
    };
    for s in ch {
        if let Some(r) = s.sun {
            rays.push(r);
            skips.push(s.skip);
            if rays.len() == Accel::MANY {
                flush(&mut rays, &mut skips);
            }
        }
    }
    if !rays.is_empty() {
        flush(&mut rays, &mut skips);
    }
    blocked
}

/// Set `set`'s rays traced again on `accel` with the engine's counters on (in parallel
/// chunks, summed): nodes, packs, instances, mask decisions and exact lookups, in
/// [`Counts`]' order. The shuffled bounce rays are the bounce rays: the same counts.
/// `deeper`: the second vertices, whose rays `bounce2` and `sun2_one` are; `file`: the
/// `--read-rays` rays.
fn count_set(
    set: &str,
    accel: &Accel,
    spp: u32,
    camera: &[Ray],
    secondary: &[Secondary],
    deeper: &[Secondary],
    file: &[Ray],
) -> [u64; 6] {
    let sum = |a, b| add_stats(a, b);
    let (set, camera) = match set {
        "file" => ("camera_one", file),
        _ => (set, camera),
    };
    let (set, secondary) = match set {
        "bounce2" => ("bounce", deeper),
        "sun2_one" => ("sun_one", deeper),
        _ => (set, secondary),
    };
    match set {
        "camera" => camera
            .par_chunks(spp as usize * 16)
            .map(|ch| {
                let st = TraversalStats::default();
                for g in ch.chunks(Accel::MANY) {
                    accel.intersect_many_counted(g, &st);
                }
                stats_array(&st)
            })
            .reduce(|| [0; 6], sum),
        "camera_one" => camera
            .par_chunks(1024)
            .map(|ch| {
                let st = TraversalStats::default();
                for r in ch {
                    accel.intersect_counted(r, PrimRef::NONE, &st);
                }
                stats_array(&st)
            })
            .reduce(|| [0; 6], sum),
        "sun" => secondary
            .par_chunks(1024)
            .map(|ch| {
                let st = TraversalStats::default();
                sun_many(accel, ch, Some(&st));
                stats_array(&st)
            })
            .reduce(|| [0; 6], sum),
        _ => secondary
            .par_chunks(1024)
            .map(|ch| {
                let st = TraversalStats::default();
                for s in ch {
                    match (set, s.sun) {
                        ("sun_one", Some(r)) => {
                            accel.occluded_counted(&r, s.skip, &st);
                        }
                        ("sun_one", None) => {}
                        _ => {
                            accel.intersect_counted(&s.bounce, s.skip, &st);
                        }
                    }
                }
                stats_array(&st)
            })
            .reduce(|| [0; 6], sum),
    }
}

/// The camera rays (pixel after pixel, `spp` each) and, for each that hits a surface, its
/// bounce and sun rays.
fn make_sets(scene: &Scene, accel: &Accel, spp: u32) -> Result<Sets> {
    let camera = CameraModel::new(&scene.camera, &scene.film)?;
    let (w, h) = (scene.film.width, scene.film.height);
    let n = u64::from(w) * u64::from(h) * u64::from(spp);
    let rays: Vec<Ray> = (0..n)
        .into_par_iter()
        .map(|i| {
            let px = i / u64::from(spp);
            let (x, y) = ((px % u64::from(w)) as f32, (px / u64::from(w)) as f32);
            let film = Vec2::new(x + unit(i, 0), y + unit(i, 1));
            let (origin, dir) = camera.generate_ray(film, Vec2::splat(0.5));
            Ray {
                origin,
                dir,
                tmax: f32::INFINITY,
            }
        })
        .collect();
    // The first sun, its disc sampled as the renderer samples it (a delta sun: its axis).
    let sun = scene.lights.iter().find_map(|l| match l {
        Light::Sun {
            direction,
            angular_diameter_deg,
            ..
        } => SunLight::new(*direction, Vec3::ONE, *angular_diameter_deg),
        _ => None,
    });
    let from_camera: Vec<(Ray, PrimRef)> = rays.iter().map(|r| (*r, PrimRef::NONE)).collect();
    let secondary = vertices(accel, sun.as_ref(), &from_camera, 0);
    let bounces: Vec<(Ray, PrimRef)> = secondary.iter().map(|s| (s.bounce, s.skip)).collect();
    let deeper = vertices(accel, sun.as_ref(), &bounces, 1);
    Ok((rays, secondary, deeper))
}

/// The vertices where `rays` (each leaving its primitive) hit a surface, in order, each
/// with its bounce ray and its sun ray toward `sun` (where there is one). `salt` picks the
/// numbers (0 at the camera's hits, 1 at the next vertices').
fn vertices(
    accel: &Accel,
    sun: Option<&SunLight>,
    rays: &[(Ray, PrimRef)],
    salt: u64,
) -> Vec<Secondary> {
    rays.par_iter()
        .enumerate()
        .filter_map(|(i, (ray, skip))| {
            let hit = accel.intersect_skip(ray, *skip)?;
            let HitKind::Triangle { prim, bary } = hit.kind else {
                return None;
            };
            let (p, info) = accel.surface(prim, bary);
            let n = info.n;
            // Salt 0 keeps the indices the first vertices always had.
            let i = i as u64 + (salt << 40);
            // What a diffuse leaf's BSDF samples: cosine-weighted, either side.
            let mut local = cosine_hemisphere(Vec2::new(unit(i, 2), unit(i, 3)));
            if unit(i, 4) >= 0.5 {
                local.z = -local.z;
            }
            let dir = Frame::from_normal(n).to_world(local).normalize();
            let bounce = Ray {
                origin: spawn_origin(p, n, dir),
                dir,
                tmax: f32::INFINITY,
            };
            let sun = sun.map(|sun| {
                let s = sun.sample(Vec2::new(unit(i, 5), unit(i, 6))).wi;
                Ray {
                    origin: spawn_origin(p, n, s),
                    dir: s,
                    tmax: f32::INFINITY,
                }
            });
            Some(Secondary {
                bounce,
                sun,
                skip: prim,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A camera above a quad (the floor, facing up) that fills its view, under a sun.
    const QUAD_UNDER_SUN: &str = r#"
[camera]
position = [0, 2, 0]
look_at = [0, 0, 0]
up = [0, 0, -1]
fov = 40.0

[film]
width = 8
height = 6
spp = 4

[[light]]
type = "sun"
direction = [0.3, 1, 0.2]
irradiance = [1, 1, 1]

[[material]]
name = "m"
type = "diffuse"
reflectance = [0.5, 0.5, 0.5]

[[object]]
type = "quad"
material = "m"
corner = [-10, 0, 10]
edge_u = [20, 0, 0]
edge_v = [0, 0, -20]
"#;

    /// A camera above a quad that fills its view, under a sun: every camera ray makes a
    /// bounce ray from the quad (on both sides, about half each, cosine-weighted) and an
    /// unblocked sun ray; the sets are the same from run to run.
    #[test]
    fn sets_of_a_quad_under_the_sun() {
        let toml = QUAD_UNDER_SUN;
        let scene = lamina_scene::parse_scene(toml, std::path::Path::new("quad.toml")).unwrap();
        let accel = Accel::build_on(&scene, Backend::Lamina).unwrap();
        let (camera, secondary, deeper) = make_sets(&scene, &accel, 4).unwrap();
        assert!(
            deeper.is_empty(),
            "nothing above the quad for a bounce ray to hit"
        );
        assert_eq!(camera.len(), 8 * 6 * 4);
        assert_eq!(
            secondary.len(),
            camera.len(),
            "every camera ray hits the quad"
        );
        let mut up = 0;
        let mut cos = 0.0;
        for s in &secondary {
            assert!(s.bounce.origin.y.abs() < 1e-3, "{:?}", s.bounce);
            assert!((s.bounce.dir.length() - 1.0).abs() < 1e-5);
            up += usize::from(s.bounce.dir.y > 0.0);
            cos += s.bounce.dir.y.abs();
            let sun = s.sun.expect("a sun ray");
            assert!(!accel.occluded_skip(&sun, s.skip), "nothing above the quad");
            assert!(
                accel.intersect_skip(&s.bounce, s.skip).is_none(),
                "nothing else"
            );
        }
        let n = secondary.len();
        assert!(up > n / 4 && up < 3 * n / 4, "{up} of {n} up");
        // Cosine-weighted: the mean |cos| is 2/3.
        let mean = cos / n as f32;
        assert!((mean - 2.0 / 3.0).abs() < 0.08, "mean cosine {mean}");
        let (again, _, _) = make_sets(&scene, &accel, 4).unwrap();
        assert_eq!(again, camera);

        // The counts: the parallel chunks add up to one sequential run, every camera ray
        // tests at least the quad's pack, and a scene without mattes or instances has no
        // mask decisions and enters no instance.
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        let counted =
            |set| pool.install(|| count_set(set, &accel, 4, &camera, &secondary, &deeper, &[]));
        let one = TraversalStats::default();
        for r in &camera {
            accel.intersect_counted(r, PrimRef::NONE, &one);
        }
        assert_eq!(counted("camera_one"), stats_array(&one));
        let many = TraversalStats::default();
        for pixel in camera.chunks(4) {
            assert_eq!(accel.intersect_many_counted(pixel, &many), 4);
        }
        assert_eq!(counted("camera"), stats_array(&many));
        let bounce = TraversalStats::default();
        let sun = TraversalStats::default();
        for s in &secondary {
            accel.intersect_counted(&s.bounce, s.skip, &bounce);
            accel.occluded_counted(&s.sun.unwrap(), s.skip, &sun);
        }
        assert_eq!(counted("bounce"), stats_array(&bounce));
        assert_eq!(counted("bounce_shuffled"), stats_array(&bounce));
        assert_eq!(counted("sun_one"), stats_array(&sun));
        let many = TraversalStats::default();
        for ch in secondary.chunks(1024) {
            assert_eq!(
                sun_many(&accel, ch, Some(&many)),
                0,
                "nothing above the quad"
            );
        }
        assert_eq!(counted("sun"), stats_array(&many));
        for set in ["camera", "camera_one"] {
            let c = Counts::per_ray(counted(set), camera.len());
            assert!(c.packs >= 1.0, "{set}: {c:?}");
            assert_eq!(
                (
                    c.instances,
                    c.mask_opaque,
                    c.mask_transparent,
                    c.alpha_lookups
                ),
                (0.0, 0.0, 0.0, 0.0),
                "{set}"
            );
        }
    }

    /// Between a floor and a ceiling under a sun: the bounce rays that leave the floor
    /// upward hit the ceiling, whose vertices make the second-vertex sets (a bounce ray
    /// from the ceiling's underside, a sun ray through it); their counts are the sets'
    /// sequential ones.
    #[test]
    fn second_vertices_between_a_floor_and_a_ceiling() {
        // The floor's camera brought down under a ceiling wider than the floor (no upward
        // bounce ray passes its edge).
        let toml = QUAD_UNDER_SUN.replace("position = [0, 2, 0]", "position = [0, 0.5, 0]")
            + r#"
[[object]]
type = "quad"
material = "m"
corner = [-50, 1, 50]
edge_u = [100, 0, 0]
edge_v = [0, 0, -100]
"#;
        let scene = lamina_scene::parse_scene(&toml, std::path::Path::new("two.toml")).unwrap();
        let accel = Accel::build_on(&scene, Backend::Lamina).unwrap();
        let (camera, secondary, deeper) = make_sets(&scene, &accel, 4).unwrap();
        assert_eq!(
            secondary.len(),
            camera.len(),
            "every camera ray hits the floor"
        );
        let up = secondary.iter().filter(|s| s.bounce.dir.y > 0.0).count();
        assert_eq!(
            deeper.len(),
            up,
            "the upward bounce rays, and only they, hit the ceiling"
        );
        assert!(up > camera.len() / 4 && up < 3 * camera.len() / 4, "{up}");
        for s in &deeper {
            assert!((s.bounce.origin.y - 1.0).abs() < 1e-3, "{:?}", s.bounce);
            let sun = s.sun.expect("a sun ray");
            assert!(
                !accel.occluded_skip(&sun, s.skip),
                "nothing above the ceiling"
            );
        }
        // The floor's sun rays are blocked by the ceiling.
        assert!(
            secondary
                .iter()
                .all(|s| accel.occluded_skip(&s.sun.unwrap(), s.skip))
        );
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        let counted =
            |set| pool.install(|| count_set(set, &accel, 4, &camera, &secondary, &deeper, &[]));
        let (bounce, sun) = (TraversalStats::default(), TraversalStats::default());
        for s in &deeper {
            accel.intersect_counted(&s.bounce, s.skip, &bounce);
            accel.occluded_counted(&s.sun.unwrap(), s.skip, &sun);
        }
        assert_eq!(counted("bounce2"), stats_array(&bounce));
        assert_eq!(counted("sun2_one"), stats_array(&sun));
        assert!(Counts::per_ray(counted("bounce2"), deeper.len()).packs >= 1.0);
        let pool_hits = pool.install(|| bounce_hits(&accel, &deeper));
        let hits = deeper
            .iter()
            .filter(|s| accel.intersect_skip(&s.bounce, s.skip).is_some())
            .count();
        assert_eq!(pool_hits, hits);
        assert_eq!(pool.install(|| suns_blocked(&accel, &deeper)), 0);
    }

    #[test]
    fn ray_files_round_trip_and_bad_ones_are_named() {
        let rays = [
            Ray {
                origin: Vec3::new(1.0, -2.5, 0.25),
                dir: Vec3::new(-0.0, 0.6, -0.8),
                tmax: f32::INFINITY,
            },
            Ray {
                origin: Vec3::ZERO,
                dir: Vec3::X,
                tmax: 3.5,
            },
        ];
        let bytes = ray_file_bytes(rays.iter());
        assert_eq!(bytes.len(), 64);
        // The layout bench/embree_rays.c reads: origin, tnear 0, direction, tfar.
        let word = |k: usize| f32::from_le_bytes(bytes[4 * k..4 * k + 4].try_into().unwrap());
        assert_eq!([word(0), word(1), word(2), word(3)], [1.0, -2.5, 0.25, 0.0]);
        assert_eq!(word(4).to_bits(), (-0.0f32).to_bits());
        assert_eq!(word(15), 3.5);
        let dir = std::env::temp_dir().join(format!("scene_rays_files_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let good = dir.join("good.f32");
        std::fs::write(&good, &bytes).unwrap();
        let back = read_ray_file(&good).unwrap();
        assert_eq!(back.len(), 2);
        for (a, b) in back.iter().zip(&rays) {
            assert_eq!(a.origin, b.origin);
            assert_eq!(
                a.dir.to_array().map(f32::to_bits),
                b.dir.to_array().map(f32::to_bits)
            );
            assert_eq!(a.tmax, b.tmax);
        }
        let short = dir.join("short.f32");
        std::fs::write(&short, &bytes[..40]).unwrap();
        let e = read_ray_file(&short).unwrap_err().to_string();
        assert!(e.contains("short.f32") && e.contains("40 bytes"), "{e}");
        let mut zero = bytes.clone();
        zero[16..28].fill(0); // ray 0's direction
        let bad = dir.join("zero.f32");
        std::fs::write(&bad, &zero).unwrap();
        let e = read_ray_file(&bad).unwrap_err().to_string();
        assert!(e.contains("zero.f32") && e.contains("ray 0"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
