//! The loop's per-tick telemetry: a fixed-size sample pushed into a lock-free mailbox every tick.
//!
//! When the consumer falls behind, the oldest samples are overwritten (the newest state is what a
//! live display wants) and each one overwritten is counted in `telemetry_drops`.

use rmd_bus::Timestamp;

use crate::config::MAX_MOTORS;
use crate::controller::MotorFeedback;

/// One motor in a telemetry sample.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct JointSample {
    /// Joint angle, degrees.
    pub joint_angle_deg: f64,
    /// Joint velocity, deg/s.
    pub joint_velocity_dps: f64,
    /// Measured torque current, amperes (motor sign).
    pub iq_amps: f64,
    /// Torque current commanded by the controller in this tick (sent next tick), amperes (motor
    /// sign, after clamping to the current limit).
    pub command_amps: f64,
    /// Temperature, degrees Celsius.
    pub temperature_celsius: f64,
    /// Whether the feedback was fresh in this tick.
    pub fresh: bool,
}

impl JointSample {
    /// The sample of one motor's feedback and command.
    pub fn new(feedback: &MotorFeedback, command_amps: f64) -> Self {
        Self {
            joint_angle_deg: feedback.joint_angle_deg,
            joint_velocity_dps: feedback.joint_velocity_dps,
            iq_amps: feedback.iq_amps,
            command_amps,
            temperature_celsius: feedback.temperature_celsius,
            fresh: feedback.fresh,
        }
    }
}

/// The state of the robot in one tick.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct TelemetrySample {
    /// Tick index.
    pub tick: u64,
    /// When the tick was due.
    pub scheduled: Timestamp,
    /// Seconds since tick 0 was due.
    pub time_s: f64,
    /// How late the tick woke, nanoseconds.
    pub wake_latency_ns: u64,
    /// Number of motors (entries of `joints` in use).
    pub motors: usize,
    /// Per motor, robot-description order; entries beyond `motors` are zero.
    pub joints: [JointSample; MAX_MOTORS],
}

impl TelemetrySample {
    /// The motors in use.
    pub fn joints(&self) -> &[JointSample] {
        &self.joints[..self.motors.min(MAX_MOTORS)]
    }
}

impl Default for TelemetrySample {
    fn default() -> Self {
        Self {
            tick: 0,
            scheduled: Timestamp::ZERO,
            time_s: 0.0,
            wake_latency_ns: 0,
            motors: 0,
            joints: [JointSample::default(); MAX_MOTORS],
        }
    }
}
