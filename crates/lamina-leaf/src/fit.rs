//! Fitting PROSPECT pigments to a measured leaf spectrum (PROSPECT inversion).
//!
//! The unknowns are PROSPECT-D's seven inputs (N, Cab, Car, Anth, Cbrown, Cw, Cm) and its
//! surface parameter `alpha` (the top face's incidence cone, 40° in standard PROSPECT: real
//! leaves with hairs or wax reflect more at the surface, in the blue and red where nothing
//! else reflects, and a fixed 40° misses that by 0.01-0.05), each
//! kept inside its published range ([`crate::prospect::PIGMENT_RANGES`]) by working in
//! `u = (x - lo) / (hi - lo)` clamped to `[0, 1]`. The cost is the squared difference of R
//! and T (R only for a reflectance-only spectrum) summed over the measured wavelengths, each
//! weighted by the width of the wavelength interval it stands for, so that an instrument's
//! dense and sparse regions count per nanometre, not per sample. Levenberg-Marquardt with a
//! forward-difference Jacobian minimises it from several starting leaves (a thin pale one,
//! the default, a thick dark one, a red one); the best result is kept. PROSPECT is evaluated
//! only at the grid wavelengths the measurement needs (linear between the two 1 nm nodes
//! around each), with the border transmissivities cached: a fit takes a few seconds.
//!
//! **Band means.** Leaf studies check a fit by its means over the bands of [`FIT_BANDS`]
//! (blue, green, red, NIR plateau, SWIR). A per-nanometre fit spreads PROSPECT's systematic
//! misfit evenly and can leave a band mean 0.01-0.03 off (often the SWIR, where real leaves'
//! water and dry-matter shapes differ from PROSPECT's). So each band's mean error (R, and T
//! where measured) is a further residual, weighted as [`FitOptions::band_weight`] (default
//! [`BAND_WEIGHT`]) times the band's width of spectrum: a band mean off by `e` costs as much as
//! the whole band off by `e`, several times. Weight 0 is the plain per-nanometre fit.

use crate::measured::MeasuredSpectrum;
use crate::prospect::{PIGMENT_RANGES, Pigments, constants, plate_pile_with, stern_tav};

/// The fit's result.
#[derive(Clone, Debug, PartialEq)]
pub struct ProspectFit {
    /// The fitted pigments (PROSPECT-D).
    pub pigments: Pigments,
    /// PROSPECT's R at the measured wavelengths.
    pub model_r: Vec<f64>,
    /// PROSPECT's T at the measured wavelengths.
    pub model_t: Vec<f64>,
    /// Root-mean-square error of R over the samples (unweighted).
    pub rmse_r: f64,
    /// Root-mean-square error of T (`None` without a measured T).
    pub rmse_t: Option<f64>,
    /// Levenberg-Marquardt iterations of the kept start.
    pub iterations: usize,
}

/// The bands the fit's band means are taken over: name, first and last wavelength (nm,
/// inclusive). A band mean is the plain mean of the samples inside.
pub const FIT_BANDS: [(&str, f64, f64); 5] = [
    ("blue 450-500 nm", 450.0, 500.0),
    ("green 500-570 nm", 500.0, 570.0),
    ("red 620-700 nm", 620.0, 700.0),
    ("NIR 800-900 nm", 800.0, 900.0),
    ("SWIR 1550-1750 nm", 1550.0, 1750.0),
];

/// How many times a band's own width of spectrum a band mean's error weighs in the cost, by
/// default ([`FitOptions::band_weight`]).
pub const BAND_WEIGHT: f64 = 8.0;

/// The mean of `v` over the samples of `nm` (nm) inside each of [`FIT_BANDS`]; `None` for a
/// band with no sample.
pub fn band_means(nm: &[f64], v: &[f64]) -> [Option<f64>; 5] {
    FIT_BANDS.map(|(_, lo, hi)| {
        let (sum, count) = nm
            .iter()
            .zip(v)
            .filter(|(l, _)| **l >= lo && **l <= hi)
            .fold((0.0, 0usize), |(s, c), (_, x)| (s + x, c + 1));
        (count > 0).then(|| sum / count as f64)
    })
}

/// What a fit is given besides the measurement.
#[derive(Clone, Debug)]
pub struct FitOptions {
    /// How many times its own width of spectrum each band mean's error weighs in the cost
    /// (0: a plain per-nanometre fit). Default [`BAND_WEIGHT`].
    pub band_weight: f64,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            band_weight: BAND_WEIGHT,
        }
    }
}

/// How many inputs are fitted.
const FITTED: usize = 8;
/// Their indices in [`PIGMENT_RANGES`]: N, Cab, Car, Anth, Cbrown, Cw, Cm and the surface
/// parameter alpha (PRO's prot and cbc stay 0).
const FIT_INDEX: [usize; FITTED] = [0, 1, 2, 3, 4, 5, 6, 9];

/// PROSPECT at a fixed set of wavelengths, with everything that does not depend on the
/// pigments precomputed.
struct Kernel {
    /// Per sample: the two grid indices around it and the weight of the upper one.
    at: Vec<(usize, usize, f64)>,
    /// Distinct grid indices needed, sorted.
    nodes: Vec<usize>,
    /// Per node: (nr, t_av(90)).
    borders: Vec<(f64, f64)>,
}

impl Kernel {
    fn new(nm: &[f64]) -> Self {
        let mut at = Vec::with_capacity(nm.len());
        let mut nodes: Vec<usize> = Vec::new();
        for &l in nm {
            let x = (l - 400.0).clamp(0.0, 2100.0);
            let i0 = (x.floor() as usize).min(2099);
            let f = x - i0 as f64;
            nodes.push(i0);
            nodes.push(i0 + 1);
            at.push((i0, i0 + 1, f));
        }
        nodes.sort_unstable();
        nodes.dedup();
        let c = constants();
        let borders = nodes
            .iter()
            .map(|&i| (c[i].nr, stern_tav(90.0, c[i].nr)))
            .collect();
        // Turn grid indices into positions in `nodes`.
        let pos = |i: usize| nodes.binary_search(&i).unwrap_or(0);
        let at = at
            .into_iter()
            .map(|(a, b, f)| (pos(a), pos(b), f))
            .collect();
        Kernel { at, nodes, borders }
    }

    /// `(R, T)` at every sample for pigments `p`.
    fn eval(&self, p: &Pigments) -> (Vec<f64>, Vec<f64>) {
        let node_rt: Vec<(f64, f64)> = self
            .nodes
            .iter()
            .zip(&self.borders)
            .map(|(&i, &(nr, t12))| {
                let t_alpha = stern_tav(p.alpha, nr);
                plate_pile_with(p.n, nr, p.plate_absorption(i), t_alpha, t12)
            })
            .collect();
        self.at
            .iter()
            .map(|&(a, b, f)| {
                let (ra, ta) = node_rt[a];
                let (rb, tb) = node_rt[b];
                (ra + f * (rb - ra), ta + f * (tb - ta))
            })
            .unzip()
    }
}

fn from_unit(u: &[f64; FITTED]) -> Pigments {
    let mut v = [0.0; 10];
    for (k, &i) in FIT_INDEX.iter().enumerate() {
        let (_, lo, hi, _) = PIGMENT_RANGES[i];
        v[i] = lo + u[k].clamp(0.0, 1.0) * (hi - lo);
    }
    Pigments::from_values(v)
}

fn to_unit(p: &Pigments) -> [f64; FITTED] {
    let v = p.values();
    std::array::from_fn(|k| {
        let (_, lo, hi, _) = PIGMENT_RANGES[FIT_INDEX[k]];
        ((v[FIT_INDEX[k]] - lo) / (hi - lo)).clamp(0.0, 1.0)
    })
}

/// Fits PROSPECT-D to `m` (see the module docs).
pub fn fit_prospect(m: &MeasuredSpectrum) -> ProspectFit {
    fit_prospect_with(m, &FitOptions::default())
}

/// Fits PROSPECT-D to `m` with `opts` (see the module docs).
pub fn fit_prospect_with(m: &MeasuredSpectrum, opts: &FitOptions) -> ProspectFit {
    let kernel = Kernel::new(&m.nm);
    let weights = Weights::new(m, opts.band_weight);
    let residuals = |u: &[f64; FITTED]| -> Vec<f64> {
        let (r, t) = kernel.eval(&from_unit(u));
        weights.residuals(m, &r, &t)
    };
    let starts = [
        Pigments {
            n: 1.2,
            cab: 15.0,
            car: 4.0,
            cw: 0.006,
            cm: 0.004,
            ..Pigments::default()
        },
        Pigments::default(),
        Pigments {
            n: 2.2,
            cab: 70.0,
            car: 15.0,
            cw: 0.02,
            cm: 0.012,
            ..Pigments::default()
        },
        Pigments {
            n: 1.6,
            cab: 15.0,
            car: 10.0,
            anth: 10.0,
            cbrown: 0.3,
            ..Pigments::default()
        },
    ];
    let mut best: Option<([f64; FITTED], f64, usize)> = None;
    for s in &starts {
        // Standard PROSPECT first (alpha held at the start's 40°), then alpha freed from
        // there: Levenberg-Marquardt only takes steps that lower the cost, so the second
        // stage can only improve on the first (from scratch, the extra freedom can lead
        // into a worse local minimum).
        let mut hold_alpha = [true; FITTED];
        hold_alpha[FITTED - 1] = false;
        let (u, _, it1) = levenberg_marquardt(to_unit(s), &hold_alpha, &residuals);
        let (u, cost, it2) = levenberg_marquardt(u, &[true; FITTED], &residuals);
        let it = it1 + it2;
        if best.as_ref().is_none_or(|b| cost < b.1) {
            best = Some((u, cost, it));
        }
    }
    let (u, _, iterations) = best.expect("at least one start");
    let pigments = from_unit(&u);
    let (model_r, model_t) = kernel.eval(&pigments);
    let rmse = |a: &[f64], b: &[f64]| {
        (a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>() / a.len() as f64).sqrt()
    };
    ProspectFit {
        rmse_r: rmse(&model_r, &m.r),
        rmse_t: m.t.as_ref().map(|t| rmse(&model_t, t)),
        pigments,
        model_r,
        model_t,
        iterations,
    }
}

/// The residuals' weights for one measurement.
struct Weights {
    /// Per sample: the square root of its wavelength interval over the mean interval.
    sample: Vec<f64>,
    /// Per band with samples: their indices and the factor of the band mean's error.
    bands: Vec<(Vec<usize>, f64)>,
}

impl Weights {
    fn new(m: &MeasuredSpectrum, band_weight: f64) -> Self {
        let n = m.nm.len();
        // Interval widths (nm) as weights, normalised to mean 1.
        let mut w: Vec<f64> = (0..n)
            .map(|i| {
                let lo = if i == 0 {
                    m.nm[0]
                } else {
                    0.5 * (m.nm[i - 1] + m.nm[i])
                };
                let hi = if i + 1 == n {
                    m.nm[n - 1]
                } else {
                    0.5 * (m.nm[i] + m.nm[i + 1])
                };
                (hi - lo).max(1e-3)
            })
            .collect();
        let mean = w.iter().sum::<f64>() / n as f64;
        w.iter_mut().for_each(|x| *x = (*x / mean).sqrt());
        // A band's width in units of the mean interval, times the band weight, as a factor.
        let bands = FIT_BANDS
            .iter()
            .filter(|_| band_weight > 0.0)
            .filter_map(|&(_, lo, hi)| {
                let idx: Vec<usize> = (0..n).filter(|&i| m.nm[i] >= lo && m.nm[i] <= hi).collect();
                let width: f64 = idx.iter().map(|&i| w[i] * w[i]).sum();
                (!idx.is_empty()).then(|| (idx, (band_weight * width).sqrt()))
            })
            .collect();
        Weights { sample: w, bands }
    }

    /// The residuals of model `r`, `t` against `m`: per sample, then per band (R, then T
    /// where measured).
    fn residuals(&self, m: &MeasuredSpectrum, r: &[f64], t: &[f64]) -> Vec<f64> {
        let n = m.nm.len();
        let mut out = Vec::with_capacity(2 * (n + self.bands.len()));
        let mut push = |model: &[f64], meas: &[f64]| {
            let e: Vec<f64> = (0..n).map(|i| model[i] - meas[i]).collect();
            out.extend(self.sample.iter().zip(&e).map(|(w, e)| w * e));
            for (idx, wb) in &self.bands {
                let mean = idx.iter().map(|&i| e[i]).sum::<f64>() / idx.len() as f64;
                out.push(wb * mean);
            }
        };
        push(r, &m.r);
        if let Some(mt) = &m.t {
            push(t, mt);
        }
        out
    }
}

fn cost_of(r: &[f64]) -> f64 {
    r.iter().map(|x| x * x).sum()
}

/// Minimises `|res(u)|²` over the unit box from `u`, moving only the coordinates `free`
/// marks: returns the point, its cost and the iterations used.
fn levenberg_marquardt(
    mut u: [f64; FITTED],
    free: &[bool; FITTED],
    res: &dyn Fn(&[f64; FITTED]) -> Vec<f64>,
) -> ([f64; FITTED], f64, usize) {
    let mut r = res(&u);
    let mut cost = cost_of(&r);
    let mut mu = 1e-3;
    let mut it = 0;
    while it < 200 {
        it += 1;
        // Forward-difference Jacobian, stepping inward at the box's upper face.
        let mut jac = vec![[0.0f64; FITTED]; r.len()];
        for k in (0..FITTED).filter(|&k| free[k]) {
            let h = if u[k] > 1.0 - 1e-4 { -1e-5 } else { 1e-5 };
            let mut v = u;
            v[k] += h;
            let rk = res(&v);
            for (row, (a, b)) in jac.iter_mut().zip(rk.iter().zip(&r)) {
                row[k] = (a - b) / h;
            }
        }
        let mut jtj = [[0.0f64; FITTED]; FITTED];
        let mut jtr = [0.0f64; FITTED];
        for (row, ri) in jac.iter().zip(&r) {
            for a in 0..FITTED {
                jtr[a] += row[a] * ri;
                for b in 0..FITTED {
                    jtj[a][b] += row[a] * row[b];
                }
            }
        }
        // A held coordinate: a unit row and no gradient, so its step is zero.
        for k in (0..FITTED).filter(|&k| !free[k]) {
            jtj[k] = [0.0; FITTED];
            for row in jtj.iter_mut() {
                row[k] = 0.0;
            }
            jtj[k][k] = 1.0;
            jtr[k] = 0.0;
        }
        let mut improved = false;
        for _ in 0..10 {
            let mut a = jtj;
            for (k, row) in a.iter_mut().enumerate() {
                row[k] += mu * (jtj[k][k] + 1e-12);
            }
            let Some(step) = solve(a, jtr.map(|x| -x)) else {
                mu *= 10.0;
                continue;
            };
            let mut v = u;
            for k in 0..FITTED {
                v[k] = (u[k] + step[k]).clamp(0.0, 1.0);
            }
            let rv = res(&v);
            let cv = cost_of(&rv);
            if cv < cost {
                let gain = cost - cv;
                u = v;
                r = rv;
                cost = cv;
                mu = (mu / 3.0).max(1e-9);
                improved = gain > 1e-12 * cost.max(1e-30);
                break;
            }
            mu *= 4.0;
        }
        if !improved {
            break;
        }
    }
    (u, cost, it)
}

/// Solves the symmetric positive system `a x = b` by Gaussian elimination with partial
/// pivoting; `None` where it is singular.
fn solve(mut a: [[f64; FITTED]; FITTED], mut b: [f64; FITTED]) -> Option<[f64; FITTED]> {
    for col in 0..FITTED {
        let piv = (col..FITTED).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if a[piv][col].abs() < 1e-300 {
            return None;
        }
        a.swap(col, piv);
        b.swap(col, piv);
        let pivot_row = a[col];
        for row in col + 1..FITTED {
            let f = a[row][col] / pivot_row[col];
            for (x, p) in a[row][col..].iter_mut().zip(&pivot_row[col..]) {
                *x -= f * p;
            }
            b[row] -= f * b[col];
        }
    }
    let mut x = [0.0; FITTED];
    for row in (0..FITTED).rev() {
        let s: f64 = (row + 1..FITTED).map(|k| a[row][k] * x[k]).sum();
        x[row] = (b[row] - s) / a[row][row];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::prospect::prospect;

    /// A PROSPECT leaf sampled every `step` nm with deterministic pseudo-random noise of
    /// standard deviation `sigma`.
    fn synthetic(p: &Pigments, step: usize, sigma: f64, with_t: bool) -> MeasuredSpectrum {
        let s = prospect(p);
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut noise = || {
            // Sum of 4 uniforms, scaled to unit variance.
            let mut acc = 0.0;
            for _ in 0..4 {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                acc += (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
            }
            acc * (3.0f64).sqrt() * sigma
        };
        let idx: Vec<usize> = (0..2101).step_by(step).collect();
        MeasuredSpectrum {
            nm: idx.iter().map(|&i| 400.0 + i as f64).collect(),
            r: idx
                .iter()
                .map(|&i| (s.r[i] + noise()).clamp(0.0, 1.0))
                .collect(),
            t: with_t.then(|| {
                idx.iter()
                    .map(|&i| (s.t[i] + noise()).clamp(0.0, 1.0))
                    .collect()
            }),
            dropped: 0,
        }
    }

    #[test]
    fn the_fit_recovers_pigments_from_noisy_prospect_leaves() {
        let leaves = [
            Pigments::default(),
            Pigments {
                n: 2.1,
                cab: 65.0,
                car: 14.0,
                anth: 3.0,
                cbrown: 0.0,
                cw: 0.022,
                cm: 0.011,
                ..Pigments::default()
            },
            Pigments {
                n: 1.3,
                cab: 12.0,
                car: 6.0,
                anth: 9.0,
                cbrown: 0.4,
                cw: 0.006,
                cm: 0.004,
                ..Pigments::default()
            },
            // A leaf that reflects more at its surface (hairs, wax).
            Pigments {
                n: 1.7,
                cab: 35.0,
                alpha: 70.0,
                ..Pigments::default()
            },
        ];
        for truth in &leaves {
            let m = synthetic(truth, 4, 0.003, true);
            let fit = fit_prospect(&m);
            let p = fit.pigments;
            let rel = |a: f64, b: f64, tol: f64, abs: f64| (a - b).abs() <= tol * b.abs() + abs;
            assert!(
                rel(p.n, truth.n, 0.05, 0.0)
                    && rel(p.cab, truth.cab, 0.08, 1.0)
                    && rel(p.car, truth.car, 0.25, 1.0)
                    && rel(p.anth, truth.anth, 0.3, 1.0)
                    && rel(p.cbrown, truth.cbrown, 0.3, 0.05)
                    && rel(p.cw, truth.cw, 0.08, 0.0005)
                    && rel(p.cm, truth.cm, 0.1, 0.0005)
                    && rel(p.alpha, truth.alpha, 0.0, 8.0),
                "fit {p:?}\ntruth {truth:?}"
            );
            // The noise is 0.003: the residual should be that, not more.
            assert!(
                fit.rmse_r < 0.0035 && fit.rmse_t.unwrap() < 0.0035,
                "{fit:?}"
            );
        }
    }

    /// A leaf PROSPECT cannot match exactly (its SWIR reflectance lowered by a smooth bump, as
    /// a leaf whose water band is shaped unlike PROSPECT's): the band-mean terms bring every
    /// band mean within 0.01, where the per-nanometre fit leaves the SWIR mean further off.
    #[test]
    fn band_means_are_weighed_where_prospect_cannot_match() {
        let truth = Pigments {
            n: 1.8,
            cab: 50.0,
            car: 12.0,
            cw: 0.015,
            cm: 0.008,
            ..Pigments::default()
        };
        let mut m = synthetic(&truth, 2, 0.002, false);
        for (nm, r) in m.nm.iter().zip(m.r.iter_mut()) {
            let x = (nm - 1650.0) / 120.0;
            *r -= 0.03 * (-x * x).exp();
        }
        let worst = |opts: &FitOptions| {
            let fit = fit_prospect_with(&m, opts);
            let (a, b) = (band_means(&m.nm, &fit.model_r), band_means(&m.nm, &m.r));
            let worst = a
                .iter()
                .zip(&b)
                .map(|(a, b)| (a.unwrap() - b.unwrap()).abs())
                .fold(0.0f64, f64::max);
            (worst, fit.rmse_r)
        };
        let (plain, plain_rmse) = worst(&FitOptions { band_weight: 0.0 });
        let (banded, banded_rmse) = worst(&FitOptions::default());
        assert!(
            banded < 0.01 && banded < 0.7 * plain,
            "worst band-mean error {banded} with band terms, {plain} without"
        );
        // The trade costs little RMSE.
        eprintln!(
            "worst band-mean error {banded:.4} (plain {plain:.4}), RMSE {banded_rmse:.4} (plain {plain_rmse:.4})"
        );
        assert!(
            banded_rmse < 1.6 * plain_rmse,
            "{banded_rmse} vs {plain_rmse}"
        );
    }

    #[test]
    fn reflectance_only_fits_r_and_predicts_t() {
        let truth = Pigments::default();
        let m = synthetic(&truth, 5, 0.002, false);
        let fit = fit_prospect(&m);
        assert!(fit.rmse_t.is_none() && fit.rmse_r < 0.003, "{fit:?}");
        let s = prospect(&truth);
        let t_err = fit
            .model_t
            .iter()
            .zip(m.nm.iter())
            .map(|(t, nm)| (t - s.t[(*nm - 400.0) as usize]).abs())
            .fold(0.0f64, f64::max);
        assert!(t_err < 0.05, "predicted T off by {t_err}");
    }
}
