//! [`RobotPort`]: what the node needs from a robot, and the validated inputs it hands it.
//!
//! The node never talks to motors. It reads samples and diagnostics from a port and gives it
//! setpoints, trajectories and enable / estop requests that have passed validation (see
//! [`crate::Validator`]); the port forwards them (for a real robot: into the real-time loop's
//! lock-free mailbox). All values are SI: rad, rad/s, rad/s², N·m, °C, V.

use std::time::{Duration, SystemTime};

/// Limits of one joint, each absent when the robot description gives none.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct JointLimits {
    /// Lowest allowed position, rad.
    pub position_min_rad: Option<f64>,
    /// Highest allowed position, rad.
    pub position_max_rad: Option<f64>,
    /// Largest allowed speed (absolute velocity), rad/s.
    pub velocity_max_rad_s: Option<f64>,
    /// Largest allowed absolute effort, N·m.
    pub effort_max_nm: Option<f64>,
}

/// A joint as the network sees it: its name (the one in `joint_states`) and its limits.
#[derive(Clone, Debug, PartialEq)]
pub struct JointInfo {
    /// The joint's name, unique within the robot.
    pub name: String,
    /// Its limits; commands outside them are rejected before they reach the port.
    pub limits: JointLimits,
}

/// Index of a joint in [`RobotPort::joints`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct JointIndex(pub usize);

/// One sample of every joint, in the order of [`RobotPort::joints`].
#[derive(Clone, Debug, PartialEq)]
pub struct RobotState {
    /// When the sample was taken (wall-clock time, as ROS stamps are).
    pub stamp: SystemTime,
    /// Positions, rad.
    pub position_rad: Vec<f64>,
    /// Velocities, rad/s.
    pub velocity_rad_s: Vec<f64>,
    /// Efforts, N·m.
    pub effort_nm: Vec<f64>,
}

/// Timing of the real-time loop, as far as the port knows it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LoopTiming {
    /// The loop's period.
    pub period: Duration,
    /// Cycles run so far.
    pub cycles: u64,
    /// Cycles that missed their deadline.
    pub deadline_misses: u64,
    /// Requests whose reply did not arrive in time.
    pub missing_replies: u64,
    /// Median wake-up lateness, when measured.
    pub wake_latency_p50: Option<Duration>,
    /// 99th percentile wake-up lateness, when measured.
    pub wake_latency_p99: Option<Duration>,
    /// Largest wake-up lateness, when measured.
    pub wake_latency_max: Option<Duration>,
}

/// Health of one motor.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MotorDiagnostics {
    /// The joint the motor drives.
    pub joint: String,
    /// How the motor is addressed (e.g. `can0:0x141`).
    pub hardware_id: String,
    /// Temperature, °C.
    pub temperature_c: Option<f64>,
    /// Supply voltage, V.
    pub voltage_v: Option<f64>,
    /// Active faults, each as a short text (empty: none).
    pub faults: Vec<String>,
}

/// Everything the node publishes on `diagnostics` about the robot.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RobotDiagnostics {
    /// The loop's timing.
    pub timing: LoopTiming,
    /// Whether the robot is enabled (not estopped).
    pub enabled: bool,
    /// One entry per motor.
    pub motors: Vec<MotorDiagnostics>,
}

/// What one joint is told to do.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Setpoint {
    /// Go to `position_rad`; `velocity_ff_rad_s` and `effort_ff_nm` are feed-forward terms.
    Position {
        /// Target position, rad.
        position_rad: f64,
        /// Velocity feed-forward, rad/s.
        velocity_ff_rad_s: f64,
        /// Effort feed-forward, N·m.
        effort_ff_nm: f64,
    },
    /// Turn at `velocity_rad_s`, with an effort feed-forward.
    Velocity {
        /// Target velocity, rad/s.
        velocity_rad_s: f64,
        /// Effort feed-forward, N·m.
        effort_ff_nm: f64,
    },
    /// Apply `effort_nm`.
    Effort {
        /// Target effort, N·m.
        effort_nm: f64,
    },
}

/// Validated setpoints for some of the robot's joints (each joint at most once, every value
/// finite and within the joint's limits). Only a [`crate::Validator`] makes them.
#[derive(Clone, Debug, PartialEq)]
pub struct Setpoints {
    pub(crate) stamp: Option<SystemTime>,
    pub(crate) joints: Vec<(JointIndex, Setpoint)>,
}

impl Setpoints {
    /// The command's stamp (its header's), if it had one.
    pub fn stamp(&self) -> Option<SystemTime> {
        self.stamp
    }

    /// The joints and what each is to do, in the order of the message.
    pub fn joints(&self) -> &[(JointIndex, Setpoint)] {
        &self.joints
    }
}

/// One validated trajectory point for the trajectory's joints.
#[derive(Clone, Debug, PartialEq)]
pub struct TrajectoryPoint {
    /// When to be there, from the trajectory's start.
    pub time_from_start: Duration,
    /// Positions, rad, one per trajectory joint.
    pub position_rad: Vec<f64>,
    /// Velocities, rad/s, one per trajectory joint, if given.
    pub velocity_rad_s: Option<Vec<f64>>,
    /// Accelerations, rad/s², one per trajectory joint, if given.
    pub acceleration_rad_s2: Option<Vec<f64>>,
}

/// A validated trajectory: distinct known joints, at least one point, strictly increasing
/// times, finite values within the limits. Only a [`crate::Validator`] makes them.
#[derive(Clone, Debug, PartialEq)]
pub struct Trajectory {
    pub(crate) start: Option<SystemTime>,
    pub(crate) joints: Vec<JointIndex>,
    pub(crate) points: Vec<TrajectoryPoint>,
}

impl Trajectory {
    /// When the trajectory starts; `None` means on receipt.
    pub fn start(&self) -> Option<SystemTime> {
        self.start
    }

    /// The joints the points' arrays refer to.
    pub fn joints(&self) -> &[JointIndex] {
        &self.joints
    }

    /// The points, in strictly increasing time.
    pub fn points(&self) -> &[TrajectoryPoint] {
        &self.points
    }
}

/// The enable / estop input.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Enable {
    /// Motors may follow setpoints and trajectories.
    Enabled,
    /// Emergency stop: the robot stops and ignores setpoints until enabled again.
    Estop,
}

/// Why a port refused a validated input (nothing about the input itself was wrong).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PortError {
    /// The queue to the real-time loop is full; the input was dropped.
    #[error("the robot's command queue is full; send commands at a lower rate")]
    QueueFull,
    /// The robot is in emergency stop; enable it first.
    #[error("the robot is in emergency stop; publish true on the enable topic first")]
    Estopped,
    /// The robot's loop is not running.
    #[error("the robot's control loop is not running: {0}")]
    NotRunning(String),
}

/// The robot as the ROS 2 node sees it.
///
/// The node calls every method from its one DDS thread (never from a real-time thread), so an
/// implementation may take `&mut self` for non-blocking queue ends. No method may block for long:
/// each call delays publishing and command handling.
pub trait RobotPort: Send + 'static {
    /// The joints, in the order of every array the port takes or gives. Constant while the
    /// node runs.
    fn joints(&self) -> &[JointInfo];

    /// The newest sample, or `None` before the first one.
    fn latest_state(&mut self) -> Option<RobotState>;

    /// The current diagnostics.
    fn diagnostics(&mut self) -> RobotDiagnostics;

    /// New setpoints for some joints (the others keep theirs).
    fn send_setpoints(&mut self, setpoints: &Setpoints) -> Result<(), PortError>;

    /// A trajectory to follow, replacing any trajectory being followed.
    fn send_trajectory(&mut self, trajectory: &Trajectory) -> Result<(), PortError>;

    /// Enable the robot, or stop it.
    fn set_enable(&mut self, enable: Enable) -> Result<(), PortError>;
}
