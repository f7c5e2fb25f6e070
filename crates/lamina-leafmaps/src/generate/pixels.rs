//! The per-pixel step: from the outline field and the rasterised major veins to the
//! front, back and translucency colours, alpha and bump of every pixel (minor veins,
//! parallel veins, mottling, grain; see the module docs of [`super`]).

use super::card::PixelGrid;
use super::outline::{Outline, smoothstep};
use crate::noise::{fbm, gradient, worley};
use crate::plane::{Gray, Plane};
use crate::species::{Palette, Preset, VenationKind, srgb8_to_linear};
use glam::{Vec2, Vec3};

/// One pixel's maps: (front, back, translucency, alpha, bump).
pub(super) type Px = ([f32; 3], [f32; 3], [f32; 3], f32, f32);

/// `a` to `b` by `t`, `t` clamped to `[0, 1]`.
#[inline]
fn mix3(a: Vec3, b: Vec3, t: f32) -> Vec3 {
    a + (b - a) * t.clamp(0.0, 1.0)
}

/// `c` moved toward its luminance (Rec. 709) by `amount`.
#[inline]
fn desaturate(c: Vec3, amount: f32) -> Vec3 {
    let y = c.dot(Vec3::new(0.2126, 0.7152, 0.0722));
    mix3(c, Vec3::splat(y), amount)
}

/// Anti-aliased coverage of a pixel at distance `d_px` from the centre line of a vein of
/// radius `r_px` (pixels).
#[inline]
fn coverage(r_px: f32, d_px: f32) -> f32 {
    (r_px + 0.5 - d_px).clamp(0.0, 1.0) * (2.0 * r_px).min(1.0)
}

/// What the per-pixel step reads (lengths in design units unless named otherwise).
pub(super) struct PixelInputs<'a> {
    /// The preset.
    pub(super) preset: &'a Preset,
    /// The outline.
    pub(super) outline: &'a Outline,
    /// The card's pixel grid.
    pub(super) grid: &'a PixelGrid,
    /// The outline function at every pixel, in pixels (negative inside).
    pub(super) field: &'a Gray,
    /// Coverage of the major veins, `[0, 1]`.
    pub(super) vein_cover: &'a Gray,
    /// Height of the major veins (mm).
    pub(super) vein_height: &'a Gray,
    /// Millimetres per design unit.
    pub(super) mm_per_unit: f32,
    /// Pixels per millimetre.
    pub(super) px_per_mm: f32,
    /// Half the range of bump heights the bump map spans (mm).
    pub(super) range_mm: f32,
    /// Seed of the noise fields.
    pub(super) seed32: u32,
}

/// Everything derived once from [`PixelInputs`] for the per-pixel function.
struct Shader<'a> {
    inp: &'a PixelInputs<'a>,
    pal: &'a Palette,
    c_front: Vec3,
    c_front_vein: Vec3,
    c_back: Vec3,
    c_back_vein: Vec3,
    c_trans: Vec3,
    /// Areole size, design units (0: no reticulate net).
    areole: f32,
    /// The number of parallel veins (grass), or `None` for reticulate venation.
    parallel: Option<u32>,
    /// Relief of the midrib (mm).
    relief: f32,
    /// Seeds of the noise fields.
    s: [u32; 6],
    /// Coarse factor of `low` (1 or 4).
    k: usize,
    /// Low-frequency fields on the coarse grid: the areole net's domain warp (two), the
    /// mottling and the pigment variation.
    low: Plane<[f32; 4]>,
}

/// The maps of every pixel.
pub(super) fn shade_pixels(inp: &PixelInputs) -> Plane<Px> {
    let p = inp.preset;
    let (w, h) = (inp.grid.w, inp.grid.h);
    let pal = &p.palette;
    let seed32 = inp.seed32;
    let areole = p.venation.areole_mm / inp.mm_per_unit;
    let s = [
        seed32.wrapping_add(11),
        seed32.wrapping_add(23),
        seed32.wrapping_add(37),
        seed32.wrapping_add(41),
        seed32.wrapping_add(53),
        seed32.wrapping_add(67),
    ];
    // Low-frequency fields (domain warp of the areole net, mottling, pigment variation) on a
    // grid 4x coarser, bilinearly interpolated: they vary over many pixels, and noise is the
    // inner-loop cost.
    let k = if w.min(h) >= 512 { 4 } else { 1 };
    let low = Plane::from_fn(w / k + 2, h / k + 2, |cx, cy| {
        let (x, y) = ((cx * k).min(w - 1), (cy * k).min(h - 1));
        let q = inp.outline.to_design(inp.grid.card(x, y));
        let u = if areole > 0.0 { q / areole } else { Vec2::ZERO };
        [
            fbm(u.x * 0.35, u.y * 0.35, s[0], 2),
            fbm(u.x * 0.35 + 5.2, u.y * 0.35, s[1], 2),
            fbm(q.x * 3.0, q.y * 3.0, s[4], 4),
            fbm(q.x * 7.0 + 31.0, q.y * 7.0, s[5], 3),
        ]
    });
    let shader = Shader {
        inp,
        pal,
        c_front: srgb8_to_linear(pal.front),
        c_front_vein: srgb8_to_linear(pal.front_vein),
        c_back: srgb8_to_linear(pal.back),
        c_back_vein: srgb8_to_linear(pal.back_vein),
        c_trans: srgb8_to_linear(pal.translucency),
        areole,
        parallel: match p.venation.kind {
            VenationKind::Parallel { count } => Some(count.max(1)),
            VenationKind::Reticulate => None,
        },
        relief: p.vein_relief_mm,
        s,
        k,
        low,
    };
    Plane::from_fn(w, h, |x, y| shader.pixel(x, y))
}

impl Shader<'_> {
    /// The maps of pixel `(x, y)`.
    fn pixel(&self, x: usize, y: usize) -> Px {
        let (inp, k) = (self.inp, self.k);
        let i = y * inp.grid.w + x;
        // Pixel (x, y) sits at coarse coordinates x / k (coarse centres at k * cx).
        let lf = self
            .low
            .bilinear(x as f32 / k as f32 + 0.5, y as f32 / k as f32 + 0.5);
        let q = inp.outline.to_design(inp.grid.card(x, y));
        let (alpha, inside_mm, rim) = self.edge(x, y, i);
        let (vt, vq, bulge) = self.minor_veins(q, lf, inside_mm);
        let (mut vm, mut hm) = (inp.vein_cover.data[i], inp.vein_height.data[i]);
        if let Some(count) = self.parallel {
            (vm, hm) = self.parallel_veins(q, count, vm, hm);
        }
        self.colours(q, lf, [vm, hm, vt, vq, bulge, rim, alpha])
    }

    /// Alpha (anti-aliased over one pixel), the distance inside the margin (mm, 0 outside)
    /// and the rim weight (1 at the margin, fading over half a millimetre) of pixel `i`.
    fn edge(&self, x: usize, y: usize, i: usize) -> (f32, f32, f32) {
        let (fgrid, px_per_mm) = (self.inp.field, self.inp.px_per_mm);
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
        (alpha, inside_mm, rim)
    }

    /// The minor veins at design point `q`: coverage of the tertiary (`vt`) and quaternary
    /// (`vq`) net, the edges of two domain-warped Voronoi diagrams, and the bulge of the
    /// areole between them; all 0 without a net.
    fn minor_veins(&self, q: Vec2, lf: [f32; 4], inside_mm: f32) -> (f32, f32, f32) {
        let (areole, s) = (self.areole, &self.s);
        let (ppu, px_per_mm) = (self.inp.grid.ppu, self.inp.px_per_mm);
        let (mut vt, mut vq, mut bulge) = (0.0f32, 0.0f32, 0.0f32);
        if areole > 0.0 {
            let u = q / areole;
            let wv = Vec2::new(lf[0], lf[1]);
            let (f1, f2) = worley(u.x + 0.45 * wv.x, u.y + 0.45 * wv.y, s[2], 0.95);
            let ed = 0.5 * (f2 - f1) * areole * ppu;
            vt = coverage(0.05 * px_per_mm, ed);
            bulge = ((f2 - f1) / 0.6).clamp(0.0, 1.0).sqrt();
            let u2 = u * 2.9 + Vec2::new(17.3, 4.1);
            let (g1, g2) = worley(u2.x + 0.5 * wv.y, u2.y + 0.5 * wv.x, s[3], 0.95);
            let ed2 = 0.5 * (g2 - g1) * (areole / 2.9) * ppu;
            vq = coverage(0.028 * px_per_mm, ed2);
            let fade = smoothstep(0.0, 0.6, inside_mm);
            vt *= fade;
            vq *= fade;
        }
        (vt, vq, bulge)
    }

    /// The major vein coverage `vm` and height `hm` (mm) at `q` with `count` parallel veins
    /// (grass) added: longitudinal veins at fixed fractions of the local half-width.
    fn parallel_veins(&self, q: Vec2, count: u32, vm: f32, hm: f32) -> (f32, f32) {
        let (outline, ppu, px_per_mm) = (self.inp.outline, self.inp.grid.ppu, self.inp.px_per_mm);
        let l = &outline.lobes[0];
        let t = (q.dot(l.dir) / l.len).clamp(0.0, 1.0);
        let lat = q.dot(l.perp);
        let hw = outline
            .half_width(0, t, usize::from(lat < 0.0), 0.0)
            .max(1e-6);
        let u = lat / hw;
        let n = count as f32;
        let k = ((u + 1.0) * 0.5 * n - 0.5).round().clamp(0.0, n - 1.0);
        let centre = -1.0 + (2.0 * k + 1.0) / n;
        let d_px = (u - centre).abs() * hw * ppu;
        let mid = (k - (n - 1.0) * 0.5).abs() < 0.5;
        let r_mm = if mid {
            0.5 * self.inp.preset.venation.midrib_mm
        } else if (k as u32).is_multiple_of(2) {
            0.09
        } else {
            0.06
        };
        let c = coverage(r_mm * px_per_mm, d_px) * if mid { 1.0 } else { 0.7 };
        let vm = vm.max(c);
        let prof = (1.0 - (d_px / (r_mm * px_per_mm).max(0.75)).powi(2))
            .max(0.0)
            .sqrt();
        let hm = hm.max(self.relief * prof * if mid { 1.0 } else { 0.4 });
        (vm, hm)
    }

    /// The colours, alpha and bump at design point `q` from the vein coverages and the edge:
    /// `v = [vm, hm, vt, vq, bulge, rim, alpha]` (major vein coverage and height in mm,
    /// tertiary and quaternary coverage, areole bulge, rim weight, alpha).
    fn colours(&self, q: Vec2, lf: [f32; 4], v: [f32; 7]) -> Px {
        let [vm, hm, vt, vq, bulge, rim, alpha] = v;
        let (pal, s) = (self.pal, &self.s);
        // Noise fields (design units ~ leaf length).
        let (mottle, chl) = (lf[2], lf[3]);
        let gs = 1.0 / (0.12 / self.inp.mm_per_unit);
        let grain = gradient(q.x * gs, q.y * gs, s[0] ^ 0x55);
        let m = pal.mottle;

        let minor = vt * 0.6 + vq * 0.35;
        // Front (adaxial).
        let mut meso =
            self.c_front * (1.0 + 0.35 * m * mottle) * (1.0 + 0.06 * grain) * (0.97 + 0.06 * bulge);
        meso = mix3(
            meso,
            meso * Vec3::new(1.35, 1.12, 0.55),
            0.6 * m * chl.max(0.0),
        );
        let mut front = mix3(
            meso,
            self.c_front_vein * (1.0 + 0.05 * grain),
            vm * pal.vein_contrast + minor * pal.vein_contrast * 0.8,
        );
        front = mix3(front, front * Vec3::new(1.15, 1.08, 0.7), 0.35 * rim);
        // Back (abaxial): paler, less saturated, veins more visible.
        let back_meso = desaturate(
            self.c_back * (1.0 + 0.2 * m * mottle) * (1.0 + 0.05 * grain),
            0.1,
        );
        let back = mix3(back_meso, self.c_back_vein, vm * 0.9 + minor * 0.7);
        // Through-light: yellow-green, veins darker, thin rim brighter.
        let mut tr =
            self.c_trans * (1.0 + 0.45 * m * chl) * (1.0 + 0.3 * m * mottle) * (1.0 + 0.06 * grain);
        tr *= (1.0 - 0.6 * vm - 0.22 * vt - 0.12 * vq).max(0.05);
        tr *= 1.0 + 0.25 * rim;
        // Bump: veins are grooves from the adaxial side (raised on the abaxial side).
        let h_mm = -(hm + 0.02 * vt + 0.008 * vq) + 0.012 * bulge + 0.004 * grain;
        let bump = if alpha > 0.0 {
            (0.5 + h_mm / (2.0 * self.inp.range_mm)).clamp(0.0, 1.0)
        } else {
            0.5
        };
        let clamp3 = |v: Vec3| v.clamp(Vec3::ZERO, Vec3::ONE).to_array();
        (clamp3(front), clamp3(back), clamp3(tr), alpha, bump)
    }
}
