//! What the loop measures about itself: latency histograms and event counters.
//!
//! A [`LatencyHistogram`] records in the tick with a handful of instructions and no branch on
//! the value: one counter per bucket, in a table sized once at start (so recording never
//! allocates), plus the exact count, sum, minimum and maximum. Its buckets are exactly those of
//! an [`hdrhistogram`] from 1 ns to 1 s with 3 significant digits (exact to the nanosecond below
//! 2,048 ns, never wider than 1/1024 of their values above); the report folds them into such a
//! histogram and asks it the percentiles, so they are what recording into the HdrHistogram
//! itself would give, except that a percentile never exceeds the exact maximum. Durations
//! longer than 1 s are counted in the last bucket; the maximum keeps their exact value. Copying
//! statistics into a snapshot of the same shape does not allocate either.

use core::time::Duration;

use hdrhistogram::Histogram;
use rmd_bus::BusEvent;
use rmd_protocol::MotorId;
use serde::Serialize;

use crate::robot::Robot;

/// Highest value a histogram resolves; longer durations are counted as this (1 s).
const HIGHEST_NANOS: u64 = 1_000_000_000;
/// Significant decimal digits kept by every histogram.
const SIGNIFICANT_DIGITS: u8 = 3;
/// log2 of the sub-buckets per power of two that [`SIGNIFICANT_DIGITS`] asks of an HdrHistogram:
/// the smallest power of two at least `2 * 10^3`.
const SUB_BUCKET_BITS: u32 = 11;
/// Half the sub-buckets: every power of two above the first has this many buckets.
const HALF_SUB_BUCKETS: usize = 1 << (SUB_BUCKET_BITS - 1);
/// Values below this have a bucket of their own (one nanosecond wide).
const EXACT_BELOW: u64 = 1 << SUB_BUCKET_BITS;
/// Counters in a histogram: `HALF_SUB_BUCKETS` per power of two up to the one holding
/// [`HIGHEST_NANOS`] (2^30), and twice that for the exact range below [`EXACT_BELOW`].
const BUCKETS: usize = (30 - SUB_BUCKET_BITS as usize + 2) * HALF_SUB_BUCKETS;

/// The bucket of `nanos` (1..=[`HIGHEST_NANOS`]): the same arithmetic as an HdrHistogram's index
/// with a unit of 1 ns. Branch-free, so a recording costs the same instructions for any value.
fn bucket_of(nanos: u64) -> usize {
    // Which power of two above the exact range (0 below it).
    let magnitude = 64 - (nanos | (EXACT_BELOW - 1)).leading_zeros() - SUB_BUCKET_BITS;
    let sub_bucket = (nanos >> magnitude) as usize;
    ((magnitude as usize) << (SUB_BUCKET_BITS - 1)) + sub_bucket
}

/// The lowest and highest value of bucket `index`, nanoseconds.
fn bucket_range(index: usize) -> (u64, u64) {
    if index < EXACT_BELOW as usize {
        return (index as u64, index as u64);
    }
    let magnitude = (index >> (SUB_BUCKET_BITS - 1)) - 1;
    let sub_bucket = (index & (HALF_SUB_BUCKETS - 1)) + HALF_SUB_BUCKETS;
    let lowest = (sub_bucket as u64) << magnitude;
    (lowest, lowest + (1u64 << magnitude) - 1)
}

/// A histogram of durations, in nanoseconds: fixed buckets counted in the tick, folded into an
/// HdrHistogram when asked for percentiles (see the [module](self) documentation).
#[derive(Clone, Debug)]
pub struct LatencyHistogram {
    /// One counter per bucket ([`bucket_of`]).
    counts: Box<[u64]>,
    count: u64,
    /// Sum of the recorded values, nanoseconds (beyond 1 s too).
    sum_nanos: u128,
    /// Smallest recorded value, nanoseconds (`u64::MAX` while empty).
    min_nanos: u64,
    /// Largest recorded value, nanoseconds (exact, even beyond the buckets' range).
    max_nanos: u64,
}

impl Default for LatencyHistogram {
    fn default() -> Self {
        Self::new()
    }
}

impl LatencyHistogram {
    /// An empty histogram (the only allocation it ever makes).
    pub fn new() -> Self {
        Self {
            counts: vec![0; BUCKETS].into_boxed_slice(),
            count: 0,
            sum_nanos: 0,
            min_nanos: u64::MAX,
            max_nanos: 0,
        }
    }

    /// Records one duration. Never allocates, never fails.
    pub fn record(&mut self, d: Duration) {
        self.record_nanos(u64::try_from(d.as_nanos()).unwrap_or(u64::MAX));
    }

    /// Records one duration given in nanoseconds. Never allocates, never fails, and costs the
    /// same instructions whatever the value.
    #[inline]
    pub fn record_nanos(&mut self, nanos: u64) {
        // Zero counts in the 1 ns bucket, as the HdrHistogram's lowest trackable value.
        let bucket = bucket_of(nanos.clamp(1, HIGHEST_NANOS));
        if let Some(counter) = self.counts.get_mut(bucket) {
            *counter += 1;
        }
        self.count += 1;
        self.sum_nanos += u128::from(nanos);
        self.min_nanos = self.min_nanos.min(nanos);
        self.max_nanos = self.max_nanos.max(nanos);
    }

    /// Number of recorded values.
    pub fn len(&self) -> u64 {
        self.count
    }

    /// Whether nothing was recorded.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// Forgets every recorded value.
    pub fn reset(&mut self) {
        self.counts.fill(0);
        self.count = 0;
        self.sum_nanos = 0;
        self.min_nanos = u64::MAX;
        self.max_nanos = 0;
    }

    /// Overwrites `self` with `other` without allocating.
    pub fn copy_from(&mut self, other: &LatencyHistogram) {
        self.counts.copy_from_slice(&other.counts);
        self.count = other.count;
        self.sum_nanos = other.sum_nanos;
        self.min_nanos = other.min_nanos;
        self.max_nanos = other.max_nanos;
    }

    /// The non-empty buckets: index and count.
    fn recorded(&self) -> impl Iterator<Item = (usize, u64)> + '_ {
        self.counts
            .iter()
            .enumerate()
            .filter(|&(_, &count)| count > 0)
            .map(|(index, &count)| (index, count))
    }

    /// The buckets folded into an HdrHistogram of the same bounds (allocates: for reports).
    fn folded(&self) -> Histogram<u64> {
        let mut histogram = Histogram::new_with_bounds(1, HIGHEST_NANOS, SIGNIFICANT_DIGITS)
            .expect("constant bounds are valid");
        for (index, count) in self.recorded() {
            // The bucket's lowest value lands in the same bucket of the HdrHistogram.
            histogram.saturating_record_n(bucket_range(index).0.max(1), count);
        }
        histogram
    }

    /// The summary the reports print, in microseconds. Percentiles come from the buckets (the
    /// highest value of the bucket holding the quantile, as an HdrHistogram reports it), never
    /// above the exact maximum; the minimum, mean and maximum are exact.
    pub fn percentiles(&self) -> Percentiles {
        if self.is_empty() {
            return Percentiles::default();
        }
        let histogram = self.folded();
        let us = |nanos: u64| nanos as f64 / 1_000.0;
        let q = |quantile: f64| us(histogram.value_at_quantile(quantile).min(self.max_nanos));
        Percentiles {
            count: self.count,
            min: us(self.min_nanos),
            mean: self.sum_nanos as f64 / self.count as f64 / 1_000.0,
            p50: q(0.50),
            p90: q(0.90),
            p99: q(0.99),
            p999: q(0.999),
            max: us(self.max_nanos),
        }
    }

    /// The non-empty buckets, for plots: each bucket's highest value in microseconds (as an
    /// HdrHistogram's iteration reports it) and its count, ascending.
    pub fn buckets_us(&self) -> impl Iterator<Item = (f64, u64)> + '_ {
        self.recorded()
            .map(|(index, count)| (bucket_range(index).1 as f64 / 1_000.0, count))
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
    /// Status replies (0x9A, the health rotation) received and read.
    pub status_replies: u64,
    /// Status requests given up without a reply (a newer one went out twice since): counted,
    /// never a fault by itself (its torque replies say whether the motor is there).
    pub missing_status_replies: u64,
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
            status_replies: 0,
            missing_status_replies: 0,
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
    /// Missing replies so far, all motors (counted with the per-motor counters, so the tick's
    /// telemetry need not sum them).
    pub(crate) missing_total: u64,
    /// Late replies so far, all motors (likewise).
    pub(crate) late_total: u64,
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
            missing_total: 0,
            late_total: 0,
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
        self.missing_total = other.missing_total;
        self.late_total = other.late_total;
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
                .map(|(counters, name)| NamedMotorCounters {
                    joint: name.clone(),
                    counters: *counters,
                })
                .collect(),
            buses: self.buses.clone(),
        }
    }
}

/// A motor's counters, with the name of its joint.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct NamedMotorCounters {
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
    /// Per-motor counters, each with its joint's name, in description order.
    pub motors: Vec<NamedMotorCounters>,
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
        for NamedMotorCounters { joint, counters: m } in &self.motors {
            writeln!(
                f,
                "{joint} (bus {} motor {}): missing {} late {} unexpected {} bad frames {} clamped {} rejected {} limited {} (longest gap {} ticks) status replies {} (missing {})",
                m.bus,
                m.motor.get(),
                m.missing_replies,
                m.late_replies,
                m.unexpected_replies,
                m.bad_frames,
                m.clamped_commands,
                m.rejected_commands,
                m.limited_commands,
                m.max_consecutive_missing,
                m.status_replies,
                m.missing_status_replies
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

    /// An HdrHistogram of the bounds the loop's histograms stand for.
    fn hdr() -> Histogram<u64> {
        Histogram::new_with_bounds(1, HIGHEST_NANOS, SIGNIFICANT_DIGITS).unwrap()
    }

    /// Values spread over the whole range: every power of two, its neighbours, and a
    /// pseudo-random sweep.
    fn spread() -> Vec<u64> {
        let mut values: Vec<u64> = (0..=30)
            .flat_map(|p| {
                let v = 1u64 << p;
                [v - 1, v, v + 1, v + v / 3]
            })
            .collect();
        let mut x = 0x2545_f491_4f6c_dd1du64;
        for _ in 0..20_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            // Log-uniform from 1 ns to 1 s.
            values.push(1 + (x >> 34) % (1u64 << ((x & 31) as u32 % 30 + 1)));
        }
        values.retain(|&v| (1..=HIGHEST_NANOS).contains(&v));
        values
    }

    #[test]
    fn the_buckets_are_those_of_the_hdr_histogram() {
        let reference = hdr();
        for v in spread() {
            let (low, high) = bucket_range(bucket_of(v));
            assert_eq!(low, reference.lowest_equivalent(v), "{v}");
            assert_eq!(high, reference.highest_equivalent(v), "{v}");
            assert!(bucket_of(v) < BUCKETS);
        }
        assert!(bucket_of(HIGHEST_NANOS) < BUCKETS);
    }

    #[test]
    fn percentiles_are_the_hdr_histograms_own_capped_at_the_exact_max() {
        let mut h = LatencyHistogram::new();
        let mut reference = hdr();
        let values = spread();
        for &v in &values {
            h.record(Duration::from_nanos(v));
            reference.record(v).unwrap();
        }
        let p = h.percentiles();
        let max = *values.iter().max().unwrap();
        for (got, q) in [(p.p50, 0.5), (p.p90, 0.9), (p.p99, 0.99), (p.p999, 0.999)] {
            let expected = reference.value_at_quantile(q).min(max) as f64 / 1000.0;
            assert_eq!(got, expected, "quantile {q}");
        }
        assert_eq!(p.max, max as f64 / 1000.0);
        assert_eq!(p.min, *values.iter().min().unwrap() as f64 / 1000.0);
        let mean = values.iter().map(|&v| v as f64).sum::<f64>() / values.len() as f64;
        assert!((p.mean - mean / 1000.0).abs() < 1e-6 * p.mean, "{p:?}");
        // The plot's buckets are the HdrHistogram's recorded buckets.
        let ours: Vec<_> = h.buckets_us().collect();
        let theirs: Vec<_> = reference
            .iter_recorded()
            .map(|v| (v.value_iterated_to() as f64 / 1000.0, v.count_at_value()))
            .collect();
        assert_eq!(ours, theirs);
    }

    #[test]
    fn a_percentile_never_exceeds_the_maximum() {
        // 1,000,123 ns lies in a bucket 512 ns wide whose highest value is 1,000,447 ns.
        let mut h = LatencyHistogram::new();
        h.record(Duration::from_nanos(1_000_123));
        let p = h.percentiles();
        assert_eq!((p.p50, p.p999, p.max), (1000.123, 1000.123, 1000.123));
        h.reset();
        assert!(h.is_empty());
        assert_eq!(h.percentiles(), Percentiles::default());
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
