//! The status writer: one joint's [`JointStatus`] for the tick, from what its motor said and
//! what the servo did with it.

use rmd_loop::JointFeedback;

use crate::law::Demand;
use crate::state::{JointCounters, JointStatus, Reference, ServoMode};

/// What the servo did with a joint this tick.
#[derive(Copy, Clone, Debug, PartialEq)]
pub(crate) struct Done {
    /// The joint's mode after the tick.
    pub(crate) mode: ServoMode,
    /// What the mode asked of the law.
    pub(crate) demand: Demand,
    /// The torque commanded (or, in motion mode, the motor's law at this tick's
    /// measurement), within the effort limit, N·m.
    pub(crate) effort_nm: f64,
    /// Reference position minus measured position, rad.
    pub(crate) error_rad: Option<f64>,
    /// Whether its setpoint went stale.
    pub(crate) stale: bool,
    /// Its counters.
    pub(crate) counters: JointCounters,
}

/// Writes `status`: the measured state from `f`, the servo's part from `done`.
pub(crate) fn write(status: &mut JointStatus, f: &JointFeedback, done: &Done) {
    status.position_rad = f.joint.angle_rad();
    status.velocity_rad_s = f.joint.velocity_rad_s();
    status.effort_nm = f.joint.torque_nm.unwrap_or(0.0);
    status.fresh = f.is_fresh();
    status.received_at = f.received_at;
    status.temperature_celsius = f.motor.temperature_celsius;
    status.voltage_volts = f.health.map(|h| h.voltage_volts);
    status.current_amps = f.motor.current_amps;
    status.mode = done.mode;
    status.reference = done.demand.reference.map(Reference::from_kin);
    status.effort_ff_nm = done.demand.effort_ff;
    status.commanded_effort_nm = done.effort_nm;
    status.position_error_rad = done.error_rad;
    status.stale = done.stale;
    status.counters = done.counters;
}

/// Writes `status` for a tick of zero torque (disabled, estopped, halted): the measured
/// position and velocity, no reference.
pub(crate) fn write_zero(status: &mut JointStatus, f: &JointFeedback) {
    status.position_rad = f.joint.angle_rad();
    status.velocity_rad_s = f.joint.velocity_rad_s();
    status.commanded_effort_nm = 0.0;
    status.mode = ServoMode::Disabled;
    status.reference = None;
    status.position_error_rad = None;
}
