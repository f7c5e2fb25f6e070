//! The path tracer of [`super::path`] carrying `G` channel sets along one path: the
//! wavelengths of a `spectral = "visible"` render or the bands of a band render, three per
//! set.
//!
//! Geometry is shared: one camera ray, one traversal per bounce, one shadow ray per light
//! sample serve every set. What differs per set are the values: each set has the scene's
//! materials and lights in its own channels ([`ChannelSet`]), and at every vertex each set's
//! BSDF is evaluated for the same directions.
//!
//! * **Light samples** are drawn from the scene's own lights ([`SceneContext::lights`],
//!   the same geometry in every set; the sky by the RGB map's importance) and weighted per
//!   set by that set's radiance along them ([`crate::lights::AnyLight::li_along`]).
//! * **BSDF samples** come from one set, the *hero*, chosen uniformly per bounce (its index
//!   from the same random number that picks the lobe, so the dimensions used are those of
//!   the RGB integrator); every set weighs the direction by the one-sample MIS density
//!   `p(ω) = (1/G) Σ_k p_k(ω)` (Veach's balance heuristic over the sets' sampling
//!   strategies, as in hero-wavelength sampling, Wilkie et al. 2014): `β_k ·= f_k / p`,
//!   unbiased for every set wherever some set's density covers its BSDF. The same `p` is
//!   the BSDF density of the power heuristic against light sampling.
//! * **Russian roulette** survives with the largest throughput of any channel of any set.
//!
//! Everything else (depth, emitters ending paths, shading normals and the geometric side
//! rule) is [`super::path`]'s.

use super::SceneContext;
use crate::accel::{FLAG_EMITTER, Hit, HitKind, ID_MASK, PrimRef, Ray, spawn_origin};
use crate::lights::{LightSet, NO_TEXEL, power_heuristic};
use crate::materials::SurfaceBsdf;
use crate::sampler::PixelSampler;
use crate::shading::{ShadingFrame, shading_normal};
use glam::Vec3;
use lamina_core::Material;
use lamina_leaf::Bsdf;
use std::array::from_fn;

/// The scene's values in three channels (wavelength bins or bands): its materials, and its
/// lights and sky in [`SceneContext::lights`]' order and geometry.
#[derive(Debug)]
pub struct ChannelSet {
    /// The scene's materials, in scene order.
    pub materials: Vec<Material>,
    /// The scene's lights and sky ([`LightSet::for_channel_set`]: looked up along the
    /// directions the scene's own lights draw, never sampled themselves).
    pub lights: LightSet,
}

/// The sets' skies as the scene sky's own texels times a coarse table of colour ratios:
/// set `j`'s radiance in texel `t` is `lum(L(t)) · r_j(c(t))`, with `L` the scene's (RGB)
/// sky map, `lum` its channel mean and `r_j` set `j`'s radiance over `lum`, averaged over
/// the `F x F` texels of the coarse cell `c(t)` (weighted by `lum`, so the cell's mean is
/// kept exactly). Exact wherever the sky's colour is constant over a cell; the sky's
/// brightness, its sharp circumsolar peak included, comes from the full-resolution map that
/// light sampling reads anyway.
///
/// Why: sky lookups at random texels are memory-bound, and the sets' own maps (16 of them
/// for a visible render, 25 MB at 512 x 256) do not stay in cache; the ratios of the sets a
/// path carries (neighbours by `slot`) sit in one cache line of a table that does (0.8 MB),
/// in half precision relative to each set's largest ratio (11 significant bits).
#[derive(Debug)]
pub struct SkySets {
    /// The index of the sky among the lights.
    pub light: usize,
    /// Number of sets.
    pub sets: usize,
    /// Per set, its place among a cell's values.
    pub slot: Vec<usize>,
    /// Per set, what its ratios are relative to.
    pub scale: Vec<f32>,
    /// Fine texels per coarse cell along each axis, and the fine and coarse widths.
    factor: usize,
    width: usize,
    coarse_width: usize,
    /// `log2` of `width` and of `factor` where both are powers of two (the usual map
    /// sizes): a texel's cell by shifts, not by integer divisions (tens of cycles each,
    /// at every sky lookup of every set).
    shifts: Option<(u32, u32)>,
    /// The relative ratios, cell-major.
    ratios: Vec<[half::f16; 3]>,
}

/// The coarse table's width at most (height half): 128 x 64 cells.
const SKY_CELLS: usize = 128;

impl SkySets {
    /// The ratio tables of `sets`' skies over `base`, the scene's sky map (all of the same
    /// size, each the last of `lights` lights), set `j` at `slot[j]` in each cell; `None`
    /// for a constant sky or none.
    pub fn new(
        base: &crate::lights::SkyLight,
        sets: &[ChannelSet],
        slot: Vec<usize>,
        lights: usize,
    ) -> Option<Self> {
        let (w, h) = base.size()?;
        let factor = (w / SKY_CELLS).max(1);
        let (cw, ch) = (w.div_ceil(factor), h.div_ceil(factor));
        let n = sets.len();
        let skies = sets
            .iter()
            .map(|set| match set.lights.lights.last() {
                Some(crate::lights::AnyLight::Sky(sky)) => Some(sky),
                _ => None,
            })
            .collect::<Option<Vec<_>>>()?;
        let lum = |t: usize| base.le_texel(Vec3::Y, t as u32).element_sum() / 3.0;
        let mut ratio = vec![Vec3::ZERO; cw * ch * n];
        let mut weight = vec![0.0f32; cw * ch];
        for y in 0..h {
            for x in 0..w {
                let (t, c) = (y * w + x, (y / factor) * cw + x / factor);
                weight[c] += lum(t);
                for (j, sky) in skies.iter().enumerate() {
                    ratio[c * n + slot[j]] += sky.le_texel(Vec3::Y, t as u32);
                }
            }
        }
        let mut scale = vec![0.0f32; n];
        for c in 0..cw * ch {
            let inv = if weight[c] > 0.0 {
                1.0 / weight[c]
            } else {
                0.0
            };
            for (j, s) in scale.iter_mut().enumerate() {
                let r = &mut ratio[c * n + slot[j]];
                *r *= inv;
                *s = s.max(r.max_element());
            }
        }
        // The set at each slot.
        let mut set_at = vec![0usize; n];
        for (j, &s) in slot.iter().enumerate() {
            set_at[s] = j;
        }
        let ratios = (0..cw * ch * n)
            .map(|i| {
                let j = set_at[i % n];
                let inv = if scale[j] > 0.0 { 1.0 / scale[j] } else { 0.0 };
                (ratio[i] * inv).to_array().map(half::f16::from_f32)
            })
            .collect();
        Some(SkySets {
            light: lights - 1,
            sets: n,
            slot,
            scale,
            factor,
            width: w,
            coarse_width: cw,
            shifts: (w.is_power_of_two() && factor.is_power_of_two())
                .then(|| (w.trailing_zeros(), factor.trailing_zeros())),
            ratios,
        })
    }

    /// The radiance of each set `sets[k]` (at `slots[k]`) in texel `t`, where the scene's
    /// sky map holds `base`: the texel's coarse cell found once for all of them.
    #[inline]
    fn at<const G: usize>(
        &self,
        t: u32,
        base: Vec3,
        sets: &[usize; G],
        slots: &[usize; G],
    ) -> [Vec3; G] {
        let t = t as usize;
        let (cx, cy) = match self.shifts {
            Some((w, f)) => ((t & (self.width - 1)) >> f, (t >> w) >> f),
            None => (
                (t % self.width) / self.factor,
                (t / self.width) / self.factor,
            ),
        };
        let cell = (cy * self.coarse_width + cx) * self.sets;
        let lum = base.element_sum() / 3.0;
        from_fn(|k| {
            let v = self.ratios[cell + slots[k]];
            Vec3::new(v[0].to_f32(), v[1].to_f32(), v[2].to_f32()) * (self.scale[sets[k]] * lum)
        })
    }
}

/// The radiance (W m⁻² sr⁻¹ per channel: per nm for spectral channels) arriving along the
/// camera ray `ray` in each of the `G` sets `sets` (indices into [`SceneContext::sets`]).
/// `first`: the camera ray's first hit where the caller found it already (with
/// `Accel::intersect_many`, a pixel's camera rays together; the same answer as the query
/// made here otherwise). `bsdfs`: room for each vertex's BSDFs, written over (whatever it
/// holds; `[SurfaceBsdf::BLANK; G]` made once for many paths: made per path it cost a copy of
/// the largest variant per set, a few per cent of a render). Adds the rays it traces to
/// `rays`.
#[allow(clippy::too_many_arguments)]
pub fn radiance_sets<const G: usize>(
    ctx: &SceneContext,
    set_ids: [usize; G],
    mut ray: Ray,
    mut first: Option<Option<Hit>>,
    sampler: &mut PixelSampler,
    max_depth: u32,
    rr_depth: u32,
    rays: &mut u64,
    bsdfs: &mut [SurfaceBsdf; G],
) -> [Vec3; G] {
    let mut l = [Vec3::ZERO; G];
    let mut beta = [Vec3::ONE; G];
    let mut prev_pdf = 0.0f32;
    let mut camera_ray = true;
    let mut skip = PrimRef::NONE;
    let mut bounces = 0u32;
    let lights = &ctx.lights.lights;
    let sets: [&ChannelSet; G] = set_ids.map(|j| &ctx.sets[j]);
    // A sky map's texel in set `j` (the interleaved copy), or the light's own value.
    let sky = ctx.sky_sets.as_ref();
    let slots: [usize; G] = from_fn(|k| sky.map_or(0, |s| s.slot[set_ids[k]]));
    let sky_texel = |i: usize, texel: u32, base: Vec3| match sky {
        Some(s) if s.light == i && texel != NO_TEXEL => Some(s.at(texel, base, &set_ids, &slots)),
        _ => None,
    };
    let weight = |camera_ray: bool, prev: f32, pdf: f32| {
        if camera_ray {
            1.0
        } else {
            power_heuristic(prev, pdf)
        }
    };
    loop {
        *rays += 1;
        let hit = match first.take() {
            Some(hit) => hit,
            None => ctx.accel.intersect_skip(&ray, skip),
        };
        let Some(hit) = hit else {
            for (i, light) in lights.iter().enumerate() {
                if !light.is_infinite() {
                    continue;
                }
                let (base, pdf, texel) = light.escaped_texel(ray.dir);
                let w = weight(camera_ray, prev_pdf, pdf * ctx.lights.pick_prob(i));
                let le = sky_texel(i, texel, base).unwrap_or_else(|| {
                    from_fn(|k| sets[k].lights.lights[i].escaped_radiance(ray.dir, texel))
                });
                for k in 0..G {
                    l[k] += beta[k] * le[k] * w;
                }
            }
            break;
        };
        if let Some(light) = ctx.emitter_light(hit.kind) {
            if let Some(base) = lights.get(light) {
                let (_, pdf) = base.hit(ray.origin, ray.dir, hit.t);
                let w = weight(camera_ray, prev_pdf, pdf * ctx.lights.pick_prob(light));
                for k in 0..G {
                    let le = sets[k].lights.lights[light]
                        .hit(ray.origin, ray.dir, hit.t)
                        .0;
                    l[k] += beta[k] * le * w;
                }
            }
            break;
        }
        let HitKind::Triangle { prim, bary } = hit.kind else {
            break;
        };
        if bounces >= max_depth {
            break;
        }
        let (p, info) = ctx.accel.surface(prim, bary);
        debug_assert!(info.flags & FLAG_EMITTER == 0);
        let m = (info.flags & ID_MASK) as usize;
        let normal_map = ctx.scene.materials[m].normal_map();
        let ns = shading_normal(&ctx.accel, prim, bary, &info, normal_map);
        let frame = ShadingFrame::new(&info, ns, -ray.dir);
        let uv = info.uv_at(bary);
        SurfaceBsdf::at_sets_into(sets.map(|s| &s.materials[m]), uv, bsdfs);
        let wo = frame.to_local(-ray.dir);

        let (first, picked, pick) = ctx.nee_lights(sampler);
        for (i, light) in (first..).zip(picked) {
            let u = sampler.next_2d_if(light.uses_sample());
            let Some(mut ls) = light.sample(p, u) else {
                continue;
            };
            ls.pdf *= pick;
            if !(ls.pdf > 0.0) || !frame.consistent(ls.wi) {
                continue;
            }
            let li: [Vec3; G] = sky_texel(i, ls.texel, ls.li)
                .unwrap_or_else(|| from_fn(|k| sets[k].lights.lights[i].li_along(&ls)));
            if li.iter().all(|v| *v == Vec3::ZERO) {
                continue;
            }
            let wi = frame.to_local(ls.wi);
            let f = SurfaceBsdf::eval_sets(bsdfs, wo, wi);
            if f.iter().all(|v| *v == Vec3::ZERO) {
                continue;
            }
            if !ctx.unoccluded(p, info.n, prim, &ls, rays) {
                continue;
            }
            let w = if ls.delta {
                1.0
            } else {
                power_heuristic(ls.pdf, SurfaceBsdf::pdf_mean(bsdfs, wo, wi))
            };
            for k in 0..G {
                l[k] += beta[k] * f[k] * li[k] * (w / ls.pdf);
            }
        }

        let u1 = sampler.next_1d();
        let u2 = sampler.next_2d();
        // The hero set and the lobe from one number: `u1 G` split into its integer and
        // fractional parts (the fraction is again uniform in [0, 1)).
        let (hero, u1) = if G == 1 {
            (0, u1)
        } else {
            let x = u1 * G as f32;
            let h = (x as usize).min(G - 1);
            (h, (x - h as f32).clamp(0.0, 1.0 - f32::EPSILON))
        };
        let u = Vec3::new(u1, u2.x, u2.y);
        // One set: its own sample, value and density. Several: the hero's direction only;
        // every set's value and the mixture density there come next, the hero's with the
        // others', so its own `sample` would evaluate it twice.
        let (wi, one) = if G == 1 {
            match bsdfs[0].sample(wo, u) {
                Some(bs) if bs.pdf > 0.0 => (bs.wi, Some((bs.f, bs.pdf))),
                _ => break,
            }
        } else {
            match bsdfs[hero].sample_direction(wo, u) {
                Some(wi) => (wi, None),
                None => break,
            }
        };
        let dir = frame.to_world_unit(wi);
        if !frame.consistent(dir) {
            break; // its geometric side disagrees with the BSDF's: no light goes there
        }
        let (f, pdf) = match one {
            Some((f, pdf)) => (from_fn(|_| f), pdf),
            None => (
                SurfaceBsdf::eval_sets(bsdfs, wo, wi),
                SurfaceBsdf::pdf_mean(bsdfs, wo, wi),
            ),
        };
        if !(pdf > 0.0) {
            break;
        }
        let mut largest = 0.0f32;
        let mut finite = true;
        for k in 0..G {
            beta[k] *= f[k] / pdf;
            largest = largest.max(beta[k].max_element());
            finite &= beta[k].is_finite();
        }
        if !(largest > 0.0) || !finite {
            break;
        }
        ray = Ray {
            origin: spawn_origin(p, info.n, dir),
            dir,
            tmax: f32::INFINITY,
        };
        skip = prim;
        prev_pdf = pdf;
        camera_ray = false;
        bounces += 1;
        if bounces >= rr_depth {
            let q = largest.min(1.0);
            let u = sampler.next_1d();
            if q < 1.0 {
                if u >= q {
                    break;
                }
                for b in &mut beta {
                    *b /= q;
                }
            }
        }
    }
    l
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lights::{AnyLight, EnvMap, SkyLight};

    fn sky_set(w: usize, h: usize, texel: impl Fn(usize, usize) -> Vec3) -> LightSet {
        let texels = (0..w * h).map(|t| texel(t % w, t / w)).collect();
        let map = EnvMap::new(w, h, texels, 0.0).expect("a map");
        LightSet {
            lights: vec![AnyLight::Sky(SkyLight::Image(Box::new(map)))],
            sky_mean: Vec3::ONE,
            pick: None,
            nee_count: 1,
            escaping: vec![0],
        }
    }

    /// Each set's sky is the grey base sky times a colour that is constant over each coarse
    /// cell (and differs between cells and sets): [`SkySets::at`] gives it back at every
    /// texel, within half precision, for a power-of-two width (cells by shifts) and for
    /// another (by divisions).
    #[test]
    fn sky_sets_give_each_sets_texels_back() {
        for (w, h) in [(512, 256), (600, 300)] {
            let factor = (w / SKY_CELLS).max(1);
            let base_value = |x: usize, y: usize| 0.5 + ((x * 7 + y * 13) % 17) as f32;
            let colour = |j: usize, x: usize, y: usize| {
                let (cx, cy) = ((x / factor) as f32, (y / factor) as f32);
                Vec3::new(
                    0.2 + 0.01 * cx + 0.1 * j as f32,
                    0.3 + 0.02 * cy,
                    0.9 - 0.003 * (cx + cy),
                )
            };
            let base = sky_set(w, h, |x, y| Vec3::splat(base_value(x, y)));
            let sets: Vec<ChannelSet> = (0..3)
                .map(|j| ChannelSet {
                    materials: Vec::new(),
                    lights: sky_set(w, h, |x, y| base_value(x, y) * colour(j, x, y)),
                })
                .collect();
            let AnyLight::Sky(sky) = &base.lights[0] else {
                unreachable!("a sky")
            };
            let s = SkySets::new(sky, &sets, vec![2, 0, 1], 1).expect("a map sky");
            assert_eq!(s.shifts.is_some(), w.is_power_of_two(), "{w}");
            for t in (0..w * h).step_by(7) {
                let (x, y) = (t % w, t / w);
                let b = Vec3::splat(base_value(x, y));
                let got = s.at(t as u32, b, &[0, 1, 2], &[2, 0, 1]);
                for (j, g) in got.iter().enumerate() {
                    let want = b * colour(j, x, y);
                    assert!(
                        ((*g - want).abs() / want).max_element() < 2e-3,
                        "{w}x{h} texel ({x}, {y}) set {j}: {g} vs {want}"
                    );
                }
            }
        }
    }
}
