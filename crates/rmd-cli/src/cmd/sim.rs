//! `rmd sim --iface vcan0 --ids 1-4`: simulated motors answering on a real SocketCAN interface
//! as their firmware would (v1.61, or `--firmware lk-v2.3x|myactuator-v3`), in real time, until
//! Ctrl-C (or SIGTERM).
//!
//! Every request frame received (single-motor ids of the simulated motors, and 0x280) goes to
//! [`SimMotors::handle`] with its kernel receive time; each reply is sent when it is due (the
//! receive time plus the motor's turnaround and jitter, plus any injected delay). Fault options
//! drop, delay, corrupt or duplicate replies, or silence motors, with a seed for repeatable
//! runs. Between frames the motors' physics is advanced every couple of milliseconds, so a
//! request never waits for a long catch-up of the simulation.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use clap::Args;
use rmd_bus::record::RecordOptions;
use rmd_bus::{BusError, BusMessage, CanBus, Clock, MonotonicClock};
use rmd_protocol::{EncoderWidth, LkSeries, ProtocolFamily};
use rmd_sim::{
    FaultRule, FirmwareFamily, GravityLink, MotorSet, ReplyFault, ScheduledFrame, SimConfig,
    SimMotorConfig, SimMotors,
};

use crate::args::ids::{self, IdList};
use crate::args::parse;
use crate::args::timing;
use crate::live::connect::{Filter, open_interface};
use crate::live::interrupt;
use crate::live::recording::{self, LogSink, Recording};
use crate::output::errln;
use crate::output::progress::{self, Progress};
use crate::output::report::{self, CliError};

/// Arguments of `rmd sim`.
#[derive(Args, Debug)]
pub(crate) struct SimArgs {
    /// The CAN interface to answer on (e.g. vcan0: `ip link add dev vcan0 type vcan && ip link
    /// set vcan0 up`).
    #[arg(long, value_name = "IFACE")]
    iface: String,
    /// Ids of the simulated motors.
    #[arg(long, value_name = "IDS", value_parser = ids::parse, default_value = "1-4")]
    ids: IdList,
    #[command(flatten)]
    motor: MotorOptions,
    #[command(flatten)]
    faults: FaultOptions,
    /// Also record every frame received and sent to this candump -L file (without direction
    /// markers: `rmd decode` pairs requests and replies by content).
    #[arg(long = "log", value_name = "FILE")]
    log: Option<PathBuf>,
}

/// The simulated motors' settings.
#[derive(Args, Debug)]
struct MotorOptions {
    /// Encoder resolution, bits (12..=18).
    #[arg(long, value_name = "BITS", value_parser = parse::encoder_width, default_value = "14")]
    encoder_bits: EncoderWidth,
    /// Gear ratio (motor turns per output turn).
    #[arg(long, value_parser = parse::positive, default_value = "9")]
    gear_ratio: f64,
    /// Time from a request to its reply, microseconds (0..=60000000).
    #[arg(long, value_name = "US", value_parser = timing::sim_delay_us, default_value = "200", allow_hyphen_values = true)]
    turnaround_us: u64,
    /// Random extra turnaround, 0..=this, microseconds (0..=60000000).
    #[arg(long, value_name = "US", value_parser = timing::sim_delay_us, default_value = "20", allow_hyphen_values = true)]
    jitter_us: u64,
    /// Seed of every random draw (jitter, faults): the same seed and traffic give the same run.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// A link under gravity on every output shaft: MASS_KG,LENGTH_M or
    /// MASS_KG,LENGTH_M,OFFSET_DEG (offset: the link's angle from hanging straight down at
    /// output angle 0).
    #[arg(long, value_name = "KG,M[,DEG]", value_parser = parse::gravity_link)]
    gravity: Option<GravityLink>,
    /// Initial output angle of every motor, degrees.
    #[arg(long, value_name = "DEG", value_parser = parse::finite, allow_hyphen_values = true, default_value = "0")]
    initial_deg: f64,
    /// The firmware the motors run: v1.61, lk-v2.3x (an MG motor, or the series of
    /// --lk-series) or myactuator-v3 (answers on 0x240 + id); one for every motor, or a
    /// comma-separated list with one per motor of --ids, in id order.
    #[arg(long, value_name = "FIRMWARE", value_parser = parse::sim_firmware, value_delimiter = ',', default_value = "v1.61")]
    firmware: Vec<ProtocolFamily>,
    /// The series of the lk-v2.3x motors: mf (±16.5 A over ±2048) or mg (±33 A, the default).
    #[arg(long, value_name = "SERIES", value_parser = parse::lk_series)]
    lk_series: Option<LkSeries>,
}

impl MotorOptions {
    /// The firmware of each of `count` motors, or what is wrong with `--firmware`.
    fn families(&self, count: usize) -> Result<Vec<FirmwareFamily>, String> {
        let series = self.lk_series.unwrap_or(LkSeries::Mg);
        let one = |family: ProtocolFamily| match family {
            ProtocolFamily::LkV23x => FirmwareFamily::LkV23x(series),
            ProtocolFamily::MyActuatorV3 => FirmwareFamily::MyActuatorV3,
            _ => FirmwareFamily::V161,
        };
        match self.firmware.as_slice() {
            [family] => Ok(vec![one(*family); count]),
            list if list.len() == count => Ok(list.iter().copied().map(one).collect()),
            list => Err(format!(
                "--firmware lists {} firmware families for {count} motors: give one for all, or \
                 one per motor of --ids",
                list.len()
            )),
        }
    }
}

/// Fault injection (each per reply, drawn from the seeded stream).
#[derive(Args, Debug)]
struct FaultOptions {
    /// Probability that a reply is not sent.
    #[arg(long, value_name = "P", value_parser = parse::probability)]
    drop: Option<f64>,
    /// Replies sent late: PROBABILITY,MILLISECONDS (e.g. 0.1,5).
    #[arg(long, value_name = "P,MS", value_parser = parse::late_fault)]
    late: Option<(f64, Duration)>,
    /// Probability that a reply has one corrupted byte.
    #[arg(long, value_name = "P", value_parser = parse::probability)]
    corrupt: Option<f64>,
    /// Probability that a reply is sent twice.
    #[arg(long, value_name = "P", value_parser = parse::probability)]
    duplicate: Option<f64>,
    /// Motors that never answer (as if unplugged).
    #[arg(long, value_name = "IDS", value_parser = ids::parse)]
    silent: Option<IdList>,
}

impl FaultOptions {
    fn rules(&self) -> Vec<FaultRule> {
        let mut rules = Vec::new();
        let mut per_reply = |p: Option<f64>, kind| {
            if let Some(p) = p {
                rules.push(FaultRule::new(kind).with_probability(p));
            }
        };
        per_reply(self.drop, ReplyFault::DropReply);
        per_reply(
            self.late.map(|(p, _)| p),
            ReplyFault::LateReply {
                delay: self.late.map_or(Duration::ZERO, |(_, d)| d),
            },
        );
        per_reply(self.corrupt, ReplyFault::CorruptBytes { count: 1 });
        per_reply(self.duplicate, ReplyFault::DuplicateReply);
        if let Some(silent) = &self.silent {
            rules.push(FaultRule::new(ReplyFault::Silent).motors(MotorSet::of(silent.ids())));
        }
        rules
    }
}

/// The simulation the arguments describe.
fn config(args: &SimArgs) -> Result<SimConfig, String> {
    let m = &args.motor;
    let families = m.families(args.ids.ids().len())?;
    let mut config = SimConfig::with_motors(0).seed(m.seed);
    config.motors = args
        .ids
        .ids()
        .iter()
        .zip(families)
        .map(|(&id, family)| {
            let mut motor = SimMotorConfig::new(id);
            motor.firmware.family = family;
            motor.firmware.encoder_width = m.encoder_bits;
            motor.motor.gear_ratio = m.gear_ratio;
            motor.turnaround = Duration::from_micros(m.turnaround_us);
            motor.turnaround_jitter = Duration::from_micros(m.jitter_us);
            motor.load.gravity = m.gravity.clone();
            motor.initial_output_angle_deg = m.initial_deg;
            motor
        })
        .collect();
    config.faults = args.faults.rules();
    config.validate().map_err(|e| format!("simulator: {e}"))?;
    Ok(config)
}

/// Runs `rmd sim`.
pub(crate) fn run(args: SimArgs) -> ExitCode {
    report::exit(serve(&args))
}

/// Counters printed when the simulator stops.
#[derive(Debug, Default)]
struct Counts {
    frames: u64,
    replies: u64,
    send_failures: u64,
}

/// Sends that fail with a full transmit queue are tried again this often...
const TX_RETRY: Duration = Duration::from_micros(200);
/// ...for at most this long, then the reply is given up.
const TX_GIVE_UP: Duration = Duration::from_millis(20);
/// Longest wait for a frame before looking at Ctrl-C and advancing the physics again: the
/// motors are kept within this of the present, so a request finds them (nearly) up to date
/// and its reply is computed without a long catch-up.
const SLICE: Duration = Duration::from_millis(2);
/// How often the progress line's counts are updated.
const PROGRESS_EVERY: Duration = Duration::from_millis(250);

fn serve(args: &SimArgs) -> Result<(), CliError> {
    let config = config(args).map_err(CliError::Usage)?;
    let clock = MonotonicClock;
    let mut motors = SimMotors::new(&config, clock.now()).map_err(|e| e.to_string())?;
    let bus = open_interface(&args.iface, Filter::MotorsAndMulti)?;
    let (mut bus, recording): (Box<dyn CanBus>, Option<Recording>) = match &args.log {
        None => (bus, None),
        Some(path) => {
            let sink = LogSink::create(path)?;
            // No direction markers: seen from the motors, T would mark the replies, which
            // `rmd decode` would take for requests; without markers it pairs by content.
            let options = RecordOptions::new(&args.iface).directions(false);
            let (bus, recording) =
                Recording::start(bus, clock, sink, |sink| Box::new(sink), options)?;
            (Box::new(bus), Some(recording))
        }
    };
    interrupt::install()?;
    let firmware: Vec<String> = config
        .motors
        .iter()
        .map(|m| m.firmware.family.to_string())
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .collect();
    errln!(
        "rmd sim: motors {} ({}) answering on {} (Ctrl-C stops)",
        args.ids,
        firmware.join(", "),
        args.iface
    );
    let mut pending: Vec<ScheduledFrame> = Vec::new();
    let mut counts = Counts::default();
    let progress = Progress::spinner(progress::shown(false));
    progress.set_prefix("rmd sim ");
    let outcome = run_loop(
        bus.as_mut(),
        &clock,
        &mut motors,
        &mut pending,
        &mut counts,
        &progress,
    );
    drop(progress);
    drop(bus);
    let ignored = motors.ignored_frames();
    let dropped: u64 = motors.iter().map(|m| m.stats().dropped_replies).sum();
    errln!(
        "rmd sim: stopped; {} frames received ({ignored} not for these motors), {} replies \
         sent, {dropped} dropped by fault injection, {} could not be sent",
        counts.frames,
        counts.replies,
        counts.send_failures
    );
    match recording {
        Some(recording) => recording::after(outcome, recording.finish()),
        None => outcome,
    }
}

fn run_loop(
    bus: &mut dyn CanBus,
    clock: &MonotonicClock,
    motors: &mut SimMotors,
    pending: &mut Vec<ScheduledFrame>,
    counts: &mut Counts,
    progress: &Progress,
) -> Result<(), CliError> {
    let mut next_report = clock.now();
    while !interrupt::requested() {
        send_due(bus, clock, pending, counts)?;
        let now = clock.now();
        if now >= next_report {
            // Not every frame: the motors' answers come first.
            progress.set_message(format!(
                "{} frames received, {} replies sent",
                counts.frames, counts.replies
            ));
            next_report = now + PROGRESS_EVERY;
        }
        let deadline = pending
            .first()
            .map_or(now + SLICE, |f| f.at.min(now + SLICE));
        match bus.recv_until(deadline) {
            Ok(Some(received)) => {
                if let BusMessage::Frame(frame) = received.message {
                    counts.frames += 1;
                    for reply in motors.handle(&frame, received.at) {
                        schedule(pending, reply);
                    }
                }
            }
            Ok(None) => motors.advance_to(clock.now()),
            Err(error) => return Err(bus_failure(error)),
        }
    }
    Ok(())
}

/// Inserts `reply` in due order (after replies due at the same time).
fn schedule(pending: &mut Vec<ScheduledFrame>, reply: ScheduledFrame) {
    let at = pending.partition_point(|f| f.at <= reply.at);
    pending.insert(at, reply);
}

/// Sends every reply that is due.
fn send_due(
    bus: &mut dyn CanBus,
    clock: &MonotonicClock,
    pending: &mut Vec<ScheduledFrame>,
    counts: &mut Counts,
) -> Result<(), CliError> {
    while let Some(next) = pending.first().copied() {
        let now = clock.now();
        if next.at > now {
            break;
        }
        match bus.send(&next.frame) {
            Ok(()) => {
                counts.replies += 1;
                pending.remove(0);
            }
            Err(BusError::TxQueueFull) if now - next.at < TX_GIVE_UP => {
                clock.sleep_until(now + TX_RETRY);
            }
            Err(BusError::TxQueueFull) => {
                counts.send_failures += 1;
                pending.remove(0);
            }
            Err(error) => return Err(bus_failure(error)),
        }
    }
    Ok(())
}

fn bus_failure(error: BusError) -> CliError {
    CliError::Failed(format!("rmd sim: {error}"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rmd_bus::Timestamp;
    use rmd_protocol::{CanFrame, MotorId};

    fn item(at: u64, id: u8) -> ScheduledFrame {
        let motor = MotorId::new(id).unwrap();
        ScheduledFrame {
            at: Timestamp::from_nanos(at),
            motor,
            frame: CanFrame::with_data(motor.can_id(), [0x9C, 0, 0, 0, 0, 0, 0, 0]).unwrap(),
        }
    }

    #[test]
    fn replies_are_kept_in_due_order_ties_in_arrival_order() {
        let mut pending = Vec::new();
        for (at, id) in [(300, 1), (100, 2), (300, 3), (200, 4)] {
            schedule(&mut pending, item(at, id));
        }
        let ids: Vec<u8> = pending.iter().map(|f| f.motor.get()).collect();
        assert_eq!(ids, [2, 4, 1, 3]);
        assert!(pending.iter().map(|f| f.at).is_sorted());
    }

    #[test]
    fn options_become_the_simulation() {
        use clap::Parser;
        #[derive(Parser)]
        struct Cli {
            #[command(flatten)]
            sim: SimArgs,
        }
        let cli = Cli::try_parse_from([
            "rmd",
            "--iface",
            "vcan0",
            "--ids",
            "2,5",
            "--encoder-bits",
            "16",
            "--gear-ratio",
            "6",
            "--seed",
            "7",
            "--gravity",
            "1.5,0.25",
            "--drop",
            "0.1",
            "--late",
            "0.2,3",
            "--silent",
            "5",
        ])
        .unwrap();
        let config = config(&cli.sim).unwrap();
        let ids: Vec<u8> = config.motors.iter().map(|m| m.id.get()).collect();
        assert_eq!(ids, [2, 5]);
        assert_eq!(config.seed, 7);
        let m = &config.motors[0];
        assert_eq!(m.firmware.encoder_width.bits(), 16);
        assert_eq!(m.motor.gear_ratio, 6.0);
        assert_eq!(m.load.gravity.as_ref().unwrap().mass_kg, 1.5);
        assert_eq!(config.faults.len(), 3);
        assert_eq!(config.faults[0].kind, ReplyFault::DropReply.into());
        assert_eq!(
            config.faults[1].kind,
            ReplyFault::LateReply {
                delay: Duration::from_millis(3)
            }
            .into()
        );
        assert!(config.faults[2].motors.contains(MotorId::new(5).unwrap()));
        assert!(!config.faults[2].motors.contains(MotorId::new(2).unwrap()));
    }
}
