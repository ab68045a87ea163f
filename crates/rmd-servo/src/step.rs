//! One joint's step in each mode, as pure functions: the mode's own state and the measured
//! state in, what the mode asks of the law this tick ([`Demand`]) and the mode's next state
//! out. No side effects: the controller applies what they return.

use crate::config::JointServo;
use crate::law::{self, Demand};
use crate::trajectory::buffer::TrajectoryBuffer;
use crate::trajectory::segment::Kin;

/// Hold `position` at rest.
pub(crate) fn hold(position: f64) -> Demand {
    Demand {
        reference: Some(Kin {
            p: position,
            v: 0.0,
            a: 0.0,
        }),
        effort_ff: 0.0,
    }
}

/// Go to `position` with velocity feed-forward `velocity_ff` (the D term's target) and effort
/// feed-forward `effort_ff`.
pub(crate) fn position(position: f64, velocity_ff: f64, effort_ff: f64) -> Demand {
    Demand {
        reference: Some(Kin {
            p: position,
            v: velocity_ff,
            a: 0.0,
        }),
        effort_ff,
    }
}

/// Turn at `velocity`: the moving reference advances from `reference` by `velocity·dt`
/// (within the position limits and near the measured position `p`,
/// [`law::advance_velocity_reference`]). Returns the demand and the new reference.
pub(crate) fn velocity(
    joint: &JointServo,
    velocity: f64,
    effort_ff: f64,
    reference: f64,
    dt: f64,
    p: f64,
) -> (Demand, f64) {
    let (r, aim) = law::advance_velocity_reference(joint, reference, velocity, dt, p);
    let demand = Demand {
        reference: Some(Kin {
            p: r,
            v: aim,
            a: 0.0,
        }),
        effort_ff,
    };
    (demand, r)
}

/// Apply `effort`, N·m.
pub(crate) fn effort(effort: f64) -> Demand {
    Demand {
        reference: None,
        effort_ff: effort,
    }
}

/// Where a trajectory's joint is in one tick.
#[derive(Copy, Clone, Debug, PartialEq)]
pub(crate) struct TrajectoryStep {
    /// PD on the trajectory's reference, no feed-forward.
    pub(crate) demand: Demand,
    /// The point the joint heads for (where the next tick's search starts).
    pub(crate) point: usize,
    /// The trajectory is over: the joint is at its last point.
    pub(crate) finished: bool,
}

/// Follow `column` of `buffer` at loop time `now`, heading for `point` or a later one.
pub(crate) fn trajectory(
    buffer: &TrajectoryBuffer,
    column: usize,
    point: usize,
    shift: f64,
    now: f64,
) -> TrajectoryStep {
    let (k, point, finished) = sample(buffer, column, point, shift, now);
    TrajectoryStep {
        demand: Demand {
            reference: Some(k),
            effort_ff: 0.0,
        },
        point,
        finished,
    }
}

/// The state of `column` of `buffer` at loop time `now`, starting the search at `point`:
/// the state, the point it heads for, and whether the trajectory is over. `shift` delays the
/// segments after the first (its re-planned duration minus the planned one).
pub(crate) fn sample(
    buffer: &TrajectoryBuffer,
    column: usize,
    mut point: usize,
    shift: f64,
    now: f64,
) -> (Kin, usize, bool) {
    let t = now - buffer.started_at;
    loop {
        let s = buffer.segment(point, column);
        let local = t - s.start_s - if point > 0 { shift } else { 0.0 };
        if local < s.duration_s {
            return (s.state_at(local), point, false);
        }
        if point + 1 >= buffer.points() {
            return (s.to, point, true);
        }
        point += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::law::tests::joint;
    use crate::trajectory::segment::Segment;
    use rmd_loop::JointId;

    #[test]
    fn hold_position_and_effort_ask_what_their_setpoints_say() {
        let j = joint();
        let held = hold(0.4);
        assert_eq!(
            held.reference,
            Some(Kin {
                p: 0.4,
                v: 0.0,
                a: 0.0
            })
        );
        assert_eq!(held.effort_ff, 0.0);
        // 10 * (0.4 - 0.3) - 0.5 * 0.2
        assert!((held.effort(&j, 0.3, 0.2) - 0.9).abs() < 1e-12);
        let go = position(-0.2, 0.3, 0.1);
        assert_eq!(
            go.reference,
            Some(Kin {
                p: -0.2,
                v: 0.3,
                a: 0.0
            })
        );
        assert_eq!(go.effort_ff, 0.1);
        let push = effort(-1.25);
        assert_eq!((push.reference, push.effort_ff), (None, -1.25));
        assert_eq!(push.effort(&j, 0.9, -4.0), -1.25);
    }

    #[test]
    fn velocity_mode_moves_its_reference_and_stops_at_the_limit() {
        let j = joint();
        let (d, r) = velocity(&j, 1.0, 0.2, 0.0, 0.01, 0.0);
        assert!((r - 0.01).abs() < 1e-12);
        assert_eq!(d.reference.map(|k| (k.p, k.v)), Some((r, 1.0)));
        assert_eq!(d.effort_ff, 0.2);
        // On the upper limit going up: the reference rests there, aiming at zero velocity.
        let (d, r) = velocity(&j, 1.0, 0.0, 0.999, 0.01, 0.99);
        assert_eq!(r, 1.0);
        assert_eq!(d.reference.map(|k| k.v), Some(0.0));
    }

    #[test]
    fn a_trajectory_is_sampled_point_by_point_and_ends_at_its_last_point() {
        let j = joint();
        let from = Kin::REST;
        let mid = Kin {
            p: 0.2,
            v: 0.0,
            a: 0.0,
        };
        let end = Kin::REST;
        let mut buffer = TrajectoryBuffer::new(2, 1);
        buffer.reset(&[JointId::from_index(0)], 2);
        buffer.started_at = 10.0;
        *buffer.segment_mut(0, 0) = Segment::plan(from, mid, 0.5, &j.limits, 0.0, 0.5).unwrap();
        *buffer.segment_mut(1, 0) = Segment::plan(mid, end, 0.5, &j.limits, 0.5, 1.0).unwrap();
        let early = trajectory(&buffer, 0, 0, 0.0, 10.25);
        assert_eq!((early.point, early.finished), (0, false));
        let k = early.demand.reference.unwrap();
        assert!(k.p > 0.0 && k.p < 0.2 && k.v > 0.0, "{k:?}");
        assert_eq!(early.demand.effort_ff, 0.0);
        let later = trajectory(&buffer, 0, early.point, 0.0, 10.75);
        assert_eq!((later.point, later.finished), (1, false));
        assert!(later.demand.reference.unwrap().v < 0.0);
        let done = trajectory(&buffer, 0, later.point, 0.0, 12.0);
        assert!(done.finished);
        assert_eq!(done.demand.reference, Some(end));
    }
}
