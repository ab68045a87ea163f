//! The faults a drill can inject, as written on the command line (`bus-off:50`, `late:0.1,3`).

use core::fmt;
use core::str::FromStr;
use core::time::Duration;

use rmd_protocol::MotorId;

/// One fault a drill injects.
///
/// Parsed from `KIND[:ARG]`; [`Display`](fmt::Display) writes the same form back.
///
/// ```
/// use rmd_drill::DrillFault;
/// let fault: DrillFault = "late:0.1,3".parse()?;
/// assert_eq!(fault.to_string(), "late:0.1,3");
/// assert!("bus-off".parse::<DrillFault>().is_err()); // bus-off needs its duration
/// # Ok::<(), rmd_drill::FaultParseError>(())
/// ```
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum DrillFault {
    /// Bus 0's controller goes bus-off for this long, then restarts.
    BusOff(Duration),
    /// Bus 0's controller cannot transmit for this long (its transmit queue fills).
    TxStall(Duration),
    /// The controller's `update` blocks for this long, once.
    ControllerHang(Duration),
    /// The controller panics.
    ControllerPanic,
    /// The controller commands NaN amperes on the first joint from then on.
    NanCommand,
    /// Every `update` from then on takes this much longer.
    SlowController(Duration),
    /// This motor on bus 0 stops answering (it still hears and obeys).
    SilentMotor(MotorId),
    /// Every motor on bus 0 drops each reply with this probability.
    Drop(Probability),
    /// Every motor on bus 0 sends each reply this late with this probability.
    Late(Probability, Duration),
    /// Every motor on bus 0 corrupts two bytes of each reply with this probability.
    Corrupt(Probability),
    /// Every motor on bus 0 sends each reply twice with this probability.
    Duplicate(Probability),
    /// Every motor on bus 0 sends each reply with DLC 5 with this probability.
    WrongDlc(Probability),
    /// Motor 1 on bus 0 overheats (its winding held above the firmware's threshold).
    OverTemperature,
    /// Motor 1 on bus 0 loses supply voltage (held below the firmware's threshold).
    LowVoltage,
    /// An emergency stop is requested.
    Estop,
    /// A stop is requested.
    Stop,
    /// A motor with this id answers on bus 0 but the robot description does not have it (it is
    /// there from power-up: the drill's `--at` does not apply).
    UnknownMotor(MotorId),
    /// The host falls silent for good, as after SIGKILL, a kernel hang or a power loss: from
    /// then on nothing it sends reaches any bus's motors, its safe stop included. The duration
    /// is the communication watchdog in every MyActuator V3 motor's ROM (0xB3, `rmd watchdog`;
    /// zero: none): the only thing that stops a motor then. v1.61 and LK-TECH motors have none.
    /// Not in the matrix: without a watchdog its honest verdict is "energised".
    HostSilent(Duration),
}

/// A probability, 0..=1.
#[derive(Copy, Clone, Debug, PartialEq, PartialOrd)]
pub struct Probability(f64);

impl Probability {
    /// `p` if it is a probability (finite, 0..=1).
    pub fn new(p: f64) -> Option<Self> {
        (p.is_finite() && (0.0..=1.0).contains(&p)).then_some(Self(p))
    }

    /// The value.
    pub fn get(self) -> f64 {
        self.0
    }
}

impl fmt::Display for Probability {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0)
    }
}

/// Why a fault could not be read.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum FaultParseError {
    /// Not one of the kinds.
    #[error("unknown fault kind `{0}`: expected one of {KINDS}")]
    UnknownKind(String),
    /// The kind needs an argument.
    #[error("fault `{kind}` needs its argument: `{kind}:{what}`")]
    MissingArgument {
        /// The kind.
        kind: &'static str,
        /// What the argument is.
        what: &'static str,
    },
    /// The kind takes no argument.
    #[error("fault `{0}` takes no argument")]
    UnexpectedArgument(&'static str),
    /// The argument is not valid.
    #[error("fault `{kind}`: `{given}` is not {what}")]
    BadArgument {
        /// The kind.
        kind: &'static str,
        /// The argument as given.
        given: String,
        /// What it should be.
        what: &'static str,
    },
}

/// Every kind, as the error message lists them.
const KINDS: &str = "bus-off:MS, tx-stall:MS, controller-hang:MS, controller-panic, nan-command, \
     slow-controller:US, silent-motor:ID, drop:P, late:P,MS, corrupt:P, duplicate:P, wrong-dlc:P, \
     over-temperature, low-voltage, estop, stop, unknown-motor:ID, host-silent:MS";

/// The longest duration a fault argument may name: one hour.
const MAX_ARG: Duration = Duration::from_secs(3600);

impl DrillFault {
    /// One drill of every kind, with the arguments `rmd drill --all` uses: each a fault a real
    /// robot meets (a 50 ms bus-off, a 100 ms transmit stall, a 3 s controller hang, 10 % of
    /// replies lost or 1-3 ms late, ...).
    pub fn matrix() -> Vec<DrillFault> {
        Self::try_matrix().unwrap_or_default()
    }

    fn try_matrix() -> Option<Vec<DrillFault>> {
        let p = |p| Probability(p);
        let ms = Duration::from_millis;
        let id = |n| MotorId::new(n).ok();
        Some(vec![
            DrillFault::BusOff(ms(50)),
            DrillFault::TxStall(ms(100)),
            DrillFault::ControllerHang(ms(3000)),
            DrillFault::ControllerPanic,
            DrillFault::NanCommand,
            DrillFault::SlowController(Duration::from_micros(1500)),
            DrillFault::SilentMotor(id(2)?),
            DrillFault::Drop(p(0.1)),
            DrillFault::Late(p(0.1), ms(3)),
            DrillFault::Corrupt(p(0.1)),
            DrillFault::Duplicate(p(0.1)),
            DrillFault::WrongDlc(p(0.1)),
            DrillFault::OverTemperature,
            DrillFault::LowVoltage,
            DrillFault::Estop,
            DrillFault::Stop,
            DrillFault::UnknownMotor(id(3)?),
        ])
    }

    /// The kind's name (`bus-off`, `late`, ...).
    pub fn kind(&self) -> &'static str {
        match self {
            DrillFault::BusOff(_) => "bus-off",
            DrillFault::TxStall(_) => "tx-stall",
            DrillFault::ControllerHang(_) => "controller-hang",
            DrillFault::ControllerPanic => "controller-panic",
            DrillFault::NanCommand => "nan-command",
            DrillFault::SlowController(_) => "slow-controller",
            DrillFault::SilentMotor(_) => "silent-motor",
            DrillFault::Drop(_) => "drop",
            DrillFault::Late(..) => "late",
            DrillFault::Corrupt(_) => "corrupt",
            DrillFault::Duplicate(_) => "duplicate",
            DrillFault::WrongDlc(_) => "wrong-dlc",
            DrillFault::OverTemperature => "over-temperature",
            DrillFault::LowVoltage => "low-voltage",
            DrillFault::Estop => "estop",
            DrillFault::Stop => "stop",
            DrillFault::UnknownMotor(_) => "unknown-motor",
            DrillFault::HostSilent(_) => "host-silent",
        }
    }

    /// Whether the controller injects it (the others are the simulated motors' and buses').
    pub fn is_controller_fault(&self) -> bool {
        matches!(
            self,
            DrillFault::ControllerHang(_)
                | DrillFault::ControllerPanic
                | DrillFault::NanCommand
                | DrillFault::SlowController(_)
                | DrillFault::Estop
                | DrillFault::Stop
        )
    }
}

impl fmt::Display for DrillFault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let kind = self.kind();
        match self {
            DrillFault::BusOff(d)
            | DrillFault::TxStall(d)
            | DrillFault::ControllerHang(d)
            | DrillFault::HostSilent(d) => {
                write!(f, "{kind}:{}", d.as_millis())
            }
            DrillFault::SlowController(d) => write!(f, "{kind}:{}", d.as_micros()),
            DrillFault::SilentMotor(id) | DrillFault::UnknownMotor(id) => {
                write!(f, "{kind}:{}", id.get())
            }
            DrillFault::Drop(p)
            | DrillFault::Corrupt(p)
            | DrillFault::Duplicate(p)
            | DrillFault::WrongDlc(p) => write!(f, "{kind}:{p}"),
            DrillFault::Late(p, d) => write!(f, "{kind}:{p},{}", d.as_millis()),
            _ => f.write_str(kind),
        }
    }
}

impl FromStr for DrillFault {
    type Err = FaultParseError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let (kind, arg) = match s.split_once(':') {
            Some((kind, arg)) => (kind.trim(), Some(arg.trim())),
            None => (s.trim(), None),
        };
        let Some(&(name, needs)) = SHAPES.iter().find(|(name, _)| *name == kind) else {
            return Err(FaultParseError::UnknownKind(kind.to_string()));
        };
        let arg = match (needs, arg) {
            (None, None) => "",
            (None, Some(_)) => return Err(FaultParseError::UnexpectedArgument(name)),
            (Some(what), None) => {
                return Err(FaultParseError::MissingArgument { kind: name, what });
            }
            (Some(_), Some(arg)) => arg,
        };
        let bad = |what| FaultParseError::BadArgument {
            kind: name,
            given: arg.to_string(),
            what,
        };
        let ms = |text: &str| parse_duration(text, 1_000).ok_or_else(|| bad(MS));
        let p = |text: &str| {
            text.trim()
                .parse::<f64>()
                .ok()
                .and_then(Probability::new)
                .ok_or_else(|| bad(PROBABILITY))
        };
        let id = |text: &str| {
            text.trim()
                .parse::<u8>()
                .ok()
                .and_then(|n| MotorId::new(n).ok())
                .ok_or_else(|| bad(ID))
        };
        Ok(match name {
            "bus-off" => DrillFault::BusOff(ms(arg)?),
            "tx-stall" => DrillFault::TxStall(ms(arg)?),
            "controller-hang" => DrillFault::ControllerHang(ms(arg)?),
            "controller-panic" => DrillFault::ControllerPanic,
            "nan-command" => DrillFault::NanCommand,
            "slow-controller" => {
                DrillFault::SlowController(parse_duration(arg, 1).ok_or_else(|| bad(US))?)
            }
            "silent-motor" => DrillFault::SilentMotor(id(arg)?),
            "drop" => DrillFault::Drop(p(arg)?),
            "late" => {
                let (prob, delay) = arg.split_once(',').ok_or_else(|| bad(LATE))?;
                DrillFault::Late(p(prob)?, ms(delay)?)
            }
            "corrupt" => DrillFault::Corrupt(p(arg)?),
            "duplicate" => DrillFault::Duplicate(p(arg)?),
            "wrong-dlc" => DrillFault::WrongDlc(p(arg)?),
            "over-temperature" => DrillFault::OverTemperature,
            "low-voltage" => DrillFault::LowVoltage,
            "estop" => DrillFault::Estop,
            "stop" => DrillFault::Stop,
            "host-silent" => DrillFault::HostSilent(ms(arg)?),
            _ => DrillFault::UnknownMotor(id(arg)?),
        })
    }
}

const MS: &str = "a whole number of milliseconds, at most one hour";
const US: &str = "a whole number of microseconds, at most one hour";
const PROBABILITY: &str = "a probability from 0 to 1";
const ID: &str = "a motor id from 1 to 32";
const LATE: &str = "`P,MS`: a probability and a delay in milliseconds";

/// Each kind and what its argument is (`None`: no argument).
const SHAPES: &[(&str, Option<&str>)] = &[
    ("bus-off", Some("MS")),
    ("tx-stall", Some("MS")),
    ("controller-hang", Some("MS")),
    ("controller-panic", None),
    ("nan-command", None),
    ("slow-controller", Some("US")),
    ("silent-motor", Some("ID")),
    ("drop", Some("P")),
    ("late", Some("P,MS")),
    ("corrupt", Some("P")),
    ("duplicate", Some("P")),
    ("wrong-dlc", Some("P")),
    ("over-temperature", None),
    ("low-voltage", None),
    ("estop", None),
    ("stop", None),
    ("unknown-motor", Some("ID")),
    ("host-silent", Some("MS")),
];

/// A whole number of `unit_us` microseconds, at most [`MAX_ARG`].
fn parse_duration(text: &str, unit_us: u64) -> Option<Duration> {
    let n: u64 = text.trim().parse().ok()?;
    let d = Duration::from_micros(n.checked_mul(unit_us)?);
    (d <= MAX_ARG).then_some(d)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_kind_of_the_matrix_reads_back_what_it_writes() {
        let matrix = DrillFault::matrix();
        // Every kind but host-silent, whose verdict without a motor watchdog is "energised".
        assert_eq!(matrix.len() + 1, SHAPES.len());
        for (fault, (name, _)) in matrix.iter().zip(SHAPES) {
            assert_eq!(fault.kind(), *name);
            assert_eq!(fault.to_string().parse::<DrillFault>(), Ok(*fault));
        }
        let silent = DrillFault::HostSilent(Duration::from_millis(50));
        assert_eq!(silent.to_string(), "host-silent:50");
        assert_eq!("host-silent:50".parse::<DrillFault>(), Ok(silent));
        assert_eq!(
            "host-silent:0".parse::<DrillFault>(),
            Ok(DrillFault::HostSilent(Duration::ZERO))
        );
    }

    #[test]
    fn arguments_are_checked() {
        let err = |s: &str| s.parse::<DrillFault>().unwrap_err().to_string();
        assert!(err("melt").contains("unknown fault kind `melt`: expected one of bus-off:MS"));
        assert_eq!(err("drop"), "fault `drop` needs its argument: `drop:P`");
        assert_eq!(err("estop:3"), "fault `estop` takes no argument");
        assert!(err("drop:1.5").contains("not a probability from 0 to 1"));
        assert!(err("drop:NaN").contains("not a probability"));
        assert!(err("late:0.1").contains("`P,MS`"));
        assert!(err("silent-motor:0").contains("a motor id from 1 to 32"));
        assert!(err("silent-motor:33").contains("a motor id from 1 to 32"));
        assert!(err("bus-off:-5").contains("milliseconds"));
        assert!(err("bus-off:18446744073709551615").contains("at most one hour"));
        assert!(err("controller-hang:3600001").contains("at most one hour"));
        assert_eq!(
            "late: 0.5 , 2".parse(),
            Ok(DrillFault::Late(
                Probability::new(0.5).unwrap(),
                Duration::from_millis(2)
            ))
        );
    }
}
