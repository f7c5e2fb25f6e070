//! IEEE 754 half-precision floats: the angular tables are uploaded as RGBA16F and the HDR
//! target is read back as RGBA16F.

/// The `f32` value of the half-float bits `h` (subnormals, infinities and NaN included).
pub(super) fn half_to_f32(h: u16) -> f32 {
    let s = if h & 0x8000 != 0 { -1.0 } else { 1.0 };
    let e = ((h >> 10) & 0x1f) as i32;
    let m = (h & 0x3ff) as f32;
    match e {
        0 => s * m * 2f32.powi(-24),
        31 => {
            if m == 0.0 {
                s * f32::INFINITY
            } else {
                f32::NAN
            }
        }
        _ => s * (1.0 + m / 1024.0) * 2f32.powi(e - 15),
    }
}

/// The half-float bits nearest `x` (overflow to infinity, underflow to zero).
pub(super) fn f32_to_half(x: f32) -> u16 {
    let b = x.to_bits();
    let sign = ((b >> 16) & 0x8000) as u16;
    let e = ((b >> 23) & 0xff) as i32 - 127 + 15;
    let m = b & 0x7f_ffff;
    if x.is_nan() {
        return 0x7e00;
    }
    if e >= 31 {
        return sign | 0x7c00;
    }
    if e <= 0 {
        if e < -10 {
            return sign;
        }
        let m = (m | 0x80_0000) >> (1 - e);
        return sign | ((m + 0x1000) >> 13) as u16;
    }
    let v = ((e as u32) << 10) | (m >> 13);
    // Round to nearest (ties away), carrying into the exponent if needed.
    let v = v + ((m >> 12) & 1);
    sign | v as u16
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn half_floats_round_trip() {
        for x in [0.0f32, 1.0, 0.5, 0.3, 3.0, 1e-3, 65000.0, -2.5] {
            let y = half_to_f32(f32_to_half(x));
            assert!((x - y).abs() <= x.abs() * 1e-3 + 1e-7, "{x} -> {y}");
        }
    }
}
