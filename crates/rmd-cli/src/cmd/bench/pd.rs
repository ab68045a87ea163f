//! The benchmark controller: PD position control of every joint towards a moving target, so that
//! the loop, the motors and the bus do real work (commands and replies change every tick).
//!
//! Joint `i` follows `AMPLITUDE_DEG * sin(2 pi FREQUENCY_HZ t + i pi / 2)` with
//! `amps = KP (target - angle) + KD (target velocity - velocity)`; the gains suit the simulator's
//! default motor (RMD-X8 class, 1:9, 2.09 N*m/A at the output): about 8 Hz bandwidth, damping 0.6.
//! The controller also measures, without allocating, how well it tracks and when the replies
//! reached it (for `rmd bench rate`).

use core::f64::consts::PI;
use core::time::Duration;

use rmd_bus::{Clock, MonotonicClock, Timestamp};
use rmd_loop::robot::JointSpec;
use rmd_loop::stats::LatencyHistogram;
use rmd_loop::{CommandKind, Commands, Controller, Feedback, Flow, MotionCommand, TickContext};

use super::robot::TORQUE_CONSTANT;

/// Target amplitude, joint degrees.
pub(crate) const AMPLITUDE_DEG: f64 = 20.0;
/// Target frequency.
pub(crate) const FREQUENCY_HZ: f64 = 0.5;
/// Proportional gain, amperes per degree.
const KP: f64 = 0.4;
/// Derivative gain, amperes per degree per second.
const KD: f64 = 0.01;
/// Tracking is measured after this long (the joints start at rest at 0 degrees).
const SETTLE_S: f64 = 0.5;

/// A tick that missed (a reply missing, or an overrun that skipped the slots after it), as the
/// benchmark's controller saw it.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) struct MissedTick {
    /// The tick's index.
    pub(crate) index: u64,
    /// When it was due.
    pub(crate) scheduled: Timestamp,
    /// How late the loop woke for it.
    pub(crate) wake_late: Duration,
    /// Slots skipped after it (0: it missed a reply but did not overrun).
    pub(crate) skipped_after: u64,
}

/// Missed ticks the controller logs at most (it never allocates while the loop runs).
const MISSED_LOG_LEN: usize = 16_384;

/// PD control towards moving targets, with tracking and timing measurements.
#[derive(Debug)]
pub(crate) struct MovingTargetPd {
    squared_error_sum: f64,
    error_samples: u64,
    max_error_deg: f64,
    /// Time from the last fresh reply's arrival to the start of `update` (real clock), only when
    /// `measure_handoff` is set (real time).
    pub(crate) handoff: LatencyHistogram,
    /// Time from the tick's scheduled start to the last fresh reply's arrival.
    pub(crate) last_reply: LatencyHistogram,
    measure_handoff: bool,
    /// When the first and the last tick the controller ran were due.
    pub(crate) ticks_due: Option<(Timestamp, Timestamp)>,
    /// Ticks that missed a reply, or were followed by skipped slots (the first
    /// [`MISSED_LOG_LEN`] entries; a tick may have two).
    pub(crate) missed: Vec<MissedTick>,
    /// The tick the controller ran last (nothing skipped after it yet): to see slots skipped.
    last: Option<MissedTick>,
    /// Whether it gives motion-mode setpoints (the same law, run in the motors) instead of
    /// currents.
    motion: bool,
}

impl MovingTargetPd {
    /// A controller; `real_time` enables the hand-off measurement (which reads the real clock).
    pub(crate) fn new(real_time: bool) -> Self {
        Self {
            squared_error_sum: 0.0,
            error_samples: 0,
            max_error_deg: 0.0,
            handoff: LatencyHistogram::new(),
            last_reply: LatencyHistogram::new(),
            measure_handoff: real_time,
            ticks_due: None,
            missed: Vec::with_capacity(MISSED_LOG_LEN),
            last: None,
            motion: false,
        }
    }

    /// The same controller giving motion-mode setpoints when `motion` (every joint then needs
    /// a `motion` bus): target, target velocity, and the gains in N*m with the simulated
    /// motor's torque constant.
    pub(crate) fn in_motion_mode(mut self, motion: bool) -> Self {
        self.motion = motion;
        self
    }

    /// Logs a missed tick, if the log has room (never grows it).
    fn log_missed(&mut self, tick: MissedTick) {
        if self.missed.len() < self.missed.capacity() {
            self.missed.push(tick);
        }
    }

    /// Logs the last tick when slots were skipped between it and `index`, and the tick `ctx`
    /// when it missed a reply.
    fn log_ticks(&mut self, ctx: &TickContext, all_fresh: bool) {
        let now = MissedTick {
            index: ctx.index,
            scheduled: ctx.scheduled,
            wake_late: ctx
                .woke
                .checked_duration_since(ctx.scheduled)
                .unwrap_or_default(),
            skipped_after: 0,
        };
        if let Some(last) = self.last
            && now.index > last.index + 1
        {
            self.log_missed(MissedTick {
                skipped_after: now.index - last.index - 1,
                ..last
            });
        }
        if !all_fresh {
            self.log_missed(now);
        }
        self.last = Some(now);
    }

    /// The target of joint `i` at `t` seconds: angle (deg) and velocity (deg/s).
    pub(crate) fn target(i: usize, t: f64) -> (f64, f64) {
        let w = 2.0 * PI * FREQUENCY_HZ;
        let phase = w * t + i as f64 * PI / 2.0;
        (AMPLITUDE_DEG * phase.sin(), AMPLITUDE_DEG * w * phase.cos())
    }

    /// RMS tracking error after the settling time, degrees (`None` if the run was shorter).
    pub(crate) fn rms_error_deg(&self) -> Option<f64> {
        (self.error_samples > 0)
            .then(|| (self.squared_error_sum / self.error_samples as f64).sqrt())
    }

    /// Largest tracking error after the settling time, degrees.
    pub(crate) fn max_error_deg(&self) -> Option<f64> {
        (self.error_samples > 0).then_some(self.max_error_deg)
    }
}

impl Controller for MovingTargetPd {
    fn command_kind(&self, _: &JointSpec) -> CommandKind {
        if self.motion {
            CommandKind::Motion
        } else {
            CommandKind::Current
        }
    }

    fn update(&mut self, ctx: &TickContext, fb: &Feedback<'_>, cmd: &mut Commands<'_>) -> Flow {
        let entered = self.measure_handoff.then(|| MonotonicClock.now());
        let t = ctx.time_s();
        self.ticks_due = Some(match self.ticks_due {
            None => (ctx.scheduled, ctx.scheduled),
            Some((first, _)) => (first, ctx.scheduled),
        });
        let mut latest: Option<Timestamp> = None;
        for (joint, f) in fb.iter() {
            if f.is_fresh() {
                latest = Some(latest.map_or(f.received_at, |l| l.max(f.received_at)));
            }
            let (angle, velocity) = Self::target(joint.index(), t);
            let error = angle - f.joint.angle_deg;
            if self.motion {
                cmd.set_motion(
                    joint,
                    MotionCommand {
                        position_deg: angle,
                        velocity_dps: velocity,
                        kp_nm_per_deg: KP * TORQUE_CONSTANT,
                        kd_nm_per_dps: KD * TORQUE_CONSTANT,
                        torque_nm: 0.0,
                    },
                );
            } else {
                let amps = KP * error + KD * (velocity - f.joint.velocity_dps);
                // The loop clamps to the current limit.
                cmd.set_current(joint, amps);
            }
            if t >= SETTLE_S {
                self.squared_error_sum += error * error;
                self.error_samples += 1;
                self.max_error_deg = self.max_error_deg.max(error.abs());
            }
        }
        self.log_ticks(ctx, fb.all_fresh());
        if fb.all_fresh()
            && let Some(last) = latest
        {
            self.last_reply.record(last - ctx.scheduled);
            if let Some(entered) = entered {
                self.handoff.record(entered - last);
            }
        }
        Flow::Continue
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn targets_move_and_are_out_of_phase() {
        let (a0, v0) = MovingTargetPd::target(0, 0.0);
        let (a1, _) = MovingTargetPd::target(1, 0.0);
        assert_eq!(a0, 0.0);
        assert!((a1 - AMPLITUDE_DEG).abs() < 1e-9);
        assert!((v0 - AMPLITUDE_DEG * 2.0 * PI * FREQUENCY_HZ).abs() < 1e-9);
        let (a, _) = MovingTargetPd::target(0, 0.5);
        assert!((a - AMPLITUDE_DEG).abs() < 1e-9);
    }

    #[test]
    fn ticks_that_missed_a_reply_or_were_followed_by_skipped_slots_are_logged() {
        let ms = Duration::from_millis;
        let ctx = |index: u64, wake_late_us: u64| TickContext {
            index,
            scheduled: Timestamp::ZERO + ms(index),
            woke: Timestamp::ZERO + ms(index) + Duration::from_micros(wake_late_us),
            period: ms(1),
            start: Timestamp::ZERO,
        };
        let mut pd = MovingTargetPd::new(false);
        // Ticks 0, 1, then 4 (1 overran: 2 and 3 skipped), 5 with a reply missing, 6.
        for (index, fresh) in [(0, true), (1, true), (4, true), (5, false), (6, true)] {
            pd.log_ticks(&ctx(index, 3 * index), fresh);
        }
        let tick = |index: u64, skipped_after: u64| MissedTick {
            index,
            scheduled: Timestamp::ZERO + ms(index),
            wake_late: Duration::from_micros(3 * index),
            skipped_after,
        };
        assert_eq!(pd.missed, vec![tick(1, 2), tick(5, 0)]);
        // The log never grows past what was reserved.
        let capacity = pd.missed.capacity();
        for index in 0..capacity as u64 + 10 {
            pd.log_ticks(&ctx(100 + 2 * index, 0), true);
        }
        assert_eq!(pd.missed.len(), capacity);
        assert_eq!(pd.missed.capacity(), capacity);
    }
}
