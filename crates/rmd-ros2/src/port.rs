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
    /// Supply voltage, V (`None`: not measured; say why in [`values`](Self::values)).
    pub voltage_v: Option<f64>,
    /// Active faults, each as a short text (empty: none). Any fault makes the motor's status
    /// an error.
    pub faults: Vec<String>,
    /// Conditions worth a look that are not faults (a missing reply, a stale setpoint), each
    /// as a short text. Any warning makes the motor's status a warning.
    pub warnings: Vec<String>,
    /// Further key-value pairs for the motor's status (counters, the servo's mode, ...).
    pub values: Vec<(String, String)>,
}

/// Everything the node publishes on `diagnostics` about the robot.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RobotDiagnostics {
    /// The loop's timing.
    pub timing: LoopTiming,
    /// Whether the robot is enabled (not estopped).
    pub enabled: bool,
    /// The loop has ended, and why (`None` while it runs). An abnormal end (a fault, an
    /// emergency stop) makes the loop's status an error.
    pub stopped: Option<LoopEnd>,
    /// Further key-value pairs for the loop's status (work per tick, late replies, ...).
    pub values: Vec<(String, String)>,
    /// One entry per motor.
    pub motors: Vec<MotorDiagnostics>,
}

/// How the robot's loop ended.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LoopEnd {
    /// Why, in words.
    pub reason: String,
    /// Whether that is a normal end (a requested stop, the end of the run's time).
    pub normal: bool,
}

/// What one joint is told to do: the joint servo's own setpoint (rad, rad/s, N·m), so a
/// validated command reaches the servo unchanged.
pub use rmd_servo::Setpoint;

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

/// Why a port refused an input that passed the node's validation.
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
    /// The robot cannot take this input now (e.g. every trajectory buffer is in use); the
    /// same input may be taken later.
    #[error("the robot is busy: {0}")]
    Busy(String),
    /// The robot's own checks, beyond the node's, found the input invalid (e.g. a trajectory
    /// whose motion between points leaves the position limits). Counted under `kind`.
    #[error("the robot refused the input: {reason}")]
    Invalid {
        /// The counter it goes to.
        kind: crate::kind::RejectionKind,
        /// The robot's reason, telling what to change.
        reason: String,
    },
}

impl PortError {
    /// The counter a refusal goes to: [`Invalid`](Self::Invalid)'s own kind, else
    /// [`RejectionKind::PortRefused`](crate::kind::RejectionKind::PortRefused).
    pub fn kind(&self) -> crate::kind::RejectionKind {
        match self {
            PortError::Invalid { kind, .. } => *kind,
            _ => crate::kind::RejectionKind::PortRefused,
        }
    }
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
