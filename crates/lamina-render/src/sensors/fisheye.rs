//! The fisheye sensor: an image of the hemisphere above or below a point, and the gap
//! fraction (the share of lines of sight that meet no surface) per 5° zenith ring.
//!
//! Pixel `(x, y)` of an `N × N` image maps to `(px, py) ∈ [-1, 1]²` (right, down); the
//! hemisphere is the inscribed circle `r = √(px² + py²) ≤ 1`, zenith angle `θ` from the
//! projection's `r(θ)`. North (`-z`) is at the top; looking up, east (`+x`) is on the
//! left (as a camera on the ground pointed at the sky sees it), looking down on the right
//! (a map). Pixels outside the circle are black.

use super::{BATCHES, Run, depths};
use crate::accel::Ray;
use crate::error::RenderError;
use crate::integrators::path;
use crate::sampler::PixelSampler;
use glam::{DVec3, Vec3};
use lamina_core::radiometry::FisheyeProjection;
use lamina_image::Image;
use rayon::prelude::*;

/// Width of a gap-fraction ring (degrees).
pub const RING_DEG: f32 = 5.0;

/// A fisheye sensor's result.
#[derive(Clone, Debug)]
pub struct FisheyeResult {
    /// The image (linear radiance, W m⁻² sr⁻¹).
    pub image: Image,
    /// Per ring `[5k, 5k + 5)` degrees of zenith angle: the gap fraction and its standard
    /// error.
    pub gap: Vec<(f64, f64)>,
}

/// The unit direction of image point `(px, py)` (see the module doc), `None` outside the
/// circle.
pub fn direction(px: f32, py: f32, up: bool, projection: FisheyeProjection) -> Option<Vec3> {
    let r = (px * px + py * py).sqrt();
    if r > 1.0 {
        return None;
    }
    let theta = projection.theta(r);
    let (s, c) = theta.sin_cos();
    let (ex, ez) = if r > 0.0 {
        (px / r, py / r)
    } else {
        (0.0, 0.0)
    };
    Some(if up {
        Vec3::new(-s * ex, c, s * ez)
    } else {
        Vec3::new(s * ex, -c, s * ez)
    })
}

/// Renders the hemisphere seen from `position`.
pub(crate) fn measure(
    run: &mut Run,
    position: Vec3,
    up: bool,
    projection: FisheyeProjection,
    resolution: u32,
) -> Result<(FisheyeResult, u64), RenderError> {
    let ctx = run.ctx;
    let (max_depth, rr_depth) = depths(ctx.scene);
    let n = resolution;
    let spp = run.samples.max(1);
    run.total = n as u64;
    let rings = (90.0 / RING_DEG) as usize;
    let run = &*run;
    // Per row: pixels, and per ring and batch (misses, rays) for the gap fraction.
    let rows: Vec<(Vec<Vec3>, Vec<[f64; 2]>, u64)> = (0..n)
        .into_par_iter()
        // One job each, for idle threads to take (see `render.rs`'s tiles).
        .with_max_len(1)
        .map(|y| {
            let mut px_out = vec![Vec3::ZERO; n as usize];
            let mut gap = vec![[0.0f64; 2]; rings * BATCHES as usize];
            let mut rays = 0u64;
            if run.cancelled() {
                return (px_out, gap, rays);
            }
            for x in 0..n {
                let mut sum = DVec3::ZERO;
                let mut count = 0u32;
                for i in 0..spp {
                    let mut s = PixelSampler::new(run.seed, x, y, i);
                    let j = s.next_2d();
                    let px = (x as f32 + j.x) / n as f32 * 2.0 - 1.0;
                    let py = (y as f32 + j.y) / n as f32 * 2.0 - 1.0;
                    let Some(dir) = direction(px, py, up, projection) else {
                        continue;
                    };
                    let ray = Ray {
                        origin: position,
                        dir,
                        tmax: f32::INFINITY,
                    };
                    let theta = dir.y.abs().clamp(0.0, 1.0).acos().to_degrees();
                    let ring = ((theta / RING_DEG) as usize).min(rings - 1);
                    let batch = (i % BATCHES) as usize;
                    let g = &mut gap[ring * BATCHES as usize + batch];
                    rays += 1;
                    if ctx.accel.intersect(&ray).is_none() {
                        g[0] += 1.0;
                    }
                    g[1] += 1.0;
                    let l = path::radiance(ctx, ray, &mut s, max_depth, rr_depth, &mut rays);
                    if l.is_finite() {
                        sum += l.as_dvec3();
                    }
                    count += 1;
                }
                // Pixels the circle's edge crosses average the samples inside it.
                if count > 0 {
                    px_out[x as usize] = (sum / spp as f64).as_vec3();
                }
            }
            run.advance(1);
            (px_out, gap, rays)
        })
        .collect();
    let mut pixels = Vec::with_capacity((n * n) as usize);
    let mut gap = vec![[0.0f64; 2]; rings * BATCHES as usize];
    let mut rays = 0;
    for (row, g, r) in rows {
        pixels.extend(row);
        for (a, b) in gap.iter_mut().zip(g) {
            a[0] += b[0];
            a[1] += b[1];
        }
        rays += r;
    }
    let gap = (0..rings)
        .map(|k| {
            let b = &gap[k * BATCHES as usize..(k + 1) * BATCHES as usize];
            let (miss, all): (f64, f64) =
                b.iter().fold((0.0, 0.0), |a, x| (a.0 + x[0], a.1 + x[1]));
            let value = if all > 0.0 { miss / all } else { 0.0 };
            let means = b
                .iter()
                .filter(|x| x[1] > 0.0)
                .map(|x| DVec3::splat(x[0] / x[1]));
            (value, super::spread(means).x)
        })
        .collect();
    Ok((
        FisheyeResult {
            image: Image {
                width: n,
                height: n,
                pixels,
            },
            gap,
        },
        rays,
    ))
}
