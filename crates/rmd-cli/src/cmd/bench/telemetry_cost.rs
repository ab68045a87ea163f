//! `rmd bench telemetry`: what the telemetry costs the loop. The `rmd bench loop` set-up (a PD
//! controller on simulated motors, real time) runs in alternating rounds, one with every sink off
//! (the loop publishes nothing) and one with every sink on (an MCAP file and a CSV file in a
//! temporary folder, the live Foxglove server on an ephemeral loopback port), in one process; the
//! loop's work per tick (wake to the end of its work, which includes publishing the sample) is
//! compared by its p99: the median of the rounds' p99 with sinks on over the median with sinks
//! off. Alternating short rounds puts both under the same machine load.
//!
//! A signal (`rmd_rig::signals`) stops the round in progress and the rounds after it: the
//! rounds run so far are printed, exit status 130.

use core::time::Duration;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;
use rmd_bus::MonotonicClock;
use rmd_loop::{RtLoop, RunLimit, robot::Robot, stats::StatsSummary};
use rmd_rig::args::RealtimeArgs;
use rmd_rig::args::duration::run_length;
use rmd_rig::telemetry::{TelemetryOutputs, TelemetryReport, TelemetrySinks};
use rmd_telemetry::LiveOptions;
use serde_json::{Value, json};

use super::flags;
use super::pd::MovingTargetPd;
use super::robot;
use crate::args::timing;
use crate::output::progress::{self, Progress};
use crate::output::report;

/// Arguments of `rmd bench telemetry`.
#[derive(Args, Debug)]
#[command(mut_arg("spin_us", |arg| arg.allow_hyphen_values(true).value_parser(timing::spin_us)))]
#[command(
    after_help = "Prints, per round, the loop's work per tick (p50, p99, p99.9, max, in us) with \
    every sink off and on, then the ratio of the medians of the rounds' p99 (on / off). JSON \
    (--json): {rounds: [{sinks, work_us: {..}, deadline_misses, ticks, telemetry}], \
    work_p99_off_us, work_p99_on_us, ratio}. The goal is a ratio of at most 1.05; on a loaded \
    machine the rounds' spread says how far the figure can be trusted."
)]
pub(crate) struct TelemetryCostArgs {
    /// Motors per bus, 1..=8 (ids 1..=N; beyond 4 driven per motor).
    #[arg(long, default_value = "4", value_parser = flags::motors)]
    motors: u8,
    /// Simulated CAN buses, 1..=8.
    #[arg(long, default_value = "1", value_parser = flags::buses)]
    buses: usize,
    /// Loop rate in Hz.
    #[arg(long, visible_alias = "rate-hz", value_name = "HZ", default_value = "1000", value_parser = flags::loop_rate, allow_hyphen_values = true)]
    rate: f64,
    /// Length of each round (e.g. 2s, 500ms).
    #[arg(long, visible_alias = "seconds", value_name = "DURATION", default_value = "2s", value_parser = run_length, allow_hyphen_values = true)]
    duration: Duration,
    /// Rounds of each kind (off, on, off, on, ...).
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..=100))]
    rounds: u32,
    #[command(flatten)]
    rt: RealtimeArgs,
    /// Print the result as one JSON object.
    #[arg(long)]
    json: bool,
}

/// One round's result.
struct Round {
    sinks: bool,
    stats: StatsSummary,
    telemetry: Option<TelemetryReport>,
}

/// Runs `rmd bench telemetry`.
pub(crate) fn run(args: TelemetryCostArgs) -> ExitCode {
    let folder = std::env::temp_dir().join(format!("rmd-bench-telemetry-{}", std::process::id()));
    let result = rounds(&args, &folder);
    let _ = std::fs::remove_dir_all(&folder);
    let rounds = match result {
        Ok(rounds) => rounds,
        Err(message) => return report::failure(message),
    };
    let p99 = |on: bool| {
        median(
            rounds
                .iter()
                .filter(|r| r.sinks == on)
                .map(|r| r.stats.work_us.p99)
                .collect(),
        )
    };
    let (off, on) = (p99(false), p99(true));
    let ratio = on / off;
    let text = if args.json {
        let list: Vec<Value> = rounds.iter().map(round_json).collect();
        format!(
            "{}\n",
            json!({
                "rounds": list,
                "work_p99_off_us": off,
                "work_p99_on_us": on,
                "ratio": ratio,
                "motors_per_bus": args.motors,
                "buses": args.buses,
                "rate_hz": args.rate,
                "round_s": args.duration.as_secs_f64(),
            })
        )
    } else {
        let mut text = format!(
            "{:<6}{:<6}{:>10}{:>10}{:>10}{:>10}{:>8}  telemetry\n",
            "round", "sinks", "p50 us", "p99 us", "p99.9 us", "max us", "misses"
        );
        for (i, r) in rounds.iter().enumerate() {
            let w = &r.stats.work_us;
            text += &format!(
                "{:<6}{:<6}{:>10.1}{:>10.1}{:>10.1}{:>10.1}{:>8}  {}\n",
                i / 2 + 1,
                if r.sinks { "on" } else { "off" },
                w.p50,
                w.p99,
                w.p999,
                w.max,
                r.stats.deadline_misses,
                r.telemetry.as_ref().map_or("-".to_string(), short)
            );
        }
        text += &format!(
            "work p99 (median of {} rounds): sinks off {off:.1} us, on {on:.1} us: ratio {ratio:.3}\n",
            rounds.len().div_ceil(2)
        );
        text
    };
    if let Err(code) = super::emit(&text) {
        return code;
    }
    if rmd_rig::signals::interrupted() {
        ExitCode::from(rmd_rig::signals::EXIT_INTERRUPTED)
    } else if rounds.iter().all(|r| r.stats.ticks > 0) {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(report::FAILURE)
    }
}

/// `written/dropped` of every sink.
fn short(report: &TelemetryReport) -> String {
    let counts: Vec<String> = report
        .sinks()
        .iter()
        .map(|s| {
            format!(
                "{} {}/{}",
                s.name.split_whitespace().next().unwrap_or(""),
                s.written,
                s.dropped
            )
        })
        .collect();
    counts.join(", ")
}

fn round_json(r: &Round) -> Value {
    json!({
        "sinks": r.sinks,
        "work_us": r.stats.work_us,
        "deadline_misses": r.stats.deadline_misses,
        "ticks": r.stats.ticks,
        "telemetry": r.telemetry.as_ref().map(crate::output::telemetry::report_json),
    })
}

/// The median (the mean of the middle two for an even count).
fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    let n = values.len();
    match n {
        0 => f64::NAN,
        _ if n % 2 == 1 => values[n / 2],
        _ => (values[n / 2 - 1] + values[n / 2]) / 2.0,
    }
}

fn rounds(args: &TelemetryCostArgs, folder: &std::path::Path) -> Result<Vec<Round>, String> {
    let progress = Progress::counter(
        u64::from(args.rounds) * 2,
        "rounds",
        progress::shown(args.json),
    );
    progress.set_prefix("bench telemetry ");
    let signals = rmd_rig::signals::install().map_err(|e| e.to_string())?;
    let mut rounds = Vec::new();
    for i in 0..args.rounds * 2 {
        if signals.interrupted() {
            break;
        }
        let sinks = i % 2 == 1;
        let outputs = if sinks {
            TelemetryOutputs {
                csv: Some(folder.join(format!("round{i}.csv"))),
                mcap: Some(folder.join(format!("round{i}.mcap"))),
                live: Some(LiveOptions {
                    addr: "127.0.0.1:0".parse().map_err(|e| format!("{e}"))?,
                    ..LiveOptions::default()
                }),
            }
        } else {
            TelemetryOutputs::default()
        };
        rounds.push(one_round(args, &outputs)?);
        progress.set_position(u64::from(i) + 1);
        // Files of a finished round are not needed: keep the disk use to one round's.
        let _ = remove(&outputs);
    }
    Ok(rounds)
}

fn remove(outputs: &TelemetryOutputs) -> std::io::Result<()> {
    for path in [&outputs.csv, &outputs.mcap].into_iter().flatten() {
        std::fs::remove_file::<&PathBuf>(path)?;
    }
    Ok(())
}

fn one_round(args: &TelemetryCostArgs, outputs: &TelemetryOutputs) -> Result<Round, String> {
    let clock = MonotonicClock;
    let mut config = robot::robot(args.rate, args.buses, args.motors);
    args.rt.apply(&mut config);
    let robot = Robot::try_from(config).map_err(|e| e.to_string())?;
    let buses =
        robot::sim_buses(&clock, args.buses, args.motors).map_err(|e| format!("simulator: {e}"))?;
    let mut rt = RtLoop::unsupervised(robot, clock, buses, MovingTargetPd::new(true))
        .map_err(|e| e.to_string())?;
    let mut sinks = TelemetrySinks::attach(&mut rt, outputs).map_err(|e| e.to_string())?;
    let on = sinks.is_some();
    let signals = rmd_rig::signals::install().map_err(|e| e.to_string())?;
    let handle = rt
        .spawn(RunLimit::Duration(args.duration))
        .map_err(|e| e.to_string())?;
    let watch = signals.watch(handle.stopper());
    while handle.is_running() {
        if let Some(sinks) = &mut sinks {
            sinks.pump(|_| {});
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    let outcome = handle.join().map_err(|e| e.to_string())?;
    drop(watch);
    let telemetry = sinks.map(|s| s.finish(outcome.report.stats.telemetry_drops));
    Ok(Round {
        sinks: on,
        stats: outcome.report.stats,
        telemetry,
    })
}

#[cfg(test)]
mod tests {
    use super::median;

    #[test]
    fn the_median_of_odd_and_even_counts() {
        assert_eq!(median(vec![3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(vec![4.0, 1.0, 2.0, 3.0]), 2.5);
        assert!(median(Vec::new()).is_nan());
    }
}
