//! The loop's samples as telemetry records: [`RecordAssembler`] turns each
//! [`TelemetrySample`](rmd_loop::telemetry::TelemetrySample) into a [`TickRecord`], on the
//! telemetry side (never on the loop thread).
//!
//! The loop publishes a tick's sample before the tick ends, so a sample carries the *previous*
//! tick's work time and deadline count. The assembler holds each record until the next sample
//! arrives and completes it from there: a record's `work_us`, `deadline_missed` and `misses` are
//! its own tick's. When the next sample is not the next tick's (a sample was lost between the
//! loop and the telemetry), or at the end of the run, they are unknown: `work_us` is NaN
//! (written as "no value") and `misses` the count before the tick.

use rmd_loop::{
    Freshness,
    telemetry::{JointSample, TelemetrySample},
};
use rmd_telemetry::{JointRecord, LoopTiming, MAX_JOINTS, MAX_SIGNALS, ReplyAge, TickRecord};

/// Nanoseconds to microseconds.
fn us(ns: u64) -> f64 {
    ns as f64 * 1e-3
}

/// One joint of a sample as a telemetry record (rmd-rig's record assembler and the Python package's
/// both use this one). The reply's age is counted at `taken_at`, when the sample was taken
/// (after the tick's replies were collected): ticks by the loop's freshness, microseconds since
/// the reply was received. A joint whose motor never answered has no reply age.
pub fn joint_record(joint: &JointSample, taken_at: rmd_bus::Timestamp) -> JointRecord {
    let f = &joint.feedback;
    let ticks = match f.freshness {
        Freshness::Fresh { .. } => 0,
        Freshness::Late { age_ticks } => age_ticks.max(1),
        Freshness::Missing { ticks_since_reply } => ticks_since_reply.max(1),
    };
    let reply = (f.received_at != rmd_bus::Timestamp::ZERO).then(|| {
        let micros = taken_at
            .checked_duration_since(f.received_at)
            .map_or(0, |age| u32::try_from(age.as_micros()).unwrap_or(u32::MAX));
        ReplyAge { ticks, micros }
    });
    JointRecord {
        position_rad: f.joint.angle_rad(),
        velocity_rad_s: f.joint.velocity_rad_s(),
        effort_nm: f.joint.torque_nm,
        current_a: f.motor.current_amps,
        commanded_a: joint.command_amps,
        temperature_c: f.motor.temperature_celsius,
        // From the motor's latest status reply (the health rotation), when its bus carries it.
        voltage_v: f.health.map(|h| h.voltage_volts),
        error_flags: f.health.map(|h| h.error_flags.as_byte()),
        reply,
    }
}

/// A sample as a record, with the timing only the next sample completes left unknown.
pub(crate) fn record_of(sample: &TelemetrySample) -> TickRecord {
    let since_start_ns = sample
        .scheduled
        .checked_duration_since(sample.start)
        .map_or(0, |d| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX));
    let mut record = TickRecord::new(sample.tick, since_start_ns, sample.scheduled.as_nanos());
    for (slot, joint) in record.joints.iter_mut().zip(sample.joints()) {
        *slot = joint_record(joint, sample.taken_at);
    }
    let times = &sample.times;
    let totals = &sample.totals;
    record.timing = LoopTiming {
        wake_latency_us: us(times.wake_latency_ns),
        round_trip_us: times.round_trip_ns.map(us),
        controller_us: us(times.controller_ns),
        work_us: f64::NAN,
        deadline_missed: false,
        misses: totals.deadline_misses,
        missing_replies: totals.missing_replies,
        late_replies: totals.late_replies,
    };
    let signals = sample.signals();
    record.signals[..signals.len().min(MAX_SIGNALS)]
        .copy_from_slice(&signals[..signals.len().min(MAX_SIGNALS)]);
    record
}

/// Turns samples into records, each completed by the sample after it (see the module docs).
///
/// ```
/// use rmd_loop::telemetry::TelemetrySample;
/// use rmd_rig::telemetry::RecordAssembler;
///
/// let mut assembler = RecordAssembler::new();
/// let mut sample = TelemetrySample::new(1, 0);
/// sample.totals.ticks = 1;
/// assert!(assembler.push(&sample).is_none(), "held until the next sample");
/// sample.tick = 1;
/// sample.totals.ticks = 2;
/// sample.times.previous_work_ns = 250_000;
/// let first = assembler.push(&sample).unwrap();
/// assert_eq!((first.tick, first.timing.work_us), (0, 250.0));
/// let last = assembler.finish().unwrap();
/// assert!(last.timing.work_us.is_nan(), "nothing came after it");
/// ```
#[derive(Debug, Default)]
pub struct RecordAssembler {
    held: Option<Held>,
    lost: u64,
}

/// A record waiting for the sample after it.
#[derive(Debug)]
struct Held {
    record: TickRecord,
    ticks: u64,
}

impl RecordAssembler {
    /// An assembler with nothing held.
    pub fn new() -> Self {
        Self::default()
    }

    /// Takes the next sample; returns the previous sample's record, now complete.
    pub fn push(&mut self, sample: &TelemetrySample) -> Option<TickRecord> {
        let next = Held {
            record: record_of(sample),
            ticks: sample.totals.ticks,
        };
        let done = self.held.replace(next)?;
        let mut record = done.record;
        let gap = sample.totals.ticks.saturating_sub(done.ticks);
        if gap == 1 {
            let timing = &mut record.timing;
            timing.work_us = us(sample.times.previous_work_ns);
            timing.deadline_missed = sample.totals.deadline_misses > timing.misses;
            timing.misses = sample.totals.deadline_misses;
        } else {
            self.lost += gap.saturating_sub(1);
        }
        Some(record)
    }

    /// The last record, with what only a later sample would tell left unknown.
    pub fn finish(&mut self) -> Option<TickRecord> {
        self.held.take().map(|held| held.record)
    }

    /// Samples missing between the ones pushed (ticks the loop ran whose sample never came).
    pub fn lost(&self) -> u64 {
        self.lost
    }
}

const _: () = assert!(MAX_JOINTS >= rmd_loop::robot::MAX_JOINTS);
const _: () = assert!(MAX_SIGNALS >= rmd_loop::MAX_SIGNALS);

#[cfg(test)]
mod tests {
    use core::time::Duration;

    use rmd_bus::Timestamp;
    use rmd_loop::telemetry::TelemetrySample;

    use super::*;

    /// Tick `k` of a 1 kHz run started at 5 s, with `misses` deadline misses before it and the
    /// previous tick's work `work_us`.
    fn sample(k: u64, misses: u64, work_us: u64) -> TelemetrySample {
        let start = Timestamp::from_nanos(5_000_000_000);
        let mut s = TelemetrySample::new(2, 1);
        s.tick = k;
        s.start = start;
        s.scheduled = start + Duration::from_millis(k);
        s.taken_at = s.scheduled + Duration::from_micros(900);
        s.time_s = k as f64 * 1e-3;
        s.totals.ticks = k + 1;
        s.totals.deadline_misses = misses;
        s.times.previous_work_ns = work_us * 1000;
        s.times.wake_latency_ns = 12_000;
        s.times.controller_ns = 3_500;
        s.times.round_trip_ns = Some(800_000);
        s.signals_mut()[0] = k as f64;
        let j = &mut s.joints_mut()[0];
        j.feedback.joint.angle_deg = 90.0;
        j.feedback.joint.velocity_dps = -180.0;
        j.feedback.joint.torque_nm = Some(1.5);
        j.feedback.motor.current_amps = 0.75;
        j.feedback.motor.temperature_celsius = 31.0;
        j.feedback.freshness = Freshness::Fresh { age_ticks: 0 };
        j.command_amps = 0.5;
        let received = s.scheduled + Duration::from_micros(800);
        s.joints_mut()[0].feedback.received_at = received;
        let earlier = s.scheduled.saturating_sub(Duration::from_millis(2));
        let k2 = &mut s.joints_mut()[1];
        k2.feedback.freshness = Freshness::Missing {
            ticks_since_reply: 3,
        };
        k2.feedback.received_at = earlier;
        // The second motor's status reply (health rotation): 23.6 V, MyActuator V3's
        // low-voltage flag.
        k2.feedback.health = Some(rmd_loop::MotorHealth {
            voltage_volts: 23.6,
            temperature_celsius: 33.0,
            error_flags: rmd_loop::ErrorFlags::V3(rmd_protocol::V3ErrorState::LOW_VOLTAGE),
            requested_tick: k.saturating_sub(2),
        });
        s
    }

    #[test]
    fn a_record_carries_the_sample_in_si_units() {
        let record = record_of(&sample(7, 0, 0));
        assert_eq!(record.tick, 7);
        assert_eq!(record.since_start_ns, 7_000_000);
        assert_eq!(record.monotonic_ns, 5_007_000_000);
        let knee = &record.joints[0];
        assert!((knee.position_rad - core::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert!((knee.velocity_rad_s + core::f64::consts::PI).abs() < 1e-12);
        assert_eq!(knee.effort_nm, Some(1.5));
        assert_eq!((knee.current_a, knee.commanded_a), (0.75, 0.5));
        assert_eq!(knee.temperature_c, 31.0);
        // No status reply yet: neither is known.
        assert_eq!((knee.voltage_v, knee.error_flags), (None, None));
        assert_eq!(knee.reply, Some(ReplyAge::fresh(100)));
        let stale = &record.joints[1];
        // From its status reply, in the error byte's terms (bit 0: low voltage).
        assert_eq!(stale.voltage_v, Some(23.6));
        assert_eq!(
            stale.error_flags,
            Some(rmd_protocol::ErrorState::LOW_VOLTAGE)
        );
        assert_eq!(
            stale.reply,
            Some(ReplyAge {
                ticks: 3,
                micros: 2900
            })
        );
        assert!(!stale.is_fresh());
        assert_eq!(record.joints[2], JointRecord::EMPTY, "beyond the robot");
        let t = &record.timing;
        assert_eq!(
            (t.wake_latency_us, t.controller_us, t.round_trip_us),
            (12.0, 3.5, Some(800.0))
        );
        assert_eq!(record.signals[..2], [7.0, 0.0]);
    }

    #[test]
    fn a_joint_whose_motor_never_answered_has_no_reply_age() {
        let mut s = sample(3, 0, 0);
        s.joints_mut()[1].feedback.received_at = Timestamp::ZERO;
        let record = record_of(&s);
        assert_eq!(record.joints[1].reply, None);
        assert_eq!(record.joints[0].reply, Some(ReplyAge::fresh(100)));
    }

    #[test]
    fn each_record_is_completed_by_the_next_tick_and_gaps_are_counted() {
        let mut assembler = RecordAssembler::new();
        assert!(assembler.push(&sample(0, 0, 0)).is_none());
        // Tick 0 took 400 us and missed its deadline: tick 1's sample says so.
        let r0 = assembler.push(&sample(1, 1, 400)).unwrap();
        assert_eq!(r0.tick, 0);
        assert_eq!(r0.timing.work_us, 400.0);
        assert!(r0.timing.deadline_missed);
        assert_eq!(r0.timing.misses, 1);
        // Tick 1 was on time.
        let r1 = assembler.push(&sample(2, 1, 300)).unwrap();
        assert_eq!(
            (r1.timing.work_us, r1.timing.deadline_missed),
            (300.0, false)
        );
        assert_eq!(r1.timing.misses, 1);
        // Ticks 3 and 4 never came: tick 2's own work is unknown.
        let r2 = assembler.push(&sample(5, 1, 200)).unwrap();
        assert_eq!(r2.tick, 2);
        assert!(r2.timing.work_us.is_nan() && !r2.timing.deadline_missed);
        assert_eq!(assembler.lost(), 2);
        let last = assembler.finish().unwrap();
        assert_eq!(last.tick, 5);
        assert!(last.timing.work_us.is_nan());
        assert!(assembler.finish().is_none());
    }
}
