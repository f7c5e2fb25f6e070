//! The one range check every input of the crate goes through.

/// An error type with the two ways a number can be a bad input.
pub(crate) trait InputError {
    /// `value` of `field` is NaN or infinite.
    fn not_finite(field: &'static str, value: f64) -> Self;
    /// `value` of `field` lies outside `range` (its description in words).
    fn out_of_range(field: &'static str, value: f64, range: &'static str) -> Self;
}

/// `Ok` when `value` is finite and in `[lo, hi]`; otherwise the error naming `field`.
pub(crate) fn check<E: InputError>(
    field: &'static str,
    value: f64,
    lo: f64,
    hi: f64,
    range: &'static str,
) -> Result<(), E> {
    if !value.is_finite() {
        return Err(E::not_finite(field, value));
    }
    if value < lo || value > hi {
        return Err(E::out_of_range(field, value, range));
    }
    Ok(())
}
