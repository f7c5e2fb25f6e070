//! The absorbed-power sensor: light tracing from the sun and sky.
//!
//! A photon starts at a point spread uniformly over the area at the top of the scene, from
//! a distant light chosen uniformly (its direction sampled as next-event estimation would,
//! so a disc sun and an image sky are followed), carrying the horizontal irradiance that
//! sample stands for, `P = n_lights · L cos θ / pdf` per channel. At each surface it meets,
//! the material's BSDF is sampled for the way on (`f |cos| / pdf` for the photon's own
//! direction: the BSDFs are reciprocal); the expected absorbed share `P (1 − w)` is added
//! to the material and to the object the surface belongs to, and the photon goes on with
//! `P w`, Russian roulette from the scene's `rr_depth` on its relative power. Photons that
//! leave upward count as the albedo, those that reach a ground material count toward
//! `ftran` (every arrival), those that leave downward (no ground) as `escaped`; `ftran_uncollided` counts the first flights that reach the ground. Every
//! fraction is of the incident power `Σ P`.

use super::{BATCHES, Estimate, Run, area_or_cell, depths, scene_top, spread};
use crate::accel::{FLAG_EMITTER, HitKind, ID_MASK, PrimRef, Ray, spawn_origin};
use crate::error::RenderError;
use crate::materials::SurfaceBsdf;
use crate::sampler::PixelSampler;
use crate::shading::{ShadingFrame, shading_normal};
use glam::{DVec3, Vec3};
use lamina_core::radiometry::Rect;
use lamina_leaf::Bsdf;
use rayon::prelude::*;

/// What an absorbed sensor measured: fractions of the incident power (per channel).
#[derive(Clone, Debug)]
pub struct AbsorbedResult {
    /// Incident horizontal irradiance of the sun and sky (W m⁻²).
    pub incident: Estimate,
    /// Leaving the top of the scene.
    pub albedo: Estimate,
    /// Absorbed by every material that is not ground.
    pub fabs: Estimate,
    /// Arriving at a ground material (all orders of scattering).
    pub ftran: Estimate,
    /// Arriving at a ground material on the first flight, through the gaps (depends on the
    /// geometry only, not on the materials).
    pub ftran_uncollided: Estimate,
    /// Leaving downward without meeting a ground (or sideways, without a periodic domain).
    pub escaped: Estimate,
    /// Absorbed per material (name, fraction), every material of the scene.
    pub materials: Vec<(String, Estimate)>,
    /// Absorbed per `[[object]]` (name, fraction).
    pub objects: Vec<(String, Estimate)>,
}

/// Picks one estimate of an [`AbsorbedResult`].
pub type Pick = fn(&AbsorbedResult) -> Estimate;

impl AbsorbedResult {
    /// The whole-scene measures by the names the CSV files and the Python dicts use, in
    /// their order.
    pub const MEASURES: [(&'static str, Pick); 6] = [
        ("albedo", |a| a.albedo),
        ("fabs", |a| a.fabs),
        ("ftran", |a| a.ftran),
        ("ftran_uncollided", |a| a.ftran_uncollided),
        ("escaped", |a| a.escaped),
        ("incident", |a| a.incident),
    ];
}

/// Tallies of one batch, in irradiance units (W m⁻² summed over photons).
#[derive(Clone, Default)]
struct Tally {
    incident: DVec3,
    albedo: DVec3,
    fabs: DVec3,
    ftran: DVec3,
    uncollided: DVec3,
    escaped: DVec3,
    materials: Vec<DVec3>,
    objects: Vec<DVec3>,
    rays: u64,
}

/// Measures the flux budget of light entering through `area` (default: the periodic cell);
/// `ground` are the ground materials.
pub(crate) fn measure(
    run: &mut Run,
    area: Option<Rect>,
    ground: &[u32],
) -> Result<(AbsorbedResult, u64), RenderError> {
    let ctx = run.ctx;
    let scene = ctx.scene;
    let area = area_or_cell(area, ctx)?;
    let top = scene_top(ctx) + 1e-3;
    let (max_depth, rr_depth) = depths(scene);
    let max_depth = max_depth.max(1);
    let distant: Vec<&crate::lights::AnyLight> = ctx
        .lights
        .lights
        .iter()
        .filter(|l| l.is_infinite())
        .collect();
    let n_mat = scene.materials.len();
    let objects = &scene.radiometry.objects;
    let mut mesh_object = vec![u32::MAX; scene.meshes.len()];
    let mut inst_object = vec![u32::MAX; scene.instances.len()];
    for (k, o) in objects.iter().enumerate() {
        for m in o.meshes.clone() {
            if let Some(x) = mesh_object.get_mut(m as usize) {
                *x = k as u32;
            }
        }
        for i in o.instances.clone() {
            if let Some(x) = inst_object.get_mut(i as usize) {
                *x = k as u32;
            }
        }
    }
    let object_of = |prim: PrimRef| -> Option<usize> {
        let o = match ctx.accel.origin(prim) {
            (Some(m), _) => *mesh_object.get(m as usize)?,
            (_, Some(i)) => *inst_object.get(i as usize)?,
            _ => return None,
        };
        (o != u32::MAX).then_some(o as usize)
    };
    let mut is_ground = vec![false; n_mat];
    for &g in ground {
        if let Some(x) = is_ground.get_mut(g as usize) {
            *x = true;
        }
    }
    let per_batch = run.samples.div_ceil(BATCHES);
    // Progress in chunks of photons.
    const CHUNK: u32 = 4096;
    let chunks = per_batch.div_ceil(CHUNK);
    run.total = BATCHES as u64 * chunks as u64;
    let run = &*run;
    let tallies: Vec<Tally> = (0..BATCHES)
        .into_par_iter()
        .map(|b| {
            let mut t = Tally {
                materials: vec![DVec3::ZERO; n_mat],
                objects: vec![DVec3::ZERO; objects.len()],
                ..Default::default()
            };
            for i in 0..per_batch {
                if i % CHUNK == 0 {
                    if run.cancelled() {
                        break;
                    }
                    if i > 0 {
                        run.advance(1);
                    }
                }
                let mut s = PixelSampler::new(run.seed, 0, b, i);
                let pick = s.next_1d();
                let u_light = s.next_2d();
                let u_pos = s.next_2d();
                if distant.is_empty() {
                    continue;
                }
                let li = ((pick * distant.len() as f32) as usize).min(distant.len() - 1);
                let Some(ls) = distant[li].sample(Vec3::ZERO, u_light) else {
                    continue;
                };
                if !(ls.pdf > 0.0) || ls.wi.y <= 0.0 {
                    continue;
                }
                let p0 = ls.li * (ls.wi.y * distant.len() as f32 / ls.pdf);
                if !p0.is_finite() || p0.max_element() <= 0.0 {
                    continue;
                }
                t.incident += p0.as_dvec3();
                let origin = Vec3::new(
                    area.min.x + u_pos.x * (area.max.x - area.min.x),
                    top,
                    area.min.y + u_pos.y * (area.max.y - area.min.y),
                );
                let mut ray = Ray {
                    origin,
                    dir: -ls.wi,
                    tmax: f32::INFINITY,
                };
                let mut power = p0;
                let mut beta = Vec3::ONE; // power relative to p0, for Russian roulette
                let mut skip = PrimRef::NONE;
                let mut depth = 0u32;
                loop {
                    t.rays += 1;
                    let Some(hit) = ctx.accel.intersect_skip(&ray, skip) else {
                        if ray.dir.y > 0.0 {
                            t.albedo += power.as_dvec3();
                        } else {
                            t.escaped += power.as_dvec3();
                        }
                        break;
                    };
                    let HitKind::Triangle { prim, bary } = hit.kind else {
                        break; // a sphere light: refused by the loader with this sensor
                    };
                    let (p, info) = ctx.accel.surface(prim, bary);
                    if info.flags & FLAG_EMITTER != 0 {
                        break;
                    }
                    let m = (info.flags & ID_MASK) as usize;
                    let material = &scene.materials[m];
                    if is_ground[m] {
                        t.ftran += power.as_dvec3();
                        if depth == 0 {
                            t.uncollided += power.as_dvec3();
                        }
                    }
                    let ns = shading_normal(&ctx.accel, prim, bary, &info, material.normal_map());
                    let frame = ShadingFrame::new(&info, ns, -ray.dir);
                    let bsdf = SurfaceBsdf::at(material, info.uv_at(bary));
                    let wo = frame.to_local(-ray.dir);
                    let u1 = s.next_1d();
                    let u2 = s.next_2d();
                    let mut next = None;
                    let mut w = Vec3::ZERO;
                    if depth + 1 < max_depth
                        && let Some(bs) = bsdf.sample(wo, Vec3::new(u1, u2.x, u2.y))
                        && bs.pdf > 0.0
                    {
                        let dir = frame.to_world_unit(bs.wi);
                        if frame.consistent(dir) {
                            w = bs.f / bs.pdf;
                            if !w.is_finite() {
                                w = Vec3::ZERO;
                            }
                            next = Some(dir);
                        }
                    }
                    let absorbed = (power * (Vec3::ONE - w)).as_dvec3();
                    t.materials[m] += absorbed;
                    if !is_ground[m] {
                        t.fabs += absorbed;
                    }
                    if let Some(o) = object_of(prim) {
                        t.objects[o] += absorbed;
                    }
                    let Some(dir) = next else { break };
                    // The photon ends here if the path is too long: what it carries is
                    // counted as absorbed above (w = 0), so the budget still closes.
                    power *= w;
                    beta *= w;
                    if !(beta.max_element() > 0.0) {
                        break;
                    }
                    depth += 1;
                    if depth >= rr_depth {
                        let q = beta.max_element().min(1.0);
                        if q < 1.0 {
                            if s.next_1d() >= q {
                                // Ended by roulette: its expected power goes on in the
                                // survivors; nothing is lost on average.
                                break;
                            }
                            power /= q;
                            beta /= q;
                        }
                    }
                    ray = Ray {
                        origin: spawn_origin(p, info.n, dir),
                        dir,
                        tmax: f32::INFINITY,
                    };
                    skip = prim;
                }
            }
            run.advance(1);
            t
        })
        .collect();
    let rays = tallies.iter().map(|t| t.rays).sum();
    let inc: Vec<DVec3> = tallies.iter().map(|t| t.incident).collect();
    let total_inc: DVec3 = inc.iter().copied().sum();
    let fraction = |get: &dyn Fn(&Tally) -> DVec3| -> Estimate {
        let num: DVec3 = tallies.iter().map(get).sum();
        let value = safe_div(num, total_inc);
        let std = spread(tallies.iter().map(|t| safe_div(get(t), t.incident)));
        Estimate { value, std }
    };
    let counts = vec![per_batch as f64; BATCHES as usize];
    let result = AbsorbedResult {
        incident: Estimate::from_batches(&inc, &counts),
        albedo: fraction(&|t| t.albedo),
        fabs: fraction(&|t| t.fabs),
        ftran: fraction(&|t| t.ftran),
        ftran_uncollided: fraction(&|t| t.uncollided),
        escaped: fraction(&|t| t.escaped),
        materials: scene
            .materials
            .iter()
            .enumerate()
            .map(|(k, m)| (m.name().to_string(), fraction(&|t| t.materials[k])))
            .collect(),
        objects: objects
            .iter()
            .enumerate()
            .map(|(k, o)| (o.name.clone(), fraction(&|t| t.objects[k])))
            .collect(),
    };
    Ok((result, rays))
}

fn safe_div(a: DVec3, b: DVec3) -> DVec3 {
    DVec3::new(
        if b.x > 0.0 { a.x / b.x } else { 0.0 },
        if b.y > 0.0 { a.y / b.y } else { 0.0 },
        if b.z > 0.0 { a.z / b.z } else { 0.0 },
    )
}
