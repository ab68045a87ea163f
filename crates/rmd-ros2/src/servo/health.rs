//! The servo port's diagnostics: the loop's timing and end from the [`LoopFeed`](super::LoopFeed),
//! each motor's health from the servo's newest state and the loop's per-motor counters.

use std::time::Duration;

use rmd_loop::stats::{Percentiles, StatsSummary};
use rmd_servo::{JointStatus, ServoHandle, ServoState};

use super::feed::{LoopEnded, LoopFeed};
use crate::port::{JointInfo, LoopEnd, LoopTiming, MotorDiagnostics, RobotDiagnostics};

/// One motor as the diagnostics describe it.
#[derive(Clone, Debug)]
pub(super) struct Motor {
    pub(super) bus: usize,
    pub(super) id: u8,
    pub(super) can_id: u16,
    pub(super) temperature_limit_c: Option<f64>,
}

/// What the diagnostics are made of.
pub(super) struct Sources<'a> {
    pub(super) handle: &'a ServoHandle,
    pub(super) joints: &'a [JointInfo],
    pub(super) motors: &'a [Motor],
    pub(super) bus_labels: &'a [String],
    pub(super) period: Duration,
    pub(super) feed: &'a LoopFeed,
    pub(super) last_trajectory: Option<&'a str>,
}

/// How close to its limit a motor's temperature is worth a warning, °C.
pub(crate) const TEMPERATURE_MARGIN_C: f64 = 10.0;

/// What the diagnostics say about the supply voltage when no status reply brought it.
pub(crate) const VOLTAGE_NOT_MEASURED: &str = "not measured: the loop's torque reply (0xA1) \
    carries no supply voltage, and its bus has no room for the health rotation's status \
    requests at this rate (or loop.health_rotation = false); `rmd status` reads it while no \
    loop runs";

fn us(d: f64) -> Option<Duration> {
    (d.is_finite() && d >= 0.0).then(|| Duration::from_secs_f64(d * 1e-6))
}

fn kv(key: &str, value: impl ToString) -> (String, String) {
    (key.to_owned(), value.to_string())
}

fn timing(
    period: Duration,
    stats: Option<&StatsSummary>,
    state: Option<&ServoState>,
) -> LoopTiming {
    let mut t = LoopTiming {
        period,
        cycles: state.map_or(0, |s| s.tick + 1),
        ..LoopTiming::default()
    };
    if let Some(s) = stats {
        let w: &Percentiles = &s.wake_latency_us;
        t.cycles = t.cycles.max(s.ticks);
        t.deadline_misses = s.deadline_misses;
        t.missing_replies = s.missing_replies;
        if w.count > 0 {
            t.wake_latency_p50 = us(w.p50);
            t.wake_latency_p99 = us(w.p99);
            t.wake_latency_max = us(w.max);
        }
    }
    t
}

fn loop_values(
    port: &Sources<'_>,
    stats: Option<&StatsSummary>,
    state: Option<&ServoState>,
) -> Vec<(String, String)> {
    let mut values = Vec::new();
    if let Some(s) = stats {
        for (name, p) in [
            ("work", &s.work_us),
            ("controller", &s.controller_us),
            ("round_trip", &s.round_trip_us),
        ] {
            if p.count > 0 {
                values.push(kv(&format!("{name}_p50_us"), format!("{:.1}", p.p50)));
                values.push(kv(&format!("{name}_p99_us"), format!("{:.1}", p.p99)));
                values.push(kv(&format!("{name}_max_us"), format!("{:.1}", p.max)));
            }
        }
        values.push(kv("late_replies", s.late_replies));
        values.push(kv("skipped_ticks", s.skipped_ticks));
        let bus_events: u64 = s
            .buses
            .iter()
            .map(|b| {
                b.tx_errors
                    + b.rx_errors
                    + b.bus_off
                    + b.error_passive
                    + b.rx_overflow
                    + b.other_events
            })
            .sum();
        values.push(kv("bus_errors", bus_events));
    }
    if let Some(s) = state {
        values.push(kv("servo_dropped_messages", s.dropped_messages));
    }
    values.push(kv(
        "servo_refusals_unattributed",
        port.handle.rejected_unattributed(),
    ));
    if let Some(t) = port.last_trajectory {
        values.push(kv("last_trajectory", t));
    }
    values
}

fn motor(
    port: &Sources<'_>,
    index: usize,
    status: Option<&JointStatus>,
    stats: Option<&StatsSummary>,
    end: Option<&LoopEnded>,
) -> MotorDiagnostics {
    let m = &port.motors[index];
    let name = &port.joints[index].name;
    let mut d = MotorDiagnostics {
        joint: name.clone(),
        hardware_id: format!(
            "{} motor {} (0x{:03x})",
            port.bus_labels.get(m.bus).map_or("?", String::as_str),
            m.id,
            m.can_id
        ),
        temperature_c: status.map(|s| s.temperature_celsius),
        voltage_v: status.and_then(|s| s.voltage_volts),
        ..MotorDiagnostics::default()
    };
    match d.voltage_v {
        Some(v) => d.values.push(kv("voltage", format!("{v:.1} V"))),
        None => d.values.push(kv("voltage", VOLTAGE_NOT_MEASURED)),
    }
    if let Some(s) = status {
        let c = &s.counters;
        d.values.extend([
            kv("mode", s.mode.name()),
            kv("fresh", s.fresh),
            kv("stale", s.stale),
            kv("current_a", format!("{:.3}", s.current_amps)),
            kv(
                "commanded_effort_nm",
                format!("{:.4}", s.commanded_effort_nm),
            ),
            kv(
                "position_error_rad",
                s.position_error_rad
                    .map_or_else(String::new, |e| format!("{e:.6}")),
            ),
            kv("setpoints", c.setpoints),
            kv("trajectories", c.trajectories),
            kv("replans", c.replans),
            kv("trajectory_failures", c.trajectory_failures),
            kv("stale_events", c.stale_events),
            kv("clamped_ticks", c.clamped),
            kv("servo_refusals", c.rejected),
        ]);
        if !s.fresh {
            d.warnings
                .push("no fresh reply in the latest tick".to_owned());
        }
        if s.stale {
            d.warnings.push(format!(
                "its setpoint went stale (now {}): renew setpoints faster than stale_after_ms",
                s.mode.name()
            ));
        }
        if c.trajectory_failures > 0 {
            d.warnings.push(format!(
                "{} trajectories abandoned at their start (held instead)",
                c.trajectory_failures
            ));
        }
        if let Some(limit) = m.temperature_limit_c {
            let t = s.temperature_celsius;
            if t >= limit {
                d.faults
                    .push(format!("over temperature: {t} °C, limit {limit} °C"));
            } else if t >= limit - TEMPERATURE_MARGIN_C {
                d.warnings.push(format!(
                    "temperature {t} °C within {TEMPERATURE_MARGIN_C} °C of its limit {limit} °C"
                ));
            }
        }
    }
    if let Some(j) = stats.and_then(|s| s.motors.get(index)) {
        let c = &j.counters;
        d.values.extend([
            kv("missing_replies", c.missing_replies),
            kv("late_replies", c.late_replies),
            kv("bad_frames", c.bad_frames),
            kv("clamped_commands", c.clamped_commands),
            kv("rejected_commands", c.rejected_commands),
            kv("longest_gap_ticks", c.max_consecutive_missing),
        ]);
    }
    if let Some(end) = end {
        if let Some((text, joints)) = &end.fault
            && joints.contains(&index)
        {
            d.faults.push(text.clone());
        }
        if end.unconfirmed_off.contains(&index) {
            d.faults.push(
                "motor-off not confirmed at the end of the run: it may still be energised".into(),
            );
        }
    }
    d
}

/// The port's diagnostics now.
pub(super) fn diagnostics(port: &Sources<'_>) -> RobotDiagnostics {
    let state = port.handle.state();
    let stats = port.feed.stats();
    let end = port.feed.end();
    let motors = (0..port.joints.len())
        .map(|i| {
            motor(
                port,
                i,
                state.as_ref().and_then(|s| s.joints().get(i)),
                stats.as_ref(),
                end.as_ref(),
            )
        })
        .collect();
    let enabled = match &state {
        Some(s) => s.enabled && !s.estopped,
        None => port.handle.is_enabled() && !port.handle.is_estopped(),
    };
    RobotDiagnostics {
        timing: timing(port.period, stats.as_ref(), state.as_ref()),
        enabled,
        stopped: end.as_ref().map(|e| LoopEnd {
            reason: e.reason.clone(),
            normal: e.normal,
        }),
        values: loop_values(port, stats.as_ref(), state.as_ref()),
        motors,
    }
}
