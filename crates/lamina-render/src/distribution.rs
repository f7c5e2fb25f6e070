//! Piecewise-constant 1D and 2D distributions (pbrt's `PiecewiseConstant1D/2D`), used for
//! sky-image importance sampling and for pixel-filter importance sampling.

use glam::Vec2;

/// A piecewise-constant density over `[0, 1)` with `n` equal bins.
#[derive(Clone, Debug)]
pub struct Distribution1D {
    func: Vec<f32>,
    cdf: Vec<f32>,
    integral: f32,
}

impl Distribution1D {
    /// A distribution proportional to `func` (negative and non-finite values count as 0).
    /// An all-zero function gives the uniform distribution. `func` must not be empty.
    pub fn new(func: &[f32]) -> Self {
        let n = func.len().max(1);
        let mut f: Vec<f32> = func
            .iter()
            .map(|&v| if v.is_finite() { v.max(0.0) } else { 0.0 })
            .collect();
        if f.is_empty() {
            f.push(1.0);
        }
        let mut cdf = Vec::with_capacity(n + 1);
        cdf.push(0.0f32);
        let mut acc = 0.0f64;
        for &v in &f {
            acc += v as f64 / n as f64;
            cdf.push(acc as f32);
        }
        let mut integral = acc as f32;
        if !(integral > 0.0) {
            for (i, c) in cdf.iter_mut().enumerate() {
                *c = i as f32 / n as f32;
            }
            f.iter_mut().for_each(|v| *v = 1.0);
            integral = 1.0;
        } else {
            let inv = 1.0 / acc;
            for c in cdf.iter_mut() {
                *c = (*c as f64 * inv) as f32;
            }
            cdf[n] = 1.0;
        }
        Distribution1D {
            func: f,
            cdf,
            integral,
        }
    }

    /// Number of bins.
    pub fn len(&self) -> usize {
        self.func.len()
    }

    /// Whether there are no bins (never true).
    pub fn is_empty(&self) -> bool {
        self.func.is_empty()
    }

    /// Integral of the (unnormalised) function over `[0, 1)`.
    pub fn integral(&self) -> f32 {
        self.integral
    }

    /// Maps `u ∈ [0, 1)` to `(x ∈ [0, 1), density at x, bin index)`.
    #[inline]
    pub fn sample(&self, u: f32) -> (f32, f32, usize) {
        let n = self.func.len();
        // Last cdf entry <= u.
        let i = (self.cdf.partition_point(|&c| c <= u).saturating_sub(1)).min(n - 1);
        let (c0, c1) = (self.cdf[i], self.cdf[i + 1]);
        let du = if c1 > c0 { (u - c0) / (c1 - c0) } else { 0.5 };
        let x = ((i as f32 + du.clamp(0.0, 1.0)) / n as f32).min(1.0 - f32::EPSILON / 2.0);
        (x, self.func[i] / self.integral, i)
    }

    /// Density at bin `i`.
    #[inline]
    pub fn pdf_bin(&self, i: usize) -> f32 {
        self.func.get(i).map_or(0.0, |f| f / self.integral)
    }
}

/// A piecewise-constant density over `[0, 1)²` on a `width x height` grid; row `0` is
/// `v ∈ [0, 1/height)`.
#[derive(Clone, Debug)]
pub struct Distribution2D {
    rows: Vec<Distribution1D>,
    marginal: Distribution1D,
}

impl Distribution2D {
    /// A distribution proportional to `func`, row-major, `width * height` values.
    pub fn new(func: &[f32], width: usize, height: usize) -> Self {
        let rows: Vec<Distribution1D> = (0..height)
            .map(|y| Distribution1D::new(&func[y * width..(y + 1) * width]))
            .collect();
        // Rows whose function is all zero were made uniform: their marginal weight is 0.
        let weights: Vec<f32> = (0..height)
            .map(|y| {
                let row = &func[y * width..(y + 1) * width];
                if row.iter().any(|v| v.is_finite() && *v > 0.0) {
                    rows[y].integral()
                } else {
                    0.0
                }
            })
            .collect();
        Distribution2D {
            marginal: Distribution1D::new(&weights),
            rows,
        }
    }

    /// Maps `u ∈ [0, 1)²` to `((x, y) ∈ [0, 1)², density, (column, row))`.
    #[inline]
    pub fn sample(&self, u: Vec2) -> (Vec2, f32, (usize, usize)) {
        let (y, pdf_y, iy) = self.marginal.sample(u.y);
        let (x, pdf_x, ix) = self.rows[iy].sample(u.x);
        (Vec2::new(x, y), pdf_x * pdf_y, (ix, iy))
    }

    /// Density in cell `(column, row)`.
    #[inline]
    pub fn pdf_cell(&self, ix: usize, iy: usize) -> f32 {
        match self.rows.get(iy) {
            Some(r) => self.marginal.pdf_bin(iy) * r.pdf_bin(ix),
            None => 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_d_sampling_matches_function() {
        let d = Distribution1D::new(&[1.0, 0.0, 3.0, 4.0]);
        let mut hist = [0u32; 4];
        let n = 8000;
        for i in 0..n {
            let (x, pdf, bin) = d.sample((i as f32 + 0.5) / n as f32);
            assert_eq!(bin, (x * 4.0) as usize);
            assert!(pdf > 0.0);
            hist[bin] += 1;
        }
        let expect = [1.0, 0.0, 3.0, 4.0].map(|v| v / 8.0 * n as f32);
        for b in 0..4 {
            assert!((hist[b] as f32 - expect[b]).abs() <= 1.0, "{hist:?}");
        }
        assert!((d.pdf_bin(3) - 2.0).abs() < 1e-6);
    }

    #[test]
    fn zero_function_is_uniform() {
        let d = Distribution1D::new(&[0.0, 0.0]);
        let (x, pdf, _) = d.sample(0.75);
        assert!((x - 0.75).abs() < 1e-6 && (pdf - 1.0).abs() < 1e-6);
    }
}
