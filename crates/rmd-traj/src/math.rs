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

/// Integrates a profile phase by phase with one convention: a jerk phase whose final
/// acceleration is zero up to rounding (|a| ≤ 16·eps·max(`a_scale`, |j·t|), where `a_scale` is the
/// axis's acceleration scale, see [`snap_scale`]) ends at exactly zero acceleration.
/// `a − j·(a/j)` is rarely exactly 0 in floating point, and a residual of 1e-13 before a cruise of
/// thousands of seconds would integrate into a visible drift that the intended profile does not
/// have. Every integration of a profile (solver, sampler, checker) uses the same rule and scale.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Integrator {
    pub(crate) p: f64,
    pub(crate) v: f64,
    pub(crate) a: f64,
    a_scale: f64,
}

/// The acceleration scale of an axis for [`Integrator`]: the largest of |a0|, |af|, `a_max`,
/// |`a_min`| (initial state before any brake).
pub(crate) fn snap_scale(a0: f64, af: f64, a_max: f64, a_min: f64) -> f64 {
    max(max(abs(a0), abs(af)), max(abs(a_max), abs(a_min)))
}

impl Integrator {
    pub(crate) fn new(p: f64, v: f64, a: f64, a_scale: f64) -> Self {
        Integrator { p, v, a, a_scale }
    }

    /// Advances by a phase of duration `t` and jerk `j`.
    #[inline]
    pub(crate) fn step(&mut self, t: f64, j: f64) {
        let (p1, v1, mut a1) = integrate(t, self.p, self.v, self.a, j);
        if j != 0.0 && abs(a1) <= 16.0 * EPS * max(self.a_scale, abs(t * j)) {
            a1 = 0.0;
        }
        self.p = p1;
        self.v = v1;
        self.a = a1;
    }

    /// The state as a tuple.
    #[inline]
    pub(crate) fn state(&self) -> (f64, f64, f64) {
        (self.p, self.v, self.a)
    }
}
