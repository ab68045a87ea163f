//! The `diagnostics` message: the loop's timing, each motor's health, and the node's own
//! counters (what it published, accepted and rejected).

use std::time::{Duration, SystemTime};

use crate::msg::{DiagnosticArray, DiagnosticStatus, Header, KeyValue, Level, Time};
use crate::port::RobotDiagnostics;
use crate::stats::NodeStats;

fn kv(key: &str, value: impl ToString) -> KeyValue {
    KeyValue {
        key: key.to_owned(),
        value: value.to_string(),
    }
}

fn micros(d: Duration) -> String {
    format!("{:.1}", d.as_secs_f64() * 1e6)
}

/// Builds the message. `node` (the node's full name, e.g. `/leg/rmd_rt`) prefixes every
/// status name, so statuses of several nodes stay apart on the shared `/diagnostics`;
/// `last_rejection` is the text of the newest rejected input, if any.
pub fn diagnostic_array(
    node: &str,
    now: SystemTime,
    robot: &RobotDiagnostics,
    stats: &NodeStats,
    last_rejection: Option<&str>,
) -> DiagnosticArray {
    let t = &robot.timing;
    let mut loop_values = vec![
        kv("enabled", robot.enabled),
        kv("period_us", micros(t.period)),
        kv("cycles", t.cycles),
        kv("deadline_misses", t.deadline_misses),
        kv("missing_replies", t.missing_replies),
    ];
    for (key, value) in [
        ("wake_latency_p50_us", t.wake_latency_p50),
        ("wake_latency_p99_us", t.wake_latency_p99),
        ("wake_latency_max_us", t.wake_latency_max),
    ] {
        if let Some(v) = value {
            loop_values.push(kv(key, micros(v)));
        }
    }
    let loop_level = if !robot.enabled || t.deadline_misses > 0 || t.missing_replies > 0 {
        Level::Warn
    } else {
        Level::Ok
    };
    let mut status = vec![DiagnosticStatus {
        level: loop_level as u8,
        name: format!("{node}: loop"),
        message: format!(
            "{}; {} cycles, {} deadline misses, {} missing replies",
            if robot.enabled { "enabled" } else { "estopped" },
            t.cycles,
            t.deadline_misses,
            t.missing_replies
        ),
        hardware_id: String::new(),
        values: loop_values,
    }];
    for m in &robot.motors {
        let mut values = Vec::with_capacity(3);
        if let Some(c) = m.temperature_c {
            values.push(kv("temperature_c", c));
        }
        if let Some(v) = m.voltage_v {
            values.push(kv("voltage_v", v));
        }
        values.push(kv("faults", m.faults.join(", ")));
        let (level, message) = if m.faults.is_empty() {
            (Level::Ok, "ok".to_owned())
        } else {
            (Level::Error, m.faults.join(", "))
        };
        status.push(DiagnosticStatus {
            level: level as u8,
            name: format!("{node}: motor {}", m.joint),
            message,
            hardware_id: m.hardware_id.clone(),
            values,
        });
    }
    let mut values = vec![
        kv("joint_states_published", stats.joint_states_published),
        kv("publish_errors", stats.publish_errors),
        kv("commands_accepted", stats.commands_accepted),
        kv("trajectories_accepted", stats.trajectories_accepted),
        kv("enables_accepted", stats.enables_accepted),
        kv("rejected_total", stats.rejected_total()),
    ];
    for (kind, n) in stats.rejections {
        values.push(kv(&format!("rejected_{}", kind.name()), n));
    }
    if let Some(text) = last_rejection {
        values.push(kv("last_rejection", text));
    }
    let rejected = stats.rejected_total();
    status.push(DiagnosticStatus {
        level: if rejected > 0 { Level::Warn } else { Level::Ok } as u8,
        name: format!("{node}: ros2 inputs"),
        message: match last_rejection {
            Some(text) => format!("{rejected} inputs rejected, the last: {text}"),
            None => format!("{rejected} inputs rejected"),
        },
        hardware_id: String::new(),
        values,
    });
    DiagnosticArray {
        header: Header {
            stamp: Time::from_system_time(now),
            frame_id: String::new(),
        },
        status,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::port::{LoopTiming, MotorDiagnostics};
    use crate::stats::Counters;
    use crate::validate::RejectionKind;

    fn value<'a>(s: &'a DiagnosticStatus, key: &str) -> &'a str {
        &s.values.iter().find(|kv| kv.key == key).unwrap().value
    }

    #[test]
    fn carries_timing_motors_and_rejection_counts() {
        let robot = RobotDiagnostics {
            timing: LoopTiming {
                period: Duration::from_micros(1000),
                cycles: 5000,
                deadline_misses: 2,
                missing_replies: 1,
                wake_latency_p99: Some(Duration::from_nanos(12_300)),
                ..LoopTiming::default()
            },
            enabled: true,
            motors: vec![
                MotorDiagnostics {
                    joint: "hip".into(),
                    hardware_id: "can0:0x141".into(),
                    temperature_c: Some(41.0),
                    voltage_v: Some(24.5),
                    faults: vec![],
                },
                MotorDiagnostics {
                    joint: "knee".into(),
                    hardware_id: "can0:0x142".into(),
                    temperature_c: None,
                    voltage_v: None,
                    faults: vec!["over temperature".into()],
                },
            ],
        };
        let c = Counters::default();
        c.rejected(RejectionKind::UnknownJoint);
        let a = diagnostic_array(
            "/rmd_rt",
            SystemTime::UNIX_EPOCH,
            &robot,
            &c.snapshot(),
            Some("unknown joint \"elbow\""),
        );
        assert_eq!(a.status.len(), 4);
        let l = &a.status[0];
        assert_eq!(l.name, "/rmd_rt: loop");
        assert_eq!(l.level, Level::Warn as u8);
        assert_eq!(value(l, "period_us"), "1000.0");
        assert_eq!(value(l, "deadline_misses"), "2");
        assert_eq!(value(l, "wake_latency_p99_us"), "12.3");
        assert!(l.values.iter().all(|kv| kv.key != "wake_latency_p50_us"));
        assert_eq!(a.status[1].hardware_id, "can0:0x141");
        assert_eq!(value(&a.status[1], "temperature_c"), "41");
        assert_eq!(a.status[1].level, Level::Ok as u8);
        assert_eq!(a.status[2].level, Level::Error as u8);
        assert_eq!(a.status[2].message, "over temperature");
        let inputs = &a.status[3];
        assert_eq!(inputs.name, "/rmd_rt: ros2 inputs");
        assert_eq!(value(inputs, "rejected_unknown_joint"), "1");
        assert_eq!(value(inputs, "rejected_total"), "1");
        assert_eq!(inputs.level, Level::Warn as u8);
        assert_eq!(value(inputs, "last_rejection"), "unknown joint \"elbow\"");
        assert!(inputs.message.starts_with("1 inputs rejected"));
    }
}
