//! Colour differences: CIELAB and CIEDE2000, for comparing renders the way the eye would.
//!
//! * [`linear_rec709_to_lab`]: linear Rec.709 to CIE 1976 L\*a\*b\* with the D65 white
//!   (`Y = 1` is white, `L* = 100`).
//! * [`ciede2000`]: the CIE 2000 colour difference (CIE 142-2001, with the implementation
//!   notes of Sharma, Wu & Dalal, Color Res. Appl. 30, 2005), `k_L = k_C = k_H = 1`. About 1
//!   is a just-noticeable difference.

use super::linear_rec709_to_xyz;
use glam::Vec3;

/// D65 white in XYZ (`Y = 1`), the white of Rec.709: the XYZ of linear RGB `(1, 1, 1)`.
fn white() -> Vec3 {
    linear_rec709_to_xyz(Vec3::ONE)
}

/// CIE L\*a\*b\* (D65 white) of a linear Rec.709 colour whose white is `(1, 1, 1)`.
pub fn linear_rec709_to_lab(rgb: Vec3) -> Vec3 {
    let xyz = linear_rec709_to_xyz(rgb) / white();
    let f = |t: f32| {
        const D: f32 = 6.0 / 29.0;
        if t > D * D * D {
            t.cbrt()
        } else {
            t / (3.0 * D * D) + 4.0 / 29.0
        }
    };
    let (fx, fy, fz) = (f(xyz.x), f(xyz.y), f(xyz.z));
    Vec3::new(116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz))
}

/// The CIEDE2000 difference `ΔE00` between two CIELAB colours (computed in `f64`).
pub fn ciede2000(lab1: Vec3, lab2: Vec3) -> f64 {
    use std::f64::consts::PI;
    let (l1, a1, b1) = (lab1.x as f64, lab1.y as f64, lab1.z as f64);
    let (l2, a2, b2) = (lab2.x as f64, lab2.y as f64, lab2.z as f64);
    let deg = |r: f64| r * 180.0 / PI;
    let rad = |d: f64| d * PI / 180.0;
    let c_bar = 0.5 * (a1.hypot(b1) + a2.hypot(b2));
    let c7 = c_bar.powi(7);
    let g = 0.5 * (1.0 - (c7 / (c7 + 25f64.powi(7))).sqrt());
    let (a1p, a2p) = ((1.0 + g) * a1, (1.0 + g) * a2);
    let (c1p, c2p) = (a1p.hypot(b1), a2p.hypot(b2));
    let hue = |b: f64, ap: f64| {
        if b == 0.0 && ap == 0.0 {
            0.0
        } else {
            let h = deg(b.atan2(ap));
            if h < 0.0 { h + 360.0 } else { h }
        }
    };
    let (h1p, h2p) = (hue(b1, a1p), hue(b2, a2p));
    let dl = l2 - l1;
    let dc = c2p - c1p;
    let dh = if c1p * c2p == 0.0 {
        0.0
    } else {
        let d = h2p - h1p;
        if d > 180.0 {
            d - 360.0
        } else if d < -180.0 {
            d + 360.0
        } else {
            d
        }
    };
    let dhh = 2.0 * (c1p * c2p).sqrt() * rad(0.5 * dh).sin();
    let l_bar = 0.5 * (l1 + l2);
    let cp_bar = 0.5 * (c1p + c2p);
    let hp_bar = if c1p * c2p == 0.0 {
        h1p + h2p
    } else if (h1p - h2p).abs() <= 180.0 {
        0.5 * (h1p + h2p)
    } else if h1p + h2p < 360.0 {
        0.5 * (h1p + h2p + 360.0)
    } else {
        0.5 * (h1p + h2p - 360.0)
    };
    let t = 1.0 - 0.17 * rad(hp_bar - 30.0).cos()
        + 0.24 * rad(2.0 * hp_bar).cos()
        + 0.32 * rad(3.0 * hp_bar + 6.0).cos()
        - 0.20 * rad(4.0 * hp_bar - 63.0).cos();
    let d_theta = 30.0 * (-((hp_bar - 275.0) / 25.0).powi(2)).exp();
    let cp7 = cp_bar.powi(7);
    let rc = 2.0 * (cp7 / (cp7 + 25f64.powi(7))).sqrt();
    let l50 = (l_bar - 50.0).powi(2);
    let sl = 1.0 + 0.015 * l50 / (20.0 + l50).sqrt();
    let sc = 1.0 + 0.045 * cp_bar;
    let sh = 1.0 + 0.015 * cp_bar * t;
    let rt = -rad(2.0 * d_theta).sin() * rc;
    let (x, y, z) = (dl / sl, dc / sc, dhh / sh);
    (x * x + y * y + z * z + rt * y * z).sqrt()
}

/// [`ciede2000`] of two linear Rec.709 colours (white `(1, 1, 1)`).
pub fn ciede2000_rgb(a: Vec3, b: Vec3) -> f64 {
    ciede2000(linear_rec709_to_lab(a), linear_rec709_to_lab(b))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Pairs from Table 1 of Sharma, Wu & Dalal (2005), chosen to cover the hue averaging
    /// across 0°, the blue rotation term, achromatic colours and large differences.
    #[test]
    fn matches_the_published_test_data() {
        let cases: [([f32; 3], [f32; 3], f64); 10] = [
            ([50.0, 2.6772, -79.7751], [50.0, 0.0, -82.7485], 2.0425),
            ([50.0, 3.1571, -77.2803], [50.0, 0.0, -82.7485], 2.8615),
            ([50.0, 2.8361, -74.0200], [50.0, 0.0, -82.7485], 3.4412),
            ([50.0, -1.3802, -84.2814], [50.0, 0.0, -82.7485], 1.0000),
            ([50.0, 0.0, 0.0], [50.0, -1.0, 2.0], 2.3669),
            ([50.0, 2.49, -0.001], [50.0, -2.49, 0.0009], 7.1792),
            ([50.0, 2.5, 0.0], [73.0, 25.0, -18.0], 27.1492),
            ([50.0, 2.5, 0.0], [50.0, 3.1736, 0.5854], 1.0000),
            (
                [60.2574, -34.0099, 36.2677],
                [60.4626, -34.1751, 39.4387],
                1.2644,
            ),
            (
                [22.7233, 20.0904, -46.6940],
                [23.0331, 14.9730, -42.5619],
                2.0373,
            ),
        ];
        for (a, b, want) in cases {
            let got = ciede2000(Vec3::from(a), Vec3::from(b));
            assert!((got - want).abs() < 1e-3, "{a:?} {b:?}: {got} vs {want}");
            let back = ciede2000(Vec3::from(b), Vec3::from(a));
            assert!((back - got).abs() < 1e-9, "symmetric");
        }
    }

    #[test]
    fn lab_of_white_grey_and_black() {
        let w = linear_rec709_to_lab(Vec3::ONE);
        assert!(
            (w - Vec3::new(100.0, 0.0, 0.0)).abs().max_element() < 1e-3,
            "{w}"
        );
        let g = linear_rec709_to_lab(Vec3::splat(0.18));
        assert!(
            (g.x - 49.5).abs() < 0.1 && g.y.abs() < 1e-3 && g.z.abs() < 1e-3,
            "{g}"
        );
        assert_eq!(linear_rec709_to_lab(Vec3::ZERO), Vec3::ZERO);
        assert_eq!(ciede2000_rgb(Vec3::splat(0.3), Vec3::splat(0.3)), 0.0);
    }
}
