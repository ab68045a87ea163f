//! Why an example cannot start: every message says what is wrong and what to do.

use rmd_traj::TrajectoryError;

/// Why an example cannot start (bad options, a robot description that does not fit the
/// example's model, a motion that cannot be planned). Nothing has moved when one is returned.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DemoError {
    /// The robot description lacks a joint the example needs, or is invalid.
    #[error(transparent)]
    Robot(#[from] rmd_loop::robot::RobotError),
    /// Opening the robot failed.
    #[error(transparent)]
    Rig(#[from] rmd_rig::RigError),
    /// A joint the example commands in N*m has no torque constant.
    #[error(
        "joint {joint} has no torque_constant_nm_per_amp in the robot description, but the \
         example commands torques in N*m: add the motor's output torque constant (2.09 for an \
         RMD-X8 with its 1:9 gearbox)"
    )]
    NoTorqueConstant {
        /// The joint.
        joint: String,
    },
    /// A pose the example needs is out of the leg's reach.
    #[error("{what} is out of the leg's reach")]
    OutOfReach {
        /// What was asked for.
        what: String,
    },
    /// A motion could not be planned.
    #[error("cannot plan {what}: {source}")]
    Plan {
        /// What was planned.
        what: &'static str,
        /// Why not.
        source: TrajectoryError,
    },
    /// The planned step cycle leaves the leg's reach.
    #[error("the step cycle leaves the leg's reach at {t_s:.3} s (a shorter or lower step fits)")]
    CycleOutOfReach {
        /// When, s after the start of the cycle's approach.
        t_s: f64,
    },
    /// The planned step cycle needs a joint too close to (or beyond) its limit.
    #[error(
        "the step cycle needs {joint} at {angle_deg:.1} deg at {t_s:.3} s, outside \
         {low_deg:.0}..{high_deg:.0} deg (its limits with a {margin_deg} deg margin): choose \
         a step that stays inside them"
    )]
    CycleBeyondLimits {
        /// The joint.
        joint: &'static str,
        /// The angle it would need, degrees.
        angle_deg: f64,
        /// When, s after the start of the cycle's approach.
        t_s: f64,
        /// Lowest angle allowed, degrees.
        low_deg: f64,
        /// Highest angle allowed, degrees.
        high_deg: f64,
        /// The margin kept inside the limits, degrees.
        margin_deg: f64,
    },
    /// A `--waypoint` value is not four angles.
    #[error(
        "waypoint {number} ({text:?}): {problem}; give four angles in degrees, e.g. 0,-40,80,-40"
    )]
    Waypoint {
        /// Its number (from 1).
        number: usize,
        /// What was given.
        text: String,
        /// What is wrong with it.
        problem: String,
    },
    /// A waypoint is outside a joint's limits.
    #[error(
        "waypoint {number}: {joint} at {angle_deg} deg is outside its limits {min_deg}..{max_deg} deg"
    )]
    WaypointBeyondLimits {
        /// Its number (from 1).
        number: usize,
        /// The joint.
        joint: &'static str,
        /// The angle asked for, degrees.
        angle_deg: f64,
        /// Lowest angle, degrees.
        min_deg: f64,
        /// Highest angle, degrees.
        max_deg: f64,
    },
    /// A bad option value.
    #[error("{0}")]
    Usage(String),
}
