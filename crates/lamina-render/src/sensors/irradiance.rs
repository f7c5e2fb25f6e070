//! The irradiance sensor: `E↓` and `E↑` (W m⁻²) on the horizontal plane `y = height`, per
//! cell of a grid. At a point spread uniformly over the cell, each hemisphere's irradiance
//! `E = ∫ L cos θ dω` is estimated as at a white Lambertian receiver: next-event estimation
//! of the sun and sky (shadow rays; to every light, or to one with `light_sampling = "one"`,
//! as at a path vertex) plus a cosine-distributed ray traced by the path tracer, the two
//! combined by the power heuristic.

use super::{BATCHES, Estimate, Run, area_or_cell, depths};
use crate::accel::{PrimRef, Ray};
use crate::error::RenderError;
use crate::integrators::path;
use crate::lights::power_heuristic;
use crate::sampler::PixelSampler;
use glam::{DVec3, Vec2, Vec3};
use lamina_core::radiometry::Rect;
use rayon::prelude::*;

/// An irradiance sensor's result: per grid cell (row-major, x fastest) its rectangle and
/// the down- and upwelling irradiance.
#[derive(Clone, Debug)]
pub struct IrradianceResult {
    /// Cells.
    pub cells: Vec<IrradianceCell>,
}

/// One grid cell of an irradiance sensor.
#[derive(Clone, Copy, Debug)]
pub struct IrradianceCell {
    /// Where.
    pub rect: Rect,
    /// Downwelling irradiance (light going down through the plane), W m⁻².
    pub down: Estimate,
    /// Upwelling irradiance, W m⁻².
    pub up: Estimate,
}

/// Cosine-distributed direction about `+z` (local), from `u`.
fn cosine_hemisphere(u: Vec2) -> Vec3 {
    let r = u.x.sqrt();
    let phi = 2.0 * std::f32::consts::PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u.x).max(0.0).sqrt())
}

/// The irradiance estimate at `p` from the hemisphere around `n` (`±y`).
fn irradiance_at(run: &Run, p: Vec3, n: Vec3, s: &mut PixelSampler, rays: &mut u64) -> Vec3 {
    let ctx = run.ctx;
    let (max_depth, rr_depth) = depths(ctx.scene);
    let mut e = Vec3::ZERO;
    // The lights as a path vertex picks them: the traced ray's MIS weights (in
    // `path::radiance_sampled`) assume these densities, the pick probability included.
    let (_, picked, pick) = ctx.nee_lights(s);
    for light in picked {
        let u = s.next_2d_if(light.uses_sample());
        let Some(mut ls) = light.sample(p, u) else {
            continue;
        };
        ls.pdf *= pick;
        let cos = ls.wi.dot(n);
        if !(ls.pdf > 0.0) || cos <= 0.0 || ls.li == Vec3::ZERO {
            continue;
        }
        if !ctx.unoccluded(p, n, PrimRef::NONE, &ls, rays) {
            continue;
        }
        let w = if ls.delta {
            1.0
        } else {
            power_heuristic(ls.pdf, cos * std::f32::consts::FRAC_1_PI)
        };
        e += ls.li * (cos * w / ls.pdf);
    }
    let d = cosine_hemisphere(s.next_2d());
    let dir = Vec3::new(d.x, d.z * n.y, d.y);
    let pdf = d.z * std::f32::consts::FRAC_1_PI;
    if pdf > 0.0 {
        let ray = Ray {
            origin: crate::accel::spawn_origin(p, n, dir),
            dir,
            tmax: f32::INFINITY,
        };
        let l = path::radiance_sampled(ctx, ray, pdf, s, max_depth, rr_depth, rays);
        e += l * std::f32::consts::PI;
    }
    e
}

/// Measures the grid over `area` (default: the periodic cell) at `height`.
pub(crate) fn measure(
    run: &mut Run,
    height: f32,
    area: Option<Rect>,
    grid: [u32; 2],
) -> Result<(IrradianceResult, u64), RenderError> {
    let area = area_or_cell(area, run.ctx)?;
    let cells = (grid[0] * grid[1]) as usize;
    let per_batch = run.samples.div_ceil(BATCHES);
    run.total = cells as u64 * BATCHES as u64;
    let run = &*run;
    let size = area.size() / Vec2::new(grid[0] as f32, grid[1] as f32);
    let rect = |k: usize| {
        let (i, j) = ((k as u32 % grid[0]) as f32, (k as u32 / grid[0]) as f32);
        let min = area.min + size * Vec2::new(i, j);
        Rect {
            min,
            max: min + size,
        }
    };
    let jobs: Vec<(usize, u32)> = (0..cells)
        .flat_map(|k| (0..BATCHES).map(move |b| (k, b)))
        .collect();
    let sums: Vec<(DVec3, DVec3, u64)> = jobs
        .par_iter()
        // One job each, for idle threads to take (see `render.rs`'s tiles).
        .with_max_len(1)
        .map(|&(k, b)| {
            if run.cancelled() {
                return (DVec3::ZERO, DVec3::ZERO, 0);
            }
            let r = rect(k);
            let (mut down, mut up, mut rays) = (DVec3::ZERO, DVec3::ZERO, 0u64);
            for i in 0..per_batch {
                let mut s = PixelSampler::new(run.seed, k as u32, b, i);
                let u = s.next_2d();
                let p = Vec3::new(r.min.x + u.x * size.x, height, r.min.y + u.y * size.y);
                let d = irradiance_at(run, p, Vec3::Y, &mut s, &mut rays);
                let w = irradiance_at(run, p, -Vec3::Y, &mut s, &mut rays);
                if d.is_finite() && w.is_finite() {
                    down += d.as_dvec3();
                    up += w.as_dvec3();
                }
            }
            run.advance(1);
            (down, up, rays)
        })
        .collect();
    let counts = vec![per_batch as f64; BATCHES as usize];
    let rays = sums.iter().map(|s| s.2).sum();
    let cells = sums
        .chunks(BATCHES as usize)
        .enumerate()
        .map(|(k, c)| {
            let d: Vec<DVec3> = c.iter().map(|x| x.0).collect();
            let u: Vec<DVec3> = c.iter().map(|x| x.1).collect();
            IrradianceCell {
                rect: rect(k),
                down: Estimate::from_batches(&d, &counts),
                up: Estimate::from_batches(&u, &counts),
            }
        })
        .collect();
    Ok((IrradianceResult { cells }, rays))
}
