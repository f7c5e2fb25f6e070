//! Planar images and the image operations the map pipelines need: resampling, separable
//! Gaussian blur, Otsu thresholding, hole filling, speck removal and the integration of a
//! gradient field into a height field.
//!
//! Everything here is row-parallel with rayon and allocation-light; none of it knows about
//! leaves.

use rayon::prelude::*;

/// A row-major image of `T`, top row first.
#[derive(Clone, Debug, PartialEq)]
pub struct Plane<T> {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// `width * height` values, row-major, top row first.
    pub data: Vec<T>,
}

/// A grey plane of `f32`.
pub type Gray = Plane<f32>;
/// An RGB plane of `f32` triples (the encoding, linear or sRGB, is stated where used).
pub type Rgb = Plane<[f32; 3]>;

impl<T: Copy + Send + Sync> Plane<T> {
    /// A plane filled with one value.
    pub fn filled(width: usize, height: usize, value: T) -> Self {
        Plane {
            width,
            height,
            data: vec![value; width * height],
        }
    }

    /// A plane whose pixel `(x, y)` is `f(x, y)`, computed row-parallel.
    pub fn from_fn(width: usize, height: usize, f: impl Fn(usize, usize) -> T + Sync) -> Self {
        let mut data = Vec::with_capacity(width * height);
        if width * height == 0 {
            return Plane {
                width,
                height,
                data,
            };
        }
        data.resize(width * height, f(0, 0));
        data.par_chunks_mut(width.max(1))
            .enumerate()
            .for_each(|(y, row)| {
                for (x, v) in row.iter_mut().enumerate() {
                    *v = f(x, y);
                }
            });
        Plane {
            width,
            height,
            data,
        }
    }

    /// The value at `(x, y)`.
    #[inline]
    pub fn get(&self, x: usize, y: usize) -> T {
        self.data[y * self.width + x]
    }

    /// The value at `(x, y)` with coordinates clamped to the image.
    #[inline]
    pub fn get_clamped(&self, x: isize, y: isize) -> T {
        let x = x.clamp(0, self.width as isize - 1) as usize;
        let y = y.clamp(0, self.height as isize - 1) as usize;
        self.data[y * self.width + x]
    }

    /// A new plane with `f` applied to every value (parallel).
    pub fn map<U: Copy + Send + Sync>(&self, f: impl Fn(T) -> U + Sync) -> Plane<U> {
        Plane {
            width: self.width,
            height: self.height,
            data: self.data.par_iter().map(|&v| f(v)).collect(),
        }
    }

    /// The transpose (parallel, in cache-friendly tiles of rows).
    pub fn transpose(&self) -> Plane<T> {
        let (w, h) = (self.width, self.height);
        let mut out = Vec::with_capacity(w * h);
        out.resize(w * h, self.data[0]);
        out.par_chunks_mut(h).enumerate().for_each(|(x, col)| {
            for (y, v) in col.iter_mut().enumerate() {
                *v = self.data[y * w + x];
            }
        });
        Plane {
            width: h,
            height: w,
            data: out,
        }
    }
}

/// Linear interpolation helper shared by the samplers.
pub trait Lerp: Copy {
    /// `a + (b - a) t`.
    fn lerp(a: Self, b: Self, t: f32) -> Self;
}

impl Lerp for f32 {
    #[inline]
    fn lerp(a: f32, b: f32, t: f32) -> f32 {
        a + (b - a) * t
    }
}

impl Lerp for [f32; 3] {
    #[inline]
    fn lerp(a: Self, b: Self, t: f32) -> Self {
        [
            a[0] + (b[0] - a[0]) * t,
            a[1] + (b[1] - a[1]) * t,
            a[2] + (b[2] - a[2]) * t,
        ]
    }
}

impl Lerp for [f32; 4] {
    // (also the coarse noise grids of `generate`)
    #[inline]
    fn lerp(a: Self, b: Self, t: f32) -> Self {
        [
            a[0] + (b[0] - a[0]) * t,
            a[1] + (b[1] - a[1]) * t,
            a[2] + (b[2] - a[2]) * t,
            a[3] + (b[3] - a[3]) * t,
        ]
    }
}

impl<T: Lerp + Send + Sync> Plane<T> {
    /// Bilinear sample at pixel coordinates (pixel centres at `i + 0.5`), clamped at edges.
    #[inline]
    pub fn bilinear(&self, px: f32, py: f32) -> T {
        let x = px - 0.5;
        let y = py - 0.5;
        let x0 = x.floor();
        let y0 = y.floor();
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as isize, y0 as isize);
        let a = T::lerp(self.get_clamped(x0, y0), self.get_clamped(x0 + 1, y0), fx);
        let b = T::lerp(
            self.get_clamped(x0, y0 + 1),
            self.get_clamped(x0 + 1, y0 + 1),
            fx,
        );
        T::lerp(a, b, fy)
    }

    /// Resamples to `width x height`. Bilinear when enlarging; when shrinking by more than
    /// 2x, each output pixel averages a grid of bilinear taps over its footprint (a box
    /// filter), so thin veins do not alias away.
    pub fn resample(&self, width: usize, height: usize) -> Plane<T> {
        let sx = self.width as f32 / width as f32;
        let sy = self.height as f32 / height as f32;
        let nx = sx.ceil().max(1.0) as usize;
        let ny = sy.ceil().max(1.0) as usize;
        Plane::from_fn(width, height, |x, y| {
            if nx == 1 && ny == 1 {
                return self.bilinear((x as f32 + 0.5) * sx, (y as f32 + 0.5) * sy);
            }
            // Running mean over the footprint taps (keeps T free of scalar multiplication).
            let tap = |i: usize, j: usize| {
                self.bilinear(
                    (x as f32 + (i as f32 + 0.5) / nx as f32) * sx,
                    (y as f32 + (j as f32 + 0.5) / ny as f32) * sy,
                )
            };
            let mut acc = tap(0, 0);
            let mut n = 1.0;
            for j in 0..ny {
                for i in 0..nx {
                    if i + j > 0 {
                        n += 1.0;
                        acc = T::lerp(acc, tap(i, j), 1.0 / n);
                    }
                }
            }
            acc
        })
    }
}

impl Gray {
    /// Mean of the values where `mask` is set (`None` when the mask is empty).
    pub fn masked_mean(&self, mask: &Plane<bool>) -> Option<f32> {
        let (s, n) = self
            .data
            .par_iter()
            .zip(mask.data.par_iter())
            .filter(|(_, m)| **m)
            .map(|(v, _)| (*v as f64, 1usize))
            .reduce(|| (0.0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
        (n > 0).then(|| (s / n as f64) as f32)
    }

    /// Minimum and maximum value.
    pub fn min_max(&self) -> (f32, f32) {
        self.data
            .par_iter()
            .fold(
                || (f32::INFINITY, f32::NEG_INFINITY),
                |(lo, hi), &v| (lo.min(v), hi.max(v)),
            )
            .reduce(
                || (f32::INFINITY, f32::NEG_INFINITY),
                |a, b| (a.0.min(b.0), a.1.max(b.1)),
            )
    }
}

/// Box blur of one row of length `n` with radius `r` into `out`, edges clamped.
fn box_row(src: &[f32], out: &mut [f32], r: usize) {
    let n = src.len();
    if r == 0 || n == 0 {
        out.copy_from_slice(src);
        return;
    }
    let ri = r as isize;
    let at = |i: isize| src[i.clamp(0, n as isize - 1) as usize];
    let mut sum: f32 = (-ri..=ri).map(at).sum();
    let norm = 1.0 / (2 * r + 1) as f32;
    for (i, o) in out.iter_mut().enumerate() {
        *o = sum * norm;
        let i = i as isize;
        sum += at(i + ri + 1) - at(i - ri);
    }
}

/// Exact Gaussian of one row with a sampled kernel `k` (centre at `k.len() / 2`), edges clamped.
fn kernel_row(src: &[f32], out: &mut [f32], k: &[f32]) {
    let n = src.len() as isize;
    let r = (k.len() / 2) as isize;
    for (i, o) in out.iter_mut().enumerate() {
        let i = i as isize;
        let mut s = 0.0;
        if i - r >= 0 && i + r < n {
            let base = (i - r) as usize;
            for (j, kj) in k.iter().enumerate() {
                s += kj * src[base + j];
            }
        } else {
            for (j, kj) in k.iter().enumerate() {
                s += kj * src[(i - r + j as isize).clamp(0, n - 1) as usize];
            }
        }
        *o = s;
    }
}

/// Blurs every row of `p` with a Gaussian of standard deviation `sigma` pixels.
///
/// Small `sigma` (below 3 px) uses an exact sampled kernel; larger ones use three successive
/// box filters whose widths match the Gaussian's variance (Wells 1986), which costs O(1) per
/// pixel whatever the radius and is within a few percent of the Gaussian.
fn blur_rows(p: &mut Gray, sigma: f32) {
    let w = p.width;
    if sigma <= 0.0 || w == 0 {
        return;
    }
    if sigma < 3.0 {
        let r = (3.0 * sigma).ceil() as isize;
        let mut k: Vec<f32> = (-r..=r)
            .map(|i| (-(i * i) as f32 / (2.0 * sigma * sigma)).exp())
            .collect();
        let s: f32 = k.iter().sum();
        k.iter_mut().for_each(|v| *v /= s);
        p.data.par_chunks_mut(w).for_each(|row| {
            let src = row.to_vec();
            kernel_row(&src, row, &k);
        });
    } else {
        // Three boxes of radius r: variance 3 * ((2r+1)^2 - 1) / 12 = sigma^2.
        let r = (((4.0 * sigma * sigma + 1.0).sqrt() - 1.0) / 2.0)
            .round()
            .max(1.0) as usize;
        p.data.par_chunks_mut(w).for_each(|row| {
            let mut tmp = row.to_vec();
            box_row(row, &mut tmp, r);
            box_row(&tmp, row, r);
            tmp.copy_from_slice(row);
            box_row(&tmp, row, r);
        });
    }
}

/// Separable Gaussian blur with standard deviation `sigma` in pixels (edges clamped),
/// parallel per row; the vertical pass runs on the transpose so it is row-parallel too.
pub fn gaussian_blur(p: &Gray, sigma: f32) -> Gray {
    let mut a = p.clone();
    if sigma <= 0.0 {
        return a;
    }
    blur_rows(&mut a, sigma);
    let mut t = a.transpose();
    blur_rows(&mut t, sigma);
    t.transpose()
}

/// Otsu's threshold (Otsu 1979) of the values where `mask` is true (all when `None`),
/// over a 256-bin histogram between the minimum and maximum. Returns `None` when the
/// values are constant (nothing to separate).
pub fn otsu(values: &Gray, mask: Option<&Plane<bool>>) -> Option<f32> {
    let sel = |i: usize| mask.is_none_or(|m| m.data[i]);
    let (lo, hi) = values
        .data
        .iter()
        .enumerate()
        .filter(|(i, v)| sel(*i) && v.is_finite())
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), (_, &v)| {
            (a.min(v), b.max(v))
        });
    if hi.is_nan() || lo.is_nan() || hi - lo <= 1e-6 {
        return None;
    }
    let mut hist = [0u64; 256];
    let scale = 255.999 / (hi - lo);
    for (i, &v) in values.data.iter().enumerate() {
        if sel(i) && v.is_finite() {
            hist[((v - lo) * scale) as usize] += 1;
        }
    }
    let total: u64 = hist.iter().sum();
    let sum_all: f64 = hist
        .iter()
        .enumerate()
        .map(|(i, &c)| i as f64 * c as f64)
        .sum();
    let (mut w0, mut sum0) = (0u64, 0.0f64);
    let (mut best, mut best_t) = (-1.0f64, 0usize);
    for (t, &c) in hist.iter().enumerate() {
        w0 += c;
        if w0 == 0 {
            continue;
        }
        let w1 = total - w0;
        if w1 == 0 {
            break;
        }
        sum0 += t as f64 * c as f64;
        let m0 = sum0 / w0 as f64;
        let m1 = (sum_all - sum0) / w1 as f64;
        let between = w0 as f64 * w1 as f64 * (m0 - m1) * (m0 - m1);
        if between > best {
            best = between;
            best_t = t;
        }
    }
    Some(lo + (best_t as f32 + 1.0) / scale)
}

/// Fills holes: every unset pixel that cannot reach the image border through unset pixels
/// (4-connected) is set. Holes in a leaf matte are pale veins or specular glints that the
/// threshold cut out; a real hole that touches the margin is kept.
pub fn fill_holes(mask: &mut Plane<bool>) {
    let (w, h) = (mask.width, mask.height);
    let mut outside = vec![false; w * h];
    let mut stack = Vec::new();
    for x in 0..w {
        stack.push(x);
        stack.push((h - 1) * w + x);
    }
    for y in 0..h {
        stack.push(y * w);
        stack.push(y * w + w - 1);
    }
    while let Some(i) = stack.pop() {
        if outside[i] || mask.data[i] {
            continue;
        }
        outside[i] = true;
        let (x, y) = (i % w, i / w);
        if x > 0 {
            stack.push(i - 1);
        }
        if x + 1 < w {
            stack.push(i + 1);
        }
        if y > 0 {
            stack.push(i - w);
        }
        if y + 1 < h {
            stack.push(i + w);
        }
    }
    mask.data
        .par_iter_mut()
        .zip(outside.par_iter())
        .for_each(|(m, o)| *m = *m || !*o);
}

/// Sizes of the 8-connected components of set pixels.
pub fn component_sizes(mask: &Plane<bool>) -> Vec<usize> {
    let (_, sizes) = label_components(mask);
    sizes.into_iter().skip(1).collect()
}

/// Labels 8-connected components (label 0 = unset); returns the labels and the size of each
/// label (index 0 unused).
fn label_components(mask: &Plane<bool>) -> (Vec<u32>, Vec<usize>) {
    let (w, h) = (mask.width, mask.height);
    let mut label = vec![0u32; w * h];
    let mut next = 0u32;
    let mut sizes = vec![0usize];
    let mut stack = Vec::new();
    for start in 0..w * h {
        if !mask.data[start] || label[start] != 0 {
            continue;
        }
        next += 1;
        let mut size = 0;
        stack.push(start);
        label[start] = next;
        while let Some(i) = stack.pop() {
            size += 1;
            let (x, y) = ((i % w) as isize, (i / w) as isize);
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let (nx, ny) = (x + dx, y + dy);
                    if nx < 0 || ny < 0 || nx >= w as isize || ny >= h as isize {
                        continue;
                    }
                    let j = ny as usize * w + nx as usize;
                    if mask.data[j] && label[j] == 0 {
                        label[j] = next;
                        stack.push(j);
                    }
                }
            }
        }
        sizes.push(size);
    }
    (label, sizes)
}

/// Removes specks: 8-connected components of set pixels smaller than `min_area` pixels are
/// cleared. Returns the number of components kept.
pub fn remove_specks(mask: &mut Plane<bool>, min_area: usize) -> usize {
    let (label, sizes) = label_components(mask);
    let keep: Vec<bool> = sizes.iter().map(|&s| s >= min_area).collect();
    mask.data
        .par_iter_mut()
        .zip(label.par_iter())
        .for_each(|(m, &l)| *m = *m && keep[l as usize]);
    keep.iter().skip(1).filter(|k| **k).count()
}

/// Integrates a gradient field `(gx, gy)` (height change per pixel to the right and *down*)
/// into a height field: the least-squares solution of `∇h = g`, i.e. the Poisson equation
/// `Δh = div g` with Neumann borders.
///
/// Solved coarse to fine: the divergence is restricted down a pyramid, solved at the coarsest
/// level, and each level starts from the prolonged coarser solution followed by a few
/// red-black Gauss-Seidel sweeps (a full-multigrid cascade without V-cycles). The low
/// frequencies come from the coarse levels, the fine detail from the sweeps, in linear time;
/// for bump maps, where only relative detail matters, that is accurate enough. The result has
/// zero mean.
pub fn integrate_gradients(gx: &Gray, gy: &Gray, sweeps: usize) -> Gray {
    let (w, h) = (gx.width, gx.height);
    // div g with backward differences (the adjoint of the forward-difference gradient).
    let div = Plane::from_fn(w, h, |x, y| {
        let dx = gx.get(x, y) - if x > 0 { gx.get(x - 1, y) } else { 0.0 };
        let dy = gy.get(x, y) - if y > 0 { gy.get(x, y - 1) } else { 0.0 };
        dx + dy
    });
    let mut h_field = solve_poisson(&div, sweeps);
    let mean = h_field.data.par_iter().map(|v| *v as f64).sum::<f64>() / (w * h) as f64;
    h_field.data.par_iter_mut().for_each(|v| *v -= mean as f32);
    h_field
}

/// Solves `Δh = f` (5-point Laplacian, Neumann borders, grid spacing 1) by the cascade
/// described at [`integrate_gradients`].
fn solve_poisson(f: &Gray, sweeps: usize) -> Gray {
    let (w, h) = (f.width, f.height);
    let mut x = if w <= 8 || h <= 8 {
        Plane::filled(w, h, 0.0)
    } else {
        // Restrict: average 2x2 blocks; the Laplacian on a grid of spacing 2 is a quarter
        // of the fine one, hence the factor 4 on the right-hand side.
        let (cw, ch) = (w.div_ceil(2), h.div_ceil(2));
        let coarse_f = Plane::from_fn(cw, ch, |cx, cy| {
            let mut s = 0.0;
            let mut n = 0.0;
            for dy in 0..2 {
                for dx in 0..2 {
                    let (fx, fy) = (2 * cx + dx, 2 * cy + dy);
                    if fx < w && fy < h {
                        s += f.get(fx, fy);
                        n += 1.0;
                    }
                }
            }
            4.0 * s / n
        });
        let coarse = solve_poisson(&coarse_f, sweeps);
        Plane::from_fn(w, h, |fx, fy| {
            coarse.bilinear((fx as f32 + 0.5) * 0.5, (fy as f32 + 0.5) * 0.5)
        })
    };
    let n = if w <= 8 || h <= 8 { 200 } else { sweeps };
    for _ in 0..n {
        for parity in 0..2 {
            gauss_seidel_half(&mut x, f, parity);
        }
    }
    x
}

/// One red-black half sweep: updates the pixels with `(x + y) % 2 == parity` from their
/// neighbours (which all have the other colour, so rows update independently in parallel).
fn gauss_seidel_half(x: &mut Gray, f: &Gray, parity: usize) {
    let (w, h) = (x.width, x.height);
    let src = x.data.clone();
    x.data.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        let start = (parity + y) % 2;
        for i in (start..w).step_by(2) {
            let mut s = 0.0;
            let mut n = 0.0;
            if i > 0 {
                s += src[y * w + i - 1];
                n += 1.0;
            }
            if i + 1 < w {
                s += src[y * w + i + 1];
                n += 1.0;
            }
            if y > 0 {
                s += src[(y - 1) * w + i];
                n += 1.0;
            }
            if y + 1 < h {
                s += src[(y + 1) * w + i];
                n += 1.0;
            }
            if n > 0.0 {
                row[i] = (s - f.data[y * w + i]) / n;
            }
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blur_keeps_mean_and_smooths() {
        let p = Plane::from_fn(
            64,
            48,
            |x, y| if (x / 8 + y / 8) % 2 == 0 { 1.0 } else { 0.0 },
        );
        for sigma in [1.0, 5.0] {
            let b = gaussian_blur(&p, sigma);
            let m0: f32 = p.data.iter().sum::<f32>() / p.data.len() as f32;
            let m1: f32 = b.data.iter().sum::<f32>() / b.data.len() as f32;
            assert!((m0 - m1).abs() < 0.02, "{m0} {m1}");
            let (lo, hi) = b.min_max();
            assert!(hi - lo < 1.0);
        }
        // Impulse response width matches sigma (box approximation within 10 %).
        let mut imp = Plane::filled(201, 1, 0.0);
        imp.data[100] = 1.0;
        let mut row = imp.clone();
        blur_rows(&mut row, 10.0);
        let var: f32 = row
            .data
            .iter()
            .enumerate()
            .map(|(i, v)| v * (i as f32 - 100.0).powi(2))
            .sum();
        assert!((var.sqrt() - 10.0).abs() < 1.0, "sigma {}", var.sqrt());
    }

    #[test]
    fn otsu_splits_two_modes() {
        let p = Plane::from_fn(100, 10, |x, _| if x < 30 { 0.1 } else { 0.8 });
        let t = otsu(&p, None).unwrap();
        assert!(t > 0.1 && t <= 0.8, "{t}");
        assert!(otsu(&Plane::filled(4, 4, 0.5), None).is_none());
    }

    #[test]
    fn holes_and_specks() {
        let mut m = Plane::from_fn(50, 50, |x, y| {
            let inside = (10..40).contains(&x) && (10..40).contains(&y);
            let hole = (20..25).contains(&x) && (20..25).contains(&y);
            let speck = x == 2 && y == 2;
            (inside && !hole) || speck
        });
        fill_holes(&mut m);
        assert!(m.get(22, 22));
        assert_eq!(remove_specks(&mut m, 10), 1);
        assert!(!m.get(2, 2));
        assert!(m.get(30, 30));
    }

    #[test]
    fn integrates_a_bump() {
        let (w, h) = (64, 64);
        let hf = Plane::from_fn(w, h, |x, y| {
            let dx = x as f32 - 32.0;
            let dy = y as f32 - 20.0;
            5.0 * (-(dx * dx + dy * dy) / 50.0).exp()
        });
        let gx = Plane::from_fn(w, h, |x, y| {
            if x + 1 < w {
                hf.get(x + 1, y) - hf.get(x, y)
            } else {
                0.0
            }
        });
        let gy = Plane::from_fn(w, h, |x, y| {
            if y + 1 < h {
                hf.get(x, y + 1) - hf.get(x, y)
            } else {
                0.0
            }
        });
        let r = integrate_gradients(&gx, &gy, 30);
        let mean = hf.data.iter().sum::<f32>() / (w * h) as f32;
        let err = hf
            .data
            .iter()
            .zip(&r.data)
            .map(|(a, b)| (a - mean - b).abs())
            .fold(0.0f32, f32::max);
        assert!(err < 0.25, "max error {err}");
    }

    #[test]
    fn resample_shrinks_and_grows() {
        let p = Plane::from_fn(8, 8, |x, _| x as f32);
        let s = p.resample(4, 4);
        assert!((s.get(0, 0) - 0.5).abs() < 0.3);
        let g = p.resample(16, 16);
        assert_eq!(g.width, 16);
    }
}
