//! One joint's motion between two trajectory points: a jerk-limited profile from rmd-traj,
//! stored compactly (start state and constant-jerk pieces) and sampled without allocation.

use rmd_traj::{AxisProfile, Input, MAX_BRAKE_PHASES, MAX_PHASES, TrajectoryError};

use crate::config::JointLimits;

/// Most constant-jerk pieces of one segment (brake and phases).
pub(crate) const MAX_PIECES: usize = MAX_PHASES + MAX_BRAKE_PHASES;

/// A kinematic state: position, velocity, acceleration (rad, rad/s, rad/s²).
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub(crate) struct Kin {
    pub(crate) p: f64,
    pub(crate) v: f64,
    pub(crate) a: f64,
}

impl Kin {
    pub(crate) const REST: Kin = Kin {
        p: 0.0,
        v: 0.0,
        a: 0.0,
    };

    /// Whether two states agree to within `tolerance` in every component.
    pub(crate) fn close_to(&self, other: &Kin, tolerance: f64) -> bool {
        (self.p - other.p).abs() <= tolerance
            && (self.v - other.v).abs() <= tolerance
            && (self.a - other.a).abs() <= tolerance
    }

    /// The state after `t` seconds of constant jerk `j`.
    fn after(&self, t: f64, j: f64) -> Kin {
        Kin {
            p: self.p + t * (self.v + t * (self.a / 2.0 + t * j / 6.0)),
            v: self.v + t * (self.a + t * j / 2.0),
            a: self.a + t * j,
        }
    }
}

#[derive(Copy, Clone, Debug, Default, PartialEq)]
struct Piece {
    duration: f64,
    jerk: f64,
}

/// One joint's motion to one point.
#[derive(Copy, Clone, Debug, PartialEq)]
pub(crate) struct Segment {
    /// When it starts, seconds from the trajectory's start (as planned).
    pub(crate) start_s: f64,
    /// How long it takes.
    pub(crate) duration_s: f64,
    /// When its point is due (`time_from_start`).
    pub(crate) due_s: f64,
    /// Where it starts.
    pub(crate) from: Kin,
    /// Where it ends: the point's state, exactly.
    pub(crate) to: Kin,
    n: u8,
    pieces: [Piece; MAX_PIECES],
}

impl Segment {
    pub(crate) const EMPTY: Segment = Segment {
        start_s: 0.0,
        duration_s: 0.0,
        due_s: 0.0,
        from: Kin::REST,
        to: Kin::REST,
        n: 0,
        pieces: [Piece {
            duration: 0.0,
            jerk: 0.0,
        }; MAX_PIECES],
    };

    /// Plans the jerk-limited motion from `from` to `to` taking `min_duration_s` or, when that is
    /// not feasible within `limits`, as little longer as feasible (rmd-traj, one axis; no
    /// allocation). `start_s` and `due_s` are recorded as given.
    pub(crate) fn plan(
        from: Kin,
        to: Kin,
        min_duration_s: f64,
        limits: &JointLimits,
        start_s: f64,
        due_s: f64,
    ) -> Result<Segment, TrajectoryError> {
        let mut input = Input::<1>::with_limits(
            [limits.max_velocity_rad_s],
            [limits.max_acceleration_rad_s2],
            [limits.max_jerk_rad_s3],
        );
        input.current_position = [from.p];
        input.current_velocity = [from.v];
        input.current_acceleration = [from.a];
        input.target_position = [to.p];
        input.target_velocity = [to.v];
        input.target_acceleration = [to.a];
        input.minimum_duration = Some(min_duration_s.max(0.0));
        let mut trajectory = rmd_traj::Trajectory::<1>::EMPTY;
        trajectory.calculate(&input)?;
        let profile: &AxisProfile = &trajectory.profiles()[0];
        let mut segment = Segment {
            start_s,
            duration_s: 0.0,
            due_s,
            from,
            to,
            ..Segment::EMPTY
        };
        for phase in profile.brake().chain(profile.phases()) {
            let slot = segment.n as usize;
            if slot < MAX_PIECES {
                segment.pieces[slot] = Piece {
                    duration: phase.duration,
                    jerk: phase.jerk,
                };
                segment.n += 1;
            }
        }
        // The common duration (a profile that ends early rests at the target until then).
        segment.duration_s = trajectory.duration().max(profile.duration());
        Ok(segment)
    }

    fn pieces(&self) -> &[Piece] {
        &self.pieces[..self.n as usize]
    }

    /// The state `t` seconds after the segment's start (the start state before 0, the point's
    /// state from the end on).
    pub(crate) fn state_at(&self, t: f64) -> Kin {
        if t.is_nan() || t <= 0.0 {
            return self.from;
        }
        if t >= self.duration_s {
            return self.to;
        }
        let mut state = self.from;
        let mut left = t;
        for piece in self.pieces() {
            if left <= piece.duration {
                return state.after(left, piece.jerk);
            }
            state = state.after(piece.duration, piece.jerk);
            left -= piece.duration;
        }
        // At rest at the target after the profile (before the common duration).
        state.after(left, 0.0)
    }

    /// The lowest and highest position the segment passes through.
    pub(crate) fn position_range(&self) -> (f64, f64) {
        let mut lo = self.from.p.min(self.to.p);
        let mut hi = self.from.p.max(self.to.p);
        let mut state = self.from;
        for piece in self.pieces() {
            // Velocity in the piece: v + a t + j t² / 2; the position has its extremes where it
            // crosses zero.
            let (a2, b, c) = (piece.jerk / 2.0, state.a, state.v);
            let mut consider = |t: f64| {
                if t > 0.0 && t < piece.duration {
                    let p = state.after(t, piece.jerk).p;
                    lo = lo.min(p);
                    hi = hi.max(p);
                }
            };
            if a2 == 0.0 {
                if b != 0.0 {
                    consider(-c / b);
                }
            } else {
                let disc = b * b - 4.0 * a2 * c;
                if disc >= 0.0 {
                    let root = disc.sqrt();
                    consider((-b + root) / (2.0 * a2));
                    consider((-b - root) / (2.0 * a2));
                }
            }
            state = state.after(piece.duration, piece.jerk);
            lo = lo.min(state.p);
            hi = hi.max(state.p);
        }
        (lo, hi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::LimitSource;

    const LIMITS: JointLimits = JointLimits {
        position_min_rad: f64::NEG_INFINITY,
        position_max_rad: f64::INFINITY,
        max_velocity_rad_s: 2.0,
        max_acceleration_rad_s2: 10.0,
        max_jerk_rad_s3: 100.0,
        max_effort_nm: 10.0,
        position_min_from: LimitSource::ServoConfiguration,
        position_max_from: LimitSource::ServoConfiguration,
        velocity_from: LimitSource::ServoConfiguration,
    };

    fn kin(p: f64, v: f64, a: f64) -> Kin {
        Kin { p, v, a }
    }

    #[test]
    fn a_feasible_segment_reaches_its_point_exactly_on_time_within_the_limits() {
        let to = kin(1.0, 0.5, 0.0);
        let s = Segment::plan(kin(0.0, 0.0, 0.0), to, 2.0, &LIMITS, 0.0, 2.0).unwrap();
        assert!((s.duration_s - 2.0).abs() < 1e-9, "{}", s.duration_s);
        // Integrating the pieces lands on the point.
        let end = s.state_at(s.duration_s - 1e-12);
        assert!(end.close_to(&to, 1e-6), "{end:?}");
        let mut t = 0.0;
        let mut previous = s.state_at(0.0);
        while t < s.duration_s {
            t += 1e-3;
            let x = s.state_at(t);
            assert!(x.v.abs() <= 2.0 + 1e-9 && x.a.abs() <= 10.0 + 1e-9, "{x:?}");
            // Continuous: no jump beyond what the limits allow in 1 ms.
            assert!((x.p - previous.p).abs() <= 2.0e-3 + 1e-9);
            previous = x;
        }
    }

    #[test]
    fn an_infeasible_time_is_stretched_to_the_fastest_motion() {
        // 3 rad at 2 rad/s need well over 1 s.
        let s = Segment::plan(
            kin(0.0, 0.0, 0.0),
            kin(3.0, 0.0, 0.0),
            1.0,
            &LIMITS,
            0.0,
            1.0,
        )
        .unwrap();
        assert!(s.duration_s > 1.5, "{}", s.duration_s);
        assert_eq!(s.state_at(10.0), kin(3.0, 0.0, 0.0));
    }

    #[test]
    fn the_position_range_includes_an_overshoot() {
        // Arriving at rest at 0 from +1 rad/s: the motion overshoots past 0 and comes back.
        let s = Segment::plan(
            kin(0.0, 1.5, 0.0),
            kin(0.0, 0.0, 0.0),
            0.0,
            &LIMITS,
            0.0,
            0.0,
        )
        .unwrap();
        let (lo, hi) = s.position_range();
        let mut seen = (0.0f64, 0.0f64);
        let mut t = 0.0;
        while t <= s.duration_s {
            let p = s.state_at(t).p;
            seen = (seen.0.min(p), seen.1.max(p));
            t += 1e-4;
        }
        assert!(hi > 0.05, "{hi}");
        assert!(
            (hi - seen.1).abs() < 1e-6 && (lo - seen.0).abs() < 1e-6,
            "{lo} {hi} {seen:?}"
        );
    }
}
