//! The wavelength bins of `[film] spectral = "visible"` renders and their way to linear
//! Rec.709 through the CIE 1931 observer.
//!
//! A visible render is a render in [`BINS`] flat bands of equal width over 360-830 nm (the
//! CIE 1931 table's range), each a [`Band`] like any band render's: every scene value is
//! its bin-mean (RGB values through the reflectance basis, RGB emission with the D65 shape,
//! physical skies and pigment leaves from their own spectra at the bin, see
//! [`super::bands`]). Each camera path carries [`PATH_BINS`] of them, equally spaced:
//! `h, h + S, h + 2S, ...` with `S = BINS / PATH_BINS` and the hero offset `h` drawn
//! uniformly per path (hero-wavelength sampling, Wilkie et al. 2014, over bins), so every
//! bin is on a path with probability `1 / S`. A path's radiances become linear Rec.709 by
//! [`bin_to_rgb`]: `rgb = Σ_b L_b · w_b`, `w_b = M ∫_bin (x̄, ȳ, z̄) dλ` with `M` the XYZ to
//! linear Rec.709 matrix and `L_b` the bin-mean spectral radiance (W m⁻² sr⁻¹ nm⁻¹). In
//! lamina's radiance convention (`Y = ∫ L ȳ dλ`) RGB white emission is D65 normalised to
//! `Y = 1`, whose `w`-weighted sum is `(1, 1, 1)`.
//!
//! Approximation: within a bin (9.8 nm) material spectra are taken at their bin mean (or,
//! for pigment leaves, PROSPECT at the bin's centre), so the render is exact for spectra
//! that are constant over each bin and differs from a continuous-wavelength one by the
//! covariance of radiance and the colour-matching functions inside a bin (tested below
//! for D65: 0.1 %).

use super::bands::Band;
use super::{cie_xyz_bar, xyz_to_linear_rec709};
use glam::Vec3;
use std::sync::OnceLock;

/// Shortest wavelength of a visible render, nm.
pub const MIN_NM: f32 = 360.0;
/// Longest wavelength of a visible render, nm.
pub const MAX_NM: f32 = 830.0;
/// Number of bins over [`MIN_NM`, `MAX_NM`].
pub const BINS: usize = 48;
/// Bins one camera path carries.
pub const PATH_BINS: usize = 6;
/// Spacing of a path's bins, in bins: the number of hero offsets.
pub const STRIDE: usize = BINS / PATH_BINS;

/// Width of one bin, nm.
pub fn bin_width() -> f32 {
    (MAX_NM - MIN_NM) / BINS as f32
}

/// Bin `k` (`0..BINS`) as a flat band named `"vis<k>"`.
pub fn bin(k: usize) -> Band {
    let w = bin_width();
    let lo = MIN_NM + k as f32 * w;
    Band::flat(format!("vis{k}"), lo, lo + w)
}

/// The linear Rec.709 weight of bin `k`: the RGB a bin-mean spectral radiance of 1 W m⁻²
/// sr⁻¹ nm⁻¹ in that bin (and nothing elsewhere) adds, `M ∫_bin (x̄, ȳ, z̄) dλ` (integrated
/// at 0.1 nm).
pub fn bin_to_rgb(k: usize) -> Vec3 {
    static W: OnceLock<Vec<Vec3>> = OnceLock::new();
    W.get_or_init(|| {
        (0..BINS)
            .map(|b| {
                let band = bin(b);
                let n = ((band.hi_nm - band.lo_nm) * 10.0).round() as usize;
                let step = (band.hi_nm - band.lo_nm) / n as f32;
                let mut xyz = glam::DVec3::ZERO;
                for i in 0..n {
                    let nm = band.lo_nm + (i as f32 + 0.5) * step;
                    xyz += cie_xyz_bar(nm).as_dvec3() * step as f64;
                }
                xyz_to_linear_rec709(xyz.as_vec3())
            })
            .collect()
    })[k]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectrum::bands::{BandBasis, Illuminant};

    #[test]
    fn bins_tile_the_range() {
        assert_eq!(BINS % PATH_BINS, 0);
        assert!((bin(0).lo_nm - MIN_NM).abs() < 1e-4);
        assert!((bin(BINS - 1).hi_nm - MAX_NM).abs() < 1e-3);
        for k in 1..BINS {
            assert!((bin(k).lo_nm - bin(k - 1).hi_nm).abs() < 1e-3);
        }
    }

    /// RGB emission through the D65-shaped basis, binned and weighted back, is the RGB it
    /// came from: white within the bins' 0.1 %, every colour within 1 CIEDE2000 (the basis'
    /// own round trip at 1 nm is 0.9 % for saturated red; the bins add about as much).
    #[test]
    fn rgb_emission_round_trips_through_the_bins() {
        let bases: Vec<BandBasis> = (0..BINS)
            .map(|k| {
                let b = bin(k);
                BandBasis::with_illuminant([&b, &b, &b], Illuminant::D65)
            })
            .collect();
        for c in [
            Vec3::ONE,
            Vec3::X,
            Vec3::Y,
            Vec3::Z,
            Vec3::new(0.05, 0.3, 0.04),
            Vec3::new(0.8, 0.5, 0.2),
        ] {
            let rgb: Vec3 = (0..BINS)
                .map(|k| bases[k].emission(c).x * bin_to_rgb(k))
                .sum();
            let de = crate::spectrum::difference::ciede2000_rgb(rgb, c);
            assert!(de < 1.0, "{c} -> {rgb}: ΔE00 {de}");
            if c == Vec3::ONE {
                assert!((rgb - c).abs().max_element() < 1e-3, "{rgb}");
            }
        }
    }
}
