//! The leaf's outline: lobes with profiles, pinnate sinuses and marginal teeth united into
//! one implicit function in design space, and the petiole (see the module docs of
//! [`super`]).

use crate::noise::Rng;
use crate::species::{Preset, Profile, Teeth};
use glam::Vec2;

/// One lobe of the outline in design space (main lobe length 1, petiole junction at the
/// origin): a region along an axis from the origin whose half-width follows a profile.
#[derive(Clone, Debug)]
pub(super) struct Lobe {
    /// Unit direction of the lobe's axis (the main lobe points toward `+y`).
    pub(super) dir: Vec2,
    /// `dir` turned 90° counter-clockwise: the lateral axis (`lat >= 0` is the left side).
    pub(super) perp: Vec2,
    /// Length of the axis, design units.
    pub(super) len: f32,
    /// Largest half-width as a fraction of `len`.
    pub(super) hw: f32,
    /// Half-width profile along the axis (`t = along / len` in `[0, 1]`, peak 1).
    profile: Profile,
    /// Relative radius of the lobe's primary vein (1 for the midrib).
    pub(super) vein_weight: f32,
    /// Half-width factors of the left (`lat >= 0`) and right side.
    asym: [f32; 2],
    /// Phase of the marginal teeth on the left and right side (fractions of a tooth).
    tooth_phase: [f32; 2],
    /// Phase of the pinnate lobes and sinuses on the left and right side (fractions of a
    /// lobe).
    pub(super) sinus_phase: [f32; 2],
    /// Seed of the pinnate lobes' sizes.
    sinus_seed: u32,
    /// The profile tabulated at `PROFILE_N + 1` points of `t` (the profile is the hot spot of
    /// the outline function, with two `powf`).
    lut: Vec<f32>,
}

const PROFILE_N: usize = 2048;

impl Lobe {
    /// The half-width profile at `t` (clamped to `[0, 1]`), from the table.
    #[inline]
    fn profile(&self, t: f32) -> f32 {
        let x = t.clamp(0.0, 1.0) * PROFILE_N as f32;
        let i = (x as usize).min(PROFILE_N - 1);
        let f = x - i as f32;
        self.lut[i] + (self.lut[i + 1] - self.lut[i]) * f
    }
}

/// The leaf's outline in design space: an implicit function (negative inside) made of
/// lobes, smoothly united, plus the petiole; design space is mapped to card space by a
/// slight bend of the midrib.
pub(super) struct Outline {
    /// The lobes; `lobes[0]` is the main one (along the midrib).
    pub(super) lobes: Vec<Lobe>,
    /// Marginal teeth, if the species has them.
    teeth: Option<Teeth>,
    /// Pinnate lobes and sinuses of the main lobe (oak), if any.
    pub(super) sinuses: Option<crate::species::Sinuses>,
    /// Blend width of the smooth union of the lobes, design units (0: a plain union).
    blend: f32,
    /// Petiole length below the junction, design units.
    pub(super) petiole_len: f32,
    /// Petiole radius at the junction, design units.
    pub(super) petiole_r: f32,
    /// Midrib bend: card `x` = design `x + bend · y²` (design units).
    bend: f32,
}

/// Forward shear of pinnate lobes (change of `t` per unit of lateral distance).
pub(super) const SINUS_SHEAR: f32 = 0.3;

/// Hermite step: 0 at `x <= e0`, 1 at `x >= e1`, smooth in between (`e1 < e0` reverses it).
#[inline]
pub(super) fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// The half-width profile `p` at `t` (peak 1 for [`Profile::Beta`]).
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

/// The margin's tooth perturbation at `u` (teeth per unit of `u`; 0 the sinus before a
/// tooth), roughly in `[-0.6, 0.6]`.
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

/// A smooth minimum of `a` and `b` (polynomial, Quilez): equal to `a.min(b)` where they
/// differ by more than `k`, rounded below it within `k` of each other; `k <= 0` is the plain
/// minimum. Used to unite lobes without a crease at the sinus.
#[inline]
fn smooth_min(a: f32, b: f32, k: f32) -> f32 {
    if k <= 0.0 {
        return a.min(b);
    }
    let h = (k - (a - b).abs()).max(0.0) / k;
    a.min(b) - h * h * k * 0.25
}

impl Outline {
    /// Half-width of lobe `l` at `t` on `side` (0 left, 1 right), design units. `lat` is
    /// the lateral distance of the point asked about: pinnate lobes are sheared toward the
    /// apex by it (they point forward, as oak lobes do).
    pub(super) fn half_width(&self, i: usize, t: f32, side: usize, lat: f32) -> f32 {
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
    fn lobe_field(&self, i: usize, q: Vec2) -> f32 {
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
    pub(super) fn field(&self, q: Vec2) -> f32 {
        let mut f = self.lobe_field(0, q);
        for i in 1..self.lobes.len() {
            f = smooth_min(f, self.lobe_field(i, q), self.blend);
        }
        // Petiole: a capsule from the junction down.
        let py = q.y.clamp(-self.petiole_len, 0.0);
        let pet = (q - Vec2::new(0.0, py)).length()
            - self.petiole_r * (1.0 + 0.3 * (-py / self.petiole_len.max(1e-6)));
        f.min(pet)
    }

    /// The lobe whose outline function is smallest at `q`.
    pub(super) fn nearest_lobe(&self, q: Vec2) -> usize {
        (0..self.lobes.len())
            .map(|i| (i, self.lobe_field(i, q)))
            .fold((0, f32::MAX), |a, b| if b.1 < a.1 { b } else { a })
            .0
    }

    /// Design space to card space (the midrib bend).
    #[inline]
    pub(super) fn to_card(&self, q: Vec2) -> Vec2 {
        let y = q.y.max(0.0);
        Vec2::new(q.x + self.bend * y * y, q.y)
    }

    /// Card space to design space.
    #[inline]
    pub(super) fn to_design(&self, c: Vec2) -> Vec2 {
        let y = c.y.max(0.0);
        Vec2::new(c.x - self.bend * y * y, c.y)
    }
}

/// `v` rotated counter-clockwise by `deg` degrees.
pub(super) fn rotate_deg(v: Vec2, deg: f32) -> Vec2 {
    let (s, c) = deg.to_radians().sin_cos();
    Vec2::new(c * v.x - s * v.y, s * v.x + c * v.y)
}

/// The outline of preset `p` with the seed's jitter of lobe angles, lengths, widths,
/// profiles, asymmetry and phases, and of the midrib's bend; `petiole_r` in design units.
pub(super) fn build_outline(p: &Preset, rng: &mut Rng, petiole_r: f32) -> Outline {
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
            let dir = rotate_deg(Vec2::Y, l.angle_deg + jitter_angle);
            let mut g = Lobe {
                dir,
                perp: rotate_deg(dir, 90.0),
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
    Outline {
        lobes,
        teeth: p.outline.teeth,
        sinuses: p.outline.sinuses,
        blend: p.outline.blend,
        petiole_len: p.outline.petiole,
        petiole_r,
        bend: rng.range(-0.06, 0.06),
    }
}
