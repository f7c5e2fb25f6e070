//! Piecewise-constant 1D and 2D distributions (pbrt's `PiecewiseConstant1D/2D`), used for
//! sky-image importance sampling and for pixel-filter importance sampling.

use glam::Vec2;

/// A piecewise-constant density over `[0, 1)` with `n` equal bins.
#[derive(Clone, Debug)]
pub struct Distribution1D {
    func: Vec<f32>,
    cdf: Vec<f32>,
    integral: f32,
    /// A guide table over `u` (`m = min(n, GUIDE_MAX)` buckets; none where `n > 2 m`,
    /// buckets holding several entries on average): bucket `b` says how many `cdf` entries
    /// are at most `b / m` and holds the entries around them, so that a sample compares `u`
    /// with a few values from one place instead of searching (a binary search is a chain of
    /// dependent loads: a third of a camera-rays-only render with a Gaussian filter's 256
    /// bins).
    buckets: Vec<Bucket>,
    /// `1 / n` where `n` is a power of two: dividing by `n` is then multiplying by this,
    /// bit for bit (both are the exact quotient rounded once).
    inv_len: Option<f32>,
}

/// Most buckets of a [`Distribution1D`]'s guide table (28 bytes each).
const GUIDE_MAX: usize = 256;
/// `cdf` entries a bucket holds from its first: a bucket whose entries are no more than one
/// fewer (about the density over its mean: one to three for a Gaussian filter's bins)
/// answers from them; a crowded one (a flat tail) leaves `u` to the full search.
const SCAN: usize = 5;

/// One bucket of [`Distribution1D`]'s guide table.
#[derive(Clone, Copy, Debug)]
struct Bucket {
    /// How many `cdf` entries are at most the bucket's start `b / m`.
    lo: u32,
    /// `cdf[lo - 1]` (`-inf` where `lo = 0`), then `cdf[lo..lo + SCAN]` (`+inf` past the
    /// end).
    v: [f32; SCAN + 1],
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
        let m = n.min(GUIDE_MAX);
        let buckets = if n > 2 * m {
            Vec::new()
        } else {
            (0..m)
                .map(|b| {
                    let lo = cdf.partition_point(|&c| c <= b as f32 / m as f32);
                    let v = std::array::from_fn(|j| match (lo + j).checked_sub(1) {
                        None => f32::NEG_INFINITY,
                        Some(k) => cdf.get(k).copied().unwrap_or(f32::INFINITY),
                    });
                    Bucket { lo: lo as u32, v }
                })
                .collect()
        };
        Distribution1D {
            func: f,
            cdf,
            integral,
            buckets,
            inv_len: n.is_power_of_two().then(|| 1.0 / n as f32),
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
        let (x, i) = self.locate(u);
        (x, self.func[i] / self.integral, i)
    }

    /// [`Self::sample`]'s `x` alone, inlined where it is called: two draws in one function
    /// (a pixel filter's offsets) then overlap.
    #[inline(always)]
    pub fn sample_x(&self, u: f32) -> f32 {
        self.locate(u).0
    }

    /// [`Self::sample`]'s `x` and bin.
    #[inline(always)]
    fn locate(&self, u: f32) -> (f32, usize) {
        let n = self.func.len();
        // The last cdf entry <= u, and it and the next.
        let (i, c0, c1) = match self.bucketed(u) {
            Some(found) => found,
            None => {
                let i = (self.cdf.partition_point(|&c| c <= u).saturating_sub(1)).min(n - 1);
                (i, self.cdf[i], self.cdf[i + 1])
            }
        };
        let du = if c1 > c0 { (u - c0) / (c1 - c0) } else { 0.5 };
        let at = i as f32 + du.clamp(0.0, 1.0);
        let x = match self.inv_len {
            Some(inv) => at * inv,
            None => at / n as f32,
        };
        (x.min(1.0 - f32::EPSILON / 2.0), i)
    }

    /// The index of the last `cdf` entry <= u (as `partition_point` over all entries
    /// finds it), that entry and the next, from `u`'s bucket: `None` where the bucket
    /// cannot show it (no buckets, a crowded bucket, rounding at a bucket's edge, `u`
    /// outside `[0, 1)` or NaN).
    #[inline]
    fn bucketed(&self, u: f32) -> Option<(usize, f32, f32)> {
        // Negative and NaN `u` give bucket 0, `u >= 1` one past the last: both checked.
        let r = self.buckets.get((u * self.buckets.len() as f32) as usize)?;
        // The cdf never decreases: every entry before the bucket's is <= u when the last
        // one is; the entries from the bucket's first that are <= u are a prefix, and when
        // one of them is > u so is every entry after it.
        let c = r.v[1..].iter().map(|&v| usize::from(v <= u)).sum::<usize>();
        let count = r.lo as usize + c;
        if !(r.v[0] <= u) || c == SCAN || count == 0 || count > self.func.len() {
            return None;
        }
        Some((count - 1, r.v[c], r.v[c + 1]))
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

    /// [`Distribution2D::sample`]'s point and cell, without reading the densities (a caller
    /// that keeps [`Distribution2D::pdf_cell`] per cell beside its own data).
    #[inline]
    pub fn sample_cell(&self, u: Vec2) -> (Vec2, (usize, usize)) {
        let (y, iy) = self.marginal.locate(u.y);
        let (x, ix) = self.rows[iy].locate(u.x);
        (Vec2::new(x, y), (ix, iy))
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

    /// The guide table gives the full search's bin and point for every `u`: at and
    /// next to every cdf entry and bucket edge, outside `[0, 1)`, NaN, and many in between,
    /// over functions with zero runs, spikes, one bin, and more bins than buckets.
    #[test]
    fn bucketed_search_is_the_full_search() {
        let mut funcs: Vec<Vec<f32>> = vec![
            vec![1.0],
            vec![1.0, 0.0, 3.0, 4.0],
            vec![0.0, 0.0, 0.0, 5.0, 0.0, 0.0],
            vec![0.0; 7],
            (0..256)
                .map(|i| (-((i as f32 - 127.5) / 40.0).powi(2)).exp() - 0.08)
                .collect(),
            (0..1000)
                .map(|i| if i % 97 == 0 { 1e6 } else { 1e-3 })
                .collect(),
            (0..3000).map(|i| ((i * 7919) % 13) as f32).collect(),
        ];
        funcs.push((0..300).map(|i| 1.0 + (i as f32 * 0.37).sin()).collect());
        // A Gaussian filter's profile (the one that matters): all but its tails' buckets.
        let gaussian = Distribution1D::new(&funcs[4]);
        let answered = (0..20000)
            .filter(|i| gaussian.bucketed((*i as f32 + 0.5) / 20000.0).is_some())
            .count();
        assert!(answered >= 19800, "{answered} of 20000");
        for f in &funcs {
            let d = Distribution1D::new(f);
            let m = d.buckets.len().max(1);
            let mut us: Vec<f32> = vec![-1.0, -0.0, 0.0, 1.0, 1.5, f32::NAN, f32::INFINITY];
            for &c in d.cdf.iter() {
                us.extend([c, c.next_down(), c.next_up()]);
            }
            for b in 0..=m {
                let t = b as f32 / m as f32;
                us.extend([t, t.next_down(), t.next_up()]);
            }
            let inside: Vec<f32> = (0..20000).map(|i| (i as f32 + 0.5) / 20000.0).collect();
            // Buckets (up to 512 bins) answer nearly every `u` inside `[0, 1)` but for
            // their crowded ones (the Gaussian's flat tails, the zero runs).
            let guided = inside.iter().filter(|&&u| d.bucketed(u).is_some()).count();
            if (256..=512).contains(&f.len()) {
                assert!(guided >= 19000, "{guided} of 20000, {} bins", f.len());
            }
            if f.len() > 512 {
                assert_eq!(guided, 0, "no buckets for {} bins", f.len());
            }
            us.extend(inside);
            for u in us {
                // The point as first written: a full search and a division by `n`.
                let full = d.cdf.partition_point(|&c| c <= u);
                let n = d.func.len();
                let i = full.saturating_sub(1).min(n - 1);
                let (c0, c1) = (d.cdf[i], d.cdf[i + 1]);
                let du = if c1 > c0 { (u - c0) / (c1 - c0) } else { 0.5 };
                let x = ((i as f32 + du.clamp(0.0, 1.0)) / n as f32).min(1.0 - f32::EPSILON / 2.0);
                let (xs, _, is) = d.sample(u);
                assert_eq!((is, xs.to_bits()), (i, x.to_bits()), "u = {u} of {n} bins");
                assert_eq!(d.sample_x(u).to_bits(), x.to_bits(), "sample_x, u = {u}");
                if let Some((bi, b0, b1)) = d.bucketed(u) {
                    let got = (bi, b0.to_bits(), b1.to_bits());
                    assert_eq!(got, (i, c0.to_bits(), c1.to_bits()), "bucket, u = {u}");
                }
            }
        }
    }

    #[test]
    fn zero_function_is_uniform() {
        let d = Distribution1D::new(&[0.0, 0.0]);
        let (x, pdf, _) = d.sample(0.75);
        assert!((x - 0.75).abs() < 1e-6 && (pdf - 1.0).abs() < 1e-6);
    }

    /// `sample_cell` gives `sample`'s point and cell, bit for bit, and the cell's density is
    /// the one `sample` reports (what a sky keeps per texel), including rows that are all
    /// zero.
    #[test]
    fn sample_cell_is_sample() {
        let (w, h) = (37, 9);
        let func: Vec<f32> = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                if y == 4 {
                    0.0
                } else {
                    ((x * 13 + y * 7) % 17) as f32 + 0.01 * x as f32
                }
            })
            .collect();
        let d = Distribution2D::new(&func, w, h);
        for k in 0..5000 {
            let u = Vec2::new(
                (k as f32 + 0.5) / 5000.0,
                ((k * 7919) % 5000) as f32 / 5000.0,
            );
            let (p, pdf, cell) = d.sample(u);
            let (q, at) = d.sample_cell(u);
            assert_eq!(
                (p.x.to_bits(), p.y.to_bits(), cell),
                (q.x.to_bits(), q.y.to_bits(), at)
            );
            assert_eq!(pdf.to_bits(), d.pdf_cell(at.0, at.1).to_bits(), "u = {u}");
            assert_ne!(at.1, 4, "a row of zeros is never drawn");
        }
    }
}
