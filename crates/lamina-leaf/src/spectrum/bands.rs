//! Spectral bands and the way RGB scene values become band values.
//!
//! A [`Band`] is a named wavelength interval (a satellite band, a PAR window, a narrow
//! line). A render in bands renders three at a time through the RGB integrator, with every
//! scene value replaced by its band value:
//!
//! * **Reflectances and other RGB material values** (colours, colour maps, a leaf's layer
//!   coefficients) become spectra through a fixed linear basis: `s(λ) = Σ_c rgb_c B_c(λ)`,
//!   `B_c` the Jakob & Hanika spectra of the three primaries ([`super::upsample`]) divided by
//!   their sum, so that white stays exactly 1 at every wavelength and any RGB in `[0, 1]`
//!   stays in `[0, 1]`. Beyond 830 nm the basis holds its 830 nm value: an RGB material says
//!   nothing about the infrared, and this is the neutral guess. Pigment leaves (PROSPECT) are
//!   spectral by themselves and do not go through it.
//! * **Emission** (lights, skies) is the same basis times the shape of the ground-level solar
//!   spectrum (ASTM G173 global, [`super::solar_global`]), normalised so that an RGB white of
//!   1 has `∫ E(λ) ȳ(λ) dλ = 1`: the convention of lamina's RGB radiance (`Y = ∫ L ȳ dλ`).
//!   A band's value is then the band-mean spectral radiance in W m⁻² sr⁻¹ nm⁻¹.
//!
//! Band values are means over the band, integrated at 1 nm.

use super::upsample::RgbSpectrum;
use super::{LAMBDA_MAX_NM, LAMBDA_MIN_NM, cie_xyz_bar, solar_global};
use glam::Vec3;
use std::sync::OnceLock;

/// A named wavelength band `[lo_nm, hi_nm]`.
#[derive(Clone, Debug, PartialEq)]
pub struct Band {
    /// Its name: the EXR channel name.
    pub name: String,
    /// Shortest wavelength, nm.
    pub lo_nm: f32,
    /// Longest wavelength, nm (`> lo_nm`).
    pub hi_nm: f32,
}

impl Band {
    /// The band's centre, nm.
    pub fn center(&self) -> f32 {
        0.5 * (self.lo_nm + self.hi_nm)
    }
}

/// `B_R, B_G, B_B` (normalised to sum to 1) at `nm`.
fn basis(nm: f32) -> Vec3 {
    static PRIMARIES: OnceLock<[RgbSpectrum; 3]> = OnceLock::new();
    let p = PRIMARIES.get_or_init(|| [Vec3::X, Vec3::Y, Vec3::Z].map(|c| RgbSpectrum::fit(c).0));
    let v = Vec3::new(p[0].eval(nm), p[1].eval(nm), p[2].eval(nm));
    v / v.element_sum().max(1e-6)
}

/// The solar shape's normalisation: `∫ S ȳ dλ` over 360-830 nm.
fn emission_norm() -> f32 {
    static NORM: OnceLock<f32> = OnceLock::new();
    *NORM.get_or_init(|| {
        (360..830)
            .map(|k| {
                let nm = k as f32 + 0.5;
                solar_global(nm) * cie_xyz_bar(nm).y
            })
            .sum()
    })
}

/// The band means of the three basis spectra, for reflectance and for emission: `(refl,
/// emit)` where `refl.dot(rgb)` is the band value of reflectance `rgb`.
fn band_means(b: &Band) -> (Vec3, Vec3) {
    let lo = b.lo_nm.max(LAMBDA_MIN_NM);
    let hi = b.hi_nm.min(LAMBDA_MAX_NM).max(lo + 1e-3);
    let n = ((hi - lo).ceil() as usize).max(1);
    let step = (hi - lo) / n as f32;
    let (mut r, mut e) = (Vec3::ZERO, Vec3::ZERO);
    for k in 0..n {
        let nm = lo + (k as f32 + 0.5) * step;
        let bs = basis(nm);
        r += bs;
        e += bs * solar_global(nm);
    }
    (r / n as f32, e / (n as f32 * emission_norm()))
}

/// How RGB values become the values of three bands (one per channel of a band render).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BandBasis {
    /// Row `i`: the weights of R, G, B in band `i`'s reflectance.
    refl: [Vec3; 3],
    /// Row `i`: the same for emission (W m⁻² sr⁻¹ nm⁻¹ per unit of RGB radiance).
    emit: [Vec3; 3],
}

impl BandBasis {
    /// The basis for `bands` (channel `i` of a band render is band `i`).
    pub fn new(bands: [&Band; 3]) -> Self {
        let m = bands.map(band_means);
        BandBasis {
            refl: m.map(|x| x.0),
            emit: m.map(|x| x.1),
        }
    }

    /// The three band values of an RGB reflectance (or any RGB material coefficient).
    #[inline]
    pub fn reflectance(&self, rgb: Vec3) -> Vec3 {
        Vec3::new(
            self.refl[0].dot(rgb),
            self.refl[1].dot(rgb),
            self.refl[2].dot(rgb),
        )
    }

    /// The three band values (band-mean spectral radiance or irradiance, per nm) of an RGB
    /// emission.
    #[inline]
    pub fn emission(&self, rgb: Vec3) -> Vec3 {
        Vec3::new(
            self.emit[0].dot(rgb),
            self.emit[1].dot(rgb),
            self.emit[2].dot(rgb),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn band(lo: f32, hi: f32) -> Band {
        Band {
            name: format!("{lo}-{hi}"),
            lo_nm: lo,
            hi_nm: hi,
        }
    }

    #[test]
    fn white_stays_white_and_colours_land_in_their_bands() {
        let (b, g, r, nir) = (
            band(440.0, 480.0),
            band(530.0, 570.0),
            band(620.0, 680.0),
            band(800.0, 900.0),
        );
        let m = BandBasis::new([&b, &g, &r]);
        assert!((m.reflectance(Vec3::ONE) - Vec3::ONE).abs().max_element() < 1e-5);
        let green = m.reflectance(Vec3::new(0.05, 0.4, 0.05));
        assert!(
            green.y > 2.0 * green.x && green.y > 2.0 * green.z,
            "{green}"
        );
        // NIR: the basis holds its 830 nm value, a grey stays that grey.
        let n = BandBasis::new([&nir, &nir, &nir]);
        assert!((n.reflectance(Vec3::splat(0.3)).x - 0.3).abs() < 1e-5);
    }

    #[test]
    fn white_light_has_unit_luminance_weighted_integral() {
        // Band-mean spectral radiance of RGB white, summed with ȳ over the visible, is 1.
        let bands: Vec<Band> = (0..47)
            .map(|k| band(360.0 + 10.0 * k as f32, 370.0 + 10.0 * k as f32))
            .collect();
        let mut y = 0.0;
        for bd in &bands {
            let e = BandBasis::new([bd, bd, bd]).emission(Vec3::ONE).x;
            let ybar: f32 = (0..10)
                .map(|i| cie_xyz_bar(bd.lo_nm + i as f32 + 0.5).y)
                .sum();
            y += e * ybar;
        }
        assert!((y - 1.0).abs() < 0.02, "{y}");
    }
}
