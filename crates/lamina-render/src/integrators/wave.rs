//! The path tracer over pixel samples side by side: a *wavefront* of up to [`LANES`]
//! paths followed vertex by vertex, the same estimator as [`super::path`] and the same
//! numbers bit for bit, computed in another order.
//!
//! [`super::path::trace`] follows one path to its end before the next starts: every
//! vertex is a chain of dependent work (hit, surface, light samples, shadow rays, BSDF
//! sample, next ray). Here the samples of a tile's pass advance [`LANES`] at a time: a
//! pixel's 16 samples of a full pass, or several pixels' samples side by side in a smaller
//! pass (a progressive render's first passes, of 1 to 8 samples per pixel, or a last pass
//! of what remains), so that no lane idles for want of samples.
//! Their camera rays are made in vector lanes, their next-event and BSDF arithmetic runs
//! in loops over the lanes that the compiler vectorizes ([`lamina_accel::wide::run_wide`]:
//! AVX2 + FMA where the CPU has them), their random numbers are drawn dimension by
//! dimension for all lanes (every sample draws the same dimensions in the same order;
//! lanes of one pixel share each dimension's seed, [`LaneSampler`]), and their ray queries
//! are issued back to back, independent walks the CPU overlaps. Each lane's radiance is
//! added to its pixel's sums in sample order, as the one-path loop adds it. The ray
//! queries stay one ray at a time ([`crate::accel::Accel`]'s), and so do the per-lane
//! parts that read memory (the hit's surface, a light's sample): only their order changes.
//!
//! **What it serves** ([`Wave::new`]): RGB renders with the `path` integrator. A lane
//! whose vertex is on a `diffuse` or `diffuse_transmission` material without a normal map
//! (colours constant or from textures, looked up per hit: the diffuse leaves of canopy and
//! comparison scenes) has its lobes' arithmetic done in the lane loops; a lane on any
//! other material (`leaf` with its maps, glTF's `pbr`, a normal map) builds the
//! material's [`SurfaceBsdf`] at its hit and calls its `eval`, `pdf` and `sample` as
//! `path.rs` does, lane by lane, in the same wave (its ray queries still back to back
//! with the other lanes'). Next-event estimation samples every light (`light_sampling =
//! "all"`, up to [`MAX_LIGHTS`] of them) or one light per lane drawn by power (`"one"`,
//! any number). Geometry (mattes, instances, vertex normals, periodic domains), lights,
//! sky, camera and filter are whatever the scene has. Spectral renders, renders with
//! [`crate::RenderOptions::one_path_at_a_time`], and CPUs without AVX2 + FMA (where the
//! lane loops compiled for plain x86-64 are slower than one path at a time) take
//! [`super::path`] one path at a time;
//! `wavefront_is_path_bit_for_bit` (the render tests) renders both ways and compares
//! every pixel's sums.
//!
//! Per lane the work follows `path::trace` step for step, with the arithmetic of
//! `Lambertian` / `DiffuseTransmission` (`lamina_leaf::lambert`), `ShadingFrame`,
//! `cosine_hemisphere`, `spawn_origin` and `power_heuristic` written out over the lanes in
//! the same operation order, so that every lane's value is the one-path value.

// Lane loops index several arrays of the same lane side by side (`for k in 0..LANES`):
// the form the compiler vectorizes, and the clearest for structure-of-arrays code.
#![allow(clippy::needless_range_loop)]

use super::SceneContext;
use crate::accel::{Hit, HitKind, ID_MASK, PrimRef, Ray, spawn_origin};
use crate::lights::{AnyLight, LightSample, power_heuristic};
use crate::materials::SurfaceBsdf;
use crate::sampler::{LaneSampler, PixelStream};
use crate::shading::{ShadingFrame, shading_normal};
use glam::{Vec2, Vec3};
use lamina_accel::wide::{WideTask, run_wide};
use lamina_core::{ColorInput, Integrator, Material};
use lamina_leaf::Bsdf;
use lamina_leaf::frame::Frame;
use lamina_leaf::lambert::DiffuseTransmission;
use std::f32::consts::{FRAC_1_PI, FRAC_PI_4};

/// Paths of a wave: samples of one pass (one pixel's or several pixels'), up to this many
/// at a time.
pub(crate) const LANES: usize = 16;
/// Most lights next-event estimation samples at a vertex, under `light_sampling = "all"`,
/// in a scene the wave serves.
const MAX_LIGHTS: usize = 8;

type Lanes = [f32; LANES];
type Lanes3 = [[f32; LANES]; 3];

/// What the unused slots of a wave's ray arrays hold (never traced).
const EMPTY_RAY: Ray = Ray {
    origin: Vec3::ZERO,
    dir: Vec3::Z,
    tmax: 0.0,
};

/// A served material's lobes at a point: `R / π` on the side of `wo`, `T / π` across, the
/// reflection lobe sampled with probability `pr` (`diffuse`: `T = 0`, `pr = 1`, which is
/// `Lambertian`'s arithmetic exactly).
#[derive(Clone, Copy, Debug)]
struct Lobes {
    r: [f32; 3],
    t: [f32; 3],
    pr: f32,
}

impl Lobes {
    /// Whether the lane arithmetic serves material `m`: `diffuse` or
    /// `diffuse_transmission` without a normal map.
    fn serves(m: &Material) -> bool {
        m.normal_map().is_none()
            && matches!(
                m,
                Material::Diffuse { .. } | Material::DiffuseTransmission { .. }
            )
    }

    /// Served material `m`'s lobes at texture coordinates `uv` (its colours as
    /// `SurfaceBsdf::at` reads them; black for a material the wave does not serve).
    fn at(m: &Material, uv: Vec2) -> Lobes {
        match m {
            Material::Diffuse { reflectance, .. } => Lobes {
                r: reflectance.at(uv).to_array(),
                t: [0.0; 3],
                pr: 1.0,
            },
            Material::DiffuseTransmission {
                reflectance,
                transmittance,
                ..
            } => {
                let d = DiffuseTransmission {
                    reflectance: reflectance.at(uv),
                    transmittance: transmittance.at(uv),
                };
                Lobes {
                    r: d.reflectance.to_array(),
                    t: d.transmittance.to_array(),
                    pr: d.reflect_probability(),
                }
            }
            _ => NO_LOBES,
        }
    }
}

/// Black lobes: what a lane whose material the lane arithmetic does not serve carries.
const NO_LOBES: Lobes = Lobes {
    r: [0.0; 3],
    t: [0.0; 3],
    pr: 1.0,
};

/// How the wave shades a material: diffuse lobes in lanes, constant or (colours from
/// textures) looked up at each hit, or any other material (`leaf`, `pbr`, a normal map)
/// through its [`SurfaceBsdf`], built at each hit and called lane by lane exactly as
/// `path.rs` calls it.
#[derive(Clone, Copy, Debug)]
enum Served {
    Constant(Lobes),
    Textured,
    General,
}

/// The wavefront path tracer for one scene (module docs).
#[derive(Debug)]
pub(crate) struct Wave {
    /// Per material index.
    lobes: Vec<Served>,
    max_depth: u32,
    rr_depth: u32,
    /// Whether any primitive or shape emits (quad and sphere lights): only then can a hit
    /// be an emitter's.
    emitters: bool,
    /// [`crate::lights::LightSet::constant_escape`]: where every escaping ray sees the same
    /// constant sky, its radiance and MIS density, so that the lanes that escape add it in
    /// lanes, with no per-lane branch on which lanes escaped.
    sky: Option<(Vec3, f32)>,
}

impl Wave {
    /// The wave for `ctx`'s scene, or `None` where it does not serve it (module docs).
    pub(crate) fn new(ctx: &SceneContext) -> Option<Wave> {
        let Integrator::Path {
            max_depth,
            rr_depth,
            ..
        } = ctx.scene.integrator
        else {
            return None;
        };
        let all = ctx.lights.pick.is_none();
        if (all && ctx.lights.nee().len() > MAX_LIGHTS) || !ctx.sets.is_empty() {
            return None;
        }
        let constant = |c: &ColorInput| matches!(c, ColorInput::Constant(_));
        let mut lobes = Vec::with_capacity(ctx.scene.materials.len());
        for m in &ctx.scene.materials {
            if !Lobes::serves(m) {
                lobes.push(Served::General);
                continue;
            }
            let here = Lobes::at(m, Vec2::ZERO);
            lobes.push(match m {
                Material::Diffuse { reflectance, .. } if constant(reflectance) => {
                    Served::Constant(here)
                }
                Material::DiffuseTransmission {
                    reflectance,
                    transmittance,
                    ..
                } if constant(reflectance) && constant(transmittance) => Served::Constant(here),
                _ => Served::Textured,
            });
        }
        let emitters = ctx
            .lights
            .lights
            .iter()
            .any(|l| matches!(l, AnyLight::Quad(_) | AnyLight::Sphere(_)));
        Some(Wave {
            lobes,
            max_depth,
            rr_depth,
            emitters,
            sky: ctx.lights.constant_escape(),
        })
    }

    /// Samples `s0..s1` of every pixel of the `w` x `h` pixels from `(x0, y0)` (a tile,
    /// row by row; `seed`: the folded render seed), each sample's radiance (RGB) added into
    /// its pixel's three `sums` (row-major) in sample order as the one-path loop adds it (a
    /// non-finite sample counts as black); the rays traced are added to `rays`.
    ///
    /// The samples go into waves of [`LANES`] in that order: a pass of 16 samples makes
    /// one wave per pixel, a pass of fewer (a progressive render's first passes add 1, 1, 2,
    /// 4 and 8) puts
    /// several pixels' samples side by side, so that no lane idles while others run (a
    /// wave of one sample costs nearly a full wave's lane work, and its one ray walk
    /// overlaps no other).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn tile(
        &self,
        ctx: &SceneContext,
        seed: u32,
        (x0, y0, w, h): (u32, u32, u32, u32),
        s0: u32,
        s1: u32,
        sums: &mut [f64],
        rays: &mut u64,
    ) {
        debug_assert_eq!(sums.len(), (w * h) as usize * 3);
        let mut lanes = WaveLanes::new();
        // The vertices' surfaces, reused from wave to wave (lanes hold stale values until
        // a hit fills them; the lane loops compute on them harmlessly and the results are
        // dropped).
        let mut g = Surfaces::new();
        for y in y0..y0 + h {
            for x in x0..x0 + w {
                let stream = PixelStream::new(seed, x, y);
                let at = ((y - y0) * w + (x - x0)) as usize * 3;
                for i in s0..s1 {
                    if lanes.n == LANES {
                        self.run(ctx, &mut lanes, &mut g, sums, rays);
                    }
                    let k = lanes.n;
                    lanes.stream[k] = stream;
                    lanes.pixel[k] = (x, y);
                    lanes.index[k] = i;
                    lanes.at[k] = at;
                    lanes.n += 1;
                }
            }
        }
        if lanes.n > 0 {
            self.run(ctx, &mut lanes, &mut g, sums, rays);
        }
    }

    /// Traces `lanes`' wave, adds each lane's radiance to its pixel's sums in lane order
    /// and empties the wave.
    fn run(
        &self,
        ctx: &SceneContext,
        lanes: &mut WaveLanes,
        g: &mut Surfaces,
        sums: &mut [f64],
        rays: &mut u64,
    ) {
        // The lanes past `n` repeat lane 0's sample: computed on, never added.
        for k in lanes.n..LANES {
            lanes.stream[k] = lanes.stream[0];
            lanes.pixel[k] = lanes.pixel[0];
            lanes.index[k] = lanes.index[0];
        }
        let l = run_wide(Paths {
            wave: self,
            ctx,
            lanes,
            rays,
            g,
        });
        // A pixel's lanes are neighbours: their sum is kept in registers across them (the
        // same additions in the same order, without a store and reload between each).
        let mut k = 0;
        while k < lanes.n {
            let at = lanes.at[k];
            let mut acc = [sums[at], sums[at + 1], sums[at + 2]];
            while k < lanes.n && lanes.at[k] == at {
                let v = [l[0][k], l[1][k], l[2][k]];
                if v.iter().all(|c| c.is_finite()) {
                    for (s, c) in acc.iter_mut().zip(v) {
                        *s += c as f64;
                    }
                }
                k += 1;
            }
            sums[at..at + 3].copy_from_slice(&acc);
        }
        lanes.n = 0;
    }
}

/// The samples of a wave: lane `k < n` is sample `index[k]` of pixel `pixel[k]`, whose
/// stream is `stream[k]` and whose sums start at `at[k]`.
struct WaveLanes {
    stream: [PixelStream; LANES],
    pixel: [(u32, u32); LANES],
    index: [u32; LANES],
    at: [usize; LANES],
    n: usize,
}

impl WaveLanes {
    fn new() -> Self {
        WaveLanes {
            stream: [PixelStream::new(0, 0, 0); LANES],
            pixel: [(0, 0); LANES],
            index: [0; LANES],
            at: [0; LANES],
            n: 0,
        }
    }
}

/// One wave, run through [`run_wide`].
struct Paths<'a, 'c> {
    wave: &'a Wave,
    ctx: &'a SceneContext<'c>,
    lanes: &'a WaveLanes,
    rays: &'a mut u64,
    g: &'a mut Surfaces,
}

impl WideTask for Paths<'_, '_> {
    /// Each lane's radiance (W m⁻² sr⁻¹, linear Rec.709), per channel.
    type Output = Lanes3;

    #[inline(always)]
    fn run(self) -> Lanes3 {
        let Paths {
            wave,
            ctx,
            lanes,
            rays,
            g,
        } = self;
        wave.trace(ctx, lanes, rays, g)
    }
}

/// A vertex's surfaces, lane by lane: the point, the shading frame (`s`, `t`, `n`), the
/// geometric normal, whether the frame is smooth, and the material's lobes.
struct Surfaces {
    p: Lanes3,
    s: Lanes3,
    t: Lanes3,
    n: Lanes3,
    ng: Lanes3,
    smooth: [bool; LANES],
    r: Lanes3,
    tr: Lanes3,
    pr: Lanes,
    prim: [PrimRef; LANES],
    /// Lanes whose material is [`Served::General`]: their BSDF, shading frame and `wo`
    /// (local) at this vertex (other lanes hold stale values, never read).
    bsdf: [SurfaceBsdf; LANES],
    frame: [ShadingFrame; LANES],
    wo: [Vec3; LANES],
}

impl Surfaces {
    fn new() -> Self {
        let z = [[0.0; LANES]; 3];
        Surfaces {
            p: z,
            s: z,
            t: z,
            n: z,
            ng: z,
            smooth: [false; LANES],
            r: z,
            tr: z,
            pr: [0.0; LANES],
            prim: [PrimRef::NONE; LANES],
            bsdf: [SurfaceBsdf::BLANK; LANES],
            frame: [ShadingFrame::geometric(Frame::from_normal(Vec3::Z), Vec3::Z); LANES],
            wo: [Vec3::Z; LANES],
        }
    }
}

/// The lanes set in `b`, as a bit mask.
#[inline(always)]
fn bits(b: &[bool; LANES]) -> u32 {
    let mut m = 0u32;
    for (k, &v) in b.iter().enumerate() {
        m |= u32::from(v) << k;
    }
    m
}

/// The lanes of mask `m`, lowest first.
#[inline(always)]
fn lanes_of(mut m: u32) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        (m != 0).then(|| {
            let k = m.trailing_zeros() as usize;
            m &= m - 1;
            k
        })
    })
}

#[inline(always)]
fn get3(a: &Lanes3, k: usize) -> Vec3 {
    Vec3::new(a[0][k], a[1][k], a[2][k])
}

#[inline(always)]
fn set3(a: &mut Lanes3, k: usize, v: Vec3) {
    for c in 0..3 {
        a[c][k] = v[c];
    }
}

/// Adds `v` to lane `k` (per channel, as `Vec3 += Vec3`).
#[inline(always)]
fn add3(a: &mut Lanes3, k: usize, v: Vec3) {
    for c in 0..3 {
        a[c][k] += v[c];
    }
}

/// `a · b` lane `k`, as glam's `Vec3::dot`: `(x x' + y y') + z z'`.
#[inline(always)]
fn dot(a: [f32; 3], b: &Lanes3, k: usize) -> f32 {
    (a[0] * b[0][k] + a[1] * b[1][k]) + a[2] * b[2][k]
}

/// `cosine_hemisphere_pdf`.
#[inline(always)]
fn cos_pdf(c: f32) -> f32 {
    c.max(0.0) * FRAC_1_PI
}

/// The lobe probability `DiffuseTransmission::pdf` (and `Lambertian`'s, `pr = 1`) weighs
/// with for `wo.z · wi.z = c`.
#[inline(always)]
fn lobe_of(c: f32, pr: f32) -> f32 {
    if c > 0.0 {
        pr
    } else if c < 0.0 {
        1.0 - pr
    } else {
        0.0
    }
}

impl Wave {
    /// The radiance of `lanes`' samples (module docs: the steps are `path::trace`'s, named
    /// alike).
    #[inline(always)]
    fn trace(
        &self,
        ctx: &SceneContext,
        lanes: &WaveLanes,
        rays: &mut u64,
        g: &mut Surfaces,
    ) -> Lanes3 {
        let n = lanes.n;
        // Camera rays: film draws, the filter's offsets, the camera.
        let (mut fx, mut fy) = ([0.0f32; LANES], [0.0f32; LANES]);
        let mut sampler = LaneSampler::<LANES>::film(&lanes.stream, &lanes.index, &mut fx, &mut fy);
        for k in 0..LANES {
            let off = ctx.filter.sample(Vec2::new(fx[k], fy[k]));
            let (x, y) = lanes.pixel[k];
            fx[k] = (x as f32 + 0.5) + off.x;
            fy[k] = (y as f32 + 0.5) + off.y;
        }
        let mut o = [[0.0f32; LANES]; 3];
        let mut d = [[0.0f32; LANES]; 3];
        let ray_of = |o: &Lanes3, d: &Lanes3, k: usize| Ray {
            origin: get3(o, k),
            dir: get3(d, k),
            tmax: f32::INFINITY,
        };
        let mut hit: [Option<Hit>; LANES] = [None; LANES];
        if ctx.camera.uses_lens() {
            let (mut lx, mut ly) = ([0.0f32; LANES], [0.0f32; LANES]);
            sampler.peek_2d(0, &mut lx, &mut ly);
            for k in 0..n {
                let (ro, rd) = ctx
                    .camera
                    .generate_ray(Vec2::new(fx[k], fy[k]), Vec2::new(lx[k], ly[k]));
                set3(&mut o, k, ro);
                set3(&mut d, k, rd);
            }
            let cam: [Ray; LANES] = std::array::from_fn(|k| ray_of(&o, &d, k));
            let m = crate::accel::Accel::MANY;
            for (r, h) in cam[..n].chunks(m).zip(hit[..n].chunks_mut(m)) {
                ctx.accel.intersect_many(r, h);
            }
        } else {
            // A pinhole's rays all leave the eye: traced from the lanes themselves.
            let eye = ctx.camera.pinhole_lanes(&fx, &fy, &mut d);
            for (c, o) in o.iter_mut().enumerate() {
                *o = [eye[c]; LANES];
            }
            ctx.accel
                .intersect_eye(eye, [&d[0][..n], &d[1][..n], &d[2][..n]], &mut hit[..n]);
        }
        sampler.skip(1); // the lens draw, made or skipped
        {
            for h in &hit[..n] {
                if let Some(Hit {
                    kind: HitKind::Triangle { prim, .. },
                    ..
                }) = h
                {
                    ctx.accel.prefetch_surface(*prim);
                }
            }
        }

        let lights = &ctx.lights.lights;
        let nee = ctx.lights.nee();
        let nl = nee.len() as u32;
        let mut alive: u32 = (1u32 << n) - 1;
        let mut l = [[0.0f32; LANES]; 3];
        let mut beta = [[1.0f32; LANES]; 3];
        let mut prev_pdf = [0.0f32; LANES];
        let mut bary = [Vec2::ZERO; LANES];
        let mut bounces = 0u32;
        loop {
            *rays += u64::from(alive.count_ones());
            // Misses see the infinite lights, emitters end their paths, and so do other
            // shapes and the depth limit.
            let mut missed = 0u32;
            for k in 0..LANES {
                missed |= u32::from(hit[k].is_none()) << k;
            }
            missed &= alive;
            match self.sky {
                // A constant sky: every lane in turn, those that escaped adding it (as the
                // loop below adds it, `b * le * w`), the others nothing.
                Some((le, pdf)) => {
                    for k in 0..LANES {
                        let w = if bounces == 0 {
                            1.0
                        } else {
                            power_heuristic(prev_pdf[k], pdf)
                        };
                        // The term times 1 in an escaped lane, times 0 in the others,
                        // where it is finite (every lane's throughput is: ended lanes
                        // keep a zero, see the BSDF sample below; `le` and `w` are), so
                        // that adding it leaves the sum as it was. Written so, the loop
                        // compiles to plain vector stores: a select, or a selected 0.0,
                        // became masked stores (slow on AMD; no store-to-load
                        // forwarding to the next read of `l`).
                        let on = f32::from(u8::from(missed & (1 << k) != 0));
                        for c in 0..3 {
                            l[c][k] += ((beta[c][k] * le[c]) * w) * on;
                        }
                    }
                }
                None => {
                    for k in lanes_of(missed) {
                        let (dir, b) = (get3(&d, k), get3(&beta, k));
                        for &i in &ctx.lights.escaping {
                            let (le, pdf) = lights[i].escaped(dir);
                            if le != Vec3::ZERO {
                                let w = if bounces == 0 {
                                    1.0
                                } else {
                                    power_heuristic(prev_pdf[k], pdf * ctx.lights.pick_prob(i))
                                };
                                add3(&mut l, k, b * le * w);
                            }
                        }
                    }
                }
            }
            alive &= !missed;
            for k in lanes_of(alive) {
                let h = hit[k].expect("a lane that did not escape has a hit");
                if let Some((le, pdf)) = self
                    .emitters
                    .then(|| ctx.emitter(h.kind, &ray_of(&o, &d, k), h.t))
                    .flatten()
                {
                    let b = get3(&beta, k);
                    let w = if bounces == 0 {
                        1.0
                    } else {
                        power_heuristic(prev_pdf[k], pdf)
                    };
                    add3(&mut l, k, b * le * w);
                    alive &= !(1 << k);
                    continue;
                }
                match h.kind {
                    HitKind::Triangle { prim, bary: b } if bounces < self.max_depth => {
                        g.prim[k] = prim;
                        bary[k] = b;
                    }
                    _ => alive &= !(1 << k),
                }
            }
            if alive == 0 {
                break;
            }
            // The surfaces (per lane: memory reads).
            let mut general = 0u32;
            for k in lanes_of(alive) {
                let (prim, b) = (g.prim[k], bary[k]);
                let (p, info) = ctx.accel.surface(prim, b);
                let m = (info.flags & ID_MASK) as usize;
                let material = &ctx.scene.materials[m];
                let lobes = match self.lobes[m] {
                    Served::Constant(l) => l,
                    Served::Textured => Lobes::at(material, info.uv_at(b)),
                    Served::General => {
                        general |= 1 << k;
                        NO_LOBES
                    }
                };
                // Only a material the lane arithmetic does not serve can have a normal map.
                let map = (general & (1 << k) != 0)
                    .then(|| material.normal_map())
                    .flatten();
                let ns = shading_normal(&ctx.accel, prim, b, &info, map);
                let frame = ShadingFrame::new(&info, ns, -get3(&d, k));
                if general & (1 << k) != 0 {
                    g.bsdf[k].set_at(material, info.uv_at(b));
                    g.frame[k] = frame;
                    g.wo[k] = frame.to_local(-get3(&d, k));
                }
                set3(&mut g.p, k, p);
                set3(&mut g.s, k, frame.frame.s);
                set3(&mut g.t, k, frame.frame.t);
                set3(&mut g.n, k, frame.frame.n);
                set3(&mut g.ng, k, info.n);
                g.smooth[k] = frame.is_smooth();
                for c in 0..3 {
                    g.r[c][k] = lobes.r[c];
                    g.tr[c][k] = lobes.t[c];
                }
                g.pr[k] = lobes.pr;
            }
            // wo's height in the shading frame (its other coordinates no lobe reads).
            let mut woz = [0.0f32; LANES];
            for k in 0..LANES {
                woz[k] = dot([-d[0][k], -d[1][k], -d[2][k]], &g.n, k);
            }
            // Next-event estimation: each light's sample per lane, its value in lanes, the
            // shadow rays per lane. Every light of `nee` in turn (`light_sampling = "all"`),
            // or (`"one"`) one light per lane, drawn by the vertex's first number
            // (`SceneContext::nee_lights`), its sample's numbers after it.
            let picked = ctx.lights.pick.as_ref().map(|pick| {
                let mut u = [0.0f32; LANES];
                sampler.peek_1d(0, &mut u);
                let (mut which, mut prob) = ([0usize; LANES], [1.0f32; LANES]);
                for k in lanes_of(alive) {
                    (which[k], prob[k]) = pick.choose(u[k]);
                }
                (which, prob)
            });
            let (first, rounds) = if picked.is_some() { (1, 1) } else { (0, nl) };
            for j in 0..rounds {
                let (mut ux, mut uy) = ([0.0f32; LANES], [0.0f32; LANES]);
                if picked.is_some() || nee[j as usize].uses_sample() {
                    sampler.peek_2d(first + j, &mut ux, &mut uy);
                }
                let mut ls: [Option<LightSample>; LANES] = [None; LANES];
                let mut wi = [[0.0f32; LANES]; 3];
                let mut li = [[0.0f32; LANES]; 3];
                let mut lpdf = [1.0f32; LANES];
                let mut delta = [false; LANES];
                let mut valid = [false; LANES];
                for k in lanes_of(alive) {
                    // The lane's light and the probability it was drawn with (1 under "all").
                    let (light, pick) = match &picked {
                        Some((which, prob)) => (&nee[which[k]], prob[k]),
                        None => (&nee[j as usize], 1.0),
                    };
                    // A light that reads no sample gets zeros (`next_2d_if`).
                    let u = if light.uses_sample() {
                        Vec2::new(ux[k], uy[k])
                    } else {
                        Vec2::ZERO
                    };
                    let Some(mut s) = light.sample(get3(&g.p, k), u) else {
                        continue;
                    };
                    s.pdf *= pick;
                    let frame_ok = !g.smooth[k]
                        || (s.wi.dot(get3(&g.ng, k)) > 0.0) == (s.wi.dot(get3(&g.n, k)) > 0.0);
                    valid[k] = s.pdf > 0.0 && s.li != Vec3::ZERO && frame_ok;
                    set3(&mut wi, k, s.wi);
                    set3(&mut li, k, s.li);
                    lpdf[k] = s.pdf;
                    delta[k] = s.delta;
                    ls[k] = Some(s);
                }
                let mut shoot = [false; LANES];
                let mut add = [[0.0f32; LANES]; 3];
                for k in 0..LANES {
                    let wiz = dot([wi[0][k], wi[1][k], wi[2][k]], &g.n, k);
                    let c = woz[k] * wiz;
                    let cos = FRAC_1_PI * wiz.abs();
                    // `eval`: R on wo's side, T across, nothing edge-on.
                    let (fr, fg, fb) = if c > 0.0 {
                        (g.r[0][k] * cos, g.r[1][k] * cos, g.r[2][k] * cos)
                    } else if c < 0.0 {
                        (g.tr[0][k] * cos, g.tr[1][k] * cos, g.tr[2][k] * cos)
                    } else {
                        (0.0, 0.0, 0.0)
                    };
                    let bpdf = lobe_of(c, g.pr[k]) * cos_pdf(wiz.abs());
                    // `power_heuristic(lpdf, bpdf)`; delta lights weigh 1.
                    let (a2, b2) = (lpdf[k] * lpdf[k], bpdf * bpdf);
                    let ph = if a2.is_infinite() {
                        1.0
                    } else if a2 + b2 > 0.0 {
                        a2 / (a2 + b2)
                    } else {
                        0.0
                    };
                    let scale = if delta[k] { 1.0 } else { ph } / lpdf[k];
                    add[0][k] = ((beta[0][k] * fr) * li[0][k]) * scale;
                    add[1][k] = ((beta[1][k] * fg) * li[1][k]) * scale;
                    add[2][k] = ((beta[2][k] * fb) * li[2][k]) * scale;
                    shoot[k] = valid[k] && (fr != 0.0 || fg != 0.0 || fb != 0.0);
                }
                // Other materials' lanes: `path.rs`'s steps, lane by lane.
                for k in lanes_of(alive & general & bits(&valid)) {
                    let Some(s) = ls[k].as_ref() else { continue };
                    let (bsdf, wo) = (&g.bsdf[k], g.wo[k]);
                    let wi = g.frame[k].to_local(s.wi);
                    let f = bsdf.eval(wo, wi);
                    shoot[k] = f != Vec3::ZERO;
                    let w = if s.delta {
                        1.0
                    } else {
                        power_heuristic(s.pdf, bsdf.pdf(wo, wi))
                    };
                    set3(&mut add, k, get3(&beta, k) * f * s.li * (w / s.pdf));
                }
                // The shadow rays of the lanes that shoot. At the first vertex the lanes are
                // one pixel's samples (or neighbouring pixels'), on the same few surfaces:
                // their rays toward a sun run the same cells of the sun's grid and are
                // tested together (`Accel::occluded_many`: `scene_rays`' sun set 24 % faster
                // on the Mitsuba scene, 35 % on the bush). Deeper vertices are scattered, and
                // so are rays toward a sky or an area light, or toward a light drawn per
                // lane: there the grouping costs more than it saves (a 4000-card frame 3 %
                // slower with it at every vertex, a sunsky scene 3 % slower with its sky's
                // rays in it), and the rays go one by one.
                let mut shadow = [EMPTY_RAY; LANES];
                let mut skip = [PrimRef::NONE; LANES];
                let mut which = [0usize; LANES];
                let mut m = 0;
                for k in lanes_of(alive & bits(&shoot)) {
                    let s = ls[k].as_ref().expect("a valid lane has its sample");
                    shadow[m] = SceneContext::shadow_ray(get3(&g.p, k), get3(&g.ng, k), s);
                    skip[m] = g.prim[k];
                    which[m] = k;
                    m += 1;
                }
                let mut blocked = [false; LANES];
                let sun = picked.is_none() && matches!(nee[j as usize], AnyLight::Sun(_));
                if bounces == 0 && sun {
                    ctx.accel
                        .occluded_many(&shadow[..m], &skip[..m], &mut blocked[..m]);
                } else {
                    for i in 0..m {
                        blocked[i] = ctx.accel.occluded_skip(&shadow[i], skip[i]);
                    }
                }
                *rays += m as u64;
                for i in 0..m {
                    if !blocked[i] {
                        add3(&mut l, which[i], get3(&add, which[i]));
                    }
                }
            }
            // The BSDF's numbers come after the lights' (one each, after the pick's), then
            // roulette's.
            let drawn = first + rounds;
            let mut u1 = [0.0f32; LANES];
            let (mut u2, mut u3) = ([0.0f32; LANES], [0.0f32; LANES]);
            sampler.peek_1d(drawn, &mut u1);
            sampler.peek_2d(drawn + 1, &mut u2, &mut u3);
            sampler.skip(drawn + 2);
            let roulette = bounces + 1 >= self.rr_depth;
            let mut ur = [0.0f32; LANES];
            if roulette {
                sampler.peek_1d(0, &mut ur);
                sampler.skip(1);
            }
            // Other materials' lanes are made after the lane loop below, from the
            // throughput it overwrites.
            let beta_in = (general != 0).then_some(beta);
            // The BSDF sample, the throughput, roulette and the next ray, in lanes.
            let mut go = [false; LANES];
            let mut pdfs = [0.0f32; LANES];
            let mut next_o = [[0.0f32; LANES]; 3];
            let mut next_d = [[0.0f32; LANES]; 3];
            for k in 0..LANES {
                // `cosine_hemisphere(u2, u3)` by the concentric map.
                let px = 2.0 * u2[k] - 1.0;
                let py = 2.0 * u3[k] - 1.0;
                let centre = px == 0.0 && py == 0.0;
                let x_major = px.abs() > py.abs();
                let (r0, other) = if x_major { (px, py) } else { (py, px) };
                let a = FRAC_PI_4 * (other / r0);
                let (cc, sn) = lamina_leaf::sampling::cos_sin_quarter(a);
                let (dx, dy) = if x_major { (cc, sn) } else { (sn, cc) };
                let r = if centre { 0.0 } else { r0 };
                let (dx, dy) = if centre { (0.0, 0.0) } else { (dx, dy) };
                let z = (1.0 - r * r).max(0.0).sqrt();
                let (wx, wy) = (r * dx, r * dy);
                // The lobe: reflection stays on wo's side, transmission crosses.
                let reflect = u1[k] < g.pr[k];
                let flip = (woz[k] < 0.0) == reflect;
                let wz = if flip { -z } else { z };
                let lobe = if reflect { g.pr[k] } else { 1.0 - g.pr[k] };
                let cos = wz.abs();
                let pdf = lobe * cos_pdf(cos);
                let fc = FRAC_1_PI * cos;
                let mut b = [0.0f32; 3];
                for c in 0..3 {
                    let albedo = if reflect { g.r[c][k] } else { g.tr[c][k] };
                    b[c] = beta[c][k] * ((albedo * fc) / pdf);
                }
                // `ShadingFrame::to_world_unit`.
                let mut w = [0.0f32; 3];
                for c in 0..3 {
                    w[c] = (g.s[c][k] * wx + g.t[c][k] * wy) + g.n[c][k] * wz;
                }
                let len2 = (w[0] * w[0] + w[1] * w[1]) + w[2] * w[2];
                let renorm = (len2 - 1.0).abs() > 1e-6;
                let inv = 1.0 / len2.sqrt();
                for v in &mut w {
                    *v = if renorm { *v * inv } else { *v };
                }
                let wng = dot(w, &g.ng, k);
                let consistent = !g.smooth[k] || (wng > 0.0) == (dot(w, &g.n, k) > 0.0);
                let mx = b[0].max(b[1]).max(b[2]);
                let mut on = woz[k] != 0.0
                    && pdf > 0.0
                    && consistent
                    && mx > 0.0
                    && b.iter().all(|v| v.is_finite());
                if roulette {
                    let q = mx.min(1.0);
                    let cut = q < 1.0;
                    on &= !cut || ur[k] < q;
                    for v in &mut b {
                        *v = if cut { *v / q } else { *v };
                    }
                }
                go[k] = on;
                pdfs[k] = pdf;
                // Lanes that end here keep a zero throughput rather than whatever their
                // inputs made (NaN even): the escaped-sky sum multiplies every lane's.
                for c in 0..3 {
                    beta[c][k] = if on { b[c] } else { 0.0 };
                }
                // `spawn_origin(p, ng, w)`.
                let p = [g.p[0][k], g.p[1][k], g.p[2][k]];
                let eps = 2e-5 * (1.0 + p[0].abs().max(p[1].abs()).max(p[2].abs()));
                let e = if wng >= 0.0 { eps } else { -eps };
                for c in 0..3 {
                    next_o[c][k] = p[c] + g.ng[c][k] * e;
                    next_d[c][k] = w[c];
                }
            }
            // Other materials' lanes: the BSDF sample, throughput, roulette and next ray as
            // `path.rs` makes them.
            if let Some(beta_in) = beta_in {
                for k in lanes_of(alive & general) {
                    go[k] = false;
                    let frame = &g.frame[k];
                    let u = Vec3::new(u1[k], u2[k], u3[k]);
                    let Some(bs) = g.bsdf[k].sample(g.wo[k], u) else {
                        continue;
                    };
                    if !(bs.pdf > 0.0) {
                        continue;
                    }
                    let dir = frame.to_world_unit(bs.wi);
                    if !frame.consistent(dir) {
                        continue;
                    }
                    let mut b = get3(&beta_in, k) * (bs.f / bs.pdf);
                    if !(b.max_element() > 0.0) || !b.is_finite() {
                        continue;
                    }
                    if roulette {
                        let q = b.max_element().min(1.0);
                        if q < 1.0 {
                            if ur[k] >= q {
                                continue;
                            }
                            b /= q;
                        }
                    }
                    go[k] = true;
                    pdfs[k] = bs.pdf;
                    set3(&mut beta, k, b);
                    set3(&mut next_o, k, spawn_origin(get3(&g.p, k), frame.ng, dir));
                    set3(&mut next_d, k, dir);
                }
            }
            alive &= bits(&go);
            prev_pdf = pdfs;
            o = next_o;
            d = next_d;
            bounces += 1;
            // The next rays, back to back.
            for k in lanes_of(alive) {
                hit[k] = ctx.accel.intersect_skip(&ray_of(&o, &d, k), g.prim[k]);
                if let Some(Hit {
                    kind: HitKind::Triangle { prim, .. },
                    ..
                }) = hit[k]
                {
                    ctx.accel.prefetch_surface(prim);
                }
            }
            if alive == 0 {
                break;
            }
        }
        l
    }
}
