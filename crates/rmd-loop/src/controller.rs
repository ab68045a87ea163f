//! What a user writes: a [`Controller`], called by the loop every tick with fresh feedback.

use core::time::Duration;

use rmd_bus::Timestamp;
use rmd_protocol::{IqControl, MotorId};

use crate::joint::JointMap;
use crate::report::{Fault, StopReason};

/// A torque controller run by the real-time loop.
///
/// All methods run on the loop's real-time thread, in this order:
///
/// 1. [`start`](Controller::start): once, in the first tick in which every motor has answered
///    (the loop sends zero torque until then, for at most `loop.startup_ticks` ticks), right
///    before the first `update`.
/// 2. [`update`](Controller::update): every tick, after the replies to this tick's 0x280 frame
///    were collected (or the reply deadline passed). The commands it writes are sent at the
///    start of the next tick. It must not block, allocate or take locks; return
///    [`Flow::Stop`] to end the run.
/// 3. [`fault`](Controller::fault): at most once, when the loop detects a fault (motor silent,
///    bus-off, deadline misses beyond the policy, over-temperature, ...), before it makes the
///    motors safe.
/// 4. [`stop`](Controller::stop): once, when the loop ends for any reason, after the motors
///    were sent zero torque and motor-off.
///
/// A panic in any of them is caught: the loop makes the motors safe and reports it.
///
/// ```
/// use rmd_loop::{Commands, Controller, Feedback, Flow, TickContext};
///
/// /// Holds every joint at 0 degrees with a PD law on joint angle.
/// struct PdHold { kp: f64, kd: f64 }
///
/// impl Controller for PdHold {
///     fn update(&mut self, _ctx: &TickContext, feedback: &Feedback<'_>, commands: &mut Commands<'_>) -> Flow {
///         for (i, joint) in feedback.iter().enumerate() {
///             let amps = -self.kp * joint.joint_angle_deg - self.kd * joint.joint_velocity_dps;
///             commands.set_current(i, amps);
///         }
///         Flow::Continue
///     }
/// }
/// ```
pub trait Controller: Send {
    /// Runs once before the first `update`, with the first complete feedback.
    fn start(&mut self, ctx: &TickContext, feedback: &Feedback<'_>) {
        let _ = (ctx, feedback);
    }

    /// Runs every tick: read `feedback`, write `commands` (they start at zero every tick).
    fn update(
        &mut self,
        ctx: &TickContext,
        feedback: &Feedback<'_>,
        commands: &mut Commands<'_>,
    ) -> Flow;

    /// Runs once when the loop detects a fault, before the motors are made safe.
    fn fault(&mut self, fault: &Fault) {
        let _ = fault;
    }

    /// Runs once when the loop ends, after the motors were made safe.
    fn stop(&mut self, reason: &StopReason) {
        let _ = reason;
    }
}

/// Whether the loop goes on after this tick.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Flow {
    /// Keep running.
    Continue,
    /// Stop the loop (the motors are made safe; the stop reason is
    /// [`StopReason::ControllerFinished`]).
    Stop,
}

/// When and how the current tick runs.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct TickContext {
    /// Tick number since the start of the loop (start-up ticks included).
    pub index: u64,
    /// When this tick was due: `t0 + index * period`.
    pub scheduled: Timestamp,
    /// When the loop thread actually woke for it.
    pub woke: Timestamp,
    /// The loop period.
    pub period: Duration,
    /// When tick 0 was due.
    pub start: Timestamp,
}

impl TickContext {
    /// How late this tick woke (`woke - scheduled`).
    pub fn wake_latency(&self) -> Duration {
        self.woke - self.scheduled
    }

    /// Scheduled time since the start of the loop, in seconds (the time base for trajectories).
    pub fn time_s(&self) -> f64 {
        (self.scheduled - self.start).as_secs_f64()
    }

    /// The period in seconds.
    pub fn dt(&self) -> f64 {
        self.period.as_secs_f64()
    }
}

/// The latest feedback of one motor, in motor and joint terms.
///
/// Physical values are `f64` with the unit in the name. Motor-side values are as the motor
/// reports them; joint-side values apply the configured gear ratio, direction and zero offset.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct MotorFeedback {
    /// Bus index.
    pub bus: usize,
    /// Motor id on that bus.
    pub motor: MotorId,
    /// Whether a reply has ever been received (all other values are zero until then).
    pub valid: bool,
    /// Whether this tick's feedback is fresh: a reply answering this tick's frame (or, in
    /// pipelined mode, the previous tick's) was received in this tick.
    pub fresh: bool,
    /// Ticks between the frame that the latest accepted reply answers and this tick (0 in
    /// same-tick mode when fresh; 1 in pipelined mode when fresh).
    pub age_ticks: u32,
    /// Ticks since the last reply was received (0 if one was received this tick).
    pub ticks_since_reply: u32,
    /// When the latest reply was received.
    pub received_at: Timestamp,
    /// Motor temperature, degrees Celsius.
    pub temperature_celsius: f64,
    /// Torque current, raw (`iq`, -2048..=2048).
    pub iq: i16,
    /// Torque current in amperes (motor sign).
    pub iq_amps: f64,
    /// Motor speed, deg/s (motor side, 1 dps resolution).
    pub speed_dps: f64,
    /// Raw single-turn encoder position.
    pub encoder: u16,
    /// Continuous motor angle, degrees (motor side, unwrapped by the loop).
    pub motor_angle_deg: f64,
    /// Joint angle, degrees.
    pub joint_angle_deg: f64,
    /// Joint velocity, deg/s.
    pub joint_velocity_dps: f64,
    /// Joint torque from the torque current, N*m (if the torque constant is configured).
    pub joint_torque_nm: Option<f64>,
}

impl MotorFeedback {
    /// Feedback of a motor that has not answered yet.
    pub fn empty(bus: usize, motor: MotorId) -> Self {
        Self {
            bus,
            motor,
            valid: false,
            fresh: false,
            age_ticks: 0,
            ticks_since_reply: 0,
            received_at: Timestamp::ZERO,
            temperature_celsius: 0.0,
            iq: 0,
            iq_amps: 0.0,
            speed_dps: 0.0,
            encoder: 0,
            motor_angle_deg: 0.0,
            joint_angle_deg: 0.0,
            joint_velocity_dps: 0.0,
            joint_torque_nm: None,
        }
    }

    /// Joint angle in radians.
    pub fn joint_angle_rad(&self) -> f64 {
        self.joint_angle_deg.to_radians()
    }

    /// Joint velocity in rad/s.
    pub fn joint_velocity_rad_s(&self) -> f64 {
        self.joint_velocity_dps.to_radians()
    }
}

/// The feedback of every motor, in robot-description order (bus by bus).
#[derive(Copy, Clone, Debug)]
pub struct Feedback<'a> {
    motors: &'a [MotorFeedback],
}

impl<'a> Feedback<'a> {
    /// A view over feedback slots.
    pub fn new(motors: &'a [MotorFeedback]) -> Self {
        Self { motors }
    }

    /// Number of motors.
    pub fn len(&self) -> usize {
        self.motors.len()
    }

    /// Whether there are no motors.
    pub fn is_empty(&self) -> bool {
        self.motors.is_empty()
    }

    /// Motor `i` (robot-description order), if it exists.
    pub fn get(&self, i: usize) -> Option<&'a MotorFeedback> {
        self.motors.get(i)
    }

    /// The motor with `id` on `bus`.
    pub fn find(&self, bus: usize, id: MotorId) -> Option<&'a MotorFeedback> {
        self.motors.iter().find(|m| m.bus == bus && m.motor == id)
    }

    /// All motors in order.
    pub fn iter(&self) -> core::slice::Iter<'a, MotorFeedback> {
        self.motors.iter()
    }

    /// All motors as a slice.
    pub fn as_slice(&self) -> &'a [MotorFeedback] {
        self.motors
    }

    /// Whether every motor's feedback is fresh this tick.
    pub fn all_fresh(&self) -> bool {
        self.motors.iter().all(|m| m.fresh)
    }
}

impl core::ops::Index<usize> for Feedback<'_> {
    type Output = MotorFeedback;
    fn index(&self, i: usize) -> &MotorFeedback {
        &self.motors[i]
    }
}

/// Why a command could not be expressed.
#[derive(Copy, Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum CommandError {
    /// No such motor index.
    #[error("no motor with index {0}")]
    NoSuchMotor(usize),
    /// A torque command needs the motor's torque constant in the robot description.
    #[error("motor {0} has no torque_constant_nm_per_amp: command it in amperes")]
    NoTorqueConstant(usize),
    /// The value is not a finite number.
    #[error("command for motor {0} is not a finite number")]
    NotFinite(usize),
}

/// The torque commands of this tick, one per motor in robot-description order.
///
/// Values are torque current in the motor's frame as raw `iqControl`, set through joint-side
/// helpers. The loop clamps each to the motor's configured current limit when it builds the
/// 0x280 frame (the motor itself does not limit 0x280 commands) and counts the clamps.
#[derive(Debug)]
pub struct Commands<'a> {
    amps: &'a mut [f64],
    maps: &'a [JointMap],
}

impl<'a> Commands<'a> {
    /// A view over command slots (motor-side amperes) and the motors' joint maps.
    pub fn new(amps: &'a mut [f64], maps: &'a [JointMap]) -> Self {
        Self { amps, maps }
    }

    /// Number of motors.
    pub fn len(&self) -> usize {
        self.amps.len()
    }

    /// Whether there are no motors.
    pub fn is_empty(&self) -> bool {
        self.amps.is_empty()
    }

    /// Sets motor `i`'s torque current in amperes, joint sign (the configured direction is
    /// applied). Non-finite values and unknown indices are ignored and reported by the result.
    pub fn set_current(&mut self, i: usize, joint_amps: f64) -> Result<(), CommandError> {
        let map = self.maps.get(i).ok_or(CommandError::NoSuchMotor(i))?;
        if !joint_amps.is_finite() {
            return Err(CommandError::NotFinite(i));
        }
        self.amps[i] = map.motor_amps(joint_amps);
        Ok(())
    }

    /// Sets motor `i`'s joint torque in N*m (needs the torque constant).
    pub fn set_torque(&mut self, i: usize, joint_nm: f64) -> Result<(), CommandError> {
        let map = self.maps.get(i).ok_or(CommandError::NoSuchMotor(i))?;
        if !joint_nm.is_finite() {
            return Err(CommandError::NotFinite(i));
        }
        let amps = map
            .motor_amps_for_torque(joint_nm)
            .ok_or(CommandError::NoTorqueConstant(i))?;
        self.amps[i] = amps;
        Ok(())
    }

    /// Sets motor `i`'s raw torque command (motor sign, no direction applied).
    pub fn set_raw(&mut self, i: usize, iq_control: IqControl) -> Result<(), CommandError> {
        let slot = self.amps.get_mut(i).ok_or(CommandError::NoSuchMotor(i))?;
        *slot = iq_control.amps();
        Ok(())
    }

    /// Motor `i`'s current command in motor-side amperes (before clamping).
    pub fn motor_amps(&self, i: usize) -> Option<f64> {
        self.amps.get(i).copied()
    }

    /// Sets every command to zero torque.
    pub fn zero_all(&mut self) {
        self.amps.fill(0.0);
    }
}
