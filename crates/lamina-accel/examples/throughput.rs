//! Ray throughput of lamina-accel alone on random opaque cards, for a range of scene sizes
//! (in cache to far out of it), one thread: `cargo run --release -p lamina-accel --example
//! throughput [-- N...]`. For the full comparison with Embree, see lamina-bench's `rays`.

use glam::Vec3;
use lamina_accel::{
    Accel, BuildOptions, Geometry, Kernel, Prim, PrimRef, Ray, SceneDesc, TraversalStats,
};
use std::time::Instant;

fn rng(seed: u64) -> impl FnMut() -> f32 {
    let mut s = seed;
    move || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 40) as f32 / (1u64 << 24) as f32
    }
}

fn unit(r: &mut impl FnMut() -> f32) -> Vec3 {
    let z = 2.0 * r() - 1.0;
    let phi = 6.2831855 * r();
    let s = (1.0 - z * z).max(0.0).sqrt();
    Vec3::new(s * phi.cos(), s * phi.sin(), z)
}

fn main() {
    let sizes: Vec<usize> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let sizes = if sizes.is_empty() {
        vec![1000, 10_000, 100_000]
    } else {
        sizes
    };
    for n in sizes {
        let mut r = rng(7);
        let side = 10.0 * (n as f32 / 100_000.0).cbrt();
        let prims = (0..n)
            .map(|_| {
                let c = Vec3::new(r(), r(), r()) * side;
                let (a, b) = (unit(&mut r) * 0.1, unit(&mut r) * 0.05);
                Prim::parallelogram(c, a, b.cross(a).normalize() * 0.05)
            })
            .collect();
        let desc = SceneDesc {
            world: Geometry { prims },
            ..Default::default()
        };
        let rays: Vec<Ray> = (0..1 << 18)
            .map(|_| Ray {
                origin: Vec3::new(r(), r(), r()) * side,
                dir: unit(&mut r),
                tmax: f32::INFINITY,
            })
            .collect();
        #[cfg(feature = "embree")]
        {
            let t = Instant::now();
            let e = lamina_accel::embree::EmbreeAccel::build(&desc).unwrap();
            let build = t.elapsed().as_secs_f64();
            if std::env::var_os("LAMINA_BUILD_ONLY").is_some() {
                println!(
                    "{n:7} cards Embree: build {build:.3} s, {:.1} MB",
                    e.memory_bytes().unwrap_or(0) as f64 / 1e6
                );
                drop(e);
                // Embree's TBB workers spin for a while after the build: on a 2-core
                // machine they would slow the next build down. Let them go idle.
                std::thread::sleep(std::time::Duration::from_millis(300));
            } else {
                let f = |_: u32, _| true;
                let (mut best, mut best_any) = (f64::INFINITY, f64::INFINITY);
                let mut hits = 0;
                for _ in 0..3 {
                    let t = Instant::now();
                    hits = rays
                        .iter()
                        .filter(|ray| e.intersect(ray, PrimRef::NONE, &f).is_some())
                        .count();
                    best = best.min(t.elapsed().as_secs_f64());
                    let t = Instant::now();
                    std::hint::black_box(
                        rays.iter()
                            .filter(|ray| e.occluded(ray, PrimRef::NONE, &f))
                            .count(),
                    );
                    best_any = best_any.min(t.elapsed().as_secs_f64());
                }
                println!(
                    "{n:7} cards Embree: build {build:.3} s, closest {:.2} Mrays/s, any {:.2} Mrays/s ({:.0} % hit), {:.1} MB",
                    rays.len() as f64 / best / 1e6,
                    rays.len() as f64 / best_any / 1e6,
                    100.0 * hits as f64 / rays.len() as f64,
                    e.memory_bytes().unwrap_or(0) as f64 / 1e6
                );
            }
        }
        for kernel in [Kernel::Avx2, Kernel::Sse, Kernel::Scalar] {
            if !kernel.available() {
                continue;
            }
            let t = Instant::now();
            let a = Accel::build_with(
                &desc,
                BuildOptions {
                    kernel,
                    // LAMINA_TRAV: the SAH's node-visit cost (for tuning).
                    trav_cost: std::env::var("LAMINA_TRAV")
                        .ok()
                        .and_then(|s| s.parse().ok())
                        .unwrap_or(1.0),
                    ..Default::default()
                },
            )
            .unwrap();
            let build = t.elapsed().as_secs_f64();
            if std::env::var_os("LAMINA_BUILD_ONLY").is_some() {
                println!(
                    "{n:7} cards {kernel:?}: build {build:.3} s, {:.1} MB",
                    a.memory().total() as f64 / 1e6
                );
                continue;
            }
            let f = |_: u32, _| true;
            let mut best = f64::INFINITY;
            let mut hits = 0;
            for _ in 0..3 {
                let t = Instant::now();
                hits = rays
                    .iter()
                    .filter(|ray| a.intersect(ray, PrimRef::NONE, &f).is_some())
                    .count();
                best = best.min(t.elapsed().as_secs_f64());
            }
            let mut best_any = f64::INFINITY;
            for _ in 0..3 {
                let t = Instant::now();
                std::hint::black_box(
                    rays.iter()
                        .filter(|ray| a.occluded(ray, PrimRef::NONE, &f))
                        .count(),
                );
                best_any = best_any.min(t.elapsed().as_secs_f64());
            }
            let st = TraversalStats::default();
            for ray in &rays[..1 << 14] {
                a.intersect_counted(ray, PrimRef::NONE, &f, &st);
            }
            let sa = TraversalStats::default();
            for ray in &rays[..1 << 14] {
                a.occluded_counted(ray, PrimRef::NONE, &f, &sa);
            }
            let k = (1 << 14) as f64;
            println!(
                "    any hit: nodes/ray {:.1}, packs/ray {:.1}",
                sa.nodes.get() as f64 / k,
                sa.packs.get() as f64 / k
            );
            println!(
                "{n:7} cards {kernel:?}: build {build:.3} s, SAH {:.1}, closest {:.2} Mrays/s, any {:.2} Mrays/s ({:.0} % hit), nodes/ray {:.1}, packs/ray {:.1}, {:.1} MB",
                a.world_sah_cost(),
                rays.len() as f64 / best / 1e6,
                rays.len() as f64 / best_any / 1e6,
                100.0 * hits as f64 / rays.len() as f64,
                st.nodes.get() as f64 / k,
                st.packs.get() as f64 / k,
                a.memory().total() as f64 / 1e6
            );
        }
    }
}
