//! Ray-throughput benchmark on a 200k-triangle leaf-card canopy (100k cards with a
//! leaf-shaped alpha matte in a 10 m box), on a pool of 2 threads (or `LAMINA_THREADS`).
//!
//! `cargo bench -p lamina-render --bench rays`
//!
//! Prints Mrays/s for camera rays (closest hit), random rays (closest hit, origins inside the
//! canopy, uniform directions) and the same random rays as shadow rays (any hit), plus a
//! full path-traced render of the scene (samples/s and rays/s, all ray kinds).
//!
//! `LAMINA_INSTANCES=1` instead compares the two-level BVH with flat geometry: the same
//! 100k cards (or `LAMINA_INSTANCES=<n>`) as (a) world meshes, (b) instances of one card
//! prototype, (c) instances of a curved leaf (4 x 8 quads), each with 512x512 camera rays
//! and 2^18 random rays (closest hit and any hit), plus the instance level's bytes per
//! instance.

#[path = "common/canopy.rs"]
mod canopy;

use glam::{Vec2, Vec3};
use lamina_leaf::sampling::uniform_sphere;
use lamina_render::accel::PrimRef;
use lamina_render::camera::CameraModel;
use lamina_render::sampler::sobol_2d;
use lamina_render::{Accel, Ray, RenderOptions, render};
use rayon::prelude::*;
use std::time::Instant;

/// CPU time of this process in seconds: the on-CPU nanoseconds of all its threads from
/// `/proc/self/task/*/schedstat` (Linux; falls back to the 10 ms ticks of
/// `/proc/self/stat`, 0 elsewhere). Lets the benchmark also report throughput per
/// CPU-second, which other processes competing for the cores do not dilute.
fn cpu_seconds() -> f64 {
    let ns: Option<u64> = std::fs::read_dir("/proc/self/task").ok().map(|tasks| {
        tasks
            .flatten()
            .filter_map(|t| std::fs::read_to_string(t.path().join("schedstat")).ok())
            .filter_map(|s| s.split_whitespace().next()?.parse::<u64>().ok())
            .sum()
    });
    if let Some(ns) = ns.filter(|&ns| ns > 0) {
        return ns as f64 * 1e-9;
    }
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else {
        return 0.0;
    };
    let Some(rest) = stat.rsplit(')').next() else {
        return 0.0;
    };
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks = |i: usize| f.get(i).and_then(|s| s.parse::<f64>().ok()).unwrap_or(0.0);
    // Fields 14 and 15 of the stat line (utime, stime), counted after the ')'.
    (ticks(11) + ticks(12)) / 100.0
}

/// Best of three runs (`LAMINA_REPEAT` to change): (Mrays/s wall clock, Mrays per
/// CPU-second, hits).
fn throughput(
    pool: &rayon::ThreadPool,
    rays: &[Ray],
    f: impl Fn(&Ray) -> bool + Sync,
) -> (f64, f64, usize) {
    let (mut best, mut best_cpu) = (f64::INFINITY, f64::INFINITY);
    let mut hits = 0;
    let repeat = std::env::var("LAMINA_REPEAT")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(3);
    for _ in 0..repeat {
        let (t, c) = (Instant::now(), cpu_seconds());
        hits = pool.install(|| {
            rays.par_chunks(1024)
                .map(|c| c.iter().filter(|r| f(r)).count())
                .sum::<usize>()
        });
        best = best.min(t.elapsed().as_secs_f64());
        best_cpu = best_cpu.min(cpu_seconds() - c);
    }
    let n = rays.len() as f64 / 1e6;
    (n / best, n / best_cpu.max(1e-6), hits)
}

fn main() {
    let threads: usize = std::env::var("LAMINA_THREADS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(2);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    if let Some(n) = std::env::var("LAMINA_INSTANCES")
        .ok()
        .and_then(|s| s.parse::<u32>().ok())
    {
        instances(&pool, if n <= 1 { 100_000 } else { n });
        return;
    }
    let (w, h) = (1024u32, 1024u32);
    let mut scene = canopy::canopy_scene(100_000, w, h, 1);
    let opaque = std::env::var_os("LAMINA_OPAQUE").is_some();
    if opaque {
        // Drop the leaf matte: every card is a full opaque rectangle.
        if let lamina_core::Material::DiffuseTransmission { alpha, .. } = &mut scene.materials[0] {
            *alpha = None;
        }
    }
    let merge = std::env::var_os("LAMINA_TRIANGLES").is_none();
    let t = Instant::now();
    let accel = Accel::build_with(&scene, merge).unwrap();
    println!(
        "scene: {} triangles as {} BVH primitives (cards as parallelograms){}, BVH build {:.2} s; {threads} threads",
        scene.meshes.iter().map(|m| m.indices.len()).sum::<usize>(),
        accel.primitive_count(),
        if opaque {
            " (opaque cards, LAMINA_OPAQUE)"
        } else {
            " (leaf matte)"
        },
        t.elapsed().as_secs_f64()
    );

    let cam = CameraModel::new(&scene.camera, &scene.film).unwrap();
    let camera_rays = camera_rays(&cam, w, h);
    let n_random = 1 << 20;
    let random_rays = random_rays(n_random);
    let report = |name: &str, (mr, mc, hits): (f64, f64, usize), n: usize| {
        println!(
            "{name:27} {mr:6.2} Mrays/s  ({mc:5.2} Mrays per CPU-second; {:.0} % hit)",
            100.0 * hits as f64 / n as f64
        );
    };
    let n = camera_rays.len();
    report(
        "camera rays (closest hit):",
        throughput(&pool, &camera_rays, |r| accel.intersect(r).is_some()),
        n,
    );
    if std::env::var_os("LAMINA_CAMERA_ONLY").is_some() {
        return;
    }
    if std::env::var_os("LAMINA_STATS").is_some() {
        let (sah, nodes, packs) = accel.world_tree();
        println!(
            "world tree: SAH cost {sah:.2}, {nodes} nodes, {packs} packs, kernel {:?}",
            accel.kernel()
        );
        for (name, rays, any) in [
            ("camera closest", &camera_rays, false),
            ("random closest", &random_rays, false),
            ("random any", &random_rays, true),
        ] {
            let st = lamina_accel::TraversalStats::default();
            let k = 65536.min(rays.len());
            for r in &rays[..k] {
                if any {
                    accel.occluded_counted(r, PrimRef::NONE, &st);
                } else {
                    accel.intersect_counted(r, PrimRef::NONE, &st);
                }
            }
            let per = |c: &std::cell::Cell<u64>| c.get() as f64 / k as f64;
            let decided = st.mask_opaque.get() + st.mask_transparent.get();
            println!(
                "{name:16} nodes/ray {:.1} packs/ray {:.1} alpha candidates/ray {:.2} decided by masks {:.1} %",
                per(&st.nodes),
                per(&st.packs),
                (decided + st.alpha_lookups.get()) as f64 / k as f64,
                100.0 * decided as f64 / (decided + st.alpha_lookups.get()).max(1) as f64
            );
        }
    }
    let n = random_rays.len();
    report(
        "random rays (closest hit):",
        throughput(&pool, &random_rays, |r| accel.intersect(r).is_some()),
        n,
    );
    report(
        "random rays (any hit):",
        throughput(&pool, &random_rays, |r| accel.occluded(r)),
        n,
    );

    if std::env::var_os("LAMINA_SKIP_RENDER").is_some() {
        return;
    }
    let mut small = scene.clone();
    small.film.width = 256;
    small.film.height = 256;
    small.film.spp = 16;
    let out = render(
        &small,
        &RenderOptions {
            threads: Some(threads),
            ..Default::default()
        },
    )
    .unwrap();
    let s = out.stats;
    let secs = s.elapsed.as_secs_f64();
    println!(
        "path render 256x256 16 spp depth 8: {secs:.2} s (BVH build included), {:.3} Msamples/s, {:.2} Mrays/s",
        s.samples as f64 / secs / 1e6,
        s.rays as f64 / secs / 1e6
    );
}

/// The `LAMINA_INSTANCES` comparison: flat cards, card instances, curved-leaf instances.
fn instances(pool: &rayon::ThreadPool, n: u32) {
    let (w, h) = (512u32, 512u32);
    let flat = canopy::canopy_scene(n, w, h, 1);
    let cards = canopy::instanced_canopy_scene(n, w, h, canopy::card_mesh());
    let curved = canopy::instanced_canopy_scene(n, w, h, canopy::curved_leaf_mesh());
    let cam = CameraModel::new(&flat.camera, &flat.film).unwrap();
    let camera_rays = camera_rays(&cam, w, h);
    let random_rays = random_rays(1 << 18);
    println!("{n} leaves; Mrays/s wall clock (per CPU-second), best of LAMINA_REPEAT (3); hit %");
    for (name, scene) in [
        ("flat cards", &flat),
        ("card instances", &cards),
        ("curved instances", &curved),
    ] {
        let t = Instant::now();
        let accel = Accel::build(scene).unwrap();
        let build = t.elapsed().as_secs_f64();
        let cell = |(mr, mc, hits): (f64, f64, usize), n: usize| {
            format!(
                "{mr:5.3} ({mc:5.3}) {:3.0}%",
                100.0 * hits as f64 / n as f64
            )
        };
        let cam = cell(
            throughput(pool, &camera_rays, |r| accel.intersect(r).is_some()),
            camera_rays.len(),
        );
        let rc = cell(
            throughput(pool, &random_rays, |r| accel.intersect(r).is_some()),
            random_rays.len(),
        );
        let ra = cell(
            throughput(pool, &random_rays, |r| accel.occluded(r)),
            random_rays.len(),
        );
        println!(
            "{name:17} camera closest {cam} | random closest {rc} | random any {ra} | build {build:.1} s, {:.1} B/instance",
            accel.memory().bytes_per_instance()
        );
    }
}

/// One camera ray through the centre of each of the `w x h` pixels.
fn camera_rays(cam: &CameraModel, w: u32, h: u32) -> Vec<Ray> {
    (0..w * h)
        .map(|i| {
            let (origin, dir) = cam.generate_ray(
                Vec2::new((i % w) as f32 + 0.5, (i / w) as f32 + 0.5),
                Vec2::ZERO,
            );
            Ray {
                origin,
                dir,
                tmax: f32::INFINITY,
            }
        })
        .collect()
}

/// `n` rays from Sobol points in the canopy box in uniformly distributed directions.
fn random_rays(n: u32) -> Vec<Ray> {
    (0..n)
        .map(|i| {
            let a = sobol_2d(i, 11);
            let b = sobol_2d(i, 12);
            Ray {
                origin: Vec3::new(a.x * 10.0 - 5.0, a.y * 10.0, b.x * 10.0 - 5.0),
                dir: uniform_sphere(sobol_2d(i, 13)),
                tmax: f32::INFINITY,
            }
        })
        .collect()
}
