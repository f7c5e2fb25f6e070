//! The BRF sensor: `BRF(v) = π L(v) / E`, with `L(v)` the radiance leaving the target area
//! toward the view direction `v` averaged over the area (a distant sensor: parallel rays
//! from points spread uniformly over the area at the top of the scene, traced toward
//! `-v` by the path tracer, wrapping around a periodic domain) and `E` the irradiance of
//! the sun and sky on a horizontal surface ([`super::incident_irradiance`]). Under sky
//! light this is the HDRF.

use super::{BATCHES, Estimate, Run, area_or_cell, depths, incident_irradiance, scene_top};
use crate::accel::Ray;
use crate::error::RenderError;
use crate::integrators::path;
use crate::lights::AnyLight;
use crate::sampler::PixelSampler;
use glam::{DVec3, Vec3};
use lamina_core::radiometry::{BrfSweep, Rect, direction_from_angles, sun_azimuth_deg};
use rayon::prelude::*;

/// A BRF sensor's result.
#[derive(Clone, Debug)]
pub struct BrfResult {
    /// Sun zenith angle (degrees): of the scene's first sun, 0 without one.
    pub sun_zenith: f32,
    /// The irradiance `E` on a horizontal surface (W m⁻², per channel).
    pub irradiance: DVec3,
    /// Per sweep, per direction, the BRF and its standard error.
    pub sweeps: Vec<Vec<Estimate>>,
}

/// The sun's zenith and azimuth (degrees): the scene's first sun, or straight overhead.
pub(crate) fn sun_angles(run: &Run) -> (f32, f32) {
    run.ctx
        .lights
        .lights
        .iter()
        .find_map(|l| match l {
            AnyLight::Sun(s) => {
                let d = s.direction();
                Some((d.y.clamp(-1.0, 1.0).acos().to_degrees(), sun_azimuth_deg(d)))
            }
            _ => None,
        })
        .unwrap_or((0.0, 0.0))
}

/// Measures every direction of `sweeps` over `target` (default: the periodic cell).
pub(crate) fn measure(
    run: &mut Run,
    target: Option<Rect>,
    sweeps: &[BrfSweep],
) -> Result<(BrfResult, u64), RenderError> {
    let ctx = run.ctx;
    let area = area_or_cell(target, ctx)?;
    let top = scene_top(ctx) + 1e-3;
    let (sza, saz) = sun_angles(run);
    let e = incident_irradiance(ctx);
    let (max_depth, rr_depth) = depths(ctx.scene);
    let dirs: Vec<Vec3> = sweeps
        .iter()
        .flat_map(|s| s.directions.iter())
        .map(|d| direction_from_angles(d.zenith, saz + d.relative_azimuth))
        .collect();
    let per_batch = run.samples.div_ceil(BATCHES);
    run.total = dirs.len() as u64 * BATCHES as u64;
    let run = &*run;
    let jobs: Vec<(usize, u32)> = (0..dirs.len())
        .flat_map(|k| (0..BATCHES).map(move |b| (k, b)))
        .collect();
    let sums: Vec<(DVec3, u64)> = jobs
        .par_iter()
        // One job each, for idle threads to take (see `render.rs`'s tiles).
        .with_max_len(1)
        .map(|&(k, b)| {
            if run.cancelled() {
                return (DVec3::ZERO, 0);
            }
            let v = dirs[k];
            let mut sum = DVec3::ZERO;
            let mut rays = 0u64;
            for i in 0..per_batch {
                let mut s = PixelSampler::new(run.seed, k as u32, b, i);
                let u = s.next_2d();
                let x = area.min.x + u.x * (area.max.x - area.min.x);
                let z = area.min.y + u.y * (area.max.y - area.min.y);
                let ray = Ray {
                    origin: Vec3::new(x, top, z),
                    dir: -v,
                    tmax: f32::INFINITY,
                };
                let l = path::radiance(ctx, ray, &mut s, max_depth, rr_depth, &mut rays);
                if l.is_finite() {
                    sum += l.as_dvec3();
                }
            }
            run.advance(1);
            (sum, rays)
        })
        .collect();
    let rays = sums.iter().map(|s| s.1).sum();
    let k = DVec3::new(
        ratio(std::f64::consts::PI, e.x),
        ratio(std::f64::consts::PI, e.y),
        ratio(std::f64::consts::PI, e.z),
    );
    let counts = vec![per_batch as f64; BATCHES as usize];
    let mut estimates = sums.chunks(BATCHES as usize).map(|c| {
        let s: Vec<DVec3> = c.iter().map(|x| x.0).collect();
        Estimate::from_batches(&s, &counts).scaled(k)
    });
    let out = sweeps
        .iter()
        .map(|s| estimates.by_ref().take(s.directions.len()).collect())
        .collect();
    Ok((
        BrfResult {
            sun_zenith: sza,
            irradiance: e,
            sweeps: out,
        },
        rays,
    ))
}

/// `a / b`, or 0 where `b` is 0 (a channel without light).
fn ratio(a: f64, b: f64) -> f64 {
    if b > 0.0 { a / b } else { 0.0 }
}
