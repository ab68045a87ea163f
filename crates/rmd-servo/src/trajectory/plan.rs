//! Planning a trajectory on the caller's thread: checks, point velocities, one jerk-limited
//! segment per joint and point, position limits along the way.

use rmd_loop::JointId;

use super::buffer::TrajectoryBuffer;
use super::segment::{Kin, Segment};
use super::{JointTrajectory, TrajectoryReceipt, TrajectoryStart};
use crate::config::{JointServo, ServoConfig};
use crate::error::TrajectoryRefusal;

/// The key of the acceleration limit, as refusals name it.
const ACCELERATION_KEY: &str = "servo configuration: max_acceleration_rad_s2";
use crate::state::ServoState;

/// Checks `trajectory` for `joints` (already resolved, distinct) and plans it into `buffer`
/// from the joints' states in `state`.
pub(crate) fn plan(
    trajectory: &JointTrajectory,
    joints: &[JointId],
    config: &ServoConfig,
    state: &ServoState,
    buffer: &mut TrajectoryBuffer,
) -> Result<TrajectoryReceipt, TrajectoryRefusal> {
    check_shape(trajectory, joints.len(), buffer)?;
    buffer.reset(joints, trajectory.points.len());
    buffer.start = trajectory.start;
    let mut receipt = TrajectoryReceipt {
        duration_s: 0.0,
        max_lateness_s: 0.0,
        latest: None,
    };
    for (column, &joint) in joints.iter().enumerate() {
        let servo = config.joint(joint);
        let from = state
            .joint(joint)
            .map(|s| s.planning_state())
            .unwrap_or(Kin::REST);
        let targets = targets(trajectory, column, servo, from)?;
        let mut t = 0.0;
        let mut here = from;
        for (point, (to, due)) in targets.into_iter().enumerate() {
            let segment =
                Segment::plan(here, to, due - t, &servo.limits, t, due).map_err(|error| {
                    TrajectoryRefusal::Plan {
                        joint: servo.name.clone(),
                        point,
                        error,
                    }
                })?;
            check_range(&segment, servo, point)?;
            t += segment.duration_s;
            let late = t - due;
            if late > receipt.max_lateness_s + 1e-9 {
                receipt.max_lateness_s = late;
                receipt.latest = Some((servo.name.clone(), point));
            }
            *buffer.segment_mut(point, column) = segment;
            here = to;
        }
        receipt.duration_s = receipt.duration_s.max(t);
    }
    Ok(receipt)
}

/// Sizes, times and the start time.
fn check_shape(
    trajectory: &JointTrajectory,
    joints: usize,
    buffer: &TrajectoryBuffer,
) -> Result<(), TrajectoryRefusal> {
    let points = trajectory.points.len();
    if joints == 0 {
        return Err(TrajectoryRefusal::NoJoints);
    }
    if points == 0 {
        return Err(TrajectoryRefusal::NoPoints);
    }
    if !buffer.fits(points, joints) {
        return Err(TrajectoryRefusal::TooManyPoints {
            points,
            max: buffer.max_points(joints),
        });
    }
    if let TrajectoryStart::AtLoopTime(t) = trajectory.start
        && !t.is_finite()
    {
        return Err(TrajectoryRefusal::StartNotFinite(t));
    }
    for (i, p) in trajectory.points.iter().enumerate() {
        let arrays = [
            ("positions", Some(&p.positions)),
            ("velocities", p.velocities.as_ref()),
            ("accelerations", p.accelerations.as_ref()),
        ];
        for (field, values) in arrays {
            if let Some(values) = values
                && values.len() != joints
            {
                return Err(TrajectoryRefusal::LengthMismatch {
                    point: i,
                    field,
                    len: values.len(),
                    joints,
                });
            }
        }
        if i > 0 && p.time_from_start <= trajectory.points[i - 1].time_from_start {
            return Err(TrajectoryRefusal::TimeNotIncreasing { point: i });
        }
    }
    Ok(())
}

/// Every point's target state and due time for one column, checked against the joint's limits.
fn targets(
    trajectory: &JointTrajectory,
    column: usize,
    servo: &JointServo,
    from: Kin,
) -> Result<Vec<(Kin, f64)>, TrajectoryRefusal> {
    let l = &servo.limits;
    let n = trajectory.points.len();
    let value = |point: usize,
                 field: &'static str,
                 v: f64,
                 min: f64,
                 max: f64,
                 keys: (&'static str, &'static str)| {
        if !v.is_finite() {
            return Err(TrajectoryRefusal::NotFinite {
                joint: servo.name.clone(),
                point,
                field,
                value: v,
            });
        }
        if !(v >= min && v <= max) {
            return Err(TrajectoryRefusal::OutOfLimit {
                joint: servo.name.clone(),
                point,
                field,
                value: v,
                min,
                max,
                key: if v < min { keys.0 } else { keys.1 },
            });
        }
        Ok(v)
    };
    let positions = trajectory
        .points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            value(
                i,
                "positions",
                p.positions[column],
                l.position_min_rad,
                l.position_max_rad,
                l.position_keys(),
            )
        })
        .collect::<Result<Vec<_>, _>>()?;
    let times: Vec<f64> = trajectory
        .points
        .iter()
        .map(|p| p.time_from_start.as_secs_f64())
        .collect();
    let mut out = Vec::with_capacity(n);
    for (i, point) in trajectory.points.iter().enumerate() {
        let vmax = l.max_velocity_rad_s;
        let amax = l.max_acceleration_rad_s2;
        let v = match &point.velocities {
            Some(v) => value(
                i,
                "velocities",
                v[column],
                -vmax,
                vmax,
                (
                    l.velocity_from.velocity_key(),
                    l.velocity_from.velocity_key(),
                ),
            )?,
            None if i + 1 == n => 0.0,
            None => {
                let (p_prev, t_prev) = if i == 0 {
                    (from.p, 0.0)
                } else {
                    (positions[i - 1], times[i - 1])
                };
                chosen_velocity(
                    (p_prev, t_prev),
                    (positions[i], times[i]),
                    (positions[i + 1], times[i + 1]),
                )
                .clamp(-vmax, vmax)
            }
        };
        let a = match &point.accelerations {
            Some(a) => value(
                i,
                "accelerations",
                a[column],
                -amax,
                amax,
                (ACCELERATION_KEY, ACCELERATION_KEY),
            )?,
            None => 0.0,
        };
        if i + 1 == n && (v != 0.0 || a != 0.0) {
            return Err(TrajectoryRefusal::EndsMoving {
                joint: servo.name.clone(),
            });
        }
        out.push((
            Kin {
                p: positions[i],
                v,
                a,
            },
            times[i],
        ));
    }
    Ok(out)
}

/// The velocity at a point between two others: zero where the motion turns round, else the
/// harmonic mean of the two slopes (never beyond either: no overshoot between the points).
fn chosen_velocity(prev: (f64, f64), here: (f64, f64), next: (f64, f64)) -> f64 {
    let slope = |a: (f64, f64), b: (f64, f64)| {
        let dt = b.1 - a.1;
        if dt > 0.0 {
            Some((b.0 - a.0) / dt)
        } else {
            None
        }
    };
    match (slope(prev, here), slope(here, next)) {
        (Some(s1), Some(s2)) if s1 * s2 > 0.0 => 2.0 * s1 * s2 / (s1 + s2),
        _ => 0.0,
    }
}

/// The segment must stay within the position limits; the first may start outside them (the
/// joint is brought back in), but not go further out.
fn check_range(
    segment: &Segment,
    servo: &JointServo,
    point: usize,
) -> Result<(), TrajectoryRefusal> {
    let l = &servo.limits;
    let (lo, hi) = segment.position_range();
    let min = l.position_min_rad.min(segment.from.p);
    let max = l.position_max_rad.max(segment.from.p);
    // A tolerance for rounding in the integration of the pieces.
    let tolerance = 1e-9;
    let reached = if lo < min - tolerance {
        lo
    } else if hi > max + tolerance {
        hi
    } else {
        return Ok(());
    };
    Err(TrajectoryRefusal::LeavesPositionLimits {
        joint: servo.name.clone(),
        point,
        reached,
        min: l.position_min_rad,
        max: l.position_max_rad,
    })
}

/// The same check on the loop thread, without building an error.
pub(crate) fn within_limits(segment: &Segment, servo: &JointServo) -> bool {
    let (lo, hi) = segment.position_range();
    let l = &servo.limits;
    lo >= l.position_min_rad.min(segment.from.p) - 1e-9
        && hi <= l.position_max_rad.max(segment.from.p) + 1e-9
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chosen_velocities_follow_the_slopes_and_stop_at_turns() {
        // Rising then rising faster: between the slopes 1 and 3, closer to the smaller.
        let v = chosen_velocity((0.0, 0.0), (1.0, 1.0), (4.0, 2.0));
        assert!((v - 1.5).abs() < 1e-12, "{v}");
        // A peak: zero.
        assert_eq!(chosen_velocity((0.0, 0.0), (1.0, 1.0), (0.5, 2.0)), 0.0);
        // A flat stretch: zero.
        assert_eq!(chosen_velocity((1.0, 0.0), (1.0, 1.0), (2.0, 2.0)), 0.0);
        // No time before the point: zero.
        assert_eq!(chosen_velocity((0.0, 0.0), (1.0, 0.0), (2.0, 1.0)), 0.0);
    }
}
