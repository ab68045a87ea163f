//! The few float functions the solver needs: `std` when available, `libm` otherwise.

#[cfg(feature = "std")]
mod imp {
    #[inline]
    pub(crate) fn sqrt(x: f64) -> f64 {
        x.sqrt()
    }
    #[inline]
    pub(crate) fn fmod(x: f64, y: f64) -> f64 {
        x % y
    }
}

#[cfg(not(feature = "std"))]
mod imp {
    #[inline]
    pub(crate) fn sqrt(x: f64) -> f64 {
        libm::sqrt(x)
    }
    #[inline]
    pub(crate) fn fmod(x: f64, y: f64) -> f64 {
        libm::fmod(x, y)
    }
}

pub(crate) use imp::{fmod, sqrt};

/// Machine epsilon of `f64`.
pub(crate) const EPS: f64 = f64::EPSILON;

/// Absolute value (in `core` without depending on its float-math availability).
#[inline]
pub(crate) fn abs(x: f64) -> f64 {
    if x < 0.0 { -x } else { x }
}

/// Larger of two values; NaN-free inputs assumed.
#[inline]
pub(crate) fn max(a: f64, b: f64) -> f64 {
    if a > b { a } else { b }
}

/// Smaller of two values; NaN-free inputs assumed.
#[inline]
pub(crate) fn min(a: f64, b: f64) -> f64 {
    if a < b { a } else { b }
}

/// Position, velocity and acceleration after a constant-jerk piece of duration `t`.
#[inline]
pub(crate) fn integrate(t: f64, p: f64, v: f64, a: f64, j: f64) -> (f64, f64, f64) {
    (
        p + t * (v + t * (a / 2.0 + t * j / 6.0)),
        v + t * (a + t * j / 2.0),
        a + t * j,
    )
}

/// [`integrate`] for a whole phase of a profile: an end acceleration that is zero up to the
/// rounding of `a + t·j` is set to exactly zero, so that a following cruise does not drift
/// (`a − j·(a/j)` is rarely exactly 0 in floating point, and a residual of 1e-12 integrates to
/// visible errors over a cruise of thousands of seconds).
#[inline]
pub(crate) fn integrate_phase(t: f64, p: f64, v: f64, a: f64, j: f64) -> (f64, f64, f64) {
    let (p1, v1, mut a1) = integrate(t, p, v, a, j);
    if j != 0.0 && abs(a1) <= 8.0 * EPS * max(abs(a), abs(t * j)) {
        a1 = 0.0;
    }
    (p1, v1, a1)
}
