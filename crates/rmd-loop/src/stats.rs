//! What the loop measures about itself: latency histograms and event counters.
//!
//! Histograms are [`hdrhistogram`]s sized once at start (1 ns to 1 s, 3 significant digits), so
//! recording never allocates; longer values are recorded as 1 s and the exact maximum is kept
//! separately. Copying statistics into a snapshot of the same shape does not allocate either.

use core::time::Duration;

use hdrhistogram::Histogram;
use rmd_bus::BusEvent;
use rmd_protocol::MotorId;
use serde::Serialize;

use crate::robot::Robot;

/// Highest value a histogram resolves; longer durations are recorded as this (1 s).
const HIGHEST_NANOS: u64 = 1_000_000_000;
/// Significant decimal digits kept by every histogram.
const SIGNIFICANT_DIGITS: u8 = 3;

/// A histogram of durations, in nanoseconds.
#[derive(Clone, Debug)]
pub struct LatencyHistogram {
    histogram: Histogram<u64>,
    max: Duration,
}

impl Default for LatencyHistogram {
    fn default() -> Self {
        Self::new()
    }
}

impl LatencyHistogram {
    /// An empty histogram (the only allocation it ever makes).
    pub fn new() -> Self {
        let mut histogram = Histogram::new_with_bounds(1, HIGHEST_NANOS, SIGNIFICANT_DIGITS)
            .expect("constant bounds are valid");
        histogram.auto(false);
        Self {
            histogram,
            max: Duration::ZERO,
        }
    }

    /// Records one duration. Never allocates, never fails.
    pub fn record(&mut self, d: Duration) {
        let nanos = d.as_nanos().min(u128::from(HIGHEST_NANOS)) as u64;
        self.histogram.saturating_record(nanos.max(1));
        self.max = self.max.max(d);
    }

    /// Number of recorded values.
    pub fn len(&self) -> u64 {
        self.histogram.len()
    }

    /// Whether nothing was recorded.
    pub fn is_empty(&self) -> bool {
        self.histogram.is_empty()
    }

    /// Forgets every recorded value.
    pub fn reset(&mut self) {
        self.histogram.reset();
        self.max = Duration::ZERO;
    }

    /// Overwrites `self` with `other` without allocating.
    pub fn copy_from(&mut self, other: &LatencyHistogram) {
        // Same bounds on both sides: set_to is a memset + memcpy of the counts.
        let _ = self.histogram.set_to(&other.histogram);
        self.max = other.max;
    }

    /// The summary the reports print, in microseconds.
    pub fn percentiles(&self) -> Percentiles {
        if self.is_empty() {
            return Percentiles::default();
        }
        let us = |nanos: u64| nanos as f64 / 1_000.0;
        let max = self.max.as_nanos() as f64 / 1_000.0;
        // A bucket's highest value may lie above the largest value recorded in it (milliseconds
        // of wake latency on a loaded machine): no percentile is above the maximum.
        let q = |quantile: f64| us(self.histogram.value_at_quantile(quantile)).min(max);
        Percentiles {
            count: self.len(),
            min: us(self.histogram.min()).min(max),
            mean: self.histogram.mean() / 1_000.0,
            p50: q(0.50),
            p90: q(0.90),
            p99: q(0.99),
            p999: q(0.999),
            max,
        }
    }

    /// Values and counts of the non-empty buckets, in microseconds (for plots).
    pub fn buckets_us(&self) -> impl Iterator<Item = (f64, u64)> + '_ {
        self.histogram
            .iter_recorded()
            .map(|v| (v.value_iterated_to() as f64 / 1_000.0, v.count_at_value()))
    }
}

/// Percentiles of a [`LatencyHistogram`], in microseconds.
#[derive(Copy, Clone, Debug, Default, PartialEq, Serialize)]
pub struct Percentiles {
    /// Number of values.
    pub count: u64,
    /// Smallest value.
    pub min: f64,
    /// Mean.
    pub mean: f64,
    /// Median.
    pub p50: f64,
    /// 90th percentile.
    pub p90: f64,
    /// 99th percentile.
    pub p99: f64,
    /// 99.9th percentile.
    pub p999: f64,
    /// Largest value (exact, even beyond the histogram's range).
    pub max: f64,
}

/// Counters of one motor.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Serialize)]
pub struct MotorCounters {
    /// Bus index in the robot description.
    pub bus: usize,
    /// Motor id.
    #[serde(serialize_with = "serialize_motor_id")]
    pub motor: MotorId,
    /// Ticks that ended without fresh feedback from this motor.
    pub missing_replies: u64,
    /// Replies that arrived after the tick they answered (recognised and not used as fresh).
    pub late_replies: u64,
    /// Replies with no outstanding request (duplicates, or answers to someone else's request).
    pub unexpected_replies: u64,
    /// Frames on this motor's id that failed to decode as a torque reply.
    pub bad_frames: u64,
    /// Torque commands that were clamped to the motor's current limit.
    pub clamped_commands: u64,
    /// Commands the controller wrote that could not be sent as given (not finite, a torque
    /// without a torque constant): sent as zero torque.
    pub rejected_commands: u64,
    /// Commands that pushed the joint further past one of its limits (`position_min_deg`,
    /// `position_max_deg`, `velocity_limit_dps`): sent as zero torque.
    pub limited_commands: u64,
    /// Longest run of consecutive ticks without fresh feedback.
    pub max_consecutive_missing: u64,
}

fn serialize_motor_id<S: serde::Serializer>(id: &MotorId, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_u8(id.get())
}

impl MotorCounters {
    /// Zeroed counters for one motor.
    pub fn new(bus: usize, motor: MotorId) -> Self {
        Self {
            bus,
            motor,
            missing_replies: 0,
            late_replies: 0,
            unexpected_replies: 0,
            bad_frames: 0,
            clamped_commands: 0,
            rejected_commands: 0,
            limited_commands: 0,
            max_consecutive_missing: 0,
        }
    }
}

/// Counters of one bus.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct BusCounters {
    /// Frames the bus refused to queue (transmit queue full) or failed to send.
    pub tx_errors: u64,
    /// Receive errors reported by the bus.
    pub rx_errors: u64,
    /// Frames that were not a reply of a configured motor on this bus (other ids, bad ids).
    pub unexpected_frames: u64,
    /// Bus-off events.
    pub bus_off: u64,
    /// Error-passive or error-warning events.
    pub error_passive: u64,
    /// Receive overflows (frames lost by the controller or the socket).
    pub rx_overflow: u64,
    /// Any other bus event (arbitration lost, transmit timeout, protocol violation, ...).
    pub other_events: u64,
}

impl BusCounters {
    /// Counts one bus event.
    pub fn count_event(&mut self, event: BusEvent) {
        match event {
            BusEvent::BusOff => self.bus_off += 1,
            BusEvent::ErrorPassive | BusEvent::ErrorWarning => self.error_passive += 1,
            BusEvent::RxOverflow => self.rx_overflow += 1,
            _ => self.other_events += 1,
        }
    }
}

/// Everything the loop measures. Sized at start; recording and copying never allocate.
#[derive(Clone, Debug)]
pub struct LoopStats {
    /// Ticks run (counted when each starts, so per-tick histograms of a snapshot agree with it).
    pub ticks: u64,
    /// Ticks whose work ended after the next tick was due.
    pub deadline_misses: u64,
    /// Ticks skipped by the `skip` overrun policy.
    pub skipped_ticks: u64,
    /// Ticks that missed their deadline or ended without fresh feedback from every motor
    /// (counted once each; skipped ticks are not among them).
    pub missed_ticks: u64,
    /// Telemetry samples dropped because the telemetry queue was full (only when something
    /// receives the telemetry).
    pub telemetry_drops: u64,
    /// Commands for joints the robot does not have.
    pub unknown_joint_commands: u64,
    /// User signals written with an index the controller did not declare.
    pub unknown_signals: u64,
    /// Wake latency: actual wake time minus scheduled time.
    pub wake_latency: LatencyHistogram,
    /// Exchange round trip: first 0x280 sent to last reply received, ticks with every reply only.
    pub round_trip: LatencyHistogram,
    /// Time spent in the controller's `update`.
    pub controller: LatencyHistogram,
    /// Total work of a tick: wake to end of the tick's work.
    pub work: LatencyHistogram,
    /// What the loop adds to each exchange: from the tick's last reply (its receive time) to the
    /// end of the tick's work, when the loop is ready to send the next frame. Ticks with every
    /// reply only.
    pub loop_added: LatencyHistogram,
    /// Per motor, in robot-description order.
    pub motors: Vec<MotorCounters>,
    /// Per bus, in robot-description order.
    pub buses: Vec<BusCounters>,
    /// The joints' names, in description order.
    names: Vec<String>,
}

impl LoopStats {
    /// Empty statistics for the joints and buses of `robot`.
    pub fn new(robot: &Robot) -> Self {
        Self {
            ticks: 0,
            deadline_misses: 0,
            skipped_ticks: 0,
            missed_ticks: 0,
            telemetry_drops: 0,
            unknown_joint_commands: 0,
            unknown_signals: 0,
            wake_latency: LatencyHistogram::new(),
            round_trip: LatencyHistogram::new(),
            controller: LatencyHistogram::new(),
            work: LatencyHistogram::new(),
            loop_added: LatencyHistogram::new(),
            motors: robot
                .joints()
                .iter()
                .map(|j| MotorCounters::new(j.bus, j.motor))
                .collect(),
            buses: vec![BusCounters::default(); robot.buses().len()],
            names: robot.joints().iter().map(|j| j.name.clone()).collect(),
        }
    }

    /// Overwrites `self` with `other` (same motors and buses) without allocating.
    pub fn copy_from(&mut self, other: &LoopStats) {
        self.ticks = other.ticks;
        self.deadline_misses = other.deadline_misses;
        self.skipped_ticks = other.skipped_ticks;
        self.missed_ticks = other.missed_ticks;
        self.telemetry_drops = other.telemetry_drops;
        self.unknown_joint_commands = other.unknown_joint_commands;
        self.unknown_signals = other.unknown_signals;
        self.wake_latency.copy_from(&other.wake_latency);
        self.round_trip.copy_from(&other.round_trip);
        self.controller.copy_from(&other.controller);
        self.work.copy_from(&other.work);
        self.loop_added.copy_from(&other.loop_added);
        if self.motors.len() == other.motors.len() {
            self.motors.copy_from_slice(&other.motors);
        }
        if self.buses.len() == other.buses.len() {
            self.buses.copy_from_slice(&other.buses);
        }
    }

    /// Missing replies summed over all motors.
    pub fn missing_replies(&self) -> u64 {
        self.motors.iter().map(|m| m.missing_replies).sum()
    }

    /// Late replies summed over all motors.
    pub fn late_replies(&self) -> u64 {
        self.motors.iter().map(|m| m.late_replies).sum()
    }

    /// A serialisable summary (the JSON report's statistics part).
    pub fn summary(&self) -> StatsSummary {
        StatsSummary {
            ticks: self.ticks,
            deadline_misses: self.deadline_misses,
            skipped_ticks: self.skipped_ticks,
            missed_ticks: self.missed_ticks,
            missing_replies: self.missing_replies(),
            late_replies: self.late_replies(),
            telemetry_drops: self.telemetry_drops,
            unknown_joint_commands: self.unknown_joint_commands,
            unknown_signals: self.unknown_signals,
            wake_latency_us: self.wake_latency.percentiles(),
            round_trip_us: self.round_trip.percentiles(),
            controller_us: self.controller.percentiles(),
            work_us: self.work.percentiles(),
            loop_added_us: self.loop_added.percentiles(),
            motors: self
                .motors
                .iter()
                .zip(&self.names)
                .map(|(counters, name)| JointCounters {
                    joint: name.clone(),
                    counters: *counters,
                })
                .collect(),
            buses: self.buses.clone(),
        }
    }
}

/// One joint's counters, with its name.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct JointCounters {
    /// The joint's name.
    pub joint: String,
    /// Its motor's counters.
    #[serde(flatten)]
    pub counters: MotorCounters,
}

/// The statistics of a run in a form ready to print or serialise.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StatsSummary {
    /// Ticks run.
    pub ticks: u64,
    /// Ticks whose work ended after the next tick was due.
    pub deadline_misses: u64,
    /// Ticks skipped by the `skip` overrun policy.
    pub skipped_ticks: u64,
    /// Ticks that missed their deadline or a motor's fresh feedback.
    pub missed_ticks: u64,
    /// Missing replies, all motors.
    pub missing_replies: u64,
    /// Late replies, all motors.
    pub late_replies: u64,
    /// Telemetry samples dropped.
    pub telemetry_drops: u64,
    /// Commands for joints the robot does not have.
    pub unknown_joint_commands: u64,
    /// User signals written with an undeclared index.
    pub unknown_signals: u64,
    /// Wake latency percentiles, microseconds.
    pub wake_latency_us: Percentiles,
    /// Exchange round trip percentiles, microseconds.
    pub round_trip_us: Percentiles,
    /// Controller time percentiles, microseconds.
    pub controller_us: Percentiles,
    /// Work per tick percentiles, microseconds.
    pub work_us: Percentiles,
    /// What the loop adds per exchange (last reply to ready for the next frame), microseconds.
    pub loop_added_us: Percentiles,
    /// Per-joint counters.
    pub motors: Vec<JointCounters>,
    /// Per-bus counters.
    pub buses: Vec<BusCounters>,
}

impl StatsSummary {
    /// Commands clamped to a joint's current limit, over every joint.
    pub fn clamped_commands(&self) -> u64 {
        self.motors
            .iter()
            .map(|m| m.counters.clamped_commands)
            .sum()
    }
}

impl core::fmt::Display for StatsSummary {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        writeln!(
            f,
            "ticks {}   deadline misses {}   skipped {}   missing replies {}   late replies {}   telemetry drops {}",
            self.ticks,
            self.deadline_misses,
            self.skipped_ticks,
            self.missing_replies,
            self.late_replies,
            self.telemetry_drops
        )?;
        writeln!(
            f,
            "{:<14}{:>10}{:>10}{:>10}{:>10}{:>10}{:>10}",
            "(us)", "min", "p50", "p90", "p99", "p99.9", "max"
        )?;
        for (name, p) in [
            ("wake latency", &self.wake_latency_us),
            ("round trip", &self.round_trip_us),
            ("controller", &self.controller_us),
            ("work/tick", &self.work_us),
            ("loop added", &self.loop_added_us),
        ] {
            writeln!(
                f,
                "{:<14}{:>10.1}{:>10.1}{:>10.1}{:>10.1}{:>10.1}{:>10.1}",
                name, p.min, p.p50, p.p90, p.p99, p.p999, p.max
            )?;
        }
        if self.unknown_joint_commands + self.unknown_signals > 0 {
            writeln!(
                f,
                "commands for unknown joints {}   undeclared signals {}",
                self.unknown_joint_commands, self.unknown_signals
            )?;
        }
        for JointCounters { joint, counters: m } in &self.motors {
            writeln!(
                f,
                "{joint} (bus {} motor {}): missing {} late {} unexpected {} bad frames {} clamped {} rejected {} limited {} (longest gap {} ticks)",
                m.bus,
                m.motor.get(),
                m.missing_replies,
                m.late_replies,
                m.unexpected_replies,
                m.bad_frames,
                m.clamped_commands,
                m.rejected_commands,
                m.limited_commands,
                m.max_consecutive_missing
            )?;
        }
        for (i, b) in self.buses.iter().enumerate() {
            if *b != BusCounters::default() {
                writeln!(
                    f,
                    "bus {i}: tx errors {} rx errors {} unexpected frames {} bus-off {} error-passive {} rx overflow {} other events {}",
                    b.tx_errors,
                    b.rx_errors,
                    b.unexpected_frames,
                    b.bus_off,
                    b.error_passive,
                    b.rx_overflow,
                    b.other_events
                )?;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn us(n: u64) -> Duration {
        Duration::from_micros(n)
    }

    #[test]
    fn no_percentile_is_above_the_maximum() {
        // 3.000001 ms falls in a bucket whose highest value is above it.
        let mut h = LatencyHistogram::new();
        for _ in 0..10 {
            h.record(Duration::from_nanos(3_000_001));
        }
        let p = h.percentiles();
        assert!(
            p.min <= p.p50
                && p.p50 <= p.p90
                && p.p90 <= p.p99
                && p.p99 <= p.p999
                && p.p999 <= p.max,
            "{p:?}"
        );
        assert_eq!(p.max, 3000.001);
    }

    #[test]
    fn percentiles_of_a_known_distribution() {
        let mut h = LatencyHistogram::new();
        for i in 1..=1000 {
            h.record(us(i));
        }
        let p = h.percentiles();
        assert_eq!(p.count, 1000);
        // Three significant digits: within 0.1% of the exact order statistics.
        assert!((p.p50 - 500.0).abs() <= 0.5, "{p:?}");
        assert!((p.p90 - 900.0).abs() <= 0.9, "{p:?}");
        assert!((p.p99 - 990.0).abs() <= 1.0, "{p:?}");
        assert!((p.p999 - 999.0).abs() <= 1.0, "{p:?}");
        assert_eq!(p.max, 1000.0);
        assert!((p.min - 1.0).abs() < 0.01);
    }

    #[test]
    fn values_beyond_the_range_saturate_but_keep_the_exact_max() {
        let mut h = LatencyHistogram::new();
        h.record(Duration::from_secs(5));
        h.record(Duration::ZERO);
        let p = h.percentiles();
        assert_eq!(p.count, 2);
        assert_eq!(p.max, 5_000_000.0);
        assert!(p.p999 <= 1_000_000.0 * 1.001);
    }

    #[test]
    fn copy_from_reproduces_the_source() {
        let robot = Robot::try_from(crate::robot::RobotConfig::new(100.0).with_bus(
            crate::robot::BusConfig::new("can0").with_motor(crate::robot::MotorConfig::new(1)),
        ))
        .unwrap();
        let mut a = LoopStats::new(&robot);
        a.ticks = 7;
        a.motors[0].missing_replies = 3;
        a.buses[0].tx_errors = 2;
        a.missed_ticks = 4;
        for i in 0..100 {
            a.work.record(us(i));
            a.loop_added.record(us(i / 2));
        }
        let mut b = LoopStats::new(&robot);
        b.work.record(us(12345));
        b.copy_from(&a);
        assert_eq!(b.summary(), a.summary());
    }

    #[test]
    fn bus_events_are_counted_by_kind() {
        let mut c = BusCounters::default();
        c.count_event(BusEvent::BusOff);
        c.count_event(BusEvent::ErrorPassive);
        c.count_event(BusEvent::ErrorWarning);
        c.count_event(BusEvent::ArbitrationLost);
        assert_eq!((c.bus_off, c.error_passive, c.other_events), (1, 2, 1));
    }
}
