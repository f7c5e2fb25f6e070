//! Radiometric sensors (`[[sensor]]`): the measurements a scene asks for besides its
//! picture, each traced through the same scene, lights and path tracer as the image.
//!
//! * [`brf`]: reflectance factor per view direction (distant sensor over an area).
//! * [`irradiance`]: up- and downwelling irradiance on a horizontal plane.
//! * [`absorbed`]: light tracing from the sun and sky: absorbed power per material and
//!   object, albedo, transmission to the ground.
//! * [`fisheye`]: hemispherical images and gap fractions.
//!
//! **Errors.** Every estimate comes in `B = 32` batches, each from its own scramble of the
//! Sobol sequence (randomised quasi-Monte Carlo): the value is the mean over all samples, its
//! standard error the spread of the batch means over `√B`. **Determinism**: batch `b` of
//! item `k` of sensor `s` draws from `PixelSampler(seed ⊕ s, k, b, i)`, and batches are
//! summed in order, so the results do not depend on the thread count.
//!
//! Values are per film channel (linear Rec.709 R, G, B; or three spectral bands of a band
//! render, see [`crate::bands`]).

pub mod absorbed;
pub mod brf;
pub mod fisheye;
pub mod irradiance;
mod output;

pub use output::{channel_names, csv_files, csv_files_bands, gather};

use crate::error::RenderError;
use crate::integrators::SceneContext;
use crate::lights::AnyLight;
use crate::sampler::{fold_seed, hash_combine, sobol_2d};
use glam::{DVec3, Vec3};
use lamina_core::radiometry::{Rect, Sensor, SensorKind};
use lamina_core::{Integrator, Scene};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// Independent batches per estimate (their spread gives the standard error).
pub const BATCHES: u32 = 32;

/// Progress callback: sensor index, its name, fraction of its work done.
pub type SensorProgress = Arc<dyn Fn(usize, &str, f32) + Send + Sync>;

/// How to run the sensors.
#[derive(Clone, Default)]
pub struct MeasureOptions {
    /// Seed of all random numbers.
    pub seed: u64,
    /// Worker threads; `None` uses all cores.
    pub threads: Option<usize>,
    /// Multiplies every sensor's sample count (e.g. 0.1 for a quick look); `None` = 1.
    pub sample_scale: Option<f64>,
    /// Set to `true` to stop: [`measure`] then returns [`RenderError::Cancelled`].
    pub cancel: Option<Arc<AtomicBool>>,
    /// Called as work completes: sensor index, its name, fraction of its work done.
    pub progress: Option<SensorProgress>,
    /// The ray-casting engine (see [`crate::RenderOptions::accel`]).
    pub accel: crate::accel::Backend,
}

/// One sensor's result.
#[derive(Clone, Debug)]
pub struct SensorOutput {
    /// The sensor as the scene gives it (files, channel).
    pub sensor: Sensor,
    /// What it measured.
    pub measurement: Measurement,
    /// Rays traced.
    pub rays: u64,
    /// Wall-clock time.
    pub elapsed: Duration,
}

/// What a sensor measured.
#[derive(Clone, Debug)]
pub enum Measurement {
    /// See [`brf::BrfResult`].
    Brf(brf::BrfResult),
    /// See [`irradiance::IrradianceResult`].
    Irradiance(irradiance::IrradianceResult),
    /// See [`absorbed::AbsorbedResult`].
    Absorbed(Box<absorbed::AbsorbedResult>),
    /// See [`fisheye::FisheyeResult`].
    Fisheye(fisheye::FisheyeResult),
}

/// A value per channel and its standard error.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Estimate {
    /// The mean.
    pub value: DVec3,
    /// Its standard error (one sigma).
    pub std: DVec3,
}

impl Estimate {
    /// From per-batch sums and sample counts: the overall mean and the spread of the batch
    /// means (`√(Σ(mᵦ − m̄)² / (B (B − 1)))`).
    pub fn from_batches(sums: &[DVec3], counts: &[f64]) -> Estimate {
        let total: f64 = counts.iter().sum();
        if total <= 0.0 {
            return Estimate::default();
        }
        let value = sums.iter().copied().sum::<DVec3>() / total;
        Estimate {
            value,
            std: spread(
                sums.iter()
                    .zip(counts)
                    .filter(|(_, c)| **c > 0.0)
                    .map(|(s, c)| *s / *c),
            ),
        }
    }

    /// This estimate times `k` (per channel).
    pub fn scaled(self, k: DVec3) -> Estimate {
        Estimate {
            value: self.value * k,
            std: self.std * k.abs(),
        }
    }
}

/// The standard error of the mean of `means` (per channel), from their spread.
pub(crate) fn spread(means: impl Iterator<Item = DVec3> + Clone) -> DVec3 {
    let n = means.clone().count() as f64;
    if n < 2.0 {
        return DVec3::ZERO;
    }
    let m = means.clone().sum::<DVec3>() / n;
    let var = means.map(|x| (x - m) * (x - m)).sum::<DVec3>() / (n - 1.0);
    (var / n).map(f64::sqrt)
}

/// The path tracer's depths for sensors: the scene's `path` integrator settings, or depth
/// 64 with Russian roulette from 3 under the `paper` renderer (which has no multiple
/// scattering to measure).
pub(crate) fn depths(scene: &Scene) -> (u32, u32) {
    match scene.integrator {
        Integrator::Path {
            max_depth,
            rr_depth,
            ..
        } => (max_depth, rr_depth),
        Integrator::Paper { .. } => (64, 3),
    }
}

/// The horizontal irradiance (W m⁻², per channel) the distant lights (sun, sky) bring onto
/// an unobstructed horizontal surface facing `+y`: exact for a delta sun, 2^16 quasi-random
/// samples for the sun's disc and the sky.
pub fn incident_irradiance(ctx: &SceneContext) -> DVec3 {
    let mut e = DVec3::ZERO;
    for (li, light) in ctx.lights.lights.iter().enumerate() {
        if !light.is_infinite() {
            continue;
        }
        let n = if matches!(light, AnyLight::Sun(s) if s.is_delta()) {
            1
        } else {
            1 << 16
        };
        let mut sum = DVec3::ZERO;
        for i in 0..n {
            let u = sobol_2d(i, hash_combine(0x5e45_0f11, li as u32));
            if let Some(ls) = light.sample(Vec3::ZERO, u)
                && ls.pdf > 0.0
                && ls.wi.y > 0.0
            {
                sum += (ls.li * (ls.wi.y / ls.pdf)).as_dvec3();
            }
        }
        e += sum / n as f64;
    }
    e
}

/// Where the geometry ends above: the top of the periodic domain's height range, or the
/// highest point of the scene (m).
pub(crate) fn scene_top(ctx: &SceneContext) -> f32 {
    match ctx.accel.periodic_heights() {
        Some((_, top)) => top,
        None => lamina_core::radiometry::height_range(ctx.scene).1 + 1e-3,
    }
}

/// The area a sensor covers: `area`, or the periodic cell.
pub(crate) fn area_or_cell(area: Option<Rect>, ctx: &SceneContext) -> Result<Rect, RenderError> {
    area.or_else(|| ctx.accel.periodic().map(|(min, max)| Rect { min, max }))
        .ok_or_else(|| {
            RenderError::InvalidScene(
                "the sensor has no area and the scene no periodic domain".into(),
            )
        })
}

/// The seed of sensor `index`.
pub(crate) fn sensor_seed(seed: u64, index: usize) -> u32 {
    hash_combine(fold_seed(seed), 0x9e37_79b9 ^ index as u32)
}

/// Shared state of one sensor run: cancellation and progress.
pub(crate) struct Run<'a> {
    pub(crate) ctx: &'a SceneContext<'a>,
    pub(crate) seed: u32,
    pub(crate) samples: u32,
    cancel: Option<Arc<AtomicBool>>,
    progress: Option<(usize, String, SensorProgress)>,
    done: std::sync::atomic::AtomicU64,
    pub(crate) total: u64,
}

impl Run<'_> {
    /// Whether the run was asked to stop.
    pub(crate) fn cancelled(&self) -> bool {
        self.cancel
            .as_ref()
            .is_some_and(|c| c.load(Ordering::Relaxed))
    }

    /// Counts `n` more units of work done.
    pub(crate) fn advance(&self, n: u64) {
        let done = self.done.fetch_add(n, Ordering::Relaxed) + n;
        if let Some((i, name, f)) = &self.progress {
            f(*i, name, (done as f64 / self.total.max(1) as f64) as f32);
        }
    }
}

/// Runs every sensor of `scene` (in file order). An error for a scene that cannot be
/// rendered, and [`RenderError::Cancelled`] when `opts.cancel` was set.
pub fn measure(scene: &Scene, opts: &MeasureOptions) -> Result<Vec<SensorOutput>, RenderError> {
    let threads = match opts.threads {
        Some(0) => {
            return Err(RenderError::InvalidOptions(
                "thread count must be at least 1".into(),
            ));
        }
        Some(n) => n,
        None => std::thread::available_parallelism().map_or(1, |n| n.get()),
    };
    if let Some(k) = opts.sample_scale
        && !(k > 0.0 && k.is_finite())
    {
        return Err(RenderError::InvalidOptions(format!(
            "sample scale {k} must be positive"
        )));
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|source| RenderError::ThreadPool { threads, source })?;
    crate::render::check_backend(opts.accel)?;
    let ctx = SceneContext::new(scene, opts.accel)?;
    let mut out = Vec::new();
    for (si, sensor) in scene.radiometry.sensors.iter().enumerate() {
        let start = Instant::now();
        let samples = ((sensor.samples as f64 * opts.sample_scale.unwrap_or(1.0)).round() as u64)
            .clamp(BATCHES as u64, u32::MAX as u64) as u32;
        let mut run = Run {
            ctx: &ctx,
            seed: sensor_seed(opts.seed, si),
            samples,
            cancel: opts.cancel.clone(),
            progress: opts.progress.clone().map(|f| (si, sensor.name.clone(), f)),
            done: Default::default(),
            total: 1,
        };
        let (measurement, rays) = pool.install(|| match &sensor.kind {
            SensorKind::Brf { target, sweeps, .. } => {
                brf::measure(&mut run, *target, sweeps).map(|(r, n)| (Measurement::Brf(r), n))
            }
            SensorKind::Irradiance {
                height, area, grid, ..
            } => irradiance::measure(&mut run, *height, *area, *grid)
                .map(|(r, n)| (Measurement::Irradiance(r), n)),
            SensorKind::Absorbed { area, ground, .. } => absorbed::measure(&mut run, *area, ground)
                .map(|(r, n)| (Measurement::Absorbed(Box::new(r)), n)),
            SensorKind::Fisheye {
                position,
                up,
                projection,
                resolution,
                ..
            } => fisheye::measure(&mut run, *position, *up, *projection, *resolution)
                .map(|(r, n)| (Measurement::Fisheye(r), n)),
        })?;
        if run.cancelled() {
            return Err(RenderError::Cancelled);
        }
        out.push(SensorOutput {
            sensor: sensor.clone(),
            measurement,
            rays,
            elapsed: start.elapsed(),
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests;
