//! Fitting PROSPECT pigments to a measured leaf spectrum (PROSPECT inversion).
//!
//! The unknowns are PROSPECT-D's seven inputs (N, Cab, Car, Anth, Cbrown, Cw, Cm), each
//! kept inside its published range ([`crate::prospect::PIGMENT_RANGES`]) by working in
//! `u = (x - lo) / (hi - lo)` clamped to `[0, 1]`. The cost is the squared difference of R
//! and T (R only for a reflectance-only spectrum) summed over the measured wavelengths, each
//! weighted by the width of the wavelength interval it stands for, so that an instrument's
//! dense and sparse regions count per nanometre, not per sample. Levenberg-Marquardt with a
//! forward-difference Jacobian minimises it from several starting leaves (a thin pale one,
//! the default, a thick dark one, a red one); the best result is kept. PROSPECT is evaluated
//! only at the grid wavelengths the measurement needs (linear between the two 1 nm nodes
//! around each), with the border transmissivities cached: a fit takes well under a second.

use crate::measured::MeasuredSpectrum;
use crate::prospect::{PIGMENT_RANGES, Pigments, constants, plate_transmissivity, stern_tav};

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

/// Index of the seven fitted inputs in [`PIGMENT_RANGES`] order (PRO's prot and cbc stay 0).
const FITTED: usize = 7;

/// PROSPECT at a fixed set of wavelengths, with everything that does not depend on the
/// pigments precomputed.
struct Kernel {
    /// Per sample: the two grid indices around it and the weight of the upper one.
    at: Vec<(usize, usize, f64)>,
    /// Distinct grid indices needed, sorted.
    nodes: Vec<usize>,
    /// Per node: (nr, t_av(40), t_av(90)).
    borders: Vec<(f64, f64, f64)>,
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
            .map(|&i| (c[i].nr, stern_tav(40.0, c[i].nr), stern_tav(90.0, c[i].nr)))
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
            .map(|(&i, &(nr, t_alpha, t12))| pile(p.n, nr, t_alpha, t12, p.plate_absorption(i)))
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

/// [`crate::prospect::plate_pile`] with the border transmissivities given.
fn pile(n: f64, nr: f64, t_alpha: f64, t12: f64, k: f64) -> (f64, f64) {
    let tau = plate_transmissivity(k);
    let r_alpha = 1.0 - t_alpha;
    let r12 = 1.0 - t12;
    let t21 = t12 / (nr * nr);
    let r21 = 1.0 - t21;
    let bounce = 1.0 - r21 * r21 * tau * tau;
    let t_top = t_alpha * tau * t21 / bounce;
    let r_top = r_alpha + r21 * tau * t_top;
    let t_one = t12 * tau * t21 / bounce;
    let r_one = r12 + r21 * tau * t_one;
    let m = n - 1.0;
    let (r_sub, t_sub) = if r_one + t_one >= 1.0 - 1e-12 {
        let t_m = t_one / (t_one + (1.0 - t_one) * m);
        (1.0 - t_m, t_m)
    } else {
        let (r, t) = (r_one, t_one);
        let d = ((1.0 + r + t) * (1.0 + r - t) * (1.0 - r + t) * (1.0 - r - t)).sqrt();
        let a = (1.0 + r * r - t * t + d) / (2.0 * r);
        let b = (1.0 - r * r + t * t + d) / (2.0 * t);
        let b_m = b.powf(m);
        let b_2m = b_m * b_m;
        let denom = a * a * b_2m - 1.0;
        (a * (b_2m - 1.0) / denom, b_m * (a * a - 1.0) / denom)
    };
    let between = 1.0 - r_sub * r_one;
    (
        r_top + t_top * r_sub * t_one / between,
        t_top * t_sub / between,
    )
}

fn from_unit(u: &[f64; FITTED]) -> Pigments {
    let mut v = [0.0; 9];
    for k in 0..FITTED {
        let (_, lo, hi, _) = PIGMENT_RANGES[k];
        v[k] = lo + u[k].clamp(0.0, 1.0) * (hi - lo);
    }
    Pigments::from_values(v)
}

fn to_unit(p: &Pigments) -> [f64; FITTED] {
    let v = p.values();
    std::array::from_fn(|k| {
        let (_, lo, hi, _) = PIGMENT_RANGES[k];
        ((v[k] - lo) / (hi - lo)).clamp(0.0, 1.0)
    })
}

/// Fits PROSPECT-D to `m` (see the module docs).
pub fn fit_prospect(m: &MeasuredSpectrum) -> ProspectFit {
    let kernel = Kernel::new(&m.nm);
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
    let residuals = |u: &[f64; FITTED]| -> Vec<f64> {
        let (r, t) = kernel.eval(&from_unit(u));
        let mut out = Vec::with_capacity(2 * n);
        for i in 0..n {
            out.push(w[i] * (r[i] - m.r[i]));
        }
        if let Some(mt) = &m.t {
            for i in 0..n {
                out.push(w[i] * (t[i] - mt[i]));
            }
        }
        out
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
        let (u, cost, it) = levenberg_marquardt(to_unit(s), &residuals);
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

fn cost_of(r: &[f64]) -> f64 {
    r.iter().map(|x| x * x).sum()
}

/// Minimises `|res(u)|²` over the unit box from `u`: returns the point, its cost and the
/// iterations used.
fn levenberg_marquardt(
    mut u: [f64; FITTED],
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
        for k in 0..FITTED {
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
        ];
        for truth in &leaves {
            let m = synthetic(truth, 2, 0.003, true);
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
                    && rel(p.cm, truth.cm, 0.1, 0.0005),
                "fit {p:?}\ntruth {truth:?}"
            );
            // The noise is 0.003: the residual should be that, not more.
            assert!(
                fit.rmse_r < 0.0035 && fit.rmse_t.unwrap() < 0.0035,
                "{fit:?}"
            );
        }
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
