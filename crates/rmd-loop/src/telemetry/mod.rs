//! The loop's per-tick telemetry: a fixed-size sample published every tick through a lock-free
//! channel of pre-allocated boxes ([`TelemetryReceiver`]), once something asked for it
//! ([`RtLoop::telemetry`](crate::RtLoop::telemetry)).
//!
//! What happens when the consumer falls behind is the [`TelemetryDelivery`] asked for: by
//! default the oldest samples are overwritten (the newest state is what a live display wants;
//! the loop never waits) and each one overwritten is counted in `telemetry_drops`; on virtual
//! time the loop may wait for room instead, so that every tick reaches the consumer. Without a
//! consumer nothing is published and nothing is counted.

use rmd_bus::Timestamp;

mod channel;

pub use channel::TelemetryReceiver;
pub(crate) use channel::{Published, TelemetrySender, channel};

use crate::commands::MAX_SIGNALS;
use crate::feedback::JointFeedback;
use crate::robot::MAX_JOINTS;

/// One joint in a telemetry sample: its feedback and the command the controller wrote.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct JointSample {
    /// The feedback the controller saw in this tick.
    pub feedback: JointFeedback,
    /// Torque current commanded in this tick (sent next tick), amperes, motor sign, after
    /// clamping to the current limit.
    pub command_amps: f64,
}

impl Default for JointSample {
    fn default() -> Self {
        Self {
            feedback: JointFeedback::UNSET,
            command_amps: 0.0,
        }
    }
}

/// How one tick went, in nanoseconds.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct TickTimes {
    /// How late the tick woke.
    pub wake_latency_ns: u64,
    /// From this tick's 0x280 frames to the last reply, when every reply came.
    pub round_trip_ns: Option<u64>,
    /// The controller's `update`.
    pub controller_ns: u64,
    /// The previous tick's whole work (wake to end).
    pub previous_work_ns: u64,
}

/// What the loop does with a sample when the telemetry mailbox is full.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub enum TelemetryDelivery {
    /// Overwrite the oldest queued sample and count it in `telemetry_drops`: the loop never
    /// waits. For real-time runs (the default).
    #[default]
    Overwrite,
    /// Wait (sleeping 50 us at a time) until the consumer makes room, so that it gets every
    /// sample. Only for runs on a virtual clock, where waiting costs no deadline: on a real-time
    /// loop a slow consumer would make it miss its deadlines. The loop stops waiting (and counts
    /// the sample dropped) when no receiver is left or a stop is requested.
    Wait,
}

/// Running totals at the end of a tick.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct Totals {
    /// Ticks run so far, this one included (skipped ticks are not run): consecutive samples of
    /// a run differ by exactly one, so a consumer sees which samples it did not get.
    pub ticks: u64,
    /// Deadline misses so far.
    pub deadline_misses: u64,
    /// Missing replies so far, all joints.
    pub missing_replies: u64,
    /// Late replies so far, all joints.
    pub late_replies: u64,
}

/// The state of the robot in one tick.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct TelemetrySample {
    /// Tick index.
    pub tick: u64,
    /// When the tick was due (bus clock).
    pub scheduled: Timestamp,
    /// When tick 0 was due (bus clock): `scheduled - start` is the tick's time in the run.
    pub start: Timestamp,
    /// When the sample was taken (bus clock): after the exchange and the controller, so the
    /// age of a joint's last reply is `taken_at - feedback.received_at`.
    pub taken_at: Timestamp,
    /// Seconds since tick 0 was due.
    pub time_s: f64,
    /// Timing of this tick.
    pub times: TickTimes,
    /// Running totals.
    pub totals: Totals,
    joint_count: usize,
    joints: [JointSample; MAX_JOINTS],
    signal_count: usize,
    signals: [f64; MAX_SIGNALS],
}

impl TelemetrySample {
    /// An empty sample for `joints` joints and `signals` user signals (each at most its maximum).
    /// The loop fills one per tick; consumers' tests build their own.
    pub fn new(joints: usize, signals: usize) -> Self {
        Self {
            tick: 0,
            scheduled: Timestamp::ZERO,
            start: Timestamp::ZERO,
            taken_at: Timestamp::ZERO,
            time_s: 0.0,
            times: TickTimes::default(),
            totals: Totals::default(),
            joint_count: joints.min(MAX_JOINTS),
            joints: [JointSample::default(); MAX_JOINTS],
            signal_count: signals.min(MAX_SIGNALS),
            signals: [0.0; MAX_SIGNALS],
        }
    }

    /// Every joint, in description order (index with a [`JointId`](crate::JointId)'s `index()`).
    pub fn joints(&self) -> &[JointSample] {
        &self.joints[..self.joint_count]
    }

    /// Every joint, to fill in.
    #[inline]
    pub fn joints_mut(&mut self) -> &mut [JointSample] {
        &mut self.joints[..self.joint_count]
    }

    /// The user signals, in the order the controller declared them.
    pub fn signals(&self) -> &[f64] {
        &self.signals[..self.signal_count]
    }

    /// The user signals, to fill in.
    #[inline]
    pub fn signals_mut(&mut self) -> &mut [f64] {
        &mut self.signals[..self.signal_count]
    }
}
