//! Rounding for `no_std` (core has no `f64::round`).

/// Rounds `x` to the nearest integer, halves away from zero, saturating at the `i64` bounds.
/// NaN gives 0 (callers reject or map NaN before).
pub(crate) fn round_half_away(x: f64) -> i64 {
    // `as` truncates toward zero and saturates (NaN -> 0). For |x| < 2^53 both `t as f64` and
    // `x - t` are exact, so `frac` is the exact fractional part; for larger |x| every f64 is an
    // integer and `frac` is 0 (or the saturation remainder, which saturating_* absorbs).
    let t = x as i64;
    let frac = x - t as f64;
    if frac >= 0.5 {
        t.saturating_add(1)
    } else if frac <= -0.5 {
        t.saturating_sub(1)
    } else {
        t
    }
}

#[cfg(test)]
mod tests {
    use super::round_half_away;

    #[test]
    fn rounds_half_away_from_zero() {
        assert_eq!(round_half_away(0.5), 1);
        assert_eq!(round_half_away(-0.5), -1);
        assert_eq!(round_half_away(1.4999), 1);
        assert_eq!(round_half_away(-1.5), -2);
        assert_eq!(round_half_away(2.5), 3);
        assert_eq!(round_half_away(0.49999999999999994), 0);
        assert_eq!(round_half_away(-0.49999999999999994), 0);
        assert_eq!(round_half_away(0.0), 0);
        assert_eq!(round_half_away(-0.0), 0);
        assert_eq!(round_half_away(1e300), i64::MAX);
        assert_eq!(round_half_away(-1e300), i64::MIN);
        assert_eq!(round_half_away(f64::NAN), 0);
        assert_eq!(round_half_away(4503599627370497.0), 4503599627370497);
    }
}
