//! `/diagnostics`: once per second of run time, the health of the loop and of each motor over
//! that second, as a `diagnostic_msgs/msg/DiagnosticArray`.
//!
//! Levels:
//! - loop: WARN when the second had a deadline miss or a missing reply, else OK;
//! - motor: STALE when it never replied or its last reply is over a second old; ERROR when its
//!   error flags are set; WARN when it replied in fewer than 95 % of the second's ticks; else OK.

use std::fmt::Write as _;

use rmd_protocol::ErrorState;

use crate::layout::RunLayout;
use crate::record::{MAX_JOINTS, TickRecord};
use crate::ros2::{DiagnosticStatus, KeyValue, Level};

/// The diagnostics period (ns of run time).
const PERIOD_NS: u64 = 1_000_000_000;

/// Below this share of fresh ticks in a window, a motor is WARN.
const FRESH_WARN_BELOW: f64 = 0.95;

/// A reply older than this makes a motor STALE (µs).
const STALE_AFTER_US: u32 = 1_000_000;

/// The running window of one diagnostics period.
#[derive(Debug, Clone)]
struct Window {
    start_ns: u64,
    ticks: u64,
    max_wake_us: f64,
    max_work_us: f64,
    max_controller_us: f64,
    max_round_trip_us: Option<f64>,
    fresh: [u64; MAX_JOINTS],
}

impl Window {
    fn new(start_ns: u64) -> Self {
        Self {
            start_ns,
            ticks: 0,
            max_wake_us: 0.0,
            max_work_us: 0.0,
            max_controller_us: 0.0,
            max_round_trip_us: None,
            fresh: [0; MAX_JOINTS],
        }
    }

    fn add(&mut self, record: &TickRecord) {
        let t = &record.timing;
        self.ticks += 1;
        self.max_wake_us = self.max_wake_us.max(t.wake_latency_us);
        self.max_work_us = self.max_work_us.max(t.work_us);
        self.max_controller_us = self.max_controller_us.max(t.controller_us);
        if let Some(rt) = t.round_trip_us {
            self.max_round_trip_us = Some(self.max_round_trip_us.map_or(rt, |m| m.max(rt)));
        }
        for (count, joint) in self.fresh.iter_mut().zip(&record.joints) {
            *count += u64::from(joint.is_fresh());
        }
    }
}

/// Cumulative counters at a window's boundary.
#[derive(Debug, Clone, Copy, Default)]
struct Totals {
    misses: u64,
    missing_replies: u64,
    late_replies: u64,
}

/// Accumulates records and yields one diagnostics message per second of run time.
#[derive(Debug, Clone)]
pub(crate) struct Health {
    window: Option<Window>,
    before: Totals,
    last: Option<TickRecord>,
}

impl Health {
    pub(crate) fn new() -> Self {
        Self {
            window: None,
            before: Totals::default(),
            last: None,
        }
    }

    /// Adds `record`; returns the statuses of the period it completes, if it completes one.
    pub(crate) fn observe(
        &mut self,
        layout: &RunLayout,
        record: &TickRecord,
    ) -> Option<Vec<DiagnosticStatus>> {
        let window = self
            .window
            .get_or_insert_with(|| Window::new(record.since_start_ns));
        window.add(record);
        self.last = Some(*record);
        let elapsed = record.since_start_ns.saturating_sub(window.start_ns);
        // A window holds the ticks of one period: it closes on the last tick before the next
        // period starts, i.e. when one more tick would reach it.
        let tick_ns = (1e9 / layout.rate_hz()) as u64;
        (elapsed + tick_ns >= PERIOD_NS).then(|| self.close(layout))
    }

    /// The statuses of the unfinished period, if it has any tick (for the end of a run).
    pub(crate) fn flush(&mut self, layout: &RunLayout) -> Option<Vec<DiagnosticStatus>> {
        self.window.as_ref()?;
        Some(self.close(layout))
    }

    fn close(&mut self, layout: &RunLayout) -> Vec<DiagnosticStatus> {
        let (Some(window), Some(last)) = (self.window.take(), self.last.as_ref()) else {
            return Vec::new();
        };
        let t = &last.timing;
        let now = Totals {
            misses: t.misses,
            missing_replies: t.missing_replies,
            late_replies: t.late_replies,
        };
        let before = std::mem::replace(&mut self.before, now);
        let mut statuses = Vec::with_capacity(1 + layout.joints().len());
        statuses.push(loop_status(layout, &window, last, before, now));
        for (i, info) in layout.joints().iter().enumerate() {
            let joint = &last.joints[i];
            let fresh_share = window.fresh[i] as f64 / window.ticks.max(1) as f64;
            let (level, message) = motor_level(
                joint.reply.map(|r| r.micros),
                joint.error_flags,
                fresh_share,
            );
            let mut values = vec![kv("fresh_percent", format!("{:.1}", fresh_share * 100.0))];
            if joint.has_reply() {
                values.push(kv("temperature_c", joint.temperature_c));
                values.push(kv("current_a", joint.current_a));
                if let Some(v) = joint.voltage_v {
                    values.push(kv("voltage_v", v));
                }
            }
            values.push(kv("commanded_a", joint.commanded_a));
            if let Some(reply) = joint.reply {
                values.push(kv("reply_age_ticks", reply.ticks));
                values.push(kv("reply_age_us", reply.micros));
            }
            if let Some(flags) = joint.error_flags {
                values.push(kv("error_flags", format!("0x{:02x}", flags.raw())));
            }
            statuses.push(DiagnosticStatus {
                level: level as u8,
                name: format!("rmd_rt: {}", info.name()),
                message,
                hardware_id: format!("bus{}/motor{}", info.bus(), info.motor()),
                values,
            });
        }
        statuses
    }
}

fn kv(key: &str, value: impl ToString) -> KeyValue {
    KeyValue {
        key: key.to_owned(),
        value: value.to_string(),
    }
}

fn loop_status(
    layout: &RunLayout,
    window: &Window,
    last: &TickRecord,
    before: Totals,
    now: Totals,
) -> DiagnosticStatus {
    let misses = now.misses.saturating_sub(before.misses);
    let missing = now.missing_replies.saturating_sub(before.missing_replies);
    let late = now.late_replies.saturating_sub(before.late_replies);
    let span_s = (last.since_start_ns.saturating_sub(window.start_ns)) as f64 * 1e-9
        + 1.0 / layout.rate_hz();
    let (level, message) = if misses == 0 && missing == 0 {
        (Level::Ok, "ok".to_owned())
    } else {
        (
            Level::Warn,
            format!("{misses} deadline misses, {missing} missing replies in {span_s:.2} s"),
        )
    };
    let mut values = vec![
        kv("ticks", window.ticks),
        kv("rate_hz", format!("{:.1}", window.ticks as f64 / span_s)),
        kv("deadline_misses", misses),
        kv("missing_replies", missing),
        kv("late_replies", late),
        kv("deadline_misses_total", now.misses),
        kv("missing_replies_total", now.missing_replies),
        kv("late_replies_total", now.late_replies),
        kv("wake_latency_max_us", format!("{:.1}", window.max_wake_us)),
        kv(
            "controller_max_us",
            format!("{:.1}", window.max_controller_us),
        ),
        kv("work_max_us", format!("{:.1}", window.max_work_us)),
    ];
    if let Some(rt) = window.max_round_trip_us {
        values.push(kv("round_trip_max_us", format!("{rt:.1}")));
    }
    DiagnosticStatus {
        level: level as u8,
        name: "rmd_rt: loop".to_owned(),
        message,
        hardware_id: "loop".to_owned(),
        values,
    }
}

fn motor_level(
    reply_age_us: Option<u32>,
    flags: Option<ErrorState>,
    fresh_share: f64,
) -> (Level, String) {
    match reply_age_us {
        None => return (Level::Stale, "no reply from the motor yet".to_owned()),
        Some(us) if us > STALE_AFTER_US => {
            return (
                Level::Stale,
                format!("no reply for {:.1} s", f64::from(us) * 1e-6),
            );
        }
        Some(_) => {}
    }
    if let Some(flags) = flags.filter(|f| !f.is_clear()) {
        let mut message = String::new();
        if flags.low_voltage() {
            message.push_str("low voltage; ");
        }
        if flags.over_temperature() {
            message.push_str("over temperature; ");
        }
        if flags.unknown_bits() != 0 {
            let _ = write!(
                message,
                "unknown error bits 0x{:02x}; ",
                flags.unknown_bits()
            );
        }
        let message = message.trim_end_matches("; ").to_owned();
        return (Level::Error, message);
    }
    if fresh_share < FRESH_WARN_BELOW {
        return (
            Level::Warn,
            format!("replied in {:.1} % of ticks", fresh_share * 100.0),
        );
    }
    (Level::Ok, "ok".to_owned())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::layout::JointInfo;
    use crate::record::{JointRecord, ReplyAge};
    use rmd_protocol::MotorId;

    fn layout() -> RunLayout {
        RunLayout::builder(100.0)
            .joint(JointInfo::new("a", 0, MotorId::new(1).unwrap()))
            .joint(JointInfo::new("b", 0, MotorId::new(2).unwrap()))
            .joint(JointInfo::new("c", 0, MotorId::new(3).unwrap()))
            .build()
            .unwrap()
    }

    fn record(tick: u64) -> TickRecord {
        let mut r = TickRecord::new(tick, tick * 10_000_000, 0);
        r.joints[0] = JointRecord {
            reply: Some(ReplyAge::fresh(100)),
            temperature_c: 30.0,
            ..JointRecord::EMPTY
        };
        r.joints[1] = JointRecord {
            reply: Some(ReplyAge::fresh(100)),
            error_flags: Some(ErrorState::LOW_VOLTAGE),
            ..JointRecord::EMPTY
        };
        r
    }

    #[test]
    fn one_message_per_second_of_run_time_with_levels_per_motor() {
        let layout = layout();
        let mut health = Health::new();
        let mut emitted = Vec::new();
        for tick in 0..250 {
            let mut r = record(tick);
            if tick >= 150 {
                r.timing.misses = 1; // cumulative: one miss at tick 150
            }
            if let Some(statuses) = health.observe(&layout, &r) {
                emitted.push((tick, statuses));
            }
        }
        // 100 ticks per second: windows close on ticks 99 and 199.
        assert_eq!(
            emitted.iter().map(|(t, _)| *t).collect::<Vec<_>>(),
            [99, 199]
        );
        let first = &emitted[0].1;
        assert_eq!(first.len(), 4);
        assert_eq!(first[0].level, Level::Ok as u8);
        assert_eq!(first[1].level, Level::Ok as u8);
        assert_eq!(first[2].level, Level::Error as u8);
        assert_eq!(first[2].message, "low voltage");
        assert_eq!(first[3].level, Level::Stale as u8);
        assert_eq!(first[1].hardware_id, "bus0/motor1");
        let second = &emitted[1].1;
        assert_eq!(second[0].level, Level::Warn as u8, "{:?}", second[0]);
        assert!(second[0].values.contains(&kv("deadline_misses", 1)));
        let rest = health.flush(&layout).unwrap();
        assert!(rest[0].values.contains(&kv("ticks", 50)));
        assert!(rest[0].values.contains(&kv("deadline_misses", 0)));
        assert!(rest[0].values.contains(&kv("deadline_misses_total", 1)));
        assert!(health.flush(&layout).is_none());
    }

    #[test]
    fn a_motor_that_often_misses_is_warn() {
        let (level, message) = motor_level(Some(5000), None, 0.5);
        assert_eq!(level, Level::Warn);
        assert_eq!(message, "replied in 50.0 % of ticks");
        assert_eq!(motor_level(Some(2_000_000), None, 1.0).0, Level::Stale);
        assert_eq!(motor_level(Some(10), None, 1.0).0, Level::Ok);
    }
}
