//! `rmd drill`: fault drills on simulated motors, judged by the simulated firmware (see
//! `rmd_drill`). A stable interface: scripts and CI run it.
//!
//! - `rmd drill --fault KIND[:ARG]`: one drill; prints the verdict (or one JSON object with
//!   `--json`); exit 0 exactly when no motor is energised after the run.
//! - `rmd drill --all`: every kind of the matrix; a table (or JSON lines); exit 0 when every
//!   drill passed.
//! - `rmd drill --chaos`: random drills for `--seconds` of run time; exit 0 when none panicked,
//!   hung, left a motor energised or grew memory.
//!
//! Signals follow the project's policy (`rmd_rig::signals`): the first stops the drill in
//! progress (its verdict and telemetry files are still written) and starts no other, the second
//! is an emergency stop; exit status 130.

use std::process::ExitCode;
use std::time::Duration;

use clap::Args;
use rmd_drill::chaos::{ChaosSpec, chaos};
use rmd_drill::{Drill, DrillFault, DrillSpec};
use rmd_rig::SimTime;
use rmd_rig::args::TelemetryArgs;
use rmd_rig::args::duration::{self, Bounds};
use rmd_rig::signals::{self, EXIT_INTERRUPTED, Signals};
use rmd_rig::telemetry::TelemetryReport;

use crate::output::progress::{self, Progress};
use crate::output::report::{self, CliError};
use crate::output::table::{Align, TextTable};
use crate::output::{errln, outln};

/// `rmd drill ...`.
#[derive(Args, Debug)]
#[command(
    after_help = "Fault kinds: bus-off:MS, tx-stall:MS, controller-hang:MS, \
    controller-panic, nan-command, slow-controller:US, silent-motor:ID, drop:P, late:P,MS, \
    corrupt:P, duplicate:P, wrong-dlc:P, over-temperature, low-voltage, estop, stop, \
    unknown-motor:ID, host-silent:MS (the host falls silent for good on every bus; MS is the \
    communication watchdog in each MyActuator V3 motor, 0 for none; not in --all). Faults of \
    the motors and buses strike bus 0.\n\n\
    The verdict comes from the simulated firmware, not from the loop: a motor is safe when its \
    firmware applies and is commanded no torque. Exit status: 0 when every motor ended safe, 1 \
    when some motor is still energised (or a chaos drill failed, or a telemetry file could not \
    be written), 2 on a usage error, 130 after Ctrl-C/SIGTERM/SIGHUP (the drill in progress is \
    stopped and judged, no other starts; a second signal is an emergency stop).\n\n\
    Telemetry of one drill (--fault): --mcap FILE, --csv FILE, --foxglove [ADDR] (docs/telemetry.md); \
    not with --all or --chaos."
)]
pub(crate) struct DrillArgs {
    #[arg(long, help = "The fault to inject (KIND[:ARG]; see below), at --at or at its own time with @SECONDS (--fault controller-hang:3000@0.5 --fault estop@0.52); repeatable", value_name = "KIND[:ARG][@SECONDS]", value_parser = timed_fault, required_unless_present_any = ["all", "chaos"], conflicts_with_all = ["all", "chaos"])]
    fault: Vec<(DrillFault, Option<Duration>)>,
    /// Run every kind of the matrix, one drill each, and print a table.
    #[arg(long, conflicts_with = "chaos")]
    all: bool,
    /// Run random drills (1 to 3 random faults each, random robot sizes) for --seconds of run
    /// time in total.
    #[arg(long)]
    chaos: bool,
    /// Buses (each with --motors motors), 1..=8.
    #[arg(long, default_value_t = 1, value_name = "N")]
    buses: u8,
    /// Motors per bus, 1..=4 [default: 4; 3 with --sim-firmware myactuator-v3, the most its
    /// per-motor exchange carries at 1 kHz on 1 Mbit/s; 2 with --exchange motion, the most
    /// whose temperature the health rotation still watches at 1 kHz].
    #[arg(long, value_name = "M")]
    motors: Option<u8>,
    /// How every bus exchanges with its motors: multi-torque, per-motor or motion (MyActuator
    /// V3's motion mode, the drill's torques as feed-forward) [default: the firmware's].
    #[arg(long, value_name = "KIND", value_parser = crate::args::parse::exchange)]
    exchange: Option<rmd_loop::robot::ExchangeKind>,
    /// The simulated motors' firmware: v1.61, lk-v2.3x (MG series) or myactuator-v3 (driven by
    /// the per-motor exchange, made safe without a 0x280 frame).
    #[arg(long, value_name = "FIRMWARE", default_value = "v1.61", value_parser = crate::args::parse::sim_firmware)]
    sim_firmware: rmd_protocol::ProtocolFamily,
    /// A second firmware for the motors of even ids (a bus mixing families, e.g. v1.61 with
    /// myactuator-v3: driven per motor, each in its own family's scale).
    #[arg(long, value_name = "FIRMWARE", value_parser = crate::args::parse::sim_firmware)]
    mix_firmware: Option<rmd_protocol::ProtocolFamily>,
    /// When the fault strikes after the start (seconds, or 300ms, ...).
    #[arg(long, default_value = "0.5", value_parser = at, value_name = "SECONDS")]
    at: Duration,
    /// How long the run lasts at most (seconds, or 1500ms, ...); with --chaos, the drills' run
    /// time in total.
    #[arg(long, default_value = "2", value_parser = duration::run_length, value_name = "SECONDS")]
    seconds: Duration,
    /// Seed of the simulated motors' and faults' random draws (with --chaos: of the drills).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Virtual time: deterministic and as fast as the CPU allows (default: real time).
    #[arg(long)]
    virtual_time: bool,
    /// One JSON object (with --all: one per line).
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    telemetry: TelemetryArgs,
}

impl DrillArgs {
    /// Motors per bus: as given, or the most the firmware's exchange carries at 1 kHz (4).
    fn motors(&self) -> u8 {
        self.motors
            .unwrap_or(match (self.sim_firmware, self.exchange) {
                (_, Some(rmd_loop::robot::ExchangeKind::Motion)) => 2,
                (rmd_protocol::ProtocolFamily::MyActuatorV3, _) => 3,
                _ if self.mix_firmware == Some(rmd_protocol::ProtocolFamily::MyActuatorV3) => 3,
                _ => 4,
            })
    }
}

fn at(text: &str) -> Result<Duration, String> {
    duration::parse(text, Bounds::up_to(duration::MAX_RUN))
}

/// `KIND[:ARG][@SECONDS]`.
fn timed_fault(text: &str) -> Result<(DrillFault, Option<Duration>), String> {
    let (fault, when) = match text.rsplit_once('@') {
        Some((fault, when)) => (fault, Some(at(when)?)),
        None => (text, None),
    };
    Ok((
        fault
            .parse()
            .map_err(|e: rmd_drill::FaultParseError| e.to_string())?,
        when,
    ))
}

pub(crate) fn run(args: DrillArgs) -> ExitCode {
    let time = if args.virtual_time {
        SimTime::Virtual
    } else {
        SimTime::Real
    };
    let signals = match signals::install() {
        Ok(signals) => signals,
        Err(e) => return report::failure(e),
    };
    let spec = |fault| {
        let spec = DrillSpec::new(fault)
            .buses(args.buses)
            .motors(args.motors())
            .firmware(args.sim_firmware)
            .at(args.at)
            .seconds(args.seconds)
            .seed(args.seed)
            .time(time)
            .stopped_by(signals)
            .tell_waits();
        let spec = match args.mix_firmware {
            Some(other) => spec.mixed_with(other),
            None => spec,
        };
        match args.exchange {
            Some(kind) => spec.exchange(kind),
            None => spec,
        }
    };
    let result = if (args.chaos || args.all) && args.telemetry.any() {
        Err(CliError::Usage(
            "--mcap, --csv and --foxglove record one drill: use them with --fault, not with \
             --all or --chaos"
                .into(),
        ))
    } else if args.chaos {
        run_chaos(&args, time, signals)
    } else if args.all {
        run_all(&args, spec, signals)
    } else if let Some((&(first, first_at), rest)) = args.fault.split_first() {
        let mut one = spec(first).at(first_at.unwrap_or(args.at));
        for &(fault, when) in rest {
            one = one.and(fault, when.unwrap_or(args.at));
        }
        run_one(&one, &args.telemetry, args.json)
    } else {
        Err(CliError::Usage(
            "give --fault KIND[:ARG], --all or --chaos".into(),
        ))
    };
    match result {
        Ok(_) if signals.interrupted() => ExitCode::from(EXIT_INTERRUPTED),
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::from(report::FAILURE),
        Err(e) => report::exit(Err(e)),
    }
}

fn drill(
    spec: &DrillSpec,
    telemetry: &TelemetryArgs,
    show: bool,
) -> Result<(Drill, Option<TelemetryReport>), CliError> {
    let progress = Progress::spinner(show);
    let faults: Vec<String> = spec.faults().iter().map(|(f, _)| f.to_string()).collect();
    progress.set_message(format!("drill {}", faults.join(" + ")));
    let ran = rmd_drill::run_with_telemetry(spec, &telemetry.outputs())
        .map_err(|e| CliError::Usage(e.to_string()))?;
    drop(progress);
    Ok(ran)
}

fn run_one(spec: &DrillSpec, telemetry: &TelemetryArgs, json: bool) -> Result<bool, CliError> {
    let (drill, report) = drill(spec, telemetry, progress::shown(json))?;
    if json {
        let mut value: serde_json::Value = serde_json::from_str(&drill.to_json())
            .map_err(|e| CliError::Failed(format!("the drill's report is not JSON: {e}")))?;
        if let (Some(report), serde_json::Value::Object(map)) = (&report, &mut value) {
            map.insert(
                "telemetry".into(),
                crate::output::telemetry::report_json(report),
            );
        }
        outln!("{value}")?;
    } else {
        outln!("{}", drill.report)?;
        outln!()?;
        outln!("{}", verdict(&drill))?;
    }
    if let Some(report) = &report {
        errln!("{report}");
    }
    // A recording asked for and not written is a failure too.
    Ok(drill.passed() && !report.as_ref().is_some_and(TelemetryReport::failed))
}

/// The verdict in words.
fn verdict(d: &Drill) -> String {
    let mut lines = vec![format!(
        "drill {}: {}",
        d.fault,
        if d.passed() {
            "every motor safe"
        } else {
            "MOTORS LEFT ENERGISED"
        }
    )];
    lines.push(format!("  stop: {}", d.stop_reason));
    lines.push(format!(
        "  energised after the run (simulated firmware): {} of {}{}",
        d.motors_energised_after,
        d.motors,
        if d.energised.is_empty() {
            String::new()
        } else {
            let names: Vec<String> = d
                .energised
                .iter()
                .map(|m| format!("motor {} on bus {}", m.motor, m.bus))
                .collect();
            format!(" ({})", names.join(", "))
        }
    ));
    lines.push(match d.time_to_safe_ms {
        Some(ms) => format!("  time to safe: {ms:.1} ms after the fault"),
        None => "  time to safe: never (some motor is still energised)".to_string(),
    });
    lines.push(format!(
        "  confirmed off by the loop: {} of {}",
        d.confirmed_off, d.motors
    ));
    // Under-voltage and over-temperature flags are read by the health rotation: where the
    // bus had no room for it, say so (the drill then rides to its end, or stops on the
    // temperature limit of the torque replies).
    for note in &d.report.health_notes {
        lines.push(format!("  motor health: {note}"));
    }
    if d.fault.contains("host-silent") && !d.passed() {
        lines.push(
            "  the host fell silent: nothing it sent reached the motors, its safe stop included; \
             only a watchdog in the motor stops it then. MyActuator V3 motors have one \
             (`rmd watchdog ID TIME`, docs/safety.md); v1.61 and LK-TECH motors have none, so \
             they stay energised until their power is cut"
                .to_owned(),
        );
    }
    lines.join("\n")
}

fn run_all(
    args: &DrillArgs,
    spec: impl Fn(DrillFault) -> DrillSpec,
    signals: Signals,
) -> Result<bool, CliError> {
    let matrix = DrillFault::matrix();
    let show = progress::shown(args.json);
    let progress = Progress::counter(matrix.len() as u64, "drills", show);
    let mut table = TextTable::new(&[
        ("fault", Align::Left),
        ("stop", Align::Left),
        ("energised", Align::Right),
        ("time to safe", Align::Right),
        ("confirmed off", Align::Right),
        ("by", Align::Left),
    ]);
    let mut passed = true;
    for (done, fault) in matrix.into_iter().enumerate() {
        if signals.interrupted() {
            break;
        }
        progress.set_message(fault.to_string());
        let mut one = spec(fault);
        if let DrillFault::SilentMotor(id) = fault
            && id.get() > args.motors()
        {
            one = spec(DrillFault::SilentMotor(
                rmd_protocol::MotorId::new(1).map_err(|e| CliError::Failed(e.to_string()))?,
            ));
        }
        if matches!(fault, DrillFault::UnknownMotor(_)) && args.motors() < 2 {
            progress.println(format!("{fault}: skipped (needs --motors 2 or more)"));
            continue;
        }
        let d = rmd_drill::run(&one).map_err(|e| CliError::Usage(e.to_string()))?;
        progress.set_position(done as u64 + 1);
        passed &= d.passed();
        if args.json {
            progress.suspend(|| outln!("{}", d.to_json()))?;
        } else {
            table.row([
                d.fault.clone(),
                short_stop(&d),
                format!("{}/{}", d.motors_energised_after, d.motors),
                d.time_to_safe_ms
                    .map_or("never".to_string(), |ms| format!("{ms:.1} ms")),
                format!("{}/{}", d.confirmed_off, d.motors),
                format!("{:?}", d.report.safe_stop.by).to_lowercase(),
            ]);
        }
    }
    drop(progress);
    if signals.interrupted() {
        errln!("interrupted: the drills after the one in progress were not run");
    }
    if !args.json {
        outln!("{}", table.render())?;
        outln!(
            "{}",
            if passed {
                "every drill ended with every motor safe"
            } else {
                "SOME DRILL LEFT MOTORS ENERGISED"
            }
        )?;
    }
    Ok(passed)
}

/// The stop reason in a few words (the table's column).
fn short_stop(d: &Drill) -> String {
    use rmd_loop::{Fault, StopReason};
    let joint = |at: &rmd_loop::MotorRef| format!("motor {} on bus {}", at.motor.get(), at.bus);
    match &d.report.stop_reason {
        StopReason::Fault(fault) => match fault {
            Fault::NoFreshFeedback { at, ticks } => {
                format!("no fresh feedback, {} ({ticks} ticks)", joint(at))
            }
            Fault::StartupTimeout { at, .. } => format!("start-up timeout, {}", joint(at)),
            Fault::BusOff { bus } => format!("bus-off, bus {bus}"),
            Fault::Bus { bus, .. } => format!("bus error, bus {bus}"),
            Fault::DeadlineMisses { consecutive } => format!("{consecutive} deadline misses"),
            Fault::OverTemperature { at, celsius } => {
                format!("over-temperature, {} ({celsius:.0} degC)", joint(at))
            }
            Fault::MotorError { at, flag, .. } => format!("{flag} flag, {}", joint(at)),
            Fault::Supervisor => "supervisor did not start".to_string(),
            Fault::UndescribedMotor { bus, motor, .. } => {
                format!("undescribed motor {} on bus {bus}", motor.get())
            }
            Fault::Firmware { at, .. } => format!("firmware refused, {}", joint(at)),
            Fault::MotionRanges { at, .. } => format!("motion ranges unknown, {}", joint(at)),
            Fault::TickStalled { bound, .. } => {
                format!("tick stalled > {} ms", bound.as_millis())
            }
            Fault::JointLimit { at, breach } => {
                format!("beyond {}, {}", breach.kind, joint(at))
            }
            Fault::RejectedCommand { .. } => "rejected command".to_string(),
        },
        StopReason::ControllerPanic(_) => "controller panicked".to_string(),
        StopReason::EmergencyStop => "emergency stop".to_string(),
        StopReason::Requested => "stop requested".to_string(),
        StopReason::TickLimit => "ran to the end".to_string(),
        other => other.to_string(),
    }
}

fn run_chaos(args: &DrillArgs, time: SimTime, signals: Signals) -> Result<bool, CliError> {
    let spec = ChaosSpec {
        seconds: args.seconds,
        seed: args.seed,
        time,
        signals: Some(signals),
        firmware: args.sim_firmware,
    };
    let show = progress::shown(args.json);
    let progress = Progress::timer(args.seconds, show);
    let mut run_time = Duration::ZERO;
    let report = chaos(&spec, |d| {
        run_time += Duration::from_secs_f64(d.seconds);
        progress.set_elapsed(run_time);
        progress.set_message(format!("drill {}", d.index + 1));
    });
    drop(progress);
    if args.json {
        let json = serde_json::to_string(&report).map_err(|e| CliError::Failed(e.to_string()))?;
        outln!("{json}")?;
    } else {
        let faults: usize = report.drills.iter().map(|d| d.faults.len()).sum();
        outln!(
            "chaos: {} drills, {faults} faults, seed {}",
            report.drills.len(),
            args.seed
        )?;
        let worst = report
            .drills
            .iter()
            .filter_map(|d| d.time_to_safe_ms)
            .fold(0.0f64, f64::max);
        outln!("longest time to safe: {worst:.1} ms")?;
        let rss: Vec<u64> = report.drills.iter().filter_map(|d| d.rss_kib).collect();
        if let (Some(first), Some(last), Some(most)) = (rss.first(), rss.last(), rss.iter().max()) {
            outln!(
                "resident memory: {first} KiB after the first drill, {most} KiB at most, {last} KiB after the last (bound: {} KiB of growth after the warm-up)",
                rmd_drill::chaos::MEMORY_BOUND_KIB
            )?;
        }
        for failure in &report.failures {
            errln!(
                "FAILED: {}",
                serde_json::to_string(failure).unwrap_or_default()
            );
        }
        outln!(
            "{}",
            if report.passed() {
                "every drill ended with every motor safe"
            } else {
                "CHAOS FOUND FAILURES"
            }
        )?;
    }
    Ok(report.passed())
}
