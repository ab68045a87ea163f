//! Brake pre-trajectory: brings an initial state that is outside the limits (or bound to leave
//! them) back inside, with at most two pieces, before the time-optimal profile starts.
//!
//! The rules follow the reference implementation (ruckig) so that durations agree: jerk towards
//! the limits until the acceleration is back inside (or until a velocity limit can be reached),
//! then, if needed, constant acceleration until the velocity is back inside. Piece times are
//! padded by [`PAD`] so the state ends strictly inside.

use crate::math::{max, min, sqrt};
use crate::profile::Phase;

/// Padding of the brake pieces.
pub(crate) const PAD: f64 = 2.2e-14;

/// Up to two brake pieces (zero durations when unused).
pub(crate) type Brake = [Phase; 2];

const NONE: Brake = [
    Phase {
        duration: 0.0,
        jerk: 0.0,
    },
    Phase {
        duration: 0.0,
        jerk: 0.0,
    },
];

#[inline]
fn v_after(v0: f64, a0: f64, j: f64, t: f64) -> f64 {
    v0 + t * (a0 + j * t / 2.0)
}

/// Mirrors a brake computed for the negated state and swapped limits.
fn negate(mut b: Brake) -> Brake {
    b[0].jerk = -b[0].jerk;
    b[1].jerk = -b[1].jerk;
    b
}

/// Replaces non-finite or negative piece times (degenerate limits) by "no brake".
fn sanitize(b: Brake) -> Brake {
    let ok = |t: f64| t.is_finite() && t >= 0.0;
    if ok(b[0].duration) && ok(b[1].duration) {
        b
    } else {
        NONE
    }
}

/// Brake for the position interface.
pub(crate) fn position_brake(
    v0: f64,
    a0: f64,
    v_max: f64,
    v_min: f64,
    a_max: f64,
    a_min: f64,
    j: f64,
) -> Brake {
    if !(j > 0.0) {
        return NONE;
    }
    let swing = a0 * a0 / (2.0 * j);
    let b = if a0 > a_max {
        acceleration_brake(v0, a0, v_max, v_min, a_max, a_min, j)
    } else if a0 < a_min {
        negate(acceleration_brake(
            -v0, -a0, -v_min, -v_max, -a_min, -a_max, j,
        ))
    } else if (v0 > v_max && v0 - swing > v_min) || (a0 > 0.0 && v0 + swing > v_max) {
        velocity_brake(v0, a0, v_max, v_min, a_min, j)
    } else if (v0 < v_min && v0 + swing < v_max) || (a0 < 0.0 && v0 - swing < v_min) {
        negate(velocity_brake(-v0, -a0, -v_min, -v_max, -a_max, j))
    } else {
        return NONE;
    };
    sanitize(b)
}

/// Brake for the velocity interface: only the acceleration is brought back.
pub(crate) fn velocity_brake_for_velocity_interface(
    a0: f64,
    a_max: f64,
    a_min: f64,
    j: f64,
) -> Brake {
    if !(j > 0.0) {
        return NONE;
    }
    let mut b = NONE;
    if a0 > a_max {
        b[0] = Phase {
            duration: (a0 - a_max) / j + PAD,
            jerk: -j,
        };
    } else if a0 < a_min {
        b[0] = Phase {
            duration: (a_min - a0) / j + PAD,
            jerk: j,
        };
    }
    sanitize(b)
}

/// `a0 > a_max`: ramp the acceleration down with −j.
fn acceleration_brake(
    v0: f64,
    a0: f64,
    v_max: f64,
    v_min: f64,
    a_max: f64,
    a_min: f64,
    j: f64,
) -> Brake {
    let t_to_a_max = (a0 - a_max) / j;
    let t_to_a_zero = a0 / j;
    let v_at_a_max = v_after(v0, a0, -j, t_to_a_max);
    let v_at_a_zero = v_after(v0, a0, -j, t_to_a_zero);
    let mut b = NONE;
    b[0].jerk = -j;
    if v_at_a_zero > v_max {
        return velocity_brake(v0, a0, v_max, v_min, a_min, j);
    } else if v_at_a_max < v_min {
        let t_to_v_min = -(v_at_a_max - v_min) / a_max;
        let t_to_v_max = -a_max / (2.0 * j) - (v_at_a_max - v_max) / a_max;
        b[0].duration = t_to_a_max + PAD;
        b[1].duration = max(min(t_to_v_min, t_to_v_max - PAD), 0.0);
    } else {
        b[0].duration = t_to_a_max + PAD;
    }
    b
}

/// The velocity is (or will be) above `v_max`: jerk −j, possibly followed by constant `a_min`.
fn velocity_brake(v0: f64, a0: f64, v_max: f64, v_min: f64, a_min: f64, j: f64) -> Brake {
    let mut b = NONE;
    b[0].jerk = -j;
    let t_to_a_min = (a0 - a_min) / j;
    let t_to_v_max = a0 / j + sqrt(max(a0 * a0 + 2.0 * j * (v0 - v_max), 0.0)) / j;
    let t_to_v_min = a0 / j + sqrt(max(a0 * a0 / 2.0 + j * (v0 - v_min), 0.0)) / j;
    let t_min_to_v_max = min(t_to_v_max, t_to_v_min);
    if t_to_a_min < t_min_to_v_max {
        let v_at_a_min = v_after(v0, a0, -j, t_to_a_min);
        let t_to_v_max_with_constant = -(v_at_a_min - v_max) / a_min;
        let t_to_v_min_with_constant = a_min / (2.0 * j) - (v_at_a_min - v_min) / a_min;
        b[0].duration = max(t_to_a_min - PAD, 0.0);
        b[1].duration = max(min(t_to_v_max_with_constant, t_to_v_min_with_constant), 0.0);
    } else {
        b[0].duration = max(t_min_to_v_max - PAD, 0.0);
    }
    b
}
