//! What a user writes: a [`Controller`], called by the loop every tick with fresh feedback.

use core::time::Duration;

use rmd_bus::Timestamp;

use crate::commands::Commands;
use crate::feedback::Feedback;
use crate::motion::CommandKind;
use crate::report::{Fault, StopReason};
use crate::robot::JointSpec;

/// A torque controller run by the real-time loop.
///
/// The methods run in this order:
///
/// 1. [`signals`](Controller::signals): once, when the loop is built ([`RtLoop::unsupervised`](crate::RtLoop::unsupervised)),
///    on the building thread: the names of the user signals the controller writes every tick.
/// 2. [`start`](Controller::start): once, on the loop thread, after every motor has answered the
///    start-up probe (zero torque until then), before the first tick.
/// 3. [`update`](Controller::update): every tick, on the loop thread, after the replies to this
///    tick's 0x280 frame were collected (or the reply deadline passed). The commands it writes
///    are sent at the start of the next tick. It must not block, allocate or take locks; return
///    [`Flow::Stop`] to end the run.
/// 4. [`fault`](Controller::fault): at most once, when the loop detects a fault (motor silent,
///    bus-off, deadline misses beyond the policy, over-temperature, a rejected command, ...),
///    before it makes the motors safe.
/// 5. [`stop`](Controller::stop): once, when the loop ends for any reason, after the motors were
///    sent zero torque and motor-off.
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
///     fn update(&mut self, _ctx: &TickContext, feedback: &Feedback<'_>, cmd: &mut Commands<'_>) -> Flow {
///         for (joint, state) in feedback.iter() {
///             cmd.set_current(joint, -self.kp * state.joint.angle_deg - self.kd * state.joint.velocity_dps);
///         }
///         Flow::Continue
///     }
/// }
/// ```
pub trait Controller: Send {
    /// The names of the user signals this controller writes with
    /// [`Commands::set_signal`] (at most [`MAX_SIGNALS`](crate::commands::MAX_SIGNALS)); they
    /// go out with the telemetry of every tick. None by default.
    fn signals(&self) -> Vec<String> {
        Vec::new()
    }

    /// How this controller commands `joint`: with currents (the default) or in motion mode
    /// ([`Commands::set_motion`]). Asked once per joint when the loop is built, which refuses
    /// motion mode for a joint whose bus is not `exchange = "motion"`
    /// ([`BuildError::NoMotionMode`](crate::BuildError::NoMotionMode)).
    fn command_kind(&self, joint: &JointSpec) -> CommandKind {
        let _ = joint;
        CommandKind::Current
    }

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
    /// Stop the loop: the controller is done (the motors are made safe; the stop reason is
    /// [`StopReason::ControllerFinished`], a normal end).
    Stop,
    /// Stop the loop for a reason of the controller's own safety (a joint beyond its limit, a
    /// plan that cannot be followed): the motors are made safe and the run ends abnormally
    /// with [`StopReason::ControllerHalted`] and this reason (keep details in the controller).
    Halt(&'static str),
}

/// When and how the current tick runs.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct TickContext {
    /// Tick number since the start of the loop (tick 0 is due one period after start-up).
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
