//! `e^x` for `x <= 0`, many arguments at once, written so the compiler vectorises it (no
//! calls, no branches, only selects): the closed-form single scattering's 18 attenuations
//! `e^{-sigma_t d / mu}` per evaluation, which were most of the leaf BSDF's cost with the C
//! library's scalar `expf`.
//!
//! The method is the classic one (Cody & Waite 1980, as in the Cephes and fdlibm `expf`):
//! `x = k ln 2 + r` with `k` the nearest integer to `x / ln 2` (found by the
//! round-to-nearest of adding `1.5 · 2^23`) and `|r| <= ln 2 / 2` (`ln 2` split in two parts
//! so `k ln 2` is exact), `e^r` by its Taylor polynomial to `r^7 / 7!` (truncation below
//! `6e-9` relative on that interval), and `2^k` written into the exponent bits. Relative
//! error against `f64::exp` below `3e-7` (a few ulp; tested) for every `x` in `[-87.3, 0]`,
//! exactly `1` at `0`, and `0` below `-87.3` (where `e^x` is under `f32::MIN_POSITIVE`).
//! Positive arguments are outside the contract (debug builds assert).

/// `1.5 · 2^23`: adding it rounds a float below `2^22` in magnitude to an integer, which
/// then sits in the low mantissa bits.
const SHIFTER: f32 = 12_582_912.0;
/// `ln 2` split so `k · LN2_HI` is exact for `|k| < 2^9` (fdlibm's split).
const LN2_HI: f32 = 0.693_145_75;
const LN2_LO: f32 = 1.428_606_8e-6;
/// Below this `e^x` is not a normal f32.
const X_MIN: f32 = -87.33;

/// `e^x` for one argument `x <= 0`, the same operations as [`exp_neg_in_place`]'s lanes.
#[inline(always)]
pub(crate) fn exp_neg(x: f32) -> f32 {
    debug_assert!(x <= 0.0 || x.is_nan(), "exp_neg({x})");
    let xc = if x < X_MIN { X_MIN } else { x };
    let t = xc * std::f32::consts::LOG2_E + SHIFTER;
    let kf = t - SHIFTER;
    // The integer `k` (in [-126, 0]) is `t`'s mantissa bits less the shifter's.
    let k = t.to_bits().wrapping_sub(SHIFTER.to_bits()) as i32;
    let r = (xc - kf * LN2_HI) - kf * LN2_LO;
    // Estrin's scheme: short dependency chains, so the lanes' multiplies overlap.
    let r2 = r * r;
    let r4 = r2 * r2;
    let p = ((1.0 + r) + r2 * (0.5 + r * (1.0 / 6.0)))
        + r4 * ((1.0 / 24.0 + r * (1.0 / 120.0)) + r2 * (1.0 / 720.0 + r * (1.0 / 5040.0)));
    // 2^k, a normal float's exponent bits.
    let y = p * f32::from_bits(((k + 127) as u32) << 23);
    if x < X_MIN { 0.0 } else { y }
}

/// Replaces every element of `x` (all `<= 0`) by `e^x` (see the module docs).
#[inline(always)]
pub(crate) fn exp_neg_in_place<const N: usize>(x: &mut [f32; N]) {
    for v in x.iter_mut() {
        *v = exp_neg(*v);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rel(x: f32) -> f64 {
        let want = (x as f64).exp();
        let got = exp_neg(x) as f64;
        ((got - want) / want).abs()
    }

    #[test]
    fn accurate_over_the_normal_range() {
        let mut worst = 0.0f64;
        let n = 2_000_000;
        for i in 0..=n {
            worst = worst.max(rel(X_MIN * i as f32 / n as f32));
        }
        // Near zero, where the attenuations of thin layers live, densely.
        for i in 0..=200_000 {
            worst = worst.max(rel(-(i as f32) * 1e-6));
        }
        assert!(worst < 3e-7, "worst relative error {worst:e}");
    }

    #[test]
    fn exact_at_zero_and_zero_below_the_range() {
        assert_eq!(exp_neg(0.0), 1.0);
        assert_eq!(exp_neg(-0.0), 1.0);
        assert!(exp_neg(X_MIN) > 0.0);
        assert_eq!(exp_neg(-87.4), 0.0);
        assert_eq!(exp_neg(-1e30), 0.0);
        assert_eq!(exp_neg(f32::NEG_INFINITY), 0.0);
    }

    #[test]
    fn lanes_equal_the_scalar() {
        let mut a = [0.0f32; 20];
        for (i, v) in a.iter_mut().enumerate() {
            *v = -4.6 * i as f32;
        }
        let want = a.map(exp_neg);
        exp_neg_in_place(&mut a);
        assert_eq!(a.map(f32::to_bits), want.map(f32::to_bits));
    }
}
