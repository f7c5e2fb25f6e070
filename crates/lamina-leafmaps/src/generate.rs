//! Procedural leaves: the seven maps from a species preset and a seed.
//!
//! # Method
//! * **Outline**: an implicit shape in *design space* (main lobe length 1, petiole junction at
//!   the origin, tip toward `+y`). Every lobe is a region along an axis whose half-width
//!   follows a profile `t^a (1-t)^b` ([`Profile`]); palmate leaves (maple, ivy) are a smooth
//!   union of several lobes fanned out from the petiole, pinnately lobed ones (oak) modulate
//!   the half-width with rounded lobes and sinuses, and the margin carries serrate, doubly
//!   serrate or crenate teeth as a periodic perturbation of the half-width along the axis (so
//!   the teeth point toward the apex, as in real serrate leaves). The seed jitters lobe angles,
//!   lengths and widths, left/right asymmetry, tooth phase and a slight bend of the midrib.
//! * **Venation**: a primary vein along each lobe axis (the midrib, or the five primaries of
//!   a palmate leaf); secondaries leave it at a species angle that flattens toward the tip
//!   and are *grown* step by step, bending toward the tip with a species curvature, until
//!   they reach the margin (craspedodromous: beech, birch, oak, maple) or arch along it
//!   (brochidodromous: ivy, willow); oak secondaries aim at the lobe tips. Some species get
//!   side branches running to the teeth. The higher orders (tertiary and quaternary veins)
//!   form a reticulate net of closed loops, the *areoles*; instead of growing them too
//!   (space colonisation after Runions et al. 2005 would), we take the edges of two
//!   domain-warped Voronoi diagrams at the species' areole size and a third of it: Voronoi
//!   edges are exactly closed polygonal loops around seed points, which is what areoles look
//!   like, at a constant cost per pixel and independent of resolution. The major veins are
//!   rasterised as tapered capsules with a round cross-section (which gives their relief).
//!   Grass blades get parallel veins instead.
//! * **Colour**: mesophyll albedo from the preset with low-frequency mottling (pigment
//!   variation), a yellowing term and fine grain; veins lighter on the front; the back paler
//!   and less saturated with more visible veins; the through-light colour yellow-green with
//!   veins darker (they are thicker, and absorb more) and the thin rim a little brighter.
//! * **Data maps**: extinction = `1 - Y'(translucency)`, thickness = its blur (as the paper
//!   derives them from a scan, see [`crate::folder`]); bump = veins as grooves seen from the
//!   adaxial side, i.e. raised on the abaxial side, plus a slight bulge of the areoles;
//!   alpha from the outline, anti-aliased over one pixel.

use crate::folder::{MapPlanes, extinction_from_translucency, thickness_from_extinction};
use crate::noise::{Rng, fbm, gradient, worley};
use crate::plane::{Gray, Plane, Rgb};
use crate::species::{Preset, Profile, Species, Teeth, VenationKind, srgb8_to_linear};
use crate::{FolderWrite, LeafMapsError, write_leaf_folder};
use glam::{Vec2, Vec3};
use lamina_leaf::{LeafMaps, LeafParams};
use std::path::{Path, PathBuf};

/// What to generate: a preset, a seed and the resolution.
#[derive(Clone, Debug, PartialEq)]
pub struct LeafSpec {
    /// The species preset (built in via [`Species::preset`], or custom).
    pub preset: Preset,
    /// Seed of every random choice: the same spec gives a bit-identical leaf.
    pub seed: u64,
    /// Pixels along the longer side of the card (clamped to `[16, 16384]`); the shorter side
    /// follows from the outline's aspect ratio.
    pub resolution: u32,
}

impl LeafSpec {
    /// A spec for a built-in species.
    pub fn new(species: Species, seed: u64, resolution: u32) -> Self {
        LeafSpec {
            preset: species.preset(),
            seed,
            resolution,
        }
    }
}

/// A generated leaf: the seven maps, its parameters and the size of its card.
#[derive(Clone, Debug)]
pub struct GeneratedLeaf {
    /// The maps as textures (linear values, clamped addressing), ready for
    /// [`lamina_leaf::LeafMaterial::new`].
    pub maps: LeafMaps,
    /// The preset's parameters, with [`LeafParams::bump_scale`] set to match the bump map.
    pub params: LeafParams,
    /// Card width and height in metres (`u` across the width, `v` along the height; the leaf
    /// tip is at the top, `v = 1`, the petiole at the bottom).
    pub size_m: (f32, f32),
    /// The same maps as planes (what [`GeneratedLeaf::write_folder`] writes).
    pub planes: MapPlanes,
    /// Preset name.
    pub species: String,
    /// The seed.
    pub seed: u64,
}

impl GeneratedLeaf {
    /// Writes the leaf folder (seven PNG maps and `leaf.toml`), replacing only a leaf folder
    /// lamina wrote; see [`write_leaf_folder`]. Returns the folder.
    pub fn write_folder(&self, dir: &Path) -> Result<PathBuf, LeafMapsError> {
        self.write_folder_with(dir, &FolderWrite::default())
    }

    /// [`GeneratedLeaf::write_folder`] with an explicit rule for an existing folder
    /// (e.g. [`crate::Replace::Force`]).
    pub fn write_folder_with(
        &self,
        dir: &Path,
        how: &FolderWrite,
    ) -> Result<PathBuf, LeafMapsError> {
        let (w, h) = self.planes.size();
        let comments = vec![
            format!(
                "Procedural {} leaf, seed {}, {w}x{h} px, generated by lamina-leafmaps.",
                self.species, self.seed
            ),
            format!(
                "Card size: {:.4} m wide x {:.4} m high (tip at the top, petiole at the bottom).",
                self.size_m.0, self.size_m.1
            ),
            "All seven maps are procedural: outline, venation and colour from the species preset;"
                .into(),
            "extinction = 1 - luma(translucency), thickness = its blur re-centred on 0.5.".into(),
        ];
        write_leaf_folder(dir, &self.planes, &self.params, &comments, how)
    }
}

// ---------------------------------------------------------------------------------------
// Outline

#[derive(Clone, Debug)]
struct LobeGeo {
    dir: Vec2,
    perp: Vec2,
    len: f32,
    hw: f32,
    profile: Profile,
    vein_weight: f32,
    /// Half-width factors of the left (`lat >= 0`) and right side.
    asym: [f32; 2],
    tooth_phase: [f32; 2],
    sinus_phase: [f32; 2],
    sinus_seed: u32,
    /// The profile tabulated at `PROFILE_N + 1` points of `t` (the profile is the hot spot of
    /// the outline function, with two `powf`).
    lut: Vec<f32>,
}

const PROFILE_N: usize = 2048;

impl LobeGeo {
    #[inline]
    fn profile(&self, t: f32) -> f32 {
        let x = t.clamp(0.0, 1.0) * PROFILE_N as f32;
        let i = (x as usize).min(PROFILE_N - 1);
        let f = x - i as f32;
        self.lut[i] + (self.lut[i + 1] - self.lut[i]) * f
    }
}

struct Shape {
    lobes: Vec<LobeGeo>,
    teeth: Option<Teeth>,
    sinuses: Option<crate::species::Sinuses>,
    blend: f32,
    petiole_len: f32,
    petiole_r: f32,
    bend: f32,
}

/// Forward shear of pinnate lobes (change of `t` per unit of lateral distance).
const SINUS_SHEAR: f32 = 0.3;

#[inline]
fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

#[inline]
fn profile(p: Profile, t: f32) -> f32 {
    match p {
        Profile::Beta { a, b } => {
            let m = a / (a + b);
            t.powf(a) * (1.0 - t).powf(b) / (m.powf(a) * (1.0 - m).powf(b))
        }
        Profile::Linear { taper } => {
            let base = (t / 0.03).min(1.0).sqrt();
            let tip = ((1.0 - t) / taper.max(1e-3)).min(1.0).powf(0.8);
            base * tip
        }
    }
}

#[inline]
fn tooth(u: f32, th: &Teeth) -> f32 {
    let saw = |u: f32| {
        let g = u - u.floor();
        if th.rounded {
            (std::f32::consts::PI * g).sin().powf(0.6) - 0.6
        } else {
            // Asymmetric pointed tooth: a long slightly concave flank toward the apex and a
            // short one back to the sinus, so the tip points toward the apex.
            let r = if g < 0.72 { g / 0.72 } else { (1.0 - g) / 0.28 };
            r.powf(1.4) - 0.4
        }
    };
    if th.double {
        0.75 * saw(u) + 0.4 * saw(3.0 * u)
    } else {
        saw(u)
    }
}

#[inline]
fn smin(a: f32, b: f32, k: f32) -> f32 {
    if k <= 0.0 {
        return a.min(b);
    }
    let h = (k - (a - b).abs()).max(0.0) / k;
    a.min(b) - h * h * k * 0.25
}

impl Shape {
    /// Half-width of lobe `l` at `t` on `side` (0 left, 1 right), design units. `lat` is
    /// the lateral distance of the point asked about: pinnate lobes are sheared toward the
    /// apex by it (they point forward, as oak lobes do).
    fn half_width(&self, i: usize, t: f32, side: usize, lat: f32) -> f32 {
        let l = &self.lobes[i];
        let pr = l.profile(t);
        let mut hw = l.len * l.hw * pr * l.asym[side];
        if i == 0
            && let Some(s) = self.sinuses
        {
            let tt = (t - SINUS_SHEAR * lat.abs() / l.len - 0.08) / 0.86;
            if (0.0..1.0).contains(&tt) {
                let x = s.count * tt + l.sinus_phase[side];
                let lobe = (std::f32::consts::PI * x).sin().abs();
                // Each lobe gets its own size (a hash of its index), as real oak lobes vary.
                let k = x.floor() as i32;
                let size = 0.8
                    + 0.35 * crate::noise::unit(crate::noise::hash2(k, side as i32, l.sinus_seed));
                hw *= ((1.0 - s.depth) + s.depth * size * lobe.powf(0.5)).min(1.15);
            }
        }
        if let Some(th) = &self.teeth {
            let u = t * l.len * th.per_length + l.tooth_phase[side];
            let ramp = smoothstep(0.02, 0.15, t) * smoothstep(1.0, 0.9, t);
            hw += th.amplitude * l.len * l.hw * pr.sqrt() * tooth(u, th) * ramp;
        }
        hw
    }

    /// Signed outline function of one lobe (negative inside), design units.
    fn lobe_f(&self, i: usize, q: Vec2) -> f32 {
        let l = &self.lobes[i];
        let along = q.dot(l.dir);
        let lat = q.dot(l.perp);
        let t = along / l.len;
        if t <= 0.0 {
            return q.length();
        }
        if t >= 1.0 {
            return (q - l.dir * l.len).length();
        }
        lat.abs() - self.half_width(i, t, usize::from(lat < 0.0), lat)
    }

    /// Signed outline function of the whole leaf with petiole (negative inside).
    fn f(&self, q: Vec2) -> f32 {
        let mut f = self.lobe_f(0, q);
        for i in 1..self.lobes.len() {
            f = smin(f, self.lobe_f(i, q), self.blend);
        }
        // Petiole: a capsule from the junction down.
        let py = q.y.clamp(-self.petiole_len, 0.0);
        let pet = (q - Vec2::new(0.0, py)).length()
            - self.petiole_r * (1.0 + 0.3 * (-py / self.petiole_len.max(1e-6)));
        f.min(pet)
    }

    /// The lobe whose outline function is smallest at `q`.
    fn nearest_lobe(&self, q: Vec2) -> usize {
        (0..self.lobes.len())
            .map(|i| (i, self.lobe_f(i, q)))
            .fold((0, f32::MAX), |a, b| if b.1 < a.1 { b } else { a })
            .0
    }

    /// Design space to card space (the midrib bend).
    #[inline]
    fn to_card(&self, q: Vec2) -> Vec2 {
        let y = q.y.max(0.0);
        Vec2::new(q.x + self.bend * y * y, q.y)
    }

    /// Card space to design space.
    #[inline]
    fn to_design(&self, c: Vec2) -> Vec2 {
        let y = c.y.max(0.0);
        Vec2::new(c.x - self.bend * y * y, c.y)
    }
}

fn rot(v: Vec2, deg: f32) -> Vec2 {
    let (s, c) = deg.to_radians().sin_cos();
    Vec2::new(c * v.x - s * v.y, s * v.x + c * v.y)
}

fn build_shape(p: &Preset, rng: &mut Rng, petiole_r: f32) -> Shape {
    let lobes = p
        .outline
        .lobes
        .iter()
        .enumerate()
        .map(|(i, l)| {
            let jitter_angle = if i == 0 {
                rng.range(-2.0, 2.0)
            } else {
                rng.range(-5.0, 5.0)
            };
            let dir = rot(Vec2::Y, l.angle_deg + jitter_angle);
            let mut g = LobeGeo {
                dir,
                perp: rot(dir, 90.0),
                len: l.length * if i == 0 { 1.0 } else { rng.range(0.92, 1.08) },
                hw: l.half_width * rng.range(0.92, 1.08),
                profile: match l.profile {
                    Profile::Beta { a, b } => Profile::Beta {
                        a: a * rng.range(0.93, 1.07),
                        b: b * rng.range(0.93, 1.07),
                    },
                    other => other,
                },
                vein_weight: l.vein_weight,
                asym: [rng.range(0.95, 1.05), rng.range(0.95, 1.05)],
                tooth_phase: [rng.next_f32(), rng.next_f32()],
                sinus_phase: {
                    let a = rng.range(0.0, 0.15);
                    [a, a + rng.range(0.35, 0.6)]
                },
                sinus_seed: (rng.next_f32() * 1.0e6) as u32,
                lut: Vec::new(),
            };
            g.lut = (0..=PROFILE_N)
                .map(|k| profile(g.profile, k as f32 / PROFILE_N as f32))
                .collect();
            g
        })
        .collect();
    Shape {
        lobes,
        teeth: p.outline.teeth,
        sinuses: p.outline.sinuses,
        blend: p.outline.blend,
        petiole_len: p.outline.petiole,
        petiole_r,
        bend: rng.range(-0.06, 0.06),
    }
}

// ---------------------------------------------------------------------------------------
// Veins

/// A tapered capsule in design space, radii in design units.
#[derive(Clone, Copy, Debug)]
struct Seg {
    a: Vec2,
    b: Vec2,
    ra: f32,
    rb: f32,
    weight: f32,
}

fn rotate_toward(d: Vec2, target: Vec2, max_angle: f32) -> Vec2 {
    let ang = d.perp_dot(target).atan2(d.dot(target));
    let step = ang.clamp(-max_angle, max_angle);
    let (s, c) = step.sin_cos();
    Vec2::new(c * d.x - s * d.y, s * d.x + c * d.y)
}

struct Grow {
    axis: Vec2,
    curvature: f32,
    crasp: bool,
    /// Distance from the margin at which brochidodromous veins start arching.
    loop_gap: f32,
    max_len: f32,
    lobe: usize,
}

/// Grows a vein polyline from `start` in direction `d0` (see the module docs).
fn grow(shape: &Shape, start: Vec2, d0: Vec2, g: &Grow, rng: &mut Rng) -> Vec<Vec2> {
    let h = 0.004;
    let mut p = start;
    let mut d = d0.normalize();
    let mut pts = vec![p];
    let mut len = 0.0;
    let wobble_seed = (rng.next_f32() * 1.0e6) as u32;
    let multi = shape.lobes.len() > 1;
    while len < g.max_len {
        let fp = shape.f(p);
        let mut turn = g.curvature * h;
        if !g.crasp && fp > -g.loop_gap {
            turn *= 6.0;
        }
        d = rotate_toward(d, g.axis, turn);
        d = rot(d, 25.0 * h * gradient(len * 12.0, 0.5, wobble_seed));
        p += d * h;
        len += h;
        let fp = shape.f(p);
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
        if multi && len > 0.05 && shape.nearest_lobe(p) != g.lobe {
            break;
        }
        pts.push(p);
    }
    pts
}

fn push_polyline(segs: &mut Vec<Seg>, pts: &[Vec2], r0: f32, r1: f32, weight: f32) {
    if pts.len() < 2 {
        return;
    }
    let n = (pts.len() - 1) as f32;
    for (i, w) in pts.windows(2).enumerate() {
        let t0 = i as f32 / n;
        let t1 = (i + 1) as f32 / n;
        segs.push(Seg {
            a: w[0],
            b: w[1],
            ra: r0 + (r1 - r0) * t0,
            rb: r0 + (r1 - r0) * t1,
            weight,
        });
    }
}

fn build_veins(shape: &Shape, p: &Preset, midrib_r: f32, rng: &mut Rng) -> Vec<Seg> {
    let mut segs = Vec::new();
    let v = &p.venation;
    // Petiole.
    if shape.petiole_len > 0.0 {
        push_polyline(
            &mut segs,
            &[Vec2::new(0.0, -shape.petiole_len), Vec2::ZERO],
            shape.petiole_r * 1.2,
            midrib_r,
            1.0,
        );
    }
    let wob = (rng.next_f32() * 1.0e6) as u32;
    for (li, l) in shape.lobes.iter().enumerate() {
        // Primary along the lobe axis, with a slight wobble.
        let n = 80;
        let mut pts = Vec::with_capacity(n + 1);
        for k in 0..=n {
            let t = 0.96 * k as f32 / n as f32;
            let lat =
                0.004 * l.len * gradient(t * 5.0, li as f32 * 3.7, wob) * smoothstep(0.0, 0.2, t);
            let q = l.dir * (t * l.len) + l.perp * lat;
            if k > 0 && shape.f(q) > -0.3 * midrib_r {
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
        let multi = shape.lobes.len() > 1;
        let (t0, t1) = if multi { (0.2, 0.85) } else { (0.05, 0.88) };
        for (si, side) in [1.0f32, -1.0].into_iter().enumerate() {
            let mut starts: Vec<(f32, Vec2, f32)> = Vec::new(); // (t, direction, curvature)
            if li == 0
                && let Some(s) = shape.sinuses
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
                    let hw0 = shape.half_width(0, tc, si, 0.0);
                    let tc = tc + SINUS_SHEAR * 0.8 * hw0 / l.len;
                    let hw = shape.half_width(0, tc, si, 0.8 * hw0).max(0.5 * hw0);
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
                    starts.push((t, rot(l.dir, side * ang), v.curvature));
                }
            }
            for (t, d0, curv) in starts {
                let start = l.dir * (t * l.len);
                let g = Grow {
                    axis: l.dir,
                    curvature: curv,
                    crasp: v.craspedodromous,
                    loop_gap: 0.22 * l.hw * l.len,
                    max_len: 1.5 * l.len,
                    lobe: li,
                };
                let pts = grow(shape, start, d0, &g, rng);
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
                    let d0 = rot(dseg, side * rng.range(35.0, 55.0));
                    let gb = Grow {
                        axis: dseg,
                        curvature: 2.0,
                        crasp: true,
                        loop_gap: 0.0,
                        max_len: 0.5 * l.len,
                        lobe: li,
                    };
                    let bp = grow(shape, pts[k], d0, &gb, rng);
                    let rb = rs * (1.0 - 0.7 * frac) * 0.6;
                    push_polyline(&mut segs, &bp, rb, 0.4 * rb, 0.65);
                }
            }
        }
    }
    segs
}

/// Card-to-pixel mapping.
#[derive(Clone, Copy, Debug)]
struct Grid {
    w: usize,
    h: usize,
    x0: f32,
    top: f32,
    /// Pixels per design unit (square pixels).
    ppu: f32,
}

impl Grid {
    #[inline]
    fn card(&self, x: usize, y: usize) -> Vec2 {
        Vec2::new(
            self.x0 + (x as f32 + 0.5) / self.ppu,
            self.top - (y as f32 + 0.5) / self.ppu,
        )
    }
    #[inline]
    fn pixel(&self, c: Vec2) -> Vec2 {
        Vec2::new((c.x - self.x0) * self.ppu, (self.top - c.y) * self.ppu)
    }
}

/// Rasterises the major veins: coverage (max of `weight * coverage`) and height in mm.
fn raster_veins(
    segs: &[Seg],
    shape: &Shape,
    g: &Grid,
    mm_per_unit: f32,
    relief_mm: f32,
    midrib_r: f32,
) -> (Gray, Gray) {
    let mut cov = Plane::filled(g.w, g.h, 0.0f32);
    let mut hgt = Plane::filled(g.w, g.h, 0.0f32);
    let _ = mm_per_unit;
    for s in segs {
        let a = g.pixel(shape.to_card(s.a));
        let b = g.pixel(shape.to_card(s.b));
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

#[inline]
fn mix3(a: Vec3, b: Vec3, t: f32) -> Vec3 {
    a + (b - a) * t.clamp(0.0, 1.0)
}

#[inline]
fn desaturate(c: Vec3, amount: f32) -> Vec3 {
    let y = c.dot(Vec3::new(0.2126, 0.7152, 0.0722));
    mix3(c, Vec3::splat(y), amount)
}

/// Generates a leaf (see the module docs for the method). Deterministic in the spec.
pub fn generate(spec: &LeafSpec) -> GeneratedLeaf {
    let p = &spec.preset;
    let res = spec.resolution.clamp(16, 16384) as usize;
    let mut rng = Rng::new(spec.seed, 1);
    let seed32 = (spec.seed ^ (spec.seed >> 32)) as u32;

    // Design units -> mm: the card height (leaf length incl. petiole stub) is height_m.
    // The shape is built first with a provisional scale, then the card is fitted around it.
    let provisional_mm_per_unit = p.height_m * 1000.0 / (1.0 + p.outline.petiole + 0.06);
    let midrib_r0 = 0.5 * p.venation.midrib_mm / provisional_mm_per_unit;
    let shape = build_shape(p, &mut rng, midrib_r0 * 1.1);

    // Fit the card: bounding box of the inside of f on a coarse grid in card space.
    let (mut lo, mut hi) = (Vec2::splat(f32::MAX), Vec2::splat(f32::MIN));
    let n = 600;
    for j in 0..=n {
        for i in 0..=n {
            let c = Vec2::new(
                -1.3 + 2.6 * i as f32 / n as f32,
                -0.8 + 2.0 * j as f32 / n as f32,
            );
            if shape.f(shape.to_design(c)) < 0.0 {
                lo = lo.min(c);
                hi = hi.max(c);
            }
        }
    }
    let step = 2.6 / n as f32;
    lo -= Vec2::splat(step);
    hi += Vec2::splat(step);
    let ext = hi - lo;
    let margin = 0.03 * ext.max_element();
    let lo = lo - Vec2::splat(margin);
    let hi = hi + Vec2::splat(margin);
    let ext = hi - lo;
    let (w, h) = if ext.x >= ext.y {
        (res, ((res as f32 * ext.y / ext.x).round() as usize).max(8))
    } else {
        (((res as f32 * ext.x / ext.y).round() as usize).max(8), res)
    };
    let ppu = (w as f32 / ext.x).min(h as f32 / ext.y);
    // Centre the shape in the pixel grid.
    let card_w = w as f32 / ppu;
    let card_h = h as f32 / ppu;
    let grid = Grid {
        w,
        h,
        x0: 0.5 * (lo.x + hi.x) - 0.5 * card_w,
        top: 0.5 * (lo.y + hi.y) + 0.5 * card_h,
        ppu,
    };
    let mm_per_unit = p.height_m * 1000.0 / card_h;
    let px_per_mm = ppu / mm_per_unit;
    let midrib_r = 0.5 * p.venation.midrib_mm / mm_per_unit;

    let mut timer = crate::PhaseTimer::new();
    let segs = build_veins(&shape, p, midrib_r, &mut rng);
    timer.lap("veins grown");
    let (vmaj, hmaj) = raster_veins(
        &segs,
        &shape,
        &grid,
        mm_per_unit,
        p.vein_relief_mm,
        midrib_r,
    );

    timer.lap("veins rasterised");
    // Outline function on the grid (for alpha and the distance to the margin).
    let fgrid = Plane::from_fn(w, h, |x, y| shape.f(shape.to_design(grid.card(x, y))) * ppu);

    timer.lap("outline");
    let pal = &p.palette;
    let c_front = srgb8_to_linear(pal.front);
    let c_front_vein = srgb8_to_linear(pal.front_vein);
    let c_back = srgb8_to_linear(pal.back);
    let c_back_vein = srgb8_to_linear(pal.back_vein);
    let c_trans = srgb8_to_linear(pal.translucency);
    let areole = p.venation.areole_mm / mm_per_unit;
    let parallel = match p.venation.kind {
        VenationKind::Parallel { count } => Some(count.max(1)),
        VenationKind::Reticulate => None,
    };
    let relief = p.vein_relief_mm;
    let range_mm = relief * 1.1 + 0.06;
    let s = [
        seed32.wrapping_add(11),
        seed32.wrapping_add(23),
        seed32.wrapping_add(37),
        seed32.wrapping_add(41),
        seed32.wrapping_add(53),
        seed32.wrapping_add(67),
    ];
    // Per pixel: (front, back, translucency, alpha, bump).
    type Px = ([f32; 3], [f32; 3], [f32; 3], f32, f32);
    let cov = |r_px: f32, d_px: f32| (r_px + 0.5 - d_px).clamp(0.0, 1.0) * (2.0 * r_px).min(1.0);
    // Low-frequency fields (domain warp of the areole net, mottling, pigment variation) on a
    // grid 4x coarser, bilinearly interpolated: they vary over many pixels, and noise is the
    // inner-loop cost.
    let k = if w.min(h) >= 512 { 4 } else { 1 };
    let low = Plane::from_fn(w / k + 2, h / k + 2, |cx, cy| {
        let (x, y) = ((cx * k).min(w - 1), (cy * k).min(h - 1));
        let q = shape.to_design(grid.card(x, y));
        let u = if areole > 0.0 { q / areole } else { Vec2::ZERO };
        [
            fbm(u.x * 0.35, u.y * 0.35, s[0], 2),
            fbm(u.x * 0.35 + 5.2, u.y * 0.35, s[1], 2),
            fbm(q.x * 3.0, q.y * 3.0, s[4], 4),
            fbm(q.x * 7.0 + 31.0, q.y * 7.0, s[5], 3),
        ]
    });
    let pixels: Plane<Px> = Plane::from_fn(w, h, |x, y| {
        let i = y * w + x;
        // Pixel (x, y) sits at coarse coordinates x / k (coarse centres at k * cx).
        let lf = low.bilinear(x as f32 / k as f32 + 0.5, y as f32 / k as f32 + 0.5);
        let q = shape.to_design(grid.card(x, y));
        let f = fgrid.data[i];
        let fx = fgrid.get_clamped(x as isize + 1, y as isize)
            - fgrid.get_clamped(x as isize - 1, y as isize);
        let fy = fgrid.get_clamped(x as isize, y as isize + 1)
            - fgrid.get_clamped(x as isize, y as isize - 1);
        let gmag = (0.5 * Vec2::new(fx, fy).length()).max(0.2);
        let sd_px = f / gmag;
        let alpha = (0.5 - sd_px).clamp(0.0, 1.0);
        let inside_mm = (-sd_px / px_per_mm).max(0.0);
        let rim = (-inside_mm / 0.5).exp() * alpha;

        // Minor veins.
        let (mut vt, mut vq, mut bulge) = (0.0f32, 0.0f32, 0.0f32);
        if areole > 0.0 {
            let u = q / areole;
            let wv = Vec2::new(lf[0], lf[1]);
            let (f1, f2) = worley(u.x + 0.45 * wv.x, u.y + 0.45 * wv.y, s[2], 0.95);
            let ed = 0.5 * (f2 - f1) * areole * ppu;
            vt = cov(0.05 * px_per_mm, ed);
            bulge = ((f2 - f1) / 0.6).clamp(0.0, 1.0).sqrt();
            let u2 = u * 2.9 + Vec2::new(17.3, 4.1);
            let (g1, g2) = worley(u2.x + 0.5 * wv.y, u2.y + 0.5 * wv.x, s[3], 0.95);
            let ed2 = 0.5 * (g2 - g1) * (areole / 2.9) * ppu;
            vq = cov(0.028 * px_per_mm, ed2);
            let fade = smoothstep(0.0, 0.6, inside_mm);
            vt *= fade;
            vq *= fade;
        }
        let mut vm = vmaj.data[i];
        let mut hm = hmaj.data[i];
        if let Some(count) = parallel {
            // Longitudinal veins at fixed fractions of the local half-width.
            let l = &shape.lobes[0];
            let t = (q.dot(l.dir) / l.len).clamp(0.0, 1.0);
            let lat = q.dot(l.perp);
            let hw = shape
                .half_width(0, t, usize::from(lat < 0.0), 0.0)
                .max(1e-6);
            let u = lat / hw;
            let n = count as f32;
            let k = ((u + 1.0) * 0.5 * n - 0.5).round().clamp(0.0, n - 1.0);
            let centre = -1.0 + (2.0 * k + 1.0) / n;
            let d_px = (u - centre).abs() * hw * ppu;
            let mid = (k - (n - 1.0) * 0.5).abs() < 0.5;
            let r_mm = if mid {
                0.5 * p.venation.midrib_mm
            } else if (k as u32).is_multiple_of(2) {
                0.09
            } else {
                0.06
            };
            let c = cov(r_mm * px_per_mm, d_px) * if mid { 1.0 } else { 0.7 };
            vm = vm.max(c);
            let prof = (1.0 - (d_px / (r_mm * px_per_mm).max(0.75)).powi(2))
                .max(0.0)
                .sqrt();
            hm = hm.max(relief * prof * if mid { 1.0 } else { 0.4 });
        }

        // Noise fields (design units ~ leaf length).
        let (mottle, chl) = (lf[2], lf[3]);
        let gs = 1.0 / (0.12 / mm_per_unit);
        let grain = gradient(q.x * gs, q.y * gs, s[0] ^ 0x55);
        let m = pal.mottle;

        let minor = vt * 0.6 + vq * 0.35;
        // Front (adaxial).
        let mut meso =
            c_front * (1.0 + 0.35 * m * mottle) * (1.0 + 0.06 * grain) * (0.97 + 0.06 * bulge);
        meso = mix3(
            meso,
            meso * Vec3::new(1.35, 1.12, 0.55),
            0.6 * m * chl.max(0.0),
        );
        let mut front = mix3(
            meso,
            c_front_vein * (1.0 + 0.05 * grain),
            vm * pal.vein_contrast + minor * pal.vein_contrast * 0.8,
        );
        front = mix3(front, front * Vec3::new(1.15, 1.08, 0.7), 0.35 * rim);
        // Back (abaxial): paler, less saturated, veins more visible.
        let back_meso = desaturate(
            c_back * (1.0 + 0.2 * m * mottle) * (1.0 + 0.05 * grain),
            0.1,
        );
        let back = mix3(back_meso, c_back_vein, vm * 0.9 + minor * 0.7);
        // Through-light: yellow-green, veins darker, thin rim brighter.
        let mut tr =
            c_trans * (1.0 + 0.45 * m * chl) * (1.0 + 0.3 * m * mottle) * (1.0 + 0.06 * grain);
        tr *= (1.0 - 0.6 * vm - 0.22 * vt - 0.12 * vq).max(0.05);
        tr *= 1.0 + 0.25 * rim;
        // Bump: veins are grooves from the adaxial side (raised on the abaxial side).
        let h_mm = -(hm + 0.02 * vt + 0.008 * vq) + 0.012 * bulge + 0.004 * grain;
        let bump = if alpha > 0.0 {
            (0.5 + h_mm / (2.0 * range_mm)).clamp(0.0, 1.0)
        } else {
            0.5
        };
        let clamp3 = |v: Vec3| v.clamp(Vec3::ZERO, Vec3::ONE).to_array();
        (clamp3(front), clamp3(back), clamp3(tr), alpha, bump)
    });

    timer.lap("pixels");
    let front: Rgb = pixels.map(|p| p.0);
    let back: Rgb = pixels.map(|p| p.1);
    let translucency: Rgb = pixels.map(|p| p.2);
    let alpha: Gray = pixels.map(|p| p.3);
    let bump: Gray = pixels.map(|p| p.4);
    drop(pixels);
    let extinction = extinction_from_translucency(&translucency);
    let thickness = thickness_from_extinction(&extinction, &alpha, 0.3 * px_per_mm, 1.5);
    timer.lap("extinction+thickness");
    let planes = MapPlanes {
        front,
        back,
        translucency,
        alpha,
        thickness,
        extinction,
        bump,
    };
    let size_m = (card_w * mm_per_unit / 1000.0, p.height_m);
    let mut params = p.params;
    // One unit of bump map value spans 2 * range_mm; express it in texture-space units,
    // taking the geometric mean of the card sides as the texture-space unit length.
    params.bump_scale = (2.0 * range_mm / 1000.0 / (size_m.0 * size_m.1).sqrt()).clamp(0.0, 1.0);
    let maps = planes.to_leaf_maps();
    timer.lap("textures");
    GeneratedLeaf {
        maps,
        params,
        size_m,
        planes,
        species: p.name.clone(),
        seed: spec.seed,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_preset_generates_a_sane_leaf() {
        for s in Species::ALL {
            let leaf = generate(&LeafSpec::new(s, 7, 160));
            let (w, h) = leaf.planes.size();
            assert!(w.max(h) == 160, "{s}: {w}x{h}");
            let a = &leaf.planes.alpha.data;
            let cover = a.iter().filter(|v| **v >= 0.5).count() as f32 / a.len() as f32;
            assert!((0.04..0.9).contains(&cover), "{s}: alpha cover {cover}");
            // Border is transparent except the petiole at the bottom.
            for x in 0..w {
                assert!(leaf.planes.alpha.get(x, 0) < 0.5, "{s}: top row opaque");
            }
            // Back paler than front, translucency yellow-green, inside the leaf.
            let mean = |p: &Rgb| {
                let mut acc = Vec3::ZERO;
                let mut n = 0.0;
                for (c, a) in p.data.iter().zip(a) {
                    if *a >= 0.5 {
                        acc += Vec3::from_array(*c);
                        n += 1.0;
                    }
                }
                acc / n
            };
            let (f, b, t) = (
                mean(&leaf.planes.front),
                mean(&leaf.planes.back),
                mean(&leaf.planes.translucency),
            );
            assert!(
                b.dot(Vec3::ONE) > f.dot(Vec3::ONE),
                "{s}: back {b} not paler than front {f}"
            );
            assert!(t.y > t.x && t.y > t.z, "{s}: translucency {t} not green");
            assert!(f.y < 0.3 && f.y > 0.02, "{s}: front {f} not a leaf albedo");
            leaf.params.validate().unwrap();
            let (e0, e1) = leaf.planes.extinction.min_max();
            assert!(e0 >= 0.0 && e1 <= 1.0);
            assert!(leaf.size_m.0 > 0.0 && leaf.size_m.1 > leaf.size_m.0 * 0.5);
        }
    }

    #[test]
    fn deterministic_and_seed_dependent() {
        let a = generate(&LeafSpec::new(Species::Beech, 3, 96));
        let b = generate(&LeafSpec::new(Species::Beech, 3, 96));
        let c = generate(&LeafSpec::new(Species::Beech, 4, 96));
        assert_eq!(a.planes.front.data, b.planes.front.data);
        assert_ne!(a.planes.front.data, c.planes.front.data);
    }
}
