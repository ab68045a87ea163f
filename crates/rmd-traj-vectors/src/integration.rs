//! The checker's own integration of a profile, written from the convention documented on
//! [`AxisProfile`](rmd_traj::AxisProfile) (not from the solver's code): phases of constant jerk
//! integrated in closed form, and a jerk phase whose final acceleration is zero up to rounding,
//! `|a| <= 16·eps·max(A, |j·t|)` with `A = max(|a0|, |af|, max_acceleration, |min_acceleration|)`,
//! ends at exactly zero acceleration.

use rmd_traj::Input;

/// One axis of an [`Input`], with the minimum limits' defaults resolved (`min_velocity` absent
/// means `-max_velocity`, `min_acceleration` absent means `-max_acceleration`, as `Input`
/// documents).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Axis {
    /// Initial position.
    pub(crate) p0: f64,
    /// Initial velocity.
    pub(crate) v0: f64,
    /// Initial acceleration.
    pub(crate) a0: f64,
    /// Target position.
    pub(crate) pf: f64,
    /// Target velocity.
    pub(crate) vf: f64,
    /// Target acceleration.
    pub(crate) af: f64,
    /// Maximum velocity.
    pub(crate) v_max: f64,
    /// Minimum velocity.
    pub(crate) v_min: f64,
    /// Maximum acceleration.
    pub(crate) a_max: f64,
    /// Minimum acceleration.
    pub(crate) a_min: f64,
    /// Maximum jerk.
    pub(crate) j_max: f64,
}

impl Axis {
    /// Axis `i` of `input`.
    pub(crate) fn of<const N: usize>(input: &Input<N>, i: usize) -> Self {
        Axis {
            p0: input.current_position[i],
            v0: input.current_velocity[i],
            a0: input.current_acceleration[i],
            pf: input.target_position[i],
            vf: input.target_velocity[i],
            af: input.target_acceleration[i],
            v_max: input.max_velocity[i],
            v_min: input.min_velocity.map_or(-input.max_velocity[i], |m| m[i]),
            a_max: input.max_acceleration[i],
            a_min: input
                .min_acceleration
                .map_or(-input.max_acceleration[i], |m| m[i]),
            j_max: input.max_jerk[i],
        }
    }

    /// The acceleration scale `A` of the zero-acceleration rule:
    /// `max(|a0|, |af|, |a_max|, |a_min|)`.
    pub(crate) fn snap_scale(&self) -> f64 {
        self.a0
            .abs()
            .max(self.af.abs())
            .max(self.a_max.abs())
            .max(self.a_min.abs())
    }
}

/// Position, velocity and acceleration after a constant-jerk piece of duration `t`.
pub(crate) fn integrate(t: f64, p: f64, v: f64, a: f64, j: f64) -> (f64, f64, f64) {
    (
        p + t * (v + t * (a / 2.0 + t * j / 6.0)),
        v + t * (a + t * j / 2.0),
        a + t * j,
    )
}

/// Integrates a profile phase by phase with the documented zero-acceleration rule.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Integrator {
    /// Position.
    pub(crate) p: f64,
    /// Velocity.
    pub(crate) v: f64,
    /// Acceleration.
    pub(crate) a: f64,
    a_scale: f64,
}

impl Integrator {
    /// Starts at `(p, v, a)` on an axis whose acceleration scale is `a_scale`
    /// ([`Axis::snap_scale`]).
    pub(crate) fn new(p: f64, v: f64, a: f64, a_scale: f64) -> Self {
        Integrator { p, v, a, a_scale }
    }

    /// Advances by a phase of duration `t` and jerk `j`.
    pub(crate) fn step(&mut self, t: f64, j: f64) {
        let (p, v, mut a) = integrate(t, self.p, self.v, self.a, j);
        if j != 0.0 && a.abs() <= 16.0 * f64::EPSILON * self.a_scale.max((t * j).abs()) {
            a = 0.0;
        }
        (self.p, self.v, self.a) = (p, v, a);
    }

    /// The state as a tuple.
    pub(crate) fn state(&self) -> (f64, f64, f64) {
        (self.p, self.v, self.a)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn minimum_limits_default_to_the_negated_maximum() {
        let mut input = Input::<2>::with_limits([2.0, 3.0], [4.0, 5.0], [6.0, 7.0]);
        input.current_acceleration = [-9.0, 0.0];
        let ax = Axis::of(&input, 0);
        assert_eq!((ax.v_min, ax.a_min), (-2.0, -4.0));
        assert_eq!(ax.snap_scale(), 9.0);
        input.min_velocity = Some([-1.0, -1.5]);
        input.min_acceleration = Some([-0.5, -8.0]);
        let ax = Axis::of(&input, 1);
        assert_eq!((ax.v_min, ax.a_min, ax.snap_scale()), (-1.5, -8.0, 8.0));
    }

    #[test]
    fn a_jerk_phase_ending_at_zero_acceleration_up_to_rounding_ends_at_exactly_zero() {
        // 0.7 / 0.3 is not exact in binary: a + j·t leaves a residual of about -1.1e-16.
        let (a0, j) = (0.7, -0.3);
        let t = a0 / -j;
        assert_ne!(integrate(t, 0.0, 0.0, a0, j).2, 0.0);
        let mut it = Integrator::new(0.0, 0.0, a0, 1.0);
        it.step(t, j);
        assert_eq!(it.a, 0.0);
        // A real remaining acceleration is kept.
        let mut it = Integrator::new(0.0, 0.0, a0, 1.0);
        it.step(1.0, j);
        assert!((it.a - 0.4).abs() < 1e-15);
        let (p, v, _) = it.state();
        assert!((v - 0.55).abs() < 1e-15 && (p - (0.35 - 0.05)).abs() < 1e-15);
    }
}
