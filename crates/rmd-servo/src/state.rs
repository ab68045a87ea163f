//! What the servo publishes every tick: each joint's measured state, what the servo does with
//! it, and counters. Plain `Copy` data of fixed size, so that publishing allocates nothing.

use rmd_bus::Timestamp;
use rmd_loop::JointId;
use rmd_loop::robot::MAX_JOINTS;

use crate::trajectory::segment::Kin;

/// What the servo does with a joint.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum ServoMode {
    /// The servo is disabled: zero torque.
    Disabled,
    /// Zero torque after a stale setpoint (stale policy `zero-torque`) until a new setpoint.
    ZeroTorque,
    /// Holding a position: at start, after a trajectory, after enabling, or after a stale
    /// setpoint (stale policy `hold`).
    Hold,
    /// Following a position setpoint.
    Position,
    /// Following a velocity setpoint.
    Velocity,
    /// Applying an effort setpoint.
    Effort,
    /// Following a trajectory.
    Trajectory,
}

impl ServoMode {
    /// The mode's name as the front ends show it (`"hold"`, `"zero-torque"`, ...).
    ///
    /// ```
    /// assert_eq!(rmd_servo::ServoMode::ZeroTorque.name(), "zero-torque");
    /// ```
    pub const fn name(self) -> &'static str {
        match self {
            ServoMode::Disabled => "disabled",
            ServoMode::ZeroTorque => "zero-torque",
            ServoMode::Hold => "hold",
            ServoMode::Position => "position",
            ServoMode::Velocity => "velocity",
            ServoMode::Effort => "effort",
            ServoMode::Trajectory => "trajectory",
        }
    }
}

/// Where the servo wants a joint to be in this tick.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct Reference {
    /// Position, rad.
    pub position_rad: f64,
    /// Velocity, rad/s.
    pub velocity_rad_s: f64,
    /// Acceleration, rad/s² (non-zero on trajectories only).
    pub acceleration_rad_s2: f64,
}

impl Reference {
    pub(crate) fn from_kin(k: Kin) -> Self {
        Self {
            position_rad: k.p,
            velocity_rad_s: k.v,
            acceleration_rad_s2: k.a,
        }
    }

    pub(crate) fn kin(&self) -> Kin {
        Kin {
            p: self.position_rad,
            v: self.velocity_rad_s,
            a: self.acceleration_rad_s2,
        }
    }
}

/// Counters of one joint since the servo started.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct JointCounters {
    /// Setpoints applied.
    pub setpoints: u64,
    /// Trajectories started on this joint.
    pub trajectories: u64,
    /// Trajectory starts whose first segment the loop thread planned again, because the joint
    /// was not where the caller planned from.
    pub replans: u64,
    /// Trajectories abandoned on this joint (the first segment could not be planned again from
    /// where the joint was, or left the position limits): the joint held its position instead.
    pub trajectory_failures: u64,
    /// Times a setpoint went stale.
    pub stale_events: u64,
    /// Ticks whose torque was clamped to `max_effort_nm`.
    pub clamped: u64,
    /// Requests naming this joint that the handle refused (filled in by
    /// [`ServoHandle::state`](crate::ServoHandle::state)).
    pub rejected: u64,
}

/// One joint in one tick.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct JointStatus {
    /// Measured position, rad.
    pub position_rad: f64,
    /// Measured velocity, rad/s.
    pub velocity_rad_s: f64,
    /// Measured torque, N·m (from the torque current and the torque constant).
    pub effort_nm: f64,
    /// Whether this tick's reply came (see `rmd_loop::Freshness`).
    pub fresh: bool,
    /// When the reply was received (bus clock).
    pub received_at: Timestamp,
    /// Motor temperature, °C.
    pub temperature_celsius: f64,
    /// The motor's supply voltage from its latest status reply (the loop's health rotation),
    /// volts; `None` until one came, or when its bus has no room for the rotation.
    pub voltage_volts: Option<f64>,
    /// Torque current, A (motor sign).
    pub current_amps: f64,
    /// What the servo does with the joint.
    pub mode: ServoMode,
    /// Where it wants the joint (modes with a position: hold, position, velocity, trajectory).
    pub reference: Option<Reference>,
    /// Effort feed-forward in force, N·m (or the effort setpoint).
    pub effort_ff_nm: f64,
    /// The torque commanded this tick (after the clamp), N·m.
    pub commanded_effort_nm: f64,
    /// Reference position minus measured position, rad (when there is a reference).
    pub position_error_rad: Option<f64>,
    /// Whether its setpoint went stale (until the next setpoint).
    pub stale: bool,
    /// Counters.
    pub counters: JointCounters,
}

impl JointStatus {
    pub(crate) const EMPTY: Self = Self {
        position_rad: 0.0,
        velocity_rad_s: 0.0,
        effort_nm: 0.0,
        fresh: false,
        received_at: Timestamp::ZERO,
        temperature_celsius: 0.0,
        voltage_volts: None,
        current_amps: 0.0,
        mode: ServoMode::Disabled,
        reference: None,
        effort_ff_nm: 0.0,
        commanded_effort_nm: 0.0,
        position_error_rad: None,
        stale: false,
        counters: JointCounters {
            setpoints: 0,
            trajectories: 0,
            replans: 0,
            trajectory_failures: 0,
            stale_events: 0,
            clamped: 0,
            rejected: 0,
        },
    };

    /// The state a trajectory submitted now is planned from: the reference when there is one,
    /// else the measured position and velocity.
    pub(crate) fn planning_state(&self) -> Kin {
        match self.reference {
            Some(r) => r.kin(),
            None => Kin {
                p: self.position_rad,
                v: self.velocity_rad_s,
                a: 0.0,
            },
        }
    }
}

/// The servo's state in one tick.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ServoState {
    /// The tick's index.
    pub tick: u64,
    /// The tick's loop time, s since tick 0 (the time base of setpoint ages and trajectory
    /// start times).
    pub time_s: f64,
    /// Whether the servo is enabled.
    pub enabled: bool,
    /// Whether it was emergency-stopped (its loop is ending).
    pub estopped: bool,
    /// Messages dropped by the loop thread because the servo was disabled (or disabled and
    /// enabled again) after they were sent.
    pub dropped_messages: u64,
    count: usize,
    joints: [JointStatus; MAX_JOINTS],
}

impl ServoState {
    pub(crate) fn new(joints: usize) -> Self {
        Self {
            tick: 0,
            time_s: 0.0,
            enabled: false,
            estopped: false,
            dropped_messages: 0,
            count: joints.min(MAX_JOINTS),
            joints: [JointStatus::EMPTY; MAX_JOINTS],
        }
    }

    /// Every joint, in the robot's joint order.
    pub fn joints(&self) -> &[JointStatus] {
        &self.joints[..self.count]
    }

    pub(crate) fn joints_mut(&mut self) -> &mut [JointStatus] {
        &mut self.joints[..self.count]
    }

    /// Joint `id`, if the robot has it.
    pub fn joint(&self, id: JointId) -> Option<&JointStatus> {
        self.joints().get(id.index())
    }
}
