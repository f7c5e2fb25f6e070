//! Rendering: tiles over a dedicated thread pool, progressive passes, time limit and
//! cancellation, determinism.
//!
//! The image is cut into 32x32 tiles. Each *pass* adds a fixed number of samples to every
//! pixel (16 per pass, the last pass what remains; a *progressive* render, see
//! [`RenderOptions::progressive`], starts with passes of 1, 1, 2, 4 and 8), all tiles of the
//! pass in parallel. The final image is the mean of the samples of the *completed* passes,
//! so a time limit or a cancel flag stops the render at a pass boundary (the interrupted
//! pass is dropped) and still returns a valid image. The first pass always completes unless
//! cancelled.
//!
//! Sample `i` of pixel `(x, y)` draws all its numbers from a [`PixelSampler`] seeded by the
//! render seed, the pixel and `i`; a pixel's samples are added into its sum one after the
//! other in sample order (a pass's tile starts from the sums the previous pass left), so
//! the image is bit-identical for a seed whatever the thread count and the passes.
//!
//! **Parts of a render.** [`RenderOptions::samples`] renders only the sample indices
//! `[start, end)` of the full render's `spp` (the same passes, clipped to the range), and
//! [`RenderOptions::crop`] only a rectangle of pixels. A pixel's value depends on its own
//! samples only (the pixel filter is importance-sampled, see [`crate::film`], so no sample
//! lands in a neighbour), so a crop's pixels are bit-identical to the same pixels of the
//! whole image, and parts split by samples add up to the whole render: every sample's
//! radiance (f32) is added into an f64 per-pixel sum, which is exact while a pixel's
//! samples span less than about 2²⁹ in magnitude, so splitting the sum changes nothing
//! (and otherwise only the order of f64 additions: at most `spp · 2⁻⁵³` of the sum of the
//! samples' magnitudes, far below the f32 image's own rounding of `2⁻²⁴`). With
//! [`RenderOptions::keep_sums`] the output carries those f64 sums for an exact merge.

use crate::accel::{AccelMemory, Hit, Ray};
use crate::error::RenderError;
use crate::film::Accumulator;
use crate::integrators::wave::Wave;
use crate::integrators::{SceneContext, paper, path};
use crate::sampler::{PixelSampler, PixelStream, fold_seed};
use glam::{Vec2, Vec3};
use lamina_core::{Integrator, Scene, SpectralMode};
use rayon::prelude::*;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// Tile edge in pixels.
const TILE: u32 = 32;
/// Largest number of samples per pixel in one pass.
const MAX_PASS_SPP: u32 = 16;
/// Largest image rendered (pixels), to fail cleanly rather than run out of memory.
const MAX_PIXELS: u64 = 1 << 28;

/// How to render: overrides of the scene's settings and controls.
#[derive(Clone, Default)]
pub struct RenderOptions {
    /// Samples per pixel; overrides `film.spp` when set. Must be > 0.
    pub spp: Option<u32>,
    /// Worker threads; `None` uses all cores. Must be > 0.
    pub threads: Option<usize>,
    /// Seed of all random numbers: the same seed gives the same image.
    pub seed: u64,
    /// Time budget from the call: when it runs out, the pass in progress is abandoned (at its
    /// next tile) and the image holds the passes completed so far. The first pass always
    /// completes; with a time limit the render is always [progressive](Self::progressive),
    /// so that the first pass is 1 spp.
    pub time_limit: Option<Duration>,
    /// Set to `true` (e.g. on Ctrl-C) to stop: the pass in progress is abandoned at its next
    /// tile and the image holds the completed passes (possibly none: then it is black).
    pub cancel: Option<Arc<AtomicBool>>,
    /// Called after every completed pass.
    pub progress: Option<Arc<dyn Fn(Progress) + Send + Sync>>,
    /// Render only these sample indices `[start, end)` of the full render's samples per
    /// pixel (a part of a render split by samples); `None`: all of them. Must be a
    /// non-empty range with `end <= spp`.
    pub samples: Option<SampleRange>,
    /// Render only these pixels (a tile of a render split by regions); `None`: the whole
    /// film. The returned image is the crop's size.
    pub crop: Option<Crop>,
    /// Return the per-pixel f64 sums of the samples ([`RenderOutput::sums`]), for merging
    /// parts exactly.
    pub keep_sums: bool,
    /// The ray-casting engine: lamina-accel (the default) or, in builds with the `embree`
    /// feature, Embree 3 (an error otherwise). The images agree within noise.
    pub accel: crate::accel::Backend,
    /// Follow every path on its own ([`crate::integrators::path`]) even where the
    /// wavefront path tracer serves the scene (`integrators::wave`: pixel samples side by
    /// side). The image is the same bit for bit either way; this is for checks and
    /// timing.
    pub one_path_at_a_time: bool,
    /// Start with passes of 1, 1, 2, 4 and 8 samples per pixel before passes of 16, so that
    /// a cancel (or the progress of someone watching) has an image after one sample per
    /// pixel; otherwise every pass is 16 spp. Small passes cost more per sample (a wave
    /// then holds several pixels' samples: less coherent rays): 3-5 % of a 64-spp frame,
    /// all of a 16-spp one's first passes. The image is the same bit for bit either way
    /// (module docs). A time limit makes a render progressive whatever this says.
    pub progressive: bool,
}

/// Sample indices `[start, end)` of every pixel (of `0..spp` of the full render).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct SampleRange {
    /// First sample index.
    pub start: u32,
    /// One past the last sample index.
    pub end: u32,
}

impl SampleRange {
    /// Samples in the range.
    pub fn len(&self) -> u32 {
        self.end.saturating_sub(self.start)
    }

    /// Whether the range holds no sample.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Part `k` of `n` (0-based) of `spp` samples: `[⌊k·spp/n⌋, ⌊(k+1)·spp/n⌋)`, so the
    /// parts are disjoint, cover `0..spp` and differ in size by at most one sample.
    pub fn part(k: u32, n: u32, spp: u32) -> SampleRange {
        let at = |i: u32| (i as u64 * spp as u64 / n.max(1) as u64) as u32;
        SampleRange {
            start: at(k),
            end: at(k + 1),
        }
    }
}

/// A rectangle of pixels `[x0, x1) x [y0, y1)`, origin at the top-left corner of the image.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Crop {
    /// Left column (inclusive).
    pub x0: u32,
    /// Top row (inclusive).
    pub y0: u32,
    /// Right column (exclusive).
    pub x1: u32,
    /// Bottom row (exclusive).
    pub y1: u32,
}

impl Crop {
    /// The whole `width x height` image.
    pub fn full(width: u32, height: u32) -> Crop {
        Crop {
            x0: 0,
            y0: 0,
            x1: width,
            y1: height,
        }
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.x1.saturating_sub(self.x0)
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.y1.saturating_sub(self.y0)
    }

    /// Pixels in the rectangle.
    pub fn pixels(&self) -> u64 {
        self.width() as u64 * self.height() as u64
    }

    /// Whether the two rectangles share a pixel.
    pub fn overlaps(&self, other: &Crop) -> bool {
        self.x0 < other.x1 && other.x0 < self.x1 && self.y0 < other.y1 && other.y0 < self.y1
    }
}

/// Where a render stands, reported after every pass.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Progress {
    /// Passes completed.
    pub passes_done: u32,
    /// Passes planned.
    pub passes_total: u32,
    /// Samples per pixel completed.
    pub spp_done: u32,
    /// Samples per pixel planned.
    pub spp_total: u32,
    /// Time since the render started.
    pub elapsed: Duration,
}

/// The image a render returns (linear Rec.709 radiance); defined in lamina-image, shared
/// with the GPU renderer.
pub use lamina_image::Image;

/// Counters of a finished render.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RenderStats {
    /// Wall-clock time of the whole call, BVH build included.
    pub elapsed: Duration,
    /// Samples per pixel in the image (completed passes; of a part, the samples of the part
    /// that were rendered).
    pub spp_done: u32,
    /// The sample indices in the image: the requested range, or its first `spp_done`
    /// samples when the render stopped early.
    pub sample_range: SampleRange,
    /// The pixels rendered (the whole film unless cropped).
    pub crop: Crop,
    /// Passes completed (their samples are the image); 0 only if cancelled in the first.
    pub passes_done: u32,
    /// Passes planned for the requested samples per pixel.
    pub passes_total: u32,
    /// Camera samples in the image (`spp_done · width · height`).
    pub samples: u64,
    /// All rays traced (camera, indirect and shadow), interrupted pass included.
    pub rays: u64,
    /// Whether the time limit or the cancel flag stopped the render before `spp`.
    pub stopped_early: bool,
    /// Wall-clock time of the BVH build (part of `elapsed`).
    pub accel_build: Duration,
    /// Bytes held by the BVHs and primitive / instance records.
    pub accel_memory: AccelMemory,
    /// Primitives stored in the BVHs (each prototype's once).
    pub primitives: usize,
    /// Wall-clock time spent making the scene's values in other channels before the first
    /// pass (wavelength bins or bands: materials, lights, skies; part of `elapsed`); zero
    /// for RGB.
    pub spectral_setup: Duration,
    /// Instances in the top-level BVH.
    pub instances: usize,
}

/// The result of [`render`].
#[derive(Clone, Debug)]
pub struct RenderOutput {
    /// The image (mean of the completed samples), the size of the crop.
    pub image: Image,
    /// Counters.
    pub stats: RenderStats,
    /// With [`RenderOptions::keep_sums`]: each pixel's sum of its samples' radiance in f64,
    /// row-major over the crop (`image` is these divided by `stats.spp_done`).
    pub sums: Option<Vec<glam::DVec3>>,
}

#[derive(Clone, Copy, Debug)]
struct Tile {
    x0: u32,
    y0: u32,
    w: u32,
    h: u32,
}

/// Pass boundaries `[s0, s1)` for `spp` samples: 16, 16, ..., or, `progressive`, 1, 1, 2,
/// 4, 8, 16, 16, ...
fn pass_schedule(spp: u32, progressive: bool) -> Vec<(u32, u32)> {
    let mut passes = Vec::new();
    let (mut s, mut size) = (0u32, if progressive { 1 } else { MAX_PASS_SPP });
    while s < spp {
        let e = s.saturating_add(size).min(spp);
        passes.push((s, e));
        s = e;
        if passes.len() > 1 {
            size = (size * 2).min(MAX_PASS_SPP);
        }
    }
    passes
}

/// Renders `scene` with `opts`. Errors for invalid scenes (bad camera, out-of-range
/// indices, non-finite lights) and invalid options (zero samples or threads).
///
/// A film with `spectral = "visible"` ([`lamina_core::SpectralMode::Visible`]) is rendered
/// over visible wavelengths and returned in linear Rec.709 ([`crate::spectral`]).
pub fn render(scene: &Scene, opts: &RenderOptions) -> Result<RenderOutput, RenderError> {
    let start = Instant::now();
    let job = Job::new(scene, opts)?;
    let (acc, stats) = match scene.film.spectral {
        SpectralMode::Rgb => {
            let ctx = SceneContext::new(scene, opts.accel)?;
            job.run(&ctx, &RgbEstimator::new(&ctx, opts), opts, start)
        }
        SpectralMode::Visible => crate::spectral::render_visible(scene, &job, opts, start)?,
    };
    Ok(RenderOutput {
        image: Image {
            width: stats.crop.width(),
            height: stats.crop.height(),
            pixels: acc.mean_rgb(stats.spp_done),
        },
        sums: opts.keep_sums.then(|| acc.into_rgb_sums()),
        stats,
    })
}

/// What a render does with one camera sample: `channels()` values from a camera ray
/// (linear RGB, or one per band).
pub(crate) trait Estimator: Sync {
    /// Working memory [`Estimator::estimate`] writes over at every sample: made once per
    /// tile ([`Estimator::scratch`]), not per sample (a spectral path's BSDFs are hundreds
    /// of bytes per channel set).
    type Scratch;
    /// Values per sample.
    fn channels(&self) -> usize;
    /// A new [`Estimator::Scratch`].
    fn scratch(&self) -> Self::Scratch;
    /// The sample's values along the camera ray `ray` into `out` (`channels()` long,
    /// zeroed), drawing its random numbers from `sampler` and counting its rays in `rays`.
    /// `first` is the ray's first hit (what [`crate::accel::Accel::intersect`] returns
    /// for it) where the renderer found it beforehand, which it does only for an
    /// estimator that [`Estimator::takes_first_hit`]; the values are the same either way.
    /// `scratch` is the tile's [`Estimator::Scratch`], holding whatever the last sample left.
    #[allow(clippy::too_many_arguments)]
    fn estimate(
        &self,
        ctx: &SceneContext,
        ray: Ray,
        first: Option<Option<Hit>>,
        sampler: &mut PixelSampler,
        rays: &mut u64,
        out: &mut [f32],
        scratch: &mut Self::Scratch,
    );
    /// Whether [`Estimator::estimate`] takes the camera ray's first hit found beforehand.
    fn takes_first_hit(&self) -> bool {
        false
    }
    /// The wavefront path tracer that estimates this render's pixels (RGB, 3 channels),
    /// where it serves the scene.
    fn wave(&self) -> Option<&Wave> {
        None
    }
}

/// The RGB render: the scene's integrator, linear Rec.709.
struct RgbEstimator {
    integrator: Integrator,
    ambient: Vec3,
    wave: Option<Wave>,
}

impl RgbEstimator {
    fn new(ctx: &SceneContext, opts: &RenderOptions) -> Self {
        let integrator = ctx.scene.integrator;
        let ambient = match integrator {
            Integrator::Paper { ambient } => ambient.unwrap_or(ctx.lights.sky_mean),
            Integrator::Path { .. } => Vec3::ZERO,
        };
        RgbEstimator {
            integrator,
            ambient,
            // Compiled for the plain x86-64 target (no AVX2) the wave's lane loops are
            // slower than one path at a time (bench/README.md), so it runs only where
            // `run_wide` has the wide units.
            wave: if opts.one_path_at_a_time || !lamina_accel::wide::wide_available() {
                None
            } else {
                Wave::new(ctx)
            },
        }
    }
}

impl Estimator for RgbEstimator {
    type Scratch = ();

    fn channels(&self) -> usize {
        3
    }

    fn scratch(&self) {}

    #[inline]
    fn estimate(
        &self,
        ctx: &SceneContext,
        ray: Ray,
        first: Option<Option<Hit>>,
        sampler: &mut PixelSampler,
        rays: &mut u64,
        out: &mut [f32],
        _: &mut (),
    ) {
        let l = match self.integrator {
            Integrator::Path {
                max_depth,
                rr_depth,
                ..
            } => match first {
                Some(hit) => path::radiance_hit(ctx, ray, hit, sampler, max_depth, rr_depth, rays),
                None => path::radiance(ctx, ray, sampler, max_depth, rr_depth, rays),
            },
            Integrator::Paper { .. } => paper::radiance(ctx, ray, sampler, self.ambient, rays),
        };
        out.copy_from_slice(&l.to_array());
    }

    fn takes_first_hit(&self) -> bool {
        matches!(self.integrator, Integrator::Path { .. })
    }

    fn wave(&self) -> Option<&Wave> {
        self.wave.as_ref()
    }
}

/// A render's checked settings: samples, threads, pixels, passes and tiles.
pub(crate) struct Job {
    pub(crate) pool: rayon::ThreadPool,
    range: SampleRange,
    crop: Crop,
    tiles: Vec<Tile>,
    passes: Vec<(u32, u32)>,
}

/// An error naming the missing feature when this build lacks `backend`.
pub(crate) fn check_backend(backend: crate::accel::Backend) -> Result<(), RenderError> {
    if backend.available() {
        return Ok(());
    }
    Err(RenderError::InvalidOptions(format!(
        "accel {}: this build of lamina has no Embree backend (build it with the `embree` \
         feature, with Debian's libembree-dev installed)",
        backend.name()
    )))
}

impl Job {
    /// Checks `opts` against `scene`'s film and plans the passes and tiles.
    pub(crate) fn new(scene: &Scene, opts: &RenderOptions) -> Result<Job, RenderError> {
        let film = scene.film;
        check_backend(opts.accel)?;
        let spp_total = opts.spp.unwrap_or(film.spp);
        if spp_total == 0 {
            return Err(RenderError::InvalidOptions(
                "samples per pixel must be at least 1".into(),
            ));
        }
        if film.width == 0
            || film.height == 0
            || film.width as u64 * film.height as u64 > MAX_PIXELS
        {
            return Err(RenderError::InvalidScene(format!(
                "film size {}x{} must be positive and at most {MAX_PIXELS} pixels",
                film.width, film.height
            )));
        }
        let threads = match opts.threads {
            Some(0) => {
                return Err(RenderError::InvalidOptions(
                    "thread count must be at least 1".into(),
                ));
            }
            Some(n) => n,
            None => std::thread::available_parallelism().map_or(1, |n| n.get()),
        };
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .map_err(|source| RenderError::ThreadPool { threads, source })?;
        let range = opts.samples.unwrap_or(SampleRange {
            start: 0,
            end: spp_total,
        });
        if range.is_empty() || range.end > spp_total {
            return Err(RenderError::InvalidOptions(format!(
                "sample range {}..{} must be non-empty and within 0..{spp_total}",
                range.start, range.end
            )));
        }
        let crop = opts.crop.unwrap_or(Crop::full(film.width, film.height));
        if crop.pixels() == 0 || crop.x1 > film.width || crop.y1 > film.height {
            return Err(RenderError::InvalidOptions(format!(
                "crop {},{},{},{} must be a non-empty rectangle inside the {}x{} image",
                crop.x0, crop.y0, crop.x1, crop.y1, film.width, film.height
            )));
        }
        let mut tiles = Vec::new();
        for y0 in (crop.y0..crop.y1).step_by(TILE as usize) {
            for x0 in (crop.x0..crop.x1).step_by(TILE as usize) {
                tiles.push(Tile {
                    x0,
                    y0,
                    w: TILE.min(crop.x1 - x0),
                    h: TILE.min(crop.y1 - y0),
                });
            }
        }
        // The full render's passes, clipped to the range: a part adds its samples in the
        // same groups as the whole render would.
        let progressive = opts.progressive || opts.time_limit.is_some();
        let passes: Vec<(u32, u32)> = pass_schedule(spp_total, progressive)
            .into_iter()
            .map(|(a, b)| (a.max(range.start), b.min(range.end)))
            .filter(|(a, b)| a < b)
            .collect();
        Ok(Job {
            pool,
            range,
            crop,
            tiles,
            passes,
        })
    }

    /// Renders the passes with `est` on the prepared `ctx`: the per-pixel sums of the
    /// completed passes and the counters (`start`: when the call began).
    pub(crate) fn run<E: Estimator>(
        &self,
        ctx: &SceneContext,
        est: &E,
        opts: &RenderOptions,
        start: Instant,
    ) -> (Accumulator, RenderStats) {
        let (range, crop) = (self.range, self.crop);
        let seed = fold_seed(opts.seed);
        let deadline = opts.time_limit.map(|d| start + d);
        let cancelled = || {
            opts.cancel
                .as_ref()
                .is_some_and(|c| c.load(Ordering::Relaxed))
        };
        let mut acc = Accumulator::new(crop.width(), crop.height(), est.channels());
        let (mut spp_done, mut rays, mut stopped_early) = (0u32, 0u64, false);
        let mut passes_done = 0u32;
        // A completed pass is reported while the next pass renders (one more job on the
        // pool: a slow progress callback does not hold the threads up).
        let report = |done: &Done| {
            if let Some(cb) = &opts.progress {
                cb(Progress {
                    passes_done: done.pass as u32 + 1,
                    passes_total: self.passes.len() as u32,
                    spp_done: done.s1 - range.start,
                    spp_total: range.len(),
                    elapsed: start.elapsed(),
                });
            }
        };
        // The last completed pass: every tile's sums of all the samples so far (a pass's
        // tile starts from the previous pass's sums of that tile), and whether it has
        // been reported.
        let mut last: Option<(Done, bool)> = None;
        for (pi, &(s0, s1)) in self.passes.iter().enumerate() {
            let first = pi == 0;
            let stop = || cancelled() || (!first && deadline.is_some_and(|d| Instant::now() >= d));
            if stop() {
                stopped_early = true;
                break;
            }
            let previous = last.as_ref().map(|(done, _)| done);
            let (_, results): ((), Vec<Option<TileSums>>) = self.pool.install(|| {
                rayon::join(
                    || {
                        if let Some(done) = previous {
                            report(done);
                        }
                    },
                    || {
                        self.tiles
                            .par_iter()
                            .enumerate()
                            // Every tile a job of its own that an idle thread can take:
                            // rayon's adaptive splitting otherwise runs runs of tiles as
                            // one job, and a thread that ends its share early waits out
                            // the other's run.
                            .with_max_len(1)
                            .map(|(i, t)| {
                                if stop() {
                                    None
                                } else {
                                    let from = previous.map(|d| &d.tiles[i].0[..]);
                                    Some(render_tile(ctx, est, t, s0, s1, seed, from))
                                }
                            })
                            .collect()
                    },
                )
            });
            if let Some((_, reported)) = &mut last {
                *reported = true;
            }
            rays += results.iter().flatten().map(|r| r.1).sum::<u64>();
            let Some(tiles) = results.into_iter().collect::<Option<Vec<_>>>() else {
                stopped_early = true;
                break;
            };
            spp_done = s1 - range.start;
            passes_done = pi as u32 + 1;
            last = Some((
                Done {
                    pass: pi,
                    s1,
                    tiles,
                },
                false,
            ));
        }
        if let Some((done, reported)) = last {
            if !reported {
                report(&done);
            }
            for (t, (sums, _)) in self.tiles.iter().zip(&done.tiles) {
                acc.add_tile(t.x0 - crop.x0, t.y0 - crop.y0, t.w, sums);
            }
        }
        let stats = RenderStats {
            elapsed: start.elapsed(),
            spp_done,
            sample_range: SampleRange {
                start: range.start,
                end: range.start + spp_done,
            },
            crop,
            passes_done,
            passes_total: self.passes.len() as u32,
            samples: spp_done as u64 * crop.pixels(),
            rays,
            stopped_early,
            accel_build: ctx.accel_build,
            accel_memory: ctx.accel.memory(),
            primitives: ctx.accel.primitive_count(),
            instances: ctx.accel.instance_count(),
            spectral_setup: Duration::ZERO,
        };
        (acc, stats)
    }
}

/// A completed pass: its index, its end sample and each tile's sums of all the samples so
/// far and rays of this pass (in [`Job`]'s tile order).
struct Done {
    pass: usize,
    s1: u32,
    tiles: Vec<TileSums>,
}

/// What [`render_tile`] gives for a tile: its pixels' sums and the rays traced.
type TileSums = (Vec<f64>, u64);

/// Camera rays whose first hits [`render_tile`] finds in a row before following their paths.
const FIRST_HITS: usize = crate::accel::Accel::MANY;

/// Samples `[s0, s1)` of every pixel of `tile` added in sample order to the per-pixel sums
/// `from` (the tile's sums after the previous pass; zeros where `None`): the new sums
/// (row-major, `channels` per pixel, f64 so that splitting a pixel's samples into parts
/// changes only the order of f64 additions) and the rays traced.
fn render_tile<E: Estimator>(
    ctx: &SceneContext,
    est: &E,
    tile: &Tile,
    s0: u32,
    s1: u32,
    seed: u32,
    from: Option<&[f64]>,
) -> TileSums {
    let c = est.channels();
    let n = (tile.w * tile.h) as usize * c;
    let mut sums = from.map_or_else(|| vec![0.0f64; n], <[f64]>::to_vec);
    debug_assert_eq!(sums.len(), n);
    let mut vals = vec![0.0f32; c];
    let mut rays = 0u64;
    // Sample `i` of pixel `(x, y)`: its sampler (past the film and lens draws) and camera
    // ray.
    // With `unit` false the direction is left unnormalized ([`normalize_dirs`] then).
    // `stream` is pixel `(x, y)`'s ([`PixelStream`]: its seeds hashed once per pixel).
    let camera = |stream: &PixelStream, x: u32, y: u32, i: u32, unit: bool| {
        let (mut sampler, film_u) = stream.film(i);
        // A pinhole reads no lens sample: its draw is skipped, not made (the same stream).
        let lens_u = sampler.next_2d_if(ctx.camera.uses_lens());
        let pos = Vec2::new(x as f32 + 0.5, y as f32 + 0.5) + ctx.filter.sample(film_u);
        let (origin, dir) = if unit {
            ctx.camera.generate_ray(pos, lens_u)
        } else {
            ctx.camera.generate_ray_unnormalized(pos, lens_u)
        };
        let ray = Ray {
            origin,
            dir,
            tmax: f32::INFINITY,
        };
        (sampler, ray)
    };
    // Follows a sample's path (from its first hit, if found) and adds it to its pixel's
    // sums (starting at `at`).
    let mut scratch = est.scratch();
    let mut run = |at: usize, sampler: &mut PixelSampler, ray: Ray, hit: Option<Option<Hit>>| {
        vals.fill(0.0);
        est.estimate(ctx, ray, hit, sampler, &mut rays, &mut vals, &mut scratch);
        // A NaN or infinite sample (a numerical accident) counts as black.
        if vals.iter().all(|v| v.is_finite()) {
            for (s, v) in sums[at..at + c].iter_mut().zip(&vals) {
                *s += *v as f64;
            }
        }
    };
    // Each sample's camera ray is made before the previous sample's path is followed, so
    // that the sampler's and the camera's arithmetic overlaps that path's ray walks
    // rather than holding up the next camera ray. The order of the additions is the same.
    let mut at = 0usize;
    if let Some(wave) = est.wave() {
        debug_assert_eq!(c, 3);
        let rect = (tile.x0, tile.y0, tile.w, tile.h);
        wave.tile(ctx, seed, rect, s0, s1, &mut sums, &mut rays);
        return (sums, rays);
    }
    if est.takes_first_hit() {
        // A pixel's samples in groups: their camera rays made, then their first hits found
        // one after the other (independent walks the CPU overlaps, where each path's own
        // work depends on the walk before it), then their paths followed from there.
        let none = Ray {
            origin: Vec3::ZERO,
            dir: Vec3::Z,
            tmax: 0.0,
        };
        // Samplers, rays and hits in arrays of their own, written in place: no tuple
        // copied between them (a copy that reads back a value just stored in narrower
        // pieces waits on the store).
        let mut samplers = [PixelSampler::new(0, 0, 0, 0); FIRST_HITS];
        let mut hits = [None; FIRST_HITS];
        let mut batch = [none; FIRST_HITS];
        for y in tile.y0..tile.y0 + tile.h {
            for x in tile.x0..tile.x0 + tile.w {
                let stream = PixelStream::new(seed, x, y);
                let mut i = s0;
                while i < s1 {
                    let n = (s1 - i).min(FIRST_HITS as u32) as usize;
                    for (k, (sampler, ray)) in samplers[..n].iter_mut().zip(&mut batch).enumerate()
                    {
                        (*sampler, *ray) = camera(&stream, x, y, i + k as u32, false);
                    }
                    normalize_dirs(&mut batch);
                    ctx.accel.intersect_many(&batch[..n], &mut hits[..n]);
                    for ((sampler, ray), hit) in samplers[..n].iter_mut().zip(&batch).zip(&hits) {
                        run(at, sampler, *ray, Some(*hit));
                    }
                    i += n as u32;
                }
                at += c;
            }
        }
        return (sums, rays);
    }
    let mut pending = None;
    for y in tile.y0..tile.y0 + tile.h {
        for x in tile.x0..tile.x0 + tile.w {
            let stream = PixelStream::new(seed, x, y);
            for i in s0..s1 {
                if let Some((at, (mut sampler, ray))) =
                    pending.replace((at, camera(&stream, x, y, i, true)))
                {
                    run(at, &mut sampler, ray, None);
                }
            }
            at += c;
        }
    }
    if let Some((at, (mut sampler, ray))) = pending {
        run(at, &mut sampler, ray, None);
    }
    (sums, rays)
}

/// The rays' directions normalized as `glam::Vec3::normalize` does (`d · (1 / √(d·d))`,
/// the dot product as `((x·x) + (y·y)) + (z·z)`), so bit for bit the same, but all of them
/// together: the square roots and divisions of the rays in SIMD lanes rather than one
/// after the other, each waiting on the last.
fn normalize_dirs(rays: &mut [Ray; FIRST_HITS]) {
    let (mut x, mut y, mut z) = ([0.0f32; FIRST_HITS], [0.0; FIRST_HITS], [0.0; FIRST_HITS]);
    for (k, r) in rays.iter().enumerate() {
        (x[k], y[k], z[k]) = (r.dir.x, r.dir.y, r.dir.z);
    }
    let mut inv = [0.0f32; FIRST_HITS];
    for k in 0..FIRST_HITS {
        inv[k] = 1.0 / ((x[k] * x[k] + y[k] * y[k]) + z[k] * z[k]).sqrt();
    }
    for (k, r) in rays.iter_mut().enumerate() {
        r.dir = Vec3::new(x[k] * inv[k], y[k] * inv[k], z[k] * inv[k]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normalize_dirs_is_glam_normalize() {
        let mut rng = 0x1234_5678u32;
        let mut next = || {
            rng = crate::sampler::hash_u32(rng);
            (rng >> 8) as f32 / (1 << 23) as f32 * 2.0 - 1.0
        };
        for _ in 0..1000 {
            let mut rays = [Ray {
                origin: Vec3::ZERO,
                dir: Vec3::Z,
                tmax: 1.0,
            }; FIRST_HITS];
            for r in &mut rays {
                let s = 10f32.powf(next() * 6.0);
                r.dir = Vec3::new(next(), next(), next() + 1.5) * s;
            }
            let want = rays.map(|r| r.dir.normalize());
            normalize_dirs(&mut rays);
            for (r, w) in rays.iter().zip(want) {
                assert_eq!(
                    r.dir.to_array().map(f32::to_bits),
                    w.to_array().map(f32::to_bits)
                );
            }
        }
    }

    #[test]
    fn passes_cover_all_samples() {
        for progressive in [false, true] {
            for spp in [1, 2, 3, 7, 64, 100] {
                let p = pass_schedule(spp, progressive);
                assert_eq!(p[0].0, 0);
                assert_eq!(p.last().unwrap().1, spp);
                assert!(p.windows(2).all(|w| w[0].1 == w[1].0 && w[0].0 < w[0].1));
            }
        }
        assert_eq!(
            pass_schedule(64, true)[..6],
            [(0, 1), (1, 2), (2, 4), (4, 8), (8, 16), (16, 32)]
        );
        assert_eq!(pass_schedule(40, false), [(0, 16), (16, 32), (32, 40)]);
    }
}
