//! Spectral renders in one pass: `[film] spectral = "visible"` and `[film] bands`, every
//! camera path carrying several channel sets of three wavelength bins or bands each
//! ([`crate::integrators::spectral`]), so that traversal, shadow rays and light sampling are
//! paid once for all of them.
//!
//! * **Visible** ([`lamina_core::SpectralMode::Visible`], through [`crate::render()`]):
//!   [`visible::BINS`] bins of 9.8 nm over 360-830 nm, grouped into sets `h` (bins `h, h + S,
//!   h + 2S`) and `S + h` (bins `h + 3S, h + 4S, h + 5S`) with `S` = [`visible::STRIDE`]; a
//!   path draws its hero offset `h` from the sample's first number after the lens and
//!   carries both sets, six wavelengths spread over the visible. Each bin's radiance goes
//!   into linear Rec.709 through the CIE 1931 observer ([`visible::bin_to_rgb`]) times `S`
//!   (each bin is on a path with probability `1 / S`). RGB emission is upsampled with the
//!   D65 shape, so RGB white light stays white and an RGB scene keeps its look; the image
//!   is an RGB image like any other (EXR, PNG, parts and merges alike).
//! * **Bands** ([`render_bands`]): the bands three to a set (the last set repeating its last
//!   band), up to [`MAX_SETS_PER_PATH`] sets per path; more bands take several paths per
//!   sample, each from the same random numbers, over the same BVH. RGB emission takes the
//!   solar shape ([`lamina_leaf::spectrum::bands`]). With the paper integrator bands render
//!   three at a time through the RGB renderer instead.
//!
//! The sets are the scene's values per bin or band ([`crate::bands::band_values`]: maps
//! shared, not copied), built in parallel before the first pass; their time is
//! [`crate::RenderStats::spectral_setup`].

use crate::accel::Ray;
use crate::bands::{band_groups, band_leaves, band_values_prebuilt, group_scene};
use crate::error::RenderError;
use crate::film::Accumulator;
use crate::integrators::SceneContext;
use crate::integrators::spectral::{ChannelSet, radiance_sets};
use crate::lights::LightSet;
use crate::materials::SurfaceBsdf;
use crate::render::{Estimator, Job, RenderOptions, RenderStats};
use crate::sampler::PixelSampler;
use glam::Vec3;
use lamina_core::{Integrator, Scene, Sky, SpectralMode};
use lamina_leaf::spectrum::bands::{Band, Illuminant};
use lamina_leaf::spectrum::visible;
use rayon::prelude::*;
use std::time::Instant;

/// The most channel sets one path carries (12 bands).
pub const MAX_SETS_PER_PATH: usize = 4;

// A visible path carries two sets of three bins.
const _: () = assert!(visible::PATH_BINS == 6 && visible::BINS == 6 * visible::STRIDE);

/// The channel sets of `scene` for `groups` (three bands each, channel `c` of set `j` =
/// `groups[j][c]`), built in parallel on `pool`.
pub(crate) fn build_sets(
    scene: &Scene,
    groups: &[[&Band; 3]],
    illuminant: Illuminant,
    pool: &rayon::ThreadPool,
) -> Result<Vec<ChannelSet>, RenderError> {
    pool.install(|| {
        // A physical sky's maps in every set at once (one spectrum per texel).
        let sky_maps: Vec<Option<lamina_leaf::Texture>> = match &scene.sky {
            Some(Sky::Image {
                spectral: Some(sp), ..
            }) => sp.band_maps(groups).into_iter().map(Some).collect(),
            _ => vec![None; groups.len()],
        };
        // Every leaf in every set, built together per leaf (their precomputations share
        // the slab geometry), then each set around them.
        let leaves = band_leaves(scene, groups, illuminant, pool.current_num_threads())?;
        groups
            .par_iter()
            .zip(sky_maps)
            .enumerate()
            .map(|(j, (g, sky_map))| {
                let v = band_values_prebuilt(scene, *g, illuminant, sky_map, |i| {
                    leaves[i].get(j).cloned()
                })?;
                Ok(ChannelSet {
                    lights: LightSet::for_channel_set(&v.lights, v.sky.as_ref())?,
                    materials: v.materials,
                })
            })
            .collect()
    })
}

/// `max_depth` and `rr_depth` of the path integrator, or why a spectral render cannot use
/// the scene's integrator.
fn path_depths(scene: &Scene, what: &str) -> Result<(u32, u32), RenderError> {
    match scene.integrator {
        Integrator::Path {
            max_depth,
            rr_depth,
            ..
        } => Ok((max_depth, rr_depth)),
        Integrator::Paper { .. } => Err(RenderError::InvalidScene(format!(
            "{what} renders with the path integrator; the paper integrator is RGB only (set \
             [integrator] type = \"path\")"
        ))),
    }
}

/// The visible render of `scene` (the module docs): its sums (linear Rec.709) and counters.
pub(crate) fn render_visible(
    scene: &Scene,
    job: &Job,
    opts: &RenderOptions,
    start: Instant,
) -> Result<(Accumulator, RenderStats), RenderError> {
    let (max_depth, rr_depth) = path_depths(scene, "spectral = \"visible\"")?;
    let s = visible::STRIDE;
    let bins: Vec<Band> = (0..visible::BINS).map(visible::bin).collect();
    // Set j < S holds bins j, j + S, j + 2S; set S + j the bins 3S to 5S further.
    let groups: Vec<[usize; 3]> = (0..2 * s)
        .map(|j| std::array::from_fn(|c| j % s + (3 * (j / s) + c) * s))
        .collect();
    let band_groups: Vec<[&Band; 3]> = groups.iter().map(|g| g.map(|b| &bins[b])).collect();
    let setup = Instant::now();
    let sets = build_sets(scene, &band_groups, Illuminant::D65, &job.pool)?;
    // The two sets of a path side by side in the sky's texels.
    let slot = (0..2 * s).map(|j| 2 * (j % s) + j / s).collect();
    let ctx = SceneContext::new(scene, opts.accel)?.with_sets(sets, slot)?;
    let spectral_setup = setup.elapsed().saturating_sub(ctx.accel_build);
    let est = VisibleEstimator {
        max_depth,
        rr_depth,
        weights: groups
            .iter()
            .map(|g| g.map(|b| visible::bin_to_rgb(b) * s as f32))
            .collect(),
    };
    let (acc, mut stats) = job.run(&ctx, &est, opts, start);
    stats.spectral_setup = spectral_setup;
    Ok((acc, stats))
}

/// A visible render's camera samples: two sets of bins per path, to linear Rec.709.
struct VisibleEstimator {
    max_depth: u32,
    rr_depth: u32,
    /// Per set and channel: the bin's RGB weight times the number of hero offsets.
    weights: Vec<[Vec3; 3]>,
}

impl Estimator for VisibleEstimator {
    /// The two sets' BSDFs at a vertex.
    type Scratch = [SurfaceBsdf; 2];

    fn channels(&self) -> usize {
        3
    }

    fn scratch(&self) -> Self::Scratch {
        [SurfaceBsdf::BLANK; 2]
    }

    /// The tile loop finds a pixel's camera hits together (`Accel::intersect_many`).
    fn takes_first_hit(&self) -> bool {
        true
    }

    fn estimate(
        &self,
        ctx: &SceneContext,
        ray: Ray,
        first: Option<Option<crate::accel::Hit>>,
        sampler: &mut PixelSampler,
        rays: &mut u64,
        out: &mut [f32],
        scratch: &mut Self::Scratch,
    ) {
        let s = visible::STRIDE;
        let h = ((sampler.next_1d() * s as f32) as usize).min(s - 1);
        let pick = [h, s + h];
        let (d, r) = (self.max_depth, self.rr_depth);
        let l = radiance_sets::<2>(ctx, pick, ray, first, sampler, d, r, rays, scratch);
        let mut rgb = Vec3::ZERO;
        for (lk, &j) in l.iter().zip(&pick) {
            for (w, v) in self.weights[j].iter().zip(lk.to_array()) {
                rgb += *w * v;
            }
        }
        out.copy_from_slice(&rgb.to_array());
    }
}

/// A render in spectral bands: one image plane per band.
#[derive(Clone, Debug)]
pub struct BandRender {
    /// Width of the planes in pixels (the crop's).
    pub width: u32,
    /// Height of the planes in pixels.
    pub height: u32,
    /// Per band, in the order given: the mean of the completed samples, row-major (band-mean
    /// spectral radiance, W m⁻² sr⁻¹ nm⁻¹).
    pub planes: Vec<Vec<f32>>,
    /// With [`RenderOptions::keep_sums`]: per band, each pixel's f64 sum of its samples.
    pub sums: Option<Vec<Vec<f64>>>,
    /// Counters (of the whole render).
    pub stats: RenderStats,
}

/// Renders `scene` in `bands` (the module docs): one pass over the samples, every band of
/// every sample from the same camera ray. The same options as [`crate::render()`]; the
/// film's own `spectral` setting is not used.
pub fn render_bands(
    scene: &Scene,
    bands: &[Band],
    opts: &RenderOptions,
) -> Result<BandRender, RenderError> {
    if bands.is_empty() {
        return Err(RenderError::InvalidOptions(
            "a band render needs at least one band".into(),
        ));
    }
    if let Integrator::Paper { .. } = scene.integrator {
        return render_bands_grouped(scene, bands, opts);
    }
    let (max_depth, rr_depth) = path_depths(scene, "a band render")?;
    let start = Instant::now();
    let job = Job::new(scene, opts)?;
    let groups = band_groups(bands.len());
    let band_groups: Vec<[&Band; 3]> = groups
        .iter()
        .map(|g| std::array::from_fn(|c| &bands[g[c.min(g.len() - 1)]]))
        .collect();
    let setup = Instant::now();
    let sets = build_sets(scene, &band_groups, Illuminant::Solar, &job.pool)?;
    let slot = (0..sets.len()).collect();
    let ctx = SceneContext::new(scene, opts.accel)?.with_sets(sets, slot)?;
    let spectral_setup = setup.elapsed().saturating_sub(ctx.accel_build);
    let chunks: Vec<std::ops::Range<usize>> = (0..groups.len())
        .step_by(MAX_SETS_PER_PATH)
        .map(|a| a..(a + MAX_SETS_PER_PATH).min(groups.len()))
        .collect();
    let est = BandEstimator {
        max_depth,
        rr_depth,
        groups,
        chunks,
        bands: bands.len(),
    };
    let (acc, mut stats) = job.run(&ctx, &est, opts, start);
    stats.spectral_setup = spectral_setup;
    let planes = acc.mean_planes(stats.spp_done);
    Ok(BandRender {
        width: stats.crop.width(),
        height: stats.crop.height(),
        planes,
        sums: opts.keep_sums.then(|| acc.into_planes()),
        stats,
    })
}

/// A band render's camera samples: every set, up to [`MAX_SETS_PER_PATH`] per path.
struct BandEstimator {
    max_depth: u32,
    rr_depth: u32,
    /// Per set, the bands of its channels.
    groups: Vec<Vec<usize>>,
    /// The sets each path carries.
    chunks: Vec<std::ops::Range<usize>>,
    bands: usize,
}

/// A band path's BSDFs at a vertex, for each number of sets a path can carry.
pub(crate) struct BandScratch {
    one: [SurfaceBsdf; 1],
    two: [SurfaceBsdf; 2],
    three: [SurfaceBsdf; 3],
    four: [SurfaceBsdf; 4],
}

impl Estimator for BandEstimator {
    type Scratch = BandScratch;

    fn channels(&self) -> usize {
        self.bands
    }

    fn scratch(&self) -> BandScratch {
        let b = SurfaceBsdf::BLANK;
        BandScratch {
            one: [b; 1],
            two: [b; 2],
            three: [b; 3],
            four: [b; 4],
        }
    }

    /// The tile loop finds a pixel's camera hits together (`Accel::intersect_many`).
    fn takes_first_hit(&self) -> bool {
        true
    }

    fn estimate(
        &self,
        ctx: &SceneContext,
        ray: Ray,
        first: Option<Option<crate::accel::Hit>>,
        sampler: &mut PixelSampler,
        rays: &mut u64,
        out: &mut [f32],
        scratch: &mut BandScratch,
    ) {
        let start = *sampler;
        for chunk in &self.chunks {
            // Every path of the sample from the same random numbers and the same camera
            // hit (found once, by the tile loop, for all of them).
            let mut s = start;
            let (a, d, r) = (chunk.start, self.max_depth, self.rr_depth);
            let mut l = [Vec3::ZERO; MAX_SETS_PER_PATH];
            let mut put = |v: &[Vec3]| l[..v.len()].copy_from_slice(v);
            match chunk.len() {
                1 => put(&radiance_sets::<1>(
                    ctx,
                    [a],
                    ray,
                    first,
                    &mut s,
                    d,
                    r,
                    rays,
                    &mut scratch.one,
                )),
                2 => put(&radiance_sets::<2>(
                    ctx,
                    [a, a + 1],
                    ray,
                    first,
                    &mut s,
                    d,
                    r,
                    rays,
                    &mut scratch.two,
                )),
                3 => put(&radiance_sets::<3>(
                    ctx,
                    [a, a + 1, a + 2],
                    ray,
                    first,
                    &mut s,
                    d,
                    r,
                    rays,
                    &mut scratch.three,
                )),
                _ => put(&radiance_sets::<4>(
                    ctx,
                    [a, a + 1, a + 2, a + 3],
                    ray,
                    first,
                    &mut s,
                    d,
                    r,
                    rays,
                    &mut scratch.four,
                )),
            }
            for (k, j) in chunk.clone().enumerate() {
                for (c, &band) in self.groups[j].iter().enumerate() {
                    out[band] = l[k][c];
                }
            }
            *sampler = s;
        }
    }
}

/// [`render_bands`] with the paper integrator: three bands at a time through the RGB
/// renderer, each group from the same seed and samples.
fn render_bands_grouped(
    scene: &Scene,
    bands: &[Band],
    opts: &RenderOptions,
) -> Result<BandRender, RenderError> {
    let start = Instant::now();
    let mut planes = vec![Vec::new(); bands.len()];
    let mut sums = vec![Vec::new(); bands.len()];
    let mut first: Option<RenderStats> = None;
    let mut rays = 0u64;
    for group in band_groups(bands.len()) {
        let mut banded = group_scene(scene, bands, &group)?;
        banded.film.spectral = SpectralMode::Rgb;
        let out = crate::render(&banded, opts)?;
        for (k, &b) in group.iter().enumerate() {
            planes[b] = out.image.pixels.iter().map(|p| p[k]).collect();
            if let Some(s) = &out.sums {
                sums[b] = s.iter().map(|s| s[k]).collect();
            }
        }
        rays += out.stats.rays;
        match &first {
            // A time limit or a cancel may stop groups at different samples: the bands
            // would not be one image.
            Some(f) if f.sample_range != out.stats.sample_range => {
                return Err(RenderError::InvalidOptions(format!(
                    "band groups stopped at different samples ({}..{} and {}..{}); a band \
                     render with the paper integrator cannot be cut short",
                    f.sample_range.start,
                    f.sample_range.end,
                    out.stats.sample_range.start,
                    out.stats.sample_range.end
                )));
            }
            Some(_) => {}
            None => first = Some(out.stats),
        }
    }
    let mut stats = first.ok_or_else(|| RenderError::InvalidOptions("no band".into()))?;
    stats.elapsed = start.elapsed();
    stats.rays = rays;
    Ok(BandRender {
        width: stats.crop.width(),
        height: stats.crop.height(),
        planes,
        sums: opts.keep_sums.then_some(sums),
        stats,
    })
}
