//! Image comparison for the GPU-versus-offline agreement: mean absolute error and SSIM;
//! and for level of detail, what a canopy must keep as leaves drop out: its mean radiance
//! and its coverage.
//!
//! Both compare the images **as displayed**: 8-bit sRGB after the film's exposure and tone
//! map (`lamina_image::to_srgb8`), scaled to `[0, 1]`, so the numbers mean what a
//! viewer sees and match the PNGs side by side.
//!
//! SSIM is Wang et al. (2004) on luma (Rec.709 weights of the sRGB-encoded values), with
//! their constants: an 11x11 Gaussian window of sigma 1.5, `K1 = 0.01`, `K2 = 0.03`,
//! dynamic range 1; the mean of the SSIM map over all windows inside the image. (A small
//! implementation: no SSIM crate is a dependency of the workspace.)

/// Mean absolute difference per channel over all pixels, of 8-bit values scaled to
/// `[0, 1]` (RGB rows of equal size).
pub fn mean_abs_error(a: &[u8], b: &[u8]) -> f64 {
    assert_eq!(a.len(), b.len(), "images must have the same size");
    let sum: u64 = a.iter().zip(b).map(|(&x, &y)| x.abs_diff(y) as u64).sum();
    sum as f64 / (255.0 * a.len().max(1) as f64)
}

/// Mean linear radiance per channel of `pixels` (W m⁻² sr⁻¹, Rec.709 RGB), in f64.
pub fn mean_radiance(pixels: &[glam::Vec3]) -> [f64; 3] {
    let mut s = [0.0f64; 3];
    for p in pixels {
        for (k, v) in s.iter_mut().enumerate() {
            *v += p[k] as f64;
        }
    }
    s.map(|v| v / pixels.len().max(1) as f64)
}

/// The share of `pixels` that differ from `background` (linear radiance, where nothing
/// was drawn) by more than `tol` relative in any channel: the coverage of what was drawn
/// when the background is a constant sky.
pub fn coverage(pixels: &[glam::Vec3], background: glam::Vec3, tol: f32) -> f64 {
    let hit = pixels
        .iter()
        .filter(|p| ((**p - background).abs() - tol * background.abs()).max_element() > 0.0)
        .count();
    hit as f64 / pixels.len().max(1) as f64
}

fn luma(rgb: &[u8]) -> Vec<f64> {
    rgb.chunks_exact(3)
        .map(|p| (0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64) / 255.0)
        .collect()
}

/// Mean SSIM of two `width x height` 8-bit RGB images (see the module docs), in `[-1, 1]`,
/// 1 for identical images.
pub fn ssim(a: &[u8], b: &[u8], width: usize, height: usize) -> f64 {
    assert_eq!(a.len(), width * height * 3);
    assert_eq!(b.len(), width * height * 3);
    const R: usize = 5;
    let sigma = 1.5f64;
    let mut w = [0.0f64; 2 * R + 1];
    for (i, wi) in w.iter_mut().enumerate() {
        let d = i as f64 - R as f64;
        *wi = (-d * d / (2.0 * sigma * sigma)).exp();
    }
    let s: f64 = w.iter().sum();
    w.iter_mut().for_each(|x| *x /= s);
    let (x, y) = (luma(a), luma(b));
    // Separable blur of the five moment images.
    let blur = |img: &[f64]| -> Vec<f64> {
        let mut tmp = vec![0.0; img.len()];
        for r in 0..height {
            for c in R..width.saturating_sub(R) {
                tmp[r * width + c] = (0..=2 * R).map(|k| w[k] * img[r * width + c + k - R]).sum();
            }
        }
        let mut out = vec![0.0; img.len()];
        for r in R..height.saturating_sub(R) {
            for c in R..width.saturating_sub(R) {
                out[r * width + c] = (0..=2 * R)
                    .map(|k| w[k] * tmp[(r + k - R) * width + c])
                    .sum();
            }
        }
        out
    };
    let xx: Vec<f64> = x.iter().map(|v| v * v).collect();
    let yy: Vec<f64> = y.iter().map(|v| v * v).collect();
    let xy: Vec<f64> = x.iter().zip(&y).map(|(p, q)| p * q).collect();
    let (mx, my, sxx, syy, sxy) = (blur(&x), blur(&y), blur(&xx), blur(&yy), blur(&xy));
    let (c1, c2) = (0.01f64.powi(2), 0.03f64.powi(2));
    let mut acc = 0.0;
    let mut n = 0usize;
    for r in R..height.saturating_sub(R) {
        for c in R..width.saturating_sub(R) {
            let i = r * width + c;
            let (ux, uy) = (mx[i], my[i]);
            let vx = sxx[i] - ux * ux;
            let vy = syy[i] - uy * uy;
            let cov = sxy[i] - ux * uy;
            acc += ((2.0 * ux * uy + c1) * (2.0 * cov + c2))
                / ((ux * ux + uy * uy + c1) * (vx + vy + c2));
            n += 1;
        }
    }
    if n == 0 { 1.0 } else { acc / n as f64 }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn noise(n: usize, seed: u32) -> Vec<u8> {
        let mut s = seed;
        (0..n)
            .map(|_| {
                s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                (s >> 24) as u8
            })
            .collect()
    }

    #[test]
    fn identical_images_score_perfectly_and_noise_does_not() {
        let a = noise(32 * 24 * 3, 1);
        assert_eq!(mean_abs_error(&a, &a), 0.0);
        assert!((ssim(&a, &a, 32, 24) - 1.0).abs() < 1e-12);
        let b = noise(32 * 24 * 3, 2);
        assert!(ssim(&a, &b, 32, 24) < 0.2);
        // Uniform random bytes differ by 1/3 of the range on average.
        assert!((mean_abs_error(&a, &b) - 1.0 / 3.0).abs() < 0.05);
    }

    #[test]
    fn a_small_brightness_shift_keeps_ssim_high() {
        let a: Vec<u8> = (0..64 * 64 * 3).map(|i| ((i / 3) % 64 * 3) as u8).collect();
        let b: Vec<u8> = a.iter().map(|&v| v.saturating_add(5)).collect();
        let s = ssim(&a, &b, 64, 64);
        assert!(s > 0.95 && s < 1.0, "{s}");
    }
}
