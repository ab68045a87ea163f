//! `rmd bench loop`: the real-time loop running a PD position controller on simulated motors,
//! and its report.
//!
//! `--motors` counts motors PER BUS (1..=8), so the robot has `--motors x --buses` motors: one
//! 0x280 frame per bus drives v1.61 motors 1..=4; more than four, and MyActuator V3 motors
//! (`--sim-firmware myactuator-v3`), get one 0xA1 request each per tick (the per-motor exchange). The simulated buses run at 1 Mbit/s with the simulator's default
//! motors; the loop refuses a rate whose exchange does not fit the period (see docs/loop.md).
//! Without `--virtual-time` everything runs in real time on the monotonic clock, each simulated
//! bus on its own thread as real motors are (`--sim inline`: in the loop's thread); with it, on
//! a virtual clock (as fast as the CPU allows, deterministic). The loop runs on its own thread
//! while this thread drains its telemetry, as an application would, into the sinks of `--csv`,
//! `--mcap` and `--foxglove` when asked (on virtual time without losing a tick: the loop waits
//! for the sinks).
//!
//! Signals follow the project's policy (`rmd_rig::signals`): the first stops the loop (zero
//! torque, motor off), the report and the telemetry files are still written, exit status 130;
//! the second is an emergency stop.

use core::time::Duration;
use std::process::ExitCode;

use clap::Args;
use rmd_bus::{CanBus, Clock, MonotonicClock, VirtualClock};
use rmd_loop::{LoopOutcome, RtLoop, RunLimit, robot::Robot};
use serde_json::{Value, json};

use super::flags;
use super::pd::{self, MovingTargetPd};
use super::robot;
use crate::args::timing;
use crate::output::errln;
use crate::output::progress::{self, Progress};
use crate::output::report;
use rmd_rig::args::duration::run_length;
use rmd_rig::args::{RealtimeArgs, TelemetryArgs};
use rmd_rig::telemetry::{TelemetryReport, TelemetrySinks};

/// Arguments of `rmd bench loop`.
#[derive(Args, Debug)]
// `--spin-us` of `rmd_rig::args::RealtimeArgs`, with the CLI's parser: `-1` or `1e300` is a
// usage error naming the flag.
#[command(mut_arg("spin_us", |arg| arg.allow_hyphen_values(true).value_parser(timing::spin_us)))]
#[command(
    after_help = "JSON (--json): the loop report as one object: ticks, deadline_misses, \
    skipped_ticks, missing_replies, late_replies, telemetry_drops, and wake_latency_us, \
    round_trip_us, controller_us, work_us as {count, min, mean, p50, p90, p99, p999, max} in \
    microseconds, per-motor and per-bus counters, the safe stop and the real-time status; plus \
    `bench` (the set-up and the controller's tracking error) and, with a telemetry sink, \
    `telemetry` (per sink: name, written, dropped, failed, errors, first_error, note). Exit \
    status 1 if the loop stopped on a fault or a telemetry sink failed (a full disk: the file \
    keeps what was written before), 130 after Ctrl-C/SIGTERM/SIGHUP (the report and the files \
    are still written; a second signal is an emergency stop).\n\n\
    Telemetry: --mcap FILE writes /joint_states (one message per tick; on --virtual-time none is \
    lost), /motor_states, /loop_timing and /diagnostics; --foxglove [ADDR] serves the same \
    channels live while it runs; --csv FILE one row per tick (docs/telemetry.md)."
)]
pub(crate) struct LoopBenchArgs {
    /// Motors per bus, 1..=8 (ids 1..=N on every bus; beyond 4 driven per motor, or with
    /// `--exchange multi-torque` the 0x280 frame for ids 1..=4 and 0xA1 requests beyond).
    #[arg(long, default_value = "4", value_parser = flags::motors)]
    motors: u8,
    /// Simulated CAN buses (1 Mbit/s each), 1..=8, exchanged in parallel.
    #[arg(long, default_value = "1", value_parser = flags::buses)]
    buses: usize,
    /// Loop rate in Hz.
    #[arg(long, visible_alias = "rate-hz", value_name = "HZ", default_value = "1000", value_parser = flags::loop_rate, allow_hyphen_values = true)]
    rate: f64,
    /// How long to run, in real or virtual time (e.g. 5s, 500ms; a bare number is seconds).
    #[arg(long, visible_alias = "seconds", value_name = "DURATION", default_value = "5s", value_parser = run_length, allow_hyphen_values = true)]
    duration: Duration,
    /// Run on a virtual clock: deterministic, as fast as the CPU allows (latencies are then 0).
    #[arg(long)]
    virtual_time: bool,
    /// Where the simulated buses run in real time: each on its own thread, or in the loop's.
    #[arg(
        long,
        value_enum,
        default_value = "thread",
        conflicts_with = "virtual_time"
    )]
    sim: super::rate::SimPlace,
    /// The simulated motors' firmware: v1.61 (default), lk-v2.3x (MG), myactuator-v3. V3 motors
    /// are described as V3 and driven per motor (one 0xA1 request each per tick); the robot is
    /// otherwise described as v1.61, so LK-TECH is refused at start-up, before any torque.
    #[arg(long, value_name = "FIRMWARE", default_value = "v1.61", value_parser = crate::args::parse::sim_firmware)]
    sim_firmware: rmd_protocol::ProtocolFamily,
    /// How every bus exchanges with its motors each tick: multi-torque (one 0x280 frame, v1.61),
    /// per-motor (one 0xA1 request per motor) or motion (MyActuator V3's motion mode: one
    /// 0x400 + id command per motor, the benchmark's PD law run in the motors). Default: per-motor
    /// for V3 motors and beyond 4 motors per bus, else multi-torque.
    #[arg(long, value_name = "KIND", value_parser = crate::args::parse::exchange)]
    exchange: Option<rmd_loop::robot::ExchangeKind>,
    #[command(flatten)]
    rt: RealtimeArgs,
    #[command(flatten)]
    telemetry: TelemetryArgs,
    /// Print the report as one JSON object.
    #[arg(long)]
    json: bool,
}

/// Runs `rmd bench loop`.
pub(crate) fn run(args: LoopBenchArgs) -> ExitCode {
    let family = sim_family(&args);
    let outcome = if args.virtual_time {
        let clock = VirtualClock::new();
        robot::sim_buses_of(&clock, args.buses, args.motors, family)
            .map_err(|e| Failure::Run(format!("simulator: {e}")))
            .and_then(|buses| run_on(clock, buses, &args))
    } else if args.sim == super::rate::SimPlace::Inline {
        robot::sim_buses_of(&MonotonicClock, args.buses, args.motors, family)
            .map_err(|e| Failure::Run(format!("simulator: {e}")))
            .and_then(|buses| run_on(MonotonicClock, buses, &args))
    } else {
        robot::threaded_buses(args.buses, args.motors, family, &args.rt, Duration::ZERO, 0)
            .map_err(Failure::Run)
            .and_then(|mut sims| {
                let ports = core::mem::take(&mut sims.ports);
                let outcome = run_on(MonotonicClock, ports, &args);
                sims.stop().map_err(Failure::Run)?;
                outcome
            })
    };
    let (outcome, telemetry, interrupted) = match outcome {
        Ok(outcome) => outcome,
        Err(Failure::Usage(msg)) => return report::usage_error(msg),
        Err(Failure::Run(msg)) => return report::failure(msg),
    };
    let report = &outcome.report;
    let controller = &outcome.controller;
    if args.json {
        let mut value: Value = match serde_json::from_str(&report.to_json()) {
            Ok(v) => v,
            Err(e) => return report::failure(format!("loop report is not JSON: {e}")),
        };
        if let Value::Object(map) = &mut value {
            map.insert("bench".into(), bench_json(&args, controller));
            if let Some(telemetry) = &telemetry {
                map.insert(
                    "telemetry".into(),
                    crate::output::telemetry::report_json(telemetry),
                );
            }
        }
        if let Err(code) = super::emit(&format!("{value}\n")) {
            return code;
        }
    } else {
        if let Err(code) = super::emit(&format!(
            "{report}bench: {} motor(s) per bus x {} bus(es), {} time; PD tracking of {AMPLITUDE} deg / \
             {FREQ} Hz sines: rms error {}, max {}\n",
            args.motors,
            args.buses,
            if args.virtual_time { "virtual" } else { "real" },
            show_deg(controller.rms_error_deg()),
            show_deg(controller.max_error_deg()),
            AMPLITUDE = pd::AMPLITUDE_DEG,
            FREQ = pd::FREQUENCY_HZ,
        )) {
            return code;
        }
    }
    if let Some(telemetry) = &telemetry {
        errln!("{telemetry}");
    }
    ExitCode::from(rmd_rig::runner::exit_status(
        interrupted,
        report,
        telemetry.as_ref(),
    ))
}

/// The simulated motors' firmware of `--sim-firmware`.
fn sim_family(args: &LoopBenchArgs) -> rmd_sim::FirmwareFamily {
    super::sim_family(args.sim_firmware)
}

fn show_deg(v: Option<f64>) -> String {
    v.map_or_else(
        || "n/a (run shorter than 0.5 s)".to_string(),
        |d| format!("{d:.3} deg"),
    )
}

fn bench_json(args: &LoopBenchArgs, controller: &MovingTargetPd) -> Value {
    json!({
        "motors_per_bus": args.motors,
        "buses": args.buses,
        "virtual_time": args.virtual_time,
        "sim": if args.virtual_time { "virtual".to_string() } else { format!("{:?}", args.sim).to_lowercase() },
        "spin_us": args.rt.spin().as_micros() as u64,
        "cpu": args.rt.cpu,
        "fifo_priority": args.rt.fifo,
        "controller": "pd-moving-target",
        "exchange": args.exchange.map(|e| e.name()),
        "target_amplitude_deg": pd::AMPLITUDE_DEG,
        "target_frequency_hz": pd::FREQUENCY_HZ,
        "tracking_rms_error_deg": controller.rms_error_deg(),
        "tracking_max_error_deg": controller.max_error_deg(),
    })
}

enum Failure {
    /// The set-up is invalid (a rate the bus cannot carry, a spin margin too long, ...).
    Usage(String),
    /// The run could not happen.
    Run(String),
}

/// The outcome, what the sinks got, and whether a signal stopped the run.
type Ran = (LoopOutcome<MovingTargetPd>, Option<TelemetryReport>, bool);

fn run_on<C: Clock + Clone + 'static, B: CanBus + Send + 'static>(
    clock: C,
    buses: Vec<B>,
    args: &LoopBenchArgs,
) -> Result<Ran, Failure> {
    let mut config = robot::robot_for(
        args.rate,
        args.buses,
        args.motors,
        sim_family(args),
        args.exchange,
    );
    args.rt.apply(&mut config);
    let robot = Robot::try_from(config).map_err(|e| Failure::Usage(e.to_string()))?;
    let period = robot.settings().period.get();
    let ticks = u64::try_from(args.duration.as_nanos() / period.as_nanos()).unwrap_or(u64::MAX);
    let controller = MovingTargetPd::new(!args.virtual_time)
        .in_motion_mode(args.exchange == Some(rmd_loop::robot::ExchangeKind::Motion));
    let mut rt = RtLoop::unsupervised(robot, clock, buses, controller)
        .map_err(|e| Failure::Usage(e.to_string()))?;
    // Before anything is served or recorded: a signal from now on follows the policy (one
    // before the loop runs stops it at once).
    let signals = rmd_rig::signals::install().map_err(|e| Failure::Run(e.to_string()))?;
    // Before the loop thread exists: the sinks' threads must not inherit its CPU.
    let mut sinks = TelemetrySinks::attach(&mut rt, &args.telemetry.outputs())
        .map_err(|e| Failure::Usage(e.to_string()))?;
    if let (Some(addr), false) = (sinks.as_ref().and_then(|s| s.live_addr()), args.json) {
        errln!("telemetry: live on ws://{addr}");
    }
    let telemetry = sinks.is_none().then(|| rt.telemetry());
    let handle = rt
        .spawn(RunLimit::Duration(args.duration))
        .map_err(|e| Failure::Run(e.to_string()))?;
    let watch = signals.watch(handle.stopper());
    let progress = Progress::counter(ticks, "ticks", progress::shown(args.json));
    progress.set_prefix("bench loop ");
    // Drain the telemetry as an application would, so that none is dropped.
    while handle.is_running() {
        match (&mut sinks, &telemetry) {
            (Some(sinks), _) => {
                sinks.pump(|sample| progress.set_position(sample.tick + 1));
            }
            (None, Some(telemetry)) => {
                while let Some(sample) = telemetry.try_recv() {
                    progress.set_position(sample.tick + 1);
                }
            }
            (None, None) => {}
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    drop(progress);
    let outcome = handle.join().map_err(|e| Failure::Run(e.to_string()))?;
    drop(watch);
    let report = sinks.map(|s| s.finish(outcome.report.stats.telemetry_drops));
    Ok((outcome, report, signals.interrupted()))
}
