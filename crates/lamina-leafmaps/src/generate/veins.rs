//! Venation: the major veins (primaries, secondaries grown toward the margin, side
//! branches) as tapered capsules in design space, and their rasterisation (see the module
//! docs of [`super`]).

use super::card::PixelGrid;
use super::outline::{Outline, SINUS_SHEAR, rotate_deg, smoothstep};
use crate::noise::{Rng, gradient};
use crate::plane::{Gray, Plane};
use crate::species::{Preset, VenationKind};
use glam::Vec2;

/// One piece of a major vein: a tapered capsule from `a` to `b` in design space.
#[derive(Clone, Copy, Debug)]
pub(super) struct VeinSegment {
    /// Start point, design units.
    a: Vec2,
    /// End point, design units.
    b: Vec2,
    /// Radius at `a`, design units.
    ra: f32,
    /// Radius at `b`, design units.
    rb: f32,
    /// How strongly the vein shows in the colour maps, `[0, 1]` (1 the primaries, less for
    /// secondaries and their branches).
    weight: f32,
}

/// `d` turned toward `target` by at most `max_angle` radians.
fn rotate_toward(d: Vec2, target: Vec2, max_angle: f32) -> Vec2 {
    let ang = d.perp_dot(target).atan2(d.dot(target));
    let step = ang.clamp(-max_angle, max_angle);
    let (s, c) = step.sin_cos();
    Vec2::new(c * d.x - s * d.y, s * d.x + c * d.y)
}

/// How one vein grows (see [`grow_vein`]), lengths in design units.
struct VeinGrowth {
    /// The direction the vein bends toward (its lobe's axis, or its parent vein's).
    axis: Vec2,
    /// Turn toward `axis` per unit of length (radians per design unit).
    curvature: f32,
    /// Craspedodromous: the vein runs into the margin; otherwise it arches along it
    /// (brochidodromous).
    crasp: bool,
    /// Distance from the margin at which brochidodromous veins start arching.
    loop_gap: f32,
    /// Longest vein grown.
    max_len: f32,
    /// The lobe the vein belongs to: in a palmate leaf it stops where another lobe's
    /// outline becomes the nearest.
    lobe: usize,
}

/// Grows a vein polyline from `start` in direction `d0` (see the module docs).
fn grow_vein(outline: &Outline, start: Vec2, d0: Vec2, g: &VeinGrowth, rng: &mut Rng) -> Vec<Vec2> {
    let h = 0.004;
    let mut p = start;
    let mut d = d0.normalize();
    let mut pts = vec![p];
    let mut len = 0.0;
    let wobble_seed = (rng.next_f32() * 1.0e6) as u32;
    let multi = outline.lobes.len() > 1;
    while len < g.max_len {
        let fp = outline.field(p);
        let mut turn = g.curvature * h;
        if !g.crasp && fp > -g.loop_gap {
            turn *= 6.0;
        }
        d = rotate_toward(d, g.axis, turn);
        d = rotate_deg(d, 25.0 * h * gradient(len * 12.0, 0.5, wobble_seed));
        p += d * h;
        len += h;
        let fp = outline.field(p);
        let stop = if g.crasp {
            fp > -0.002
        } else {
            fp > -0.3 * g.loop_gap
        };
        if stop {
            if g.crasp {
                pts.push(p);
            }
            break;
        }
        if multi && len > 0.05 && outline.nearest_lobe(p) != g.lobe {
            break;
        }
        pts.push(p);
    }
    pts
}

/// Appends polyline `pts` as segments whose radius tapers linearly from `r0` to `r1`.
fn push_polyline(segs: &mut Vec<VeinSegment>, pts: &[Vec2], r0: f32, r1: f32, weight: f32) {
    if pts.len() < 2 {
        return;
    }
    let n = (pts.len() - 1) as f32;
    for (i, w) in pts.windows(2).enumerate() {
        let t0 = i as f32 / n;
        let t1 = (i + 1) as f32 / n;
        segs.push(VeinSegment {
            a: w[0],
            b: w[1],
            ra: r0 + (r1 - r0) * t0,
            rb: r0 + (r1 - r0) * t1,
            weight,
        });
    }
}

/// The major veins of `outline` (design units): petiole, primaries along the lobe axes,
/// and for reticulate venation the grown secondaries and their side branches.
pub(super) fn build_veins(
    outline: &Outline,
    p: &Preset,
    midrib_r: f32,
    rng: &mut Rng,
) -> Vec<VeinSegment> {
    let mut segs = Vec::new();
    let v = &p.venation;
    // Petiole.
    if outline.petiole_len > 0.0 {
        push_polyline(
            &mut segs,
            &[Vec2::new(0.0, -outline.petiole_len), Vec2::ZERO],
            outline.petiole_r * 1.2,
            midrib_r,
            1.0,
        );
    }
    let wob = (rng.next_f32() * 1.0e6) as u32;
    for (li, l) in outline.lobes.iter().enumerate() {
        // Primary along the lobe axis, with a slight wobble.
        let n = 80;
        let mut pts = Vec::with_capacity(n + 1);
        for k in 0..=n {
            let t = 0.96 * k as f32 / n as f32;
            let lat =
                0.004 * l.len * gradient(t * 5.0, li as f32 * 3.7, wob) * smoothstep(0.0, 0.2, t);
            let q = l.dir * (t * l.len) + l.perp * lat;
            if k > 0 && outline.field(q) > -0.3 * midrib_r {
                break;
            }
            pts.push(q);
        }
        let r0 = midrib_r * l.vein_weight;
        push_polyline(&mut segs, &pts, r0, 0.22 * r0, 1.0);
        if !matches!(v.kind, VenationKind::Reticulate) {
            continue;
        }
        // Secondaries.
        let count = ((v.secondaries as f32 * l.len).round() as usize).max(2);
        let multi = outline.lobes.len() > 1;
        let (t0, t1) = if multi { (0.2, 0.85) } else { (0.05, 0.88) };
        for (si, side) in [1.0f32, -1.0].into_iter().enumerate() {
            let mut starts: Vec<(f32, Vec2, f32)> = Vec::new(); // (t, direction, curvature)
            if li == 0
                && let Some(s) = outline.sinuses
            {
                // One secondary to each lobe tip (lobe centres where the sine peaks).
                let phase = l.sinus_phase[si];
                let mut k = 0.0;
                while k < s.count + 1.0 {
                    let tt = (k + 0.5 - phase) / s.count;
                    k += 1.0;
                    if !(0.02..0.98).contains(&tt) {
                        continue;
                    }
                    let tc = 0.08 + 0.86 * tt;
                    let hw0 = outline.half_width(0, tc, si, 0.0);
                    let tc = tc + SINUS_SHEAR * 0.8 * hw0 / l.len;
                    let hw = outline.half_width(0, tc, si, 0.8 * hw0).max(0.5 * hw0);
                    let tip = l.dir * (tc * l.len) + l.perp * (side * 0.95 * hw);
                    let ts = (tc - 0.55 * hw / l.len).max(0.03);
                    let start = l.dir * (ts * l.len);
                    starts.push((ts, (tip - start).normalize(), 0.3));
                }
            } else {
                for i in 0..count {
                    let jitter = rng.range(-0.2, 0.2) + if side < 0.0 { 0.3 } else { 0.0 };
                    let u = ((i as f32 + 0.5 + jitter) / count as f32).clamp(0.0, 1.0);
                    let t = t0 + (t1 - t0) * u.powf(0.9);
                    let ang = v.angle_base_deg
                        + (v.angle_tip_deg - v.angle_base_deg) * t
                        + rng.range(-4.0, 4.0);
                    starts.push((t, rotate_deg(l.dir, side * ang), v.curvature));
                }
            }
            for (t, d0, curv) in starts {
                let start = l.dir * (t * l.len);
                let g = VeinGrowth {
                    axis: l.dir,
                    curvature: curv,
                    crasp: v.craspedodromous,
                    loop_gap: 0.22 * l.hw * l.len,
                    max_len: 1.5 * l.len,
                    lobe: li,
                };
                let pts = grow_vein(outline, start, d0, &g, rng);
                let rs = midrib_r * 0.5 * l.vein_weight.sqrt() * (1.0 - 0.4 * t);
                push_polyline(&mut segs, &pts, rs, 0.3 * rs, 0.85);
                // Side branches toward the margin on the basal side.
                for b in 0..v.branches {
                    if pts.len() < 8 {
                        break;
                    }
                    let frac = 0.35
                        + 0.45 * (b as f32 + 1.0) / (v.branches as f32 + 1.0)
                        + rng.range(-0.05, 0.05);
                    let k = ((pts.len() - 1) as f32 * frac) as usize;
                    let dseg = (pts[(k + 1).min(pts.len() - 1)] - pts[k.saturating_sub(1)])
                        .normalize_or(l.dir);
                    let d0 = rotate_deg(dseg, side * rng.range(35.0, 55.0));
                    let gb = VeinGrowth {
                        axis: dseg,
                        curvature: 2.0,
                        crasp: true,
                        loop_gap: 0.0,
                        max_len: 0.5 * l.len,
                        lobe: li,
                    };
                    let bp = grow_vein(outline, pts[k], d0, &gb, rng);
                    let rb = rs * (1.0 - 0.7 * frac) * 0.6;
                    push_polyline(&mut segs, &bp, rb, 0.4 * rb, 0.65);
                }
            }
        }
    }
    segs
}

/// Rasterises the major veins: coverage (max of `weight * coverage`) and height in mm
/// (`relief_mm` for a vein of radius `midrib_r`, design units).
pub(super) fn raster_veins(
    segs: &[VeinSegment],
    outline: &Outline,
    g: &PixelGrid,
    relief_mm: f32,
    midrib_r: f32,
) -> (Gray, Gray) {
    let mut cov = Plane::filled(g.w, g.h, 0.0f32);
    let mut hgt = Plane::filled(g.w, g.h, 0.0f32);
    for s in segs {
        let a = g.pixel(outline.to_card(s.a));
        let b = g.pixel(outline.to_card(s.b));
        let ra = s.ra * g.ppu;
        let rb = s.rb * g.ppu;
        let rmax = ra.max(rb) + 1.0;
        let x0 = (a.x.min(b.x) - rmax).floor().max(0.0) as usize;
        let x1 = ((a.x.max(b.x) + rmax).ceil().max(0.0) as usize).min(g.w);
        let y0 = (a.y.min(b.y) - rmax).floor().max(0.0) as usize;
        let y1 = ((a.y.max(b.y) + rmax).ceil().max(0.0) as usize).min(g.h);
        let ab = b - a;
        let l2 = ab.length_squared().max(1e-12);
        for y in y0..y1 {
            for x in x0..x1 {
                let p = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
                let t = ((p - a).dot(ab) / l2).clamp(0.0, 1.0);
                let d = (p - a - ab * t).length();
                let r = ra + (rb - ra) * t;
                let c = (r + 0.5 - d).clamp(0.0, 1.0) * (2.0 * r).min(1.0);
                if c <= 0.0 {
                    continue;
                }
                let i = y * g.w + x;
                let cw = c * s.weight;
                if cw > cov.data[i] {
                    cov.data[i] = cw;
                }
                let rp = r.max(0.75);
                let prof = (1.0 - (d / rp).powi(2)).max(0.0).sqrt();
                let rel = relief_mm * ((r / g.ppu) / midrib_r).clamp(0.0, 1.5).powf(0.8);
                let hv = rel * prof;
                if hv > hgt.data[i] {
                    hgt.data[i] = hv;
                }
            }
        }
    }
    (cov, hgt)
}
