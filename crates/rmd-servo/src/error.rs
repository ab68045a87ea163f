//! Why the servo refused a request (on the caller's thread: nothing refused reaches the loop).

use rmd_loop::JointId;

/// A request the servo refused. Every refusal is counted (per joint when it names one; see
/// [`JointCounters::rejected`](crate::JointCounters::rejected) and
/// [`ServoHandle::rejected_unattributed`](crate::ServoHandle::rejected_unattributed)).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ServoError {
    /// A joint name the robot does not have.
    #[error("no joint named `{name}` (the servo's joints: {known})")]
    UnknownJoint {
        /// The name asked for.
        name: String,
        /// The joints it has, comma-separated.
        known: String,
    },
    /// A joint id beyond the robot's joints.
    #[error("{id} is not a joint of this robot (it has {count} joints)")]
    UnknownJointId {
        /// The id.
        id: JointId,
        /// How many joints the robot has.
        count: usize,
    },
    /// NaN or an infinity.
    #[error("joint `{joint}`: {field} is {value}, not a finite number")]
    NotFinite {
        /// The joint.
        joint: String,
        /// Which value.
        field: &'static str,
        /// The value.
        value: f64,
    },
    /// A value beyond the joint's limits.
    #[error(
        "joint `{joint}`: {field} is {value}, outside the joint's limits [{}, {}] \
         ({key})", Short(*.min), Short(*.max)
    )]
    OutOfLimit {
        /// The joint.
        joint: String,
        /// Which value.
        field: &'static str,
        /// The value.
        value: f64,
        /// The lowest value allowed.
        min: f64,
        /// The highest value allowed.
        max: f64,
        /// Where the limit comes from and its key (`robot description:
        /// position_min_deg/position_max_deg`, `servo configuration: max_effort_nm`).
        key: &'static str,
    },
    /// The same joint twice in one batch or trajectory.
    #[error("joint `{joint}` appears twice in one request: name each joint once")]
    DuplicateJoint {
        /// The joint.
        joint: String,
    },
    /// The servo is disabled: setpoints and trajectories are refused until it is enabled.
    #[error("the servo is disabled: enable it first (ServoHandle::enable)")]
    Disabled,
    /// The servo was emergency-stopped: its loop ends; nothing more is taken.
    #[error("the servo was emergency-stopped: its loop has ended, start a new one")]
    EStopped,
    /// The servo's loop has ended.
    #[error("the servo's loop has ended: nothing more is taken")]
    Stopped,
    /// The queue to the loop thread is full: the loop is not taking messages (not started yet,
    /// or stalled).
    #[error(
        "the servo's queue is full ({capacity} messages waiting): the loop thread is not taking \
         them (is the loop running?); send fewer messages or raise servo.queue_capacity"
    )]
    QueueFull {
        /// The queue's capacity.
        capacity: usize,
    },
    /// Every trajectory buffer is in use (planned, waiting or running).
    #[error(
        "all {count} trajectory buffers are in use: wait for a trajectory to finish, or raise \
         servo.trajectory_buffers"
    )]
    NoTrajectoryBuffer {
        /// How many buffers the servo has.
        count: usize,
    },
    /// A trajectory is planned from the joints' current state, which the servo publishes once
    /// its loop runs.
    #[error("the servo has not published a state yet (its loop has not started): try again")]
    NoState,
    /// The trajectory cannot be followed as given.
    #[error("trajectory refused: {0}")]
    Trajectory(#[from] TrajectoryRefusal),
}

impl ServoError {
    /// The joint the refusal is about, if it names one of the robot's joints.
    pub fn joint(&self) -> Option<&str> {
        match self {
            ServoError::NotFinite { joint, .. }
            | ServoError::OutOfLimit { joint, .. }
            | ServoError::DuplicateJoint { joint } => Some(joint),
            ServoError::Trajectory(t) => t.joint(),
            _ => None,
        }
    }
}

/// Why a trajectory cannot be followed as given.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TrajectoryRefusal {
    /// No joint named.
    #[error("it names no joint")]
    NoJoints,
    /// No point.
    #[error("it has no point")]
    NoPoints,
    /// More points than a trajectory buffer holds.
    #[error("it has {points} points, at most {max} fit (servo.max_trajectory_points)")]
    TooManyPoints {
        /// Its points.
        points: usize,
        /// The most allowed.
        max: usize,
    },
    /// A point's array does not have one value per joint.
    #[error("point {point}: {field} has {len} values for {joints} joints")]
    LengthMismatch {
        /// The point.
        point: usize,
        /// Which array.
        field: &'static str,
        /// Its length.
        len: usize,
        /// How many joints the trajectory names.
        joints: usize,
    },
    /// Point times must increase strictly.
    #[error("point {point}: time_from_start does not come after the previous point's")]
    TimeNotIncreasing {
        /// The point.
        point: usize,
    },
    /// A start time that is not a finite number.
    #[error("the start time is {0}, not a finite number")]
    StartNotFinite(f64),
    /// A value is NaN or an infinity.
    #[error("joint `{joint}`, point {point}: {field} is {value}, not a finite number")]
    NotFinite {
        /// The joint.
        joint: String,
        /// The point.
        point: usize,
        /// Which value.
        field: &'static str,
        /// The value.
        value: f64,
    },
    /// A value beyond the joint's limits.
    #[error(
        "joint `{joint}`, point {point}: {field} is {value}, outside the joint's limits \
         [{}, {}] ({key})",
        Short(*.min),
        Short(*.max)
    )]
    OutOfLimit {
        /// The joint.
        joint: String,
        /// The point.
        point: usize,
        /// Which value.
        field: &'static str,
        /// The value.
        value: f64,
        /// The lowest value allowed.
        min: f64,
        /// The highest value allowed.
        max: f64,
        /// Where the limit comes from and its key (`robot description:
        /// position_min_deg/position_max_deg`, `servo configuration: max_effort_nm`).
        key: &'static str,
    },
    /// The last point must be at rest (the joint holds it afterwards).
    #[error(
        "joint `{joint}`: the last point has a velocity or acceleration; a trajectory must end \
         at rest (the joint holds its last point)"
    )]
    EndsMoving {
        /// The joint.
        joint: String,
    },
    /// The jerk-limited planner found no motion to the point.
    #[error("joint `{joint}`, point {point}: no jerk-limited motion reaches it: {error}")]
    Plan {
        /// The joint.
        joint: String,
        /// The point.
        point: usize,
        /// The planner's error.
        error: rmd_traj::TrajectoryError,
    },
    /// The motion between two points leaves the position limits.
    #[error(
        "joint `{joint}`: on its way to point {point} the motion reaches {} rad, beyond \
         the position limits [{}, {}]: add points, or lower velocities at the points",
        Short(*.reached),
        Short(*.min),
        Short(*.max)
    )]
    LeavesPositionLimits {
        /// The joint.
        joint: String,
        /// The point the motion goes to.
        point: usize,
        /// The position reached beyond a limit.
        reached: f64,
        /// The lower limit.
        min: f64,
        /// The upper limit.
        max: f64,
    },
}

impl TrajectoryRefusal {
    /// The joint the refusal is about, if any.
    pub fn joint(&self) -> Option<&str> {
        match self {
            TrajectoryRefusal::NotFinite { joint, .. }
            | TrajectoryRefusal::OutOfLimit { joint, .. }
            | TrajectoryRefusal::EndsMoving { joint }
            | TrajectoryRefusal::Plan { joint, .. }
            | TrajectoryRefusal::LeavesPositionLimits { joint, .. } => Some(joint),
            _ => None,
        }
    }
}

/// A limit as a person reads it: at most six decimals, no trailing zeros (`0.087266` for five
/// degrees in radians, `-0.5` as it is, `inf` for none).
struct Short(f64);

impl core::fmt::Display for Short {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let v = self.0;
        if !v.is_finite() || v == v.trunc() {
            return write!(f, "{v}");
        }
        let text = format!("{v:.6}");
        f.write_str(text.trim_end_matches('0').trim_end_matches('.'))
    }
}
