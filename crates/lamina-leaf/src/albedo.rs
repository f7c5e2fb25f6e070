//! Directional-hemispherical reflectance and transmittance of a leaf, integrated from the
//! BSDF the renderer evaluates.
//!
//! For light arriving from direction `L` (incidence angle `θ` on the adaxial or abaxial
//! side), the leaf reflects `R(θ) = ∫_{same side} f(w, L) |cos θ_w| dw` and transmits
//! `T(θ) = ∫_{other side} f(w, L) |cos θ_w| dw`. The leaf BSDF is reciprocal
//! (`f(w, L) = f(L, w)`, tested in `tests/`), so both are the expectation of
//! [`Bsdf::sample`]'s weight `f |cos| / pdf` for `wo = L`: exactly what a path tracer does
//! at a leaf, with the same code (`LeafMaterial::bsdf(uv)`, then `sample`). The sample
//! points are a deterministic low-discrepancy set (a Hammersley set in the two direction
//! dimensions, a golden-ratio sequence for the lobe choice), so the result is the same on
//! every run, and the texels are a stratified grid of the leaf's opaque texels.
//!
//! That includes the specular lobe, the bump map and every map: what a measurement of the
//! leaf in an integrating sphere would see (the paper's and PROSPECT's quantity).

use crate::bsdf::Bsdf;
use crate::material::LeafMaterial;
use glam::{Vec2, Vec3};

/// Which side of the leaf the light comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Side {
    /// The upper (adaxial, `+z`) side: the usual measurement.
    #[default]
    Adaxial,
    /// The lower (abaxial, `-z`) side.
    Abaxial,
}

impl std::str::FromStr for Side {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "adaxial" | "upper" | "front" => Ok(Side::Adaxial),
            "abaxial" | "lower" | "back" => Ok(Side::Abaxial),
            _ => Err(format!("unknown side '{s}': use adaxial or abaxial")),
        }
    }
}

/// How to integrate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AlbedoOptions {
    /// Incidence angle from the leaf normal, degrees, in `[0, 89]`. Integrating spheres
    /// measure at 8°.
    pub theta_deg: f32,
    /// Which side is lit.
    pub side: Side,
    /// Direction samples in all (split over the texels); the error is about
    /// `0.3 / sqrt(samples)` on the specular part and far less on the diffuse lobes.
    pub samples: u32,
    /// At most this many texels (a stratified grid over the leaf's opaque area).
    pub max_texels: u32,
}

impl Default for AlbedoOptions {
    fn default() -> Self {
        AlbedoOptions {
            theta_deg: 8.0,
            side: Side::Adaxial,
            samples: 1 << 16,
            max_texels: 1024,
        }
    }
}

/// `(R, T)` per channel of `leaf` for light from `opts`' direction, averaged over its
/// opaque texels. A leaf with no opaque texel on the grid gives zeros.
pub fn directional_albedo(leaf: &LeafMaterial, opts: &AlbedoOptions) -> (Vec3, Vec3) {
    let uvs = opaque_texels(leaf, opts.max_texels);
    if uvs.is_empty() {
        return (Vec3::ZERO, Vec3::ZERO);
    }
    let per = (opts.samples as usize / uvs.len()).max(16);
    let (s, c) = opts.theta_deg.clamp(0.0, 89.0).to_radians().sin_cos();
    let wo = match opts.side {
        Side::Adaxial => Vec3::new(s, 0.0, c),
        Side::Abaxial => Vec3::new(s, 0.0, -c),
    };
    let mut r = Vec3::ZERO;
    let mut t = Vec3::ZERO;
    for (k, uv) in uvs.iter().enumerate() {
        let bsdf = leaf.bsdf(*uv);
        // A per-texel rotation of the point set (Cranley-Patterson), so texels do not all
        // use the same directions.
        let shift = Vec2::new(fract(k as f32 * 0.618_034), fract(k as f32 * 0.754_877_7));
        let mut rk = Vec3::ZERO;
        let mut tk = Vec3::ZERO;
        for i in 0..per {
            let u = Vec3::new(
                fract((i as f32 + 0.5) / per as f32 + shift.x),
                fract(radical_inverse(i as u32) + shift.y),
                fract(i as f32 * 0.618_034 + 0.5 * shift.x),
            );
            if let Some(smp) = bsdf.sample(wo, u) {
                let w = smp.weight();
                if !w.is_finite() {
                    continue;
                }
                if smp.wi.z * wo.z > 0.0 {
                    rk += w;
                } else {
                    tk += w;
                }
            }
        }
        r += rk / per as f32;
        t += tk / per as f32;
    }
    (r / uvs.len() as f32, t / uvs.len() as f32)
}

/// Texture coordinates of up to `max` opaque texel centres on a stratified grid over the
/// leaf (just the centre for a leaf without an alpha matte or maps).
pub fn opaque_texels(leaf: &LeafMaterial, max: u32) -> Vec<Vec2> {
    let maps = leaf.maps();
    let size = [
        &maps.front,
        &maps.back,
        &maps.translucency,
        &maps.alpha,
        &maps.thickness,
        &maps.extinction,
        &maps.bump,
    ]
    .iter()
    .filter_map(|t| t.as_ref().map(|t| t.width().max(t.height())))
    .max()
    .unwrap_or(1);
    if size <= 1 {
        return vec![Vec2::splat(0.5)];
    }
    // A grid of g x g cells over the card; the opaque centres of a finer grid, thinned to
    // `max`, keep the average unbiased where the matte covers part of the card.
    let g = size.clamp(2, 512);
    let mut all = Vec::new();
    for y in 0..g {
        for x in 0..g {
            let uv = Vec2::new((x as f32 + 0.5) / g as f32, (y as f32 + 0.5) / g as f32);
            if leaf.opaque(uv) {
                all.push(uv);
            }
        }
    }
    let max = max.max(1) as usize;
    if all.len() <= max {
        return all;
    }
    let stride = all.len() as f64 / max as f64;
    (0..max)
        .map(|k| all[((k as f64 + 0.5) * stride) as usize])
        .collect()
}

fn fract(x: f32) -> f32 {
    x - x.floor()
}

/// Van der Corput radical inverse in base 2.
fn radical_inverse(i: u32) -> f32 {
    (i.reverse_bits() as f64 / 4_294_967_296.0) as f32
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{LeafMaps, LeafParams};

    #[test]
    fn albedo_is_deterministic_and_energy_bounded() {
        let leaf = LeafMaterial::new(LeafMaps::default(), LeafParams::default()).unwrap();
        let opts = AlbedoOptions::default();
        let a = directional_albedo(&leaf, &opts);
        assert_eq!(a, directional_albedo(&leaf, &opts));
        let (r, t) = a;
        assert!((r + t).max_element() < 1.0, "{r} {t}");
        // The README's normal-incidence table: R (0.067, 0.136, 0.045), T (0.013, 0.160, 0).
        let (r0, t0) = directional_albedo(
            &leaf,
            &AlbedoOptions {
                theta_deg: 0.0,
                ..opts
            },
        );
        assert!(
            (r0 - Vec3::new(0.067, 0.136, 0.045)).abs().max_element() < 4e-3,
            "{r0}"
        );
        assert!(
            (t0 - Vec3::new(0.013, 0.160, 0.0)).abs().max_element() < 4e-3,
            "{t0}"
        );
    }
}
