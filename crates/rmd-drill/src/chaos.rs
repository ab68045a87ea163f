//! Chaos: drill after drill with random faults from the matrix, each judged by the simulated
//! firmware, watched for panics, hangs and growing memory.

use core::time::Duration;
use std::sync::mpsc;

use rand_pcg::Pcg64Mcg;
use rand_pcg::rand_core::{Rng, SeedableRng};
use rmd_protocol::MotorId;
use rmd_rig::SimTime;
use rmd_rig::signals::Signals;
use serde::Serialize;

use crate::fault::{DrillFault, Probability};
use crate::spec::DrillSpec;
use crate::verdict::SimMotorRef;
use rmd_protocol::ProtocolFamily;

/// How much the resident memory may grow after the warm-up, KiB: drills hold nothing from one
/// to the next, so growth beyond allocator noise is a leak. (The warm-up fills the process's
/// one-time caches: the first panic with `RUST_BACKTRACE=1` loads the debug information to
/// symbolise its backtrace, tens of MiB in a debug build.)
pub const MEMORY_BOUND_KIB: u64 = 64 * 1024;

/// A chaos run: a warm-up of one short drill of every kind of the matrix, in order, then drills
/// with random faults until their run time adds up to `seconds` (the warm-up's included).
#[derive(Clone, Debug, PartialEq)]
pub struct ChaosSpec {
    /// Total run time of the drills (simulated time in virtual time).
    pub seconds: Duration,
    /// Seeds the choice of faults and every drill's seed: the same seed, the same drills.
    pub seed: u64,
    /// Real or virtual time for every drill.
    pub time: SimTime,
    /// The program's signals, if they are to stop the run: the drill in progress is stopped
    /// (and judged), no other starts (`rmd_rig::signals`).
    pub signals: Option<Signals>,
    /// The simulated motors' firmware family ([`DrillSpec::firmware`]); MyActuator V3 drills
    /// have at most 3 motors per bus (the per-motor exchange's wire budget at 1 kHz).
    pub firmware: ProtocolFamily,
}

/// One drill of a chaos run, and what it found.
#[derive(Clone, Debug, Serialize)]
pub struct ChaosDrill {
    /// Its position in the run.
    pub index: usize,
    /// The faults, as written, each with its time after the start in seconds.
    pub faults: Vec<(String, f64)>,
    /// Buses.
    pub buses: u8,
    /// Motors per bus.
    pub motors: u8,
    /// Its length, seconds.
    pub seconds: f64,
    /// Its seed.
    pub seed: u64,
    /// Why the loop ended.
    pub stop_reason: String,
    /// Motors still energised after the run (ground truth).
    pub energised: Vec<SimMotorRef>,
    /// From the first fault until every motor was safe, milliseconds.
    pub time_to_safe_ms: Option<f64>,
    /// Resident memory after the drill, KiB (Linux only).
    pub rss_kib: Option<u64>,
}

/// Something a chaos run must never see.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum ChaosFailure {
    /// A drill left motors energised.
    Energised {
        /// The drill.
        index: usize,
        /// How many.
        motors: usize,
    },
    /// The loop confirmed a motor off that the firmware says is energised.
    WrongBelief {
        /// The drill.
        index: usize,
    },
    /// A drill panicked outside the loop's own handling.
    Panicked {
        /// The drill.
        index: usize,
        /// The panic message.
        message: String,
    },
    /// A drill did not finish within its budget (the run stops there: its thread is left).
    Hung {
        /// The drill.
        index: usize,
        /// The budget, seconds.
        budget_s: f64,
    },
    /// A drill could not run.
    Error {
        /// The drill.
        index: usize,
        /// Why.
        message: String,
    },
    /// Resident memory grew by more than [`MEMORY_BOUND_KIB`] after the warm-up.
    Memory {
        /// After the warm-up, KiB.
        first_kib: u64,
        /// The most seen, KiB.
        max_kib: u64,
    },
}

/// What a chaos run found.
#[derive(Clone, Debug, Default, Serialize)]
pub struct ChaosReport {
    /// Every drill, in order.
    pub drills: Vec<ChaosDrill>,
    /// Everything that went wrong (empty: the run passed).
    pub failures: Vec<ChaosFailure>,
}

impl ChaosReport {
    /// Whether no drill failed.
    pub fn passed(&self) -> bool {
        self.failures.is_empty()
    }
}

/// Runs drills with random faults until their run time adds up to `spec.seconds`; `each` sees
/// every drill as it ends (for progress).
///
/// ```
/// use core::time::Duration;
/// use rmd_drill::chaos::{ChaosSpec, chaos};
/// use rmd_rig::SimTime;
/// let spec = ChaosSpec {
///     seconds: Duration::from_secs(1),
///     seed: 7,
///     time: SimTime::Virtual,
///     signals: None,
///     firmware: rmd_protocol::ProtocolFamily::V161,
/// };
/// let report = chaos(&spec, |_| {});
/// assert!(report.passed(), "{:?}", report.failures);
/// assert!(report.drills.len() >= 2);
/// ```
pub fn chaos(spec: &ChaosSpec, mut each: impl FnMut(&ChaosDrill)) -> ChaosReport {
    let mut rng = Pcg64Mcg::seed_from_u64(spec.seed);
    let mut report = ChaosReport::default();
    let mut elapsed = Duration::ZERO;
    let mut baseline_rss = None;
    let mut max_rss = 0;
    let mut warm_up = warm_up(&mut rng, spec.time, spec.firmware).into_iter();
    while elapsed < spec.seconds && !spec.signals.is_some_and(|s| s.interrupted()) {
        let index = report.drills.len();
        let (mut drill, warming) = match warm_up.next() {
            Some(drill) => (drill, true),
            None => (random_drill(&mut rng, spec.time, spec.firmware), false),
        };
        if let Some(signals) = spec.signals {
            drill = drill.stopped_by(signals);
        }
        elapsed += drill.seconds;
        let budget = budget(&drill);
        let (tx, rx) = mpsc::channel();
        let to_run = drill.clone();
        let spawned = std::thread::Builder::new()
            .name(format!("rmd-drill-chaos-{index}"))
            .spawn(move || {
                let result = std::panic::catch_unwind(|| crate::run(&to_run));
                let _ = tx.send(result);
            });
        let outcome = match spawned {
            Ok(_) => rx.recv_timeout(budget),
            Err(e) => {
                report.failures.push(ChaosFailure::Error {
                    index,
                    message: format!("cannot start the drill's thread: {e}"),
                });
                break;
            }
        };
        let result = match outcome {
            Ok(Ok(Ok(result))) => result,
            Ok(Ok(Err(e))) => {
                report.failures.push(ChaosFailure::Error {
                    index,
                    message: e.to_string(),
                });
                continue;
            }
            Ok(Err(panic)) => {
                report.failures.push(ChaosFailure::Panicked {
                    index,
                    message: panic_message(&*panic),
                });
                continue;
            }
            Err(_) => {
                report.failures.push(ChaosFailure::Hung {
                    index,
                    budget_s: budget.as_secs_f64(),
                });
                break;
            }
        };
        if !result.passed() {
            report.failures.push(ChaosFailure::Energised {
                index,
                motors: result.motors_energised_after,
            });
        }
        if !result.believed_off_but_energised.is_empty() {
            report.failures.push(ChaosFailure::WrongBelief { index });
        }
        let rss_kib = resident_kib();
        if let Some(rss) = rss_kib.filter(|_| !warming) {
            let first = *baseline_rss.get_or_insert(rss);
            max_rss = max_rss.max(rss);
            if max_rss > first + MEMORY_BOUND_KIB
                && !report
                    .failures
                    .iter()
                    .any(|f| matches!(f, ChaosFailure::Memory { .. }))
            {
                report.failures.push(ChaosFailure::Memory {
                    first_kib: first,
                    max_kib: max_rss,
                });
            }
        }
        let seen = ChaosDrill {
            index,
            faults: drill
                .faults
                .iter()
                .map(|(f, at)| (f.to_string(), at.as_secs_f64()))
                .collect(),
            buses: drill.buses,
            motors: drill.motors,
            seconds: drill.seconds.as_secs_f64(),
            seed: drill.seed,
            stop_reason: result.stop_reason,
            energised: result.energised,
            time_to_safe_ms: result.time_to_safe_ms,
            rss_kib,
        };
        each(&seen);
        report.drills.push(seen);
    }
    report
}

/// How long a drill may take in real time before it counts as hung: its own length in real
/// time, its hangs (which take real time even in virtual time, at a quarter of their length),
/// the safe stop's patience, and a wide margin for a loaded machine.
fn budget(drill: &DrillSpec) -> Duration {
    let hangs: Duration = drill
        .faults
        .iter()
        .map(|(fault, _)| match fault {
            DrillFault::ControllerHang(d) => *d,
            _ => Duration::ZERO,
        })
        .sum();
    let own = match drill.time {
        SimTime::Real => drill.seconds,
        SimTime::Virtual => Duration::ZERO,
    };
    own + hangs + Duration::from_secs(60)
}

/// The most motors a drill of `firmware` puts on a bus.
fn most_motors(firmware: ProtocolFamily) -> u8 {
    match firmware {
        ProtocolFamily::MyActuatorV3 => 3,
        ProtocolFamily::V161 | ProtocolFamily::LkV23x | ProtocolFamily::Unknown => 4,
    }
}

/// One drill of every kind of the matrix, 300 ms each, on two buses of as many motors as the
/// firmware's exchange carries (four; three for MyActuator V3).
fn warm_up(rng: &mut Pcg64Mcg, time: SimTime, firmware: ProtocolFamily) -> Vec<DrillSpec> {
    DrillFault::matrix()
        .into_iter()
        .map(|fault| {
            DrillSpec::new(fault)
                .firmware(firmware)
                .motors(most_motors(firmware))
                .buses(2)
                .at(Duration::from_millis(100))
                .seconds(Duration::from_millis(300))
                .seed(rng.next_u64())
                .time(time)
        })
        .collect()
}

/// A drill with 1 to 3 random faults from the matrix at random times.
fn random_drill(rng: &mut Pcg64Mcg, time: SimTime, firmware: ProtocolFamily) -> DrillSpec {
    let buses = 1 + below(rng, 3) as u8;
    let motors = 1 + below(rng, u64::from(most_motors(firmware))) as u8;
    let seconds = Duration::from_millis(100 + below(rng, 700));
    let mut spec: Option<DrillSpec> = None;
    for _ in 0..1 + below(rng, 3) {
        let fault = random_fault(rng, motors);
        let at = Duration::from_millis(20 + below(rng, seconds.as_millis() as u64 * 9 / 10 - 20));
        spec = Some(match spec {
            None => DrillSpec::new(fault).at(at),
            Some(spec)
                if matches!(fault, DrillFault::UnknownMotor(_))
                    && spec
                        .faults
                        .iter()
                        .any(|(f, _)| matches!(f, DrillFault::UnknownMotor(_))) =>
            {
                spec
            }
            Some(spec) => spec.and(fault, at),
        });
    }
    spec.unwrap_or_else(|| DrillSpec::new(DrillFault::Stop))
        .buses(buses)
        .motors(motors)
        .firmware(firmware)
        .seconds(seconds)
        .seed(rng.next_u64())
        .time(time)
}

/// A fault of a random kind with a random argument within what the defaults can make safe (a
/// bus-off shorter than `safe_stop.bus_off_wait_ms`, a stall shorter than its deadline).
fn random_fault(rng: &mut Pcg64Mcg, motors: u8) -> DrillFault {
    let ms = |rng: &mut Pcg64Mcg, lo: u64, hi: u64| Duration::from_millis(lo + below(rng, hi - lo));
    let p = |rng: &mut Pcg64Mcg| Probability::new(below(rng, 101) as f64 / 100.0);
    let id = |n: u64| MotorId::new(n as u8).ok();
    let fault = match below(rng, 17) {
        0 => Some(DrillFault::BusOff(ms(rng, 1, 400))),
        1 => Some(DrillFault::TxStall(ms(rng, 1, 400))),
        2 => Some(DrillFault::ControllerHang(ms(rng, 10, 1500))),
        3 => Some(DrillFault::ControllerPanic),
        4 => Some(DrillFault::NanCommand),
        5 => Some(DrillFault::SlowController(Duration::from_micros(
            50 + below(rng, 3000),
        ))),
        6 => id(1 + below(rng, u64::from(motors))).map(DrillFault::SilentMotor),
        7 => p(rng).map(DrillFault::Drop),
        8 => p(rng).map(|p| DrillFault::Late(p, ms(rng, 1, 6))),
        9 => p(rng).map(DrillFault::Corrupt),
        10 => p(rng).map(DrillFault::Duplicate),
        11 => p(rng).map(DrillFault::WrongDlc),
        12 => Some(DrillFault::OverTemperature),
        13 => Some(DrillFault::LowVoltage),
        14 => Some(DrillFault::Estop),
        15 => Some(DrillFault::Stop),
        // An undescribed motor beside the described ones (ids 1..=4 are the 0x280 frame's).
        _ if motors >= 2 => id(1 + below(rng, 4)).map(DrillFault::UnknownMotor),
        _ => id(2 + below(rng, 3)).map(DrillFault::UnknownMotor),
    };
    fault.unwrap_or(DrillFault::Stop)
}

/// A uniform draw from `0..n` (`n > 0`).
fn below(rng: &mut Pcg64Mcg, n: u64) -> u64 {
    rng.next_u64() % n.max(1)
}

fn panic_message(panic: &(dyn core::any::Any + Send)) -> String {
    panic
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| panic.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "a panic without a message".to_string())
}

/// The process's resident memory, KiB (`VmRSS` in /proc/self/status).
fn resident_kib() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    status
        .lines()
        .find_map(|line| line.strip_prefix("VmRSS:"))
        .and_then(|rest| rest.trim().trim_end_matches("kB").trim().parse().ok())
}
