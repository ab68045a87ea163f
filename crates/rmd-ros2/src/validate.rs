//! Turning network messages into port inputs: every check a message must pass before anything
//! of it reaches the robot, each failure a typed [`MessageRejection`].
//!
//! A message is taken whole or not at all: one bad value rejects the message, and the robot
//! keeps what it had.

use std::time::Duration;

use crate::kind::RejectionKind;
use crate::msg;
use crate::port::{JointIndex, JointInfo, Setpoint, Setpoints, Trajectory, TrajectoryPoint};

/// Which array of a message a rejection is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MessageField {
    /// `position` / `positions`.
    Position,
    /// `velocity` / `velocities`.
    Velocity,
    /// `effort`.
    Effort,
    /// `accelerations`.
    Acceleration,
}

impl std::fmt::Display for MessageField {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            MessageField::Position => "position",
            MessageField::Velocity => "velocity",
            MessageField::Effort => "effort",
            MessageField::Acceleration => "acceleration",
        })
    }
}

/// Why a message from the network was not passed to the robot.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MessageRejection {
    /// The message names no joints, or carries no values or no points.
    #[error("empty {0}: send at least one joint with at least one value")]
    Empty(&'static str),
    /// A name that is not one of the robot's joints.
    #[error("unknown joint {name:?}: use the names published on joint_states")]
    UnknownJoint {
        /// The name as received.
        name: String,
    },
    /// A joint named twice.
    #[error("joint {name:?} appears twice: name each joint once per message")]
    DuplicateJoint {
        /// The repeated name.
        name: String,
    },
    /// An array whose length is neither zero nor the number of joints.
    #[error(
        "{field} has {got} values for {expected} joints: give one value per joint or leave it empty"
    )]
    LengthMismatch {
        /// The array.
        field: MessageField,
        /// The number of joints named.
        expected: usize,
        /// The array's length.
        got: usize,
    },
    /// An array the configured command mode needs is empty.
    #[error("{field} is required by the node's command mode but the message has none")]
    MissingField {
        /// The missing array.
        field: MessageField,
    },
    /// NaN or infinity.
    #[error("{field} of joint {joint:?} is {value}: send finite numbers only")]
    NotFinite {
        /// The joint.
        joint: String,
        /// The array.
        field: MessageField,
        /// The value (NaN or ±inf).
        value: f64,
    },
    /// A value outside the joint's limit.
    #[error(
        "{field} {value} of joint {joint:?} is outside its limit {limit}: stay within the joint limits"
    )]
    OutOfLimit {
        /// The joint.
        joint: String,
        /// The array.
        field: MessageField,
        /// The value received.
        value: f64,
        /// The limit it broke (the bound for positions, the magnitude for the others).
        limit: f64,
    },
    /// A trajectory point not later than the one before it.
    #[error(
        "trajectory point {index} is not later than the point before it: times must strictly increase"
    )]
    TimeNotIncreasing {
        /// The point's index.
        index: usize,
    },
    /// A negative `time_from_start` or one with nanoseconds out of range.
    #[error(
        "trajectory point {index} has an invalid time_from_start: use sec >= 0 and nanosec < 1e9"
    )]
    BadTime {
        /// The point's index.
        index: usize,
    },
    /// A field the node does not forward.
    #[error("{0} in trajectory points is not supported: leave it empty")]
    Unsupported(MessageField),
}

impl MessageRejection {
    /// The counter this rejection goes to.
    pub fn kind(&self) -> RejectionKind {
        match self {
            MessageRejection::Empty(_) => RejectionKind::Empty,
            MessageRejection::UnknownJoint { .. } => RejectionKind::UnknownJoint,
            MessageRejection::DuplicateJoint { .. } => RejectionKind::DuplicateJoint,
            MessageRejection::LengthMismatch { .. } | MessageRejection::MissingField { .. } => {
                RejectionKind::LengthMismatch
            }
            MessageRejection::NotFinite { .. } => RejectionKind::NotFinite,
            MessageRejection::OutOfLimit { .. } => RejectionKind::OutOfLimit,
            MessageRejection::TimeNotIncreasing { .. } | MessageRejection::BadTime { .. } => {
                RejectionKind::BadTime
            }
            MessageRejection::Unsupported(_) => RejectionKind::Unsupported,
        }
    }
}

/// How `joint_commands` messages become setpoints.
///
/// ROS 2 `JointState` commands do not say which interface they command: the bridges fill
/// arrays differently (see `docs/ros2.md`). `Auto` suits senders that fill only the arrays
/// they command (`joint_state_topic_hardware_interface`, hand-written clients); a fixed mode
/// suits `topic_based_ros2_control`, which always fills all three.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum CommandMode {
    /// Position if the message has positions (velocity and effort, if given, are
    /// feed-forward), else velocity (effort as feed-forward), else effort.
    #[default]
    Auto,
    /// Positions required; velocity and effort, if given, are feed-forward.
    Position,
    /// Velocities required; effort, if given, is feed-forward; positions are not used.
    Velocity,
    /// Efforts required; positions and velocities are not used.
    Effort,
}

/// Checks messages against the robot's joints and limits.
#[derive(Clone, Debug)]
pub struct Validator {
    joints: Vec<JointInfo>,
    mode: CommandMode,
}

impl Validator {
    /// A validator for these joints, reading `joint_commands` in `mode`.
    pub fn new(joints: &[JointInfo], mode: CommandMode) -> Self {
        Validator {
            joints: joints.to_vec(),
            mode,
        }
    }

    /// The joints it checks against.
    pub fn joints(&self) -> &[JointInfo] {
        &self.joints
    }

    /// Maps names to joint indices: known, distinct, at least one.
    fn resolve(
        &self,
        names: &[String],
        what: &'static str,
    ) -> Result<Vec<JointIndex>, MessageRejection> {
        if names.is_empty() {
            return Err(MessageRejection::Empty(what));
        }
        let mut out: Vec<JointIndex> = Vec::with_capacity(names.len());
        for name in names {
            let index = self
                .joints
                .iter()
                .position(|j| &j.name == name)
                .map(JointIndex)
                .ok_or_else(|| MessageRejection::UnknownJoint { name: name.clone() })?;
            if out.contains(&index) {
                return Err(MessageRejection::DuplicateJoint { name: name.clone() });
            }
            out.push(index);
        }
        Ok(out)
    }

    fn check_value(
        &self,
        joint: JointIndex,
        field: MessageField,
        value: f64,
    ) -> Result<(), MessageRejection> {
        let info = &self.joints[joint.0];
        if !value.is_finite() {
            return Err(MessageRejection::NotFinite {
                joint: info.name.clone(),
                field,
                value,
            });
        }
        let out_of_limit = |limit: f64| MessageRejection::OutOfLimit {
            joint: info.name.clone(),
            field,
            value,
            limit,
        };
        let l = &info.limits;
        match field {
            MessageField::Position => {
                if let Some(min) = l.position_min_rad.filter(|&min| value < min) {
                    return Err(out_of_limit(min));
                }
                if let Some(max) = l.position_max_rad.filter(|&max| value > max) {
                    return Err(out_of_limit(max));
                }
            }
            MessageField::Velocity => {
                if let Some(max) = l.velocity_max_rad_s.filter(|&max| value.abs() > max) {
                    return Err(out_of_limit(max));
                }
            }
            MessageField::Effort => {
                if let Some(max) = l.effort_max_nm.filter(|&max| value.abs() > max) {
                    return Err(out_of_limit(max));
                }
            }
            MessageField::Acceleration => {}
        }
        Ok(())
    }

    /// Checks an array's length (zero or one per joint) and that every value is finite.
    /// Returns whether it has values.
    fn check_array(
        &self,
        joints: &[JointIndex],
        field: MessageField,
        values: &[f64],
    ) -> Result<bool, MessageRejection> {
        if values.is_empty() {
            return Ok(false);
        }
        if values.len() != joints.len() {
            return Err(MessageRejection::LengthMismatch {
                field,
                expected: joints.len(),
                got: values.len(),
            });
        }
        for (&joint, &value) in joints.iter().zip(values) {
            if !value.is_finite() {
                return Err(MessageRejection::NotFinite {
                    joint: self.joints[joint.0].name.clone(),
                    field,
                    value,
                });
            }
        }
        Ok(true)
    }

    /// A `joint_commands` message as setpoints.
    pub fn joint_command(&self, m: &msg::JointState) -> Result<Setpoints, MessageRejection> {
        let joints = self.resolve(&m.name, "joint command")?;
        let has_p = self.check_array(&joints, MessageField::Position, &m.position)?;
        let has_v = self.check_array(&joints, MessageField::Velocity, &m.velocity)?;
        let has_e = self.check_array(&joints, MessageField::Effort, &m.effort)?;
        let used = match self.mode {
            CommandMode::Auto if has_p => MessageField::Position,
            CommandMode::Auto if has_v => MessageField::Velocity,
            CommandMode::Auto if has_e => MessageField::Effort,
            CommandMode::Auto => return Err(MessageRejection::Empty("joint command")),
            CommandMode::Position => MessageField::Position,
            CommandMode::Velocity => MessageField::Velocity,
            CommandMode::Effort => MessageField::Effort,
        };
        let present = match used {
            MessageField::Position => has_p,
            MessageField::Velocity => has_v,
            _ => has_e,
        };
        if !present {
            return Err(MessageRejection::MissingField { field: used });
        }
        let value = |values: &[f64], i: usize, present: bool| if present { values[i] } else { 0.0 };
        let mut out = Vec::with_capacity(joints.len());
        for (i, &joint) in joints.iter().enumerate() {
            let p = value(&m.position, i, has_p);
            let v = value(&m.velocity, i, has_v);
            let e = value(&m.effort, i, has_e);
            // Limits apply to every value the setpoint carries (feed-forward included), and
            // only to those: an unused array's contents do not matter.
            let setpoint = match used {
                MessageField::Position => {
                    self.check_value(joint, MessageField::Position, p)?;
                    self.check_value(joint, MessageField::Velocity, v)?;
                    self.check_value(joint, MessageField::Effort, e)?;
                    Setpoint::Position {
                        position_rad: p,
                        velocity_ff_rad_s: v,
                        effort_ff_nm: e,
                    }
                }
                MessageField::Velocity => {
                    self.check_value(joint, MessageField::Velocity, v)?;
                    self.check_value(joint, MessageField::Effort, e)?;
                    Setpoint::Velocity {
                        velocity_rad_s: v,
                        effort_ff_nm: e,
                    }
                }
                _ => {
                    self.check_value(joint, MessageField::Effort, e)?;
                    Setpoint::Effort { effort_nm: e }
                }
            };
            out.push((joint, setpoint));
        }
        Ok(Setpoints {
            stamp: m.header.stamp.to_system_time(),
            joints: out,
        })
    }

    /// A `joint_trajectory` message as a trajectory.
    pub fn trajectory(&self, m: &msg::JointTrajectory) -> Result<Trajectory, MessageRejection> {
        let joints = self.resolve(&m.joint_names, "trajectory")?;
        if m.points.is_empty() {
            return Err(MessageRejection::Empty("trajectory (no points)"));
        }
        let mut points: Vec<TrajectoryPoint> = Vec::with_capacity(m.points.len());
        for (index, p) in m.points.iter().enumerate() {
            if !self.check_array(&joints, MessageField::Position, &p.positions)? {
                return Err(MessageRejection::MissingField {
                    field: MessageField::Position,
                });
            }
            let has_v = self.check_array(&joints, MessageField::Velocity, &p.velocities)?;
            let has_a = self.check_array(&joints, MessageField::Acceleration, &p.accelerations)?;
            if !p.effort.is_empty() {
                return Err(MessageRejection::Unsupported(MessageField::Effort));
            }
            for (i, &joint) in joints.iter().enumerate() {
                self.check_value(joint, MessageField::Position, p.positions[i])?;
                if has_v {
                    self.check_value(joint, MessageField::Velocity, p.velocities[i])?;
                }
            }
            let t = p.time_from_start;
            if t.sec < 0 || t.nanosec >= 1_000_000_000 {
                return Err(MessageRejection::BadTime { index });
            }
            let time_from_start = Duration::new(u64::from(t.sec.unsigned_abs()), t.nanosec);
            if points
                .last()
                .is_some_and(|prev| time_from_start <= prev.time_from_start)
            {
                return Err(MessageRejection::TimeNotIncreasing { index });
            }
            points.push(TrajectoryPoint {
                time_from_start,
                position_rad: p.positions.clone(),
                velocity_rad_s: has_v.then(|| p.velocities.clone()),
                acceleration_rad_s2: has_a.then(|| p.accelerations.clone()),
            });
        }
        Ok(Trajectory {
            start: m.header.stamp.to_system_time(),
            joints,
            points,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::port::JointLimits;

    fn joints() -> Vec<JointInfo> {
        let limits = JointLimits {
            position_min_rad: Some(-1.0),
            position_max_rad: Some(2.0),
            velocity_max_rad_s: Some(5.0),
            effort_max_nm: Some(3.0),
        };
        vec![
            JointInfo {
                name: "hip".into(),
                limits,
            },
            JointInfo {
                name: "knee".into(),
                limits,
            },
            JointInfo {
                name: "free".into(),
                limits: JointLimits::default(),
            },
        ]
    }

    fn v(mode: CommandMode) -> Validator {
        Validator::new(&joints(), mode)
    }

    fn cmd(names: &[&str], p: &[f64], vel: &[f64], e: &[f64]) -> msg::JointState {
        msg::JointState {
            header: msg::Header::default(),
            name: names.iter().map(|s| s.to_string()).collect(),
            position: p.to_vec(),
            velocity: vel.to_vec(),
            effort: e.to_vec(),
        }
    }

    fn point(t: f64, p: &[f64]) -> msg::JointTrajectoryPoint {
        msg::JointTrajectoryPoint {
            positions: p.to_vec(),
            time_from_start: msg::Duration {
                sec: t.trunc() as i32,
                nanosec: (t.fract() * 1e9).round() as u32,
            },
            ..Default::default()
        }
    }

    fn traj(names: &[&str], points: Vec<msg::JointTrajectoryPoint>) -> msg::JointTrajectory {
        msg::JointTrajectory {
            header: msg::Header::default(),
            joint_names: names.iter().map(|s| s.to_string()).collect(),
            points,
        }
    }

    #[test]
    fn position_command_maps_names_to_indices_with_feed_forward() {
        let s = v(CommandMode::Auto)
            .joint_command(&cmd(&["knee", "hip"], &[0.5, -0.5], &[1.0, 2.0], &[]))
            .unwrap();
        assert_eq!(
            s.joints(),
            &[
                (
                    JointIndex(1),
                    Setpoint::Position {
                        position_rad: 0.5,
                        velocity_ff_rad_s: 1.0,
                        effort_ff_nm: 0.0
                    }
                ),
                (
                    JointIndex(0),
                    Setpoint::Position {
                        position_rad: -0.5,
                        velocity_ff_rad_s: 2.0,
                        effort_ff_nm: 0.0
                    }
                ),
            ]
        );
        assert_eq!(s.stamp(), None);
    }

    #[test]
    fn auto_mode_picks_velocity_then_effort() {
        let s = v(CommandMode::Auto)
            .joint_command(&cmd(&["hip"], &[], &[1.5], &[0.25]))
            .unwrap();
        assert_eq!(
            s.joints()[0].1,
            Setpoint::Velocity {
                velocity_rad_s: 1.5,
                effort_ff_nm: 0.25
            }
        );
        let s = v(CommandMode::Auto)
            .joint_command(&cmd(&["free"], &[], &[], &[-7.0]))
            .unwrap();
        assert_eq!(s.joints()[0].1, Setpoint::Effort { effort_nm: -7.0 });
    }

    #[test]
    fn fixed_mode_uses_its_array_and_ignores_the_others_values() {
        // topic_based_ros2_control fills all three arrays; in velocity mode the (out of range)
        // position must not matter.
        let s = v(CommandMode::Velocity)
            .joint_command(&cmd(&["hip"], &[99.0], &[-2.0], &[0.0]))
            .unwrap();
        assert_eq!(
            s.joints()[0].1,
            Setpoint::Velocity {
                velocity_rad_s: -2.0,
                effort_ff_nm: 0.0
            }
        );
        let r = v(CommandMode::Effort).joint_command(&cmd(&["hip"], &[0.0], &[], &[]));
        assert_eq!(
            r,
            Err(MessageRejection::MissingField {
                field: MessageField::Effort
            })
        );
        assert_eq!(r.unwrap_err().kind(), RejectionKind::LengthMismatch);
    }

    #[test]
    fn command_stamp_is_passed_on() {
        let mut m = cmd(&["hip"], &[0.0], &[], &[]);
        m.header.stamp = msg::Time {
            sec: 10,
            nanosec: 5,
        };
        let s = v(CommandMode::Auto).joint_command(&m).unwrap();
        assert_eq!(
            s.stamp(),
            Some(std::time::UNIX_EPOCH + Duration::new(10, 5))
        );
    }

    #[test]
    fn empty_commands_are_rejected() {
        let v = v(CommandMode::Auto);
        let r = v.joint_command(&cmd(&[], &[], &[], &[])).unwrap_err();
        assert_eq!(r.kind(), RejectionKind::Empty);
        let r = v.joint_command(&cmd(&["hip"], &[], &[], &[])).unwrap_err();
        assert_eq!(r.kind(), RejectionKind::Empty);
    }

    #[test]
    fn unknown_and_duplicate_joints_are_rejected() {
        let v = v(CommandMode::Auto);
        assert_eq!(
            v.joint_command(&cmd(&["hip", "elbow"], &[0.0, 0.0], &[], &[])),
            Err(MessageRejection::UnknownJoint {
                name: "elbow".into()
            })
        );
        assert_eq!(
            v.joint_command(&cmd(&["hip", "hip"], &[0.0, 0.0], &[], &[])),
            Err(MessageRejection::DuplicateJoint { name: "hip".into() })
        );
    }

    #[test]
    fn mismatched_lengths_are_rejected() {
        let r = v(CommandMode::Auto).joint_command(&cmd(&["hip", "knee"], &[0.0], &[], &[]));
        assert_eq!(
            r,
            Err(MessageRejection::LengthMismatch {
                field: MessageField::Position,
                expected: 2,
                got: 1
            })
        );
        // A mismatch in an array the mode does not use still rejects: the sender is confused.
        let r = v(CommandMode::Position).joint_command(&cmd(&["hip"], &[0.0], &[1.0, 2.0], &[]));
        assert_eq!(r.unwrap_err().kind(), RejectionKind::LengthMismatch);
    }

    #[test]
    fn nan_and_infinity_are_rejected_in_any_array() {
        let v = v(CommandMode::Position);
        for m in [
            cmd(&["hip"], &[f64::NAN], &[], &[]),
            cmd(&["hip"], &[0.0], &[f64::INFINITY], &[]),
            cmd(&["free"], &[0.0], &[], &[f64::NEG_INFINITY]),
        ] {
            assert_eq!(
                v.joint_command(&m).unwrap_err().kind(),
                RejectionKind::NotFinite
            );
        }
    }

    #[test]
    fn out_of_limit_values_are_rejected_feed_forward_included() {
        let v = v(CommandMode::Auto);
        assert_eq!(
            v.joint_command(&cmd(&["hip"], &[2.5], &[], &[])),
            Err(MessageRejection::OutOfLimit {
                joint: "hip".into(),
                field: MessageField::Position,
                value: 2.5,
                limit: 2.0
            })
        );
        assert_eq!(
            v.joint_command(&cmd(&["hip"], &[-1.5], &[], &[]))
                .unwrap_err()
                .kind(),
            RejectionKind::OutOfLimit
        );
        assert_eq!(
            v.joint_command(&cmd(&["knee"], &[0.0], &[-5.5], &[]))
                .unwrap_err()
                .kind(),
            RejectionKind::OutOfLimit
        );
        assert_eq!(
            v.joint_command(&cmd(&["knee"], &[], &[], &[3.1]))
                .unwrap_err()
                .kind(),
            RejectionKind::OutOfLimit
        );
        // Limits are inclusive; a joint without limits takes any finite value.
        assert!(
            v.joint_command(&cmd(&["hip"], &[2.0], &[5.0], &[-3.0]))
                .is_ok()
        );
        assert!(v.joint_command(&cmd(&["free"], &[1e6], &[], &[])).is_ok());
    }

    #[test]
    fn trajectory_is_converted_with_times_and_optional_arrays() {
        let mut p1 = point(0.5, &[0.1, 0.2]);
        p1.velocities = vec![0.0, 1.0];
        let t = v(CommandMode::Auto)
            .trajectory(&traj(&["knee", "hip"], vec![p1, point(1.25, &[0.3, 0.4])]))
            .unwrap();
        assert_eq!(t.joints(), &[JointIndex(1), JointIndex(0)]);
        assert_eq!(t.start(), None);
        assert_eq!(t.points().len(), 2);
        assert_eq!(t.points()[0].time_from_start, Duration::from_millis(500));
        assert_eq!(t.points()[0].velocity_rad_s, Some(vec![0.0, 1.0]));
        assert_eq!(t.points()[1].velocity_rad_s, None);
        assert_eq!(t.points()[1].time_from_start, Duration::from_millis(1250));
        assert_eq!(t.points()[1].position_rad, vec![0.3, 0.4]);
    }

    #[test]
    fn trajectory_rejections() {
        let v = v(CommandMode::Auto);
        let kind = |m: msg::JointTrajectory| v.trajectory(&m).unwrap_err().kind();
        assert_eq!(kind(traj(&[], vec![point(1.0, &[])])), RejectionKind::Empty);
        assert_eq!(kind(traj(&["hip"], vec![])), RejectionKind::Empty);
        assert_eq!(
            kind(traj(&["hip", "nope"], vec![point(1.0, &[0.0, 0.0])])),
            RejectionKind::UnknownJoint
        );
        assert_eq!(
            kind(traj(&["hip"], vec![point(1.0, &[0.0, 0.0])])),
            RejectionKind::LengthMismatch
        );
        assert_eq!(
            kind(traj(&["hip"], vec![point(1.0, &[])])),
            RejectionKind::LengthMismatch
        );
        assert_eq!(
            kind(traj(&["hip"], vec![point(1.0, &[f64::NAN])])),
            RejectionKind::NotFinite
        );
        assert_eq!(
            kind(traj(&["hip"], vec![point(1.0, &[0.0]), point(2.0, &[3.0])])),
            RejectionKind::OutOfLimit
        );
        assert_eq!(
            v.trajectory(&traj(
                &["hip"],
                vec![point(1.0, &[0.0]), point(1.0, &[0.5])]
            )),
            Err(MessageRejection::TimeNotIncreasing { index: 1 })
        );
        assert_eq!(
            kind(traj(&["hip"], vec![point(2.0, &[0.0]), point(1.0, &[0.5])])),
            RejectionKind::BadTime
        );
        let mut bad = point(1.0, &[0.0]);
        bad.time_from_start.sec = -1;
        assert_eq!(kind(traj(&["hip"], vec![bad])), RejectionKind::BadTime);
        let mut bad = point(1.0, &[0.0]);
        bad.time_from_start.nanosec = 1_000_000_000;
        assert_eq!(kind(traj(&["hip"], vec![bad])), RejectionKind::BadTime);
        let mut eff = point(1.0, &[0.0]);
        eff.effort = vec![0.0];
        assert_eq!(kind(traj(&["hip"], vec![eff])), RejectionKind::Unsupported);
        let mut fast = point(1.0, &[0.0]);
        fast.velocities = vec![6.0];
        assert_eq!(kind(traj(&["hip"], vec![fast])), RejectionKind::OutOfLimit);
    }

    #[test]
    fn rejection_messages_tell_what_to_do() {
        let r = MessageRejection::UnknownJoint {
            name: "elbow".into(),
        };
        assert_eq!(
            r.to_string(),
            "unknown joint \"elbow\": use the names published on joint_states"
        );
    }
}
