//! Opening the bus every live command talks to: `--iface IFACE` (SocketCAN) or `--sim`
//! (simulated motors in this process, in real time, running the firmware of `--sim-firmware`),
//! optionally recorded with `--log FILE`; and each motor's protocol, learned before the first
//! request to it.
//!
//! # Each motor's protocol
//!
//! Every request goes through [`Connection::request`], which learns the motor's family first
//! ([`Connection::dialect`]), once per command: named (`--protocol`, or the robot description's),
//! it is checked by reading status 1 in it (a motor of another family answers on the other
//! reply identifier); not named, the motor is identified from its answers to read-only
//! requests ([`probe`], `rmd_protocol::identify`), and a MyActuator V3 motor's firmware date is
//! read (0xB2: it chooses the V4.3 or V4.4 layouts). Only then is the request encoded, in that
//! family's layouts and scales, or refused with what to use instead. So no frame that moves or
//! writes a motor leaves before its family is known, and none in another family's scale.
//!
//! Motor off ([`Connection::motor_off`]) needs no family: 0x80 is the same frame everywhere.

use std::collections::BTreeMap;
use std::time::Duration;

use rmd_bus::record::RecordOptions;
use rmd_bus::{CanBus, MonotonicClock};
use rmd_protocol::{
    Command, Dialect, EncoderWidth, Finding, FirmwareDate, MotorId, ProtocolFamily, Reply, Request,
    Status1, V3Firmware, identify,
};
use rmd_sim::{FirmwareFamily, SimBus, SimConfig, SimMotorConfig};

use crate::args::bus::BusArgs;
use crate::args::ids::IdList;
use crate::live::exchange::{self, ExchangeError, Policy, Setup};
use crate::live::family::{MotorFamily, ProtocolSource};
use crate::live::frames_mcap::FramesMcap;
use crate::live::probe::{Identified, ProbeTiming, probe};
use crate::live::recording::{LogSink, Recording};
use crate::output::report::CliError;

/// Default reply timeout of a request.
pub(crate) const DEFAULT_TIMEOUT: Duration = Duration::from_millis(50);
/// Default retries of a request.
pub(crate) const DEFAULT_RETRIES: u32 = 2;
/// How long a MyActuator V3 motor may take to echo a brake release: 50 to 150 ms measured,
/// and a host that gave up sooner left a motor half enabled (github.com/almond-bot/axol PR 45,
/// which waits up to 1 s).
const BRAKE_RELEASE_TIME: Duration = Duration::from_secs(1);

/// An open bus: the bus (recorded if asked), its clock, the exchange policy, and what is known
/// of each motor's protocol.
pub(crate) struct Connection {
    bus: Box<dyn CanBus>,
    clock: MonotonicClock,
    policy: Policy,
    width: EncoderWidth,
    recording: Option<Recording>,
    frames_mcap: Option<FramesMcap>,
    /// How each motor's protocol is learned.
    source: ProtocolSource,
    /// Motors whose protocol a robot description names (checked like `--protocol`).
    named: BTreeMap<MotorId, Dialect>,
    /// What this command learned of each motor's family.
    families: BTreeMap<MotorId, MotorFamily>,
}

/// A motor turned off ([`Connection::motor_off`]).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) struct MotorOff {
    /// Its brake was locked too (MyActuator V3).
    pub(crate) brake_locked: bool,
}

/// The bus of a connection while its real one is being wrapped: sends and receives nothing.
struct Detached;

impl CanBus for Detached {
    fn send(&mut self, _: &rmd_bus::CanFrame) -> Result<(), rmd_bus::BusError> {
        Err(rmd_bus::BusError::InterfaceDown)
    }
    fn recv_until(
        &mut self,
        _: rmd_bus::Timestamp,
    ) -> Result<Option<rmd_bus::Received>, rmd_bus::BusError> {
        Ok(None)
    }
}

impl Connection {
    /// Opens what `args` names, with the given default timeout and retries (the command line
    /// overrides them).
    pub(crate) fn open(
        args: &BusArgs,
        default_timeout: Duration,
        default_retries: u32,
    ) -> Result<Self, CliError> {
        if let Some(robot) = &args.robot {
            // Joint names are for the commands that open `Motors`; here a description would
            // be silently ignored and the command would talk to whatever --iface/--sim says.
            return Err(CliError::Usage(format!(
                "--robot {}: this command takes motor ids, not a robot's joints (--robot works \
                 with status, monitor, move, off, stop and run): give --iface IFACE or --sim",
                robot.display()
            )));
        }
        let (bus, setup): (Box<dyn CanBus>, Setup) = if args.sim {
            (
                Box::new(simulated_bus(
                    &args.sim_ids,
                    args.encoder_bits,
                    &args.sim_families().map_err(CliError::Usage)?,
                )?),
                Setup::Simulator(args.sim_ids.clone()),
            )
        } else if let Some(iface) = &args.iface {
            if !args.sim_firmware.is_empty() {
                return Err(CliError::Usage(format!(
                    "--sim-firmware chooses the firmware of the simulated motors of --sim; the \
                     motors on {iface} run their own"
                )));
            }
            (
                open_interface(iface, Filter::Motors)?,
                Setup::Interface(iface.clone()),
            )
        } else {
            return Err(CliError::Usage(
                "no bus given: use --iface IFACE for a CAN interface (e.g. --iface can0), or \
                 --sim for simulated motors"
                    .to_owned(),
            ));
        };
        Self::on(
            bus,
            setup,
            args,
            args.encoder_bits,
            default_timeout,
            default_retries,
        )
    }

    /// A connection on an open `bus` (recorded if `args` asks), with the timeout and retries of
    /// `args` or the defaults.
    pub(crate) fn on(
        bus: Box<dyn CanBus>,
        setup: Setup,
        args: &BusArgs,
        width: EncoderWidth,
        default_timeout: Duration,
        default_retries: u32,
    ) -> Result<Self, CliError> {
        let source = args.protocol_source().map_err(CliError::Usage)?;
        let (bus, recording) = match &args.log {
            None => (bus, None),
            Some(path) => {
                let name = match &setup {
                    Setup::Interface(iface) => iface.as_str(),
                    Setup::Simulator(_) | Setup::Robot(_) => "sim",
                };
                let (bus, recording) = record_to(bus, path, name)?;
                (bus, Some(recording))
            }
        };
        Ok(Self {
            bus,
            clock: MonotonicClock,
            policy: Policy {
                timeout: args
                    .timeout_ms
                    .map_or(default_timeout, Duration::from_millis),
                retries: args.retries.unwrap_or(default_retries),
                setup,
            },
            width,
            recording,
            frames_mcap: None,
            source,
            named: BTreeMap::new(),
            families: BTreeMap::new(),
        })
    }

    /// Records every frame from now on for `--mcap path`: the file is written, decoded, when
    /// the connection [finishes](Self::finish).
    pub(crate) fn record_mcap(&mut self, path: Option<&std::path::Path>) -> Result<(), CliError> {
        let Some(path) = path else {
            return Ok(());
        };
        let name = match &self.policy.setup {
            Setup::Interface(iface) => iface.clone(),
            Setup::Simulator(_) | Setup::Robot(_) => "sim".to_owned(),
        };
        let bus = std::mem::replace(&mut self.bus, Box::new(Detached));
        let (bus, mcap) = FramesMcap::start(bus, &name, path.to_owned(), self.width)?;
        self.bus = bus;
        self.frames_mcap = Some(mcap);
        Ok(())
    }

    /// Names `motor`'s protocol, as a robot description does: checked, not identified.
    pub(crate) fn name_protocol(&mut self, motor: MotorId, dialect: Dialect) {
        self.named.insert(motor, dialect);
    }

    /// Sends `request` to `motor` in its protocol (learned first, see the module docs) and
    /// returns its reply.
    pub(crate) fn request(
        &mut self,
        motor: MotorId,
        request: &Request,
    ) -> Result<Reply, ExchangeError> {
        let dialect = self.dialect(motor, request.command())?;
        self.exchange_in(dialect, motor, request)
    }

    /// The dialect to send `command` to `motor` in, its family learned first if this command
    /// has not yet; refused when the family does not have the command
    /// ([`ExchangeError::NotInFamily`]) or its current's scale is not known
    /// ([`ExchangeError::LkSeriesNeeded`]).
    pub(crate) fn dialect(
        &mut self,
        motor: MotorId,
        command: Command,
    ) -> Result<Dialect, ExchangeError> {
        let family = self.family(motor)?;
        let dialect = family
            .dialect_for(command)
            .ok_or(ExchangeError::LkSeriesNeeded { motor, command })?;
        if !dialect.supports(command) {
            return Err(ExchangeError::NotInFamily {
                motor,
                command,
                dialect,
            });
        }
        Ok(dialect)
    }

    /// What is known of `motor`'s family, learned now if this command has not yet.
    pub(crate) fn family(&mut self, motor: MotorId) -> Result<MotorFamily, ExchangeError> {
        if let Some(&family) = self.families.get(&motor) {
            return Ok(family);
        }
        let family = self.learn(motor)?;
        self.families.insert(motor, family);
        Ok(family)
    }

    /// Learns `motor`'s family (see the module docs).
    fn learn(&mut self, motor: MotorId) -> Result<MotorFamily, ExchangeError> {
        let source = match self.named.get(&motor) {
            Some(&dialect) => ProtocolSource::Named(dialect),
            None => self.source,
        };
        match source {
            ProtocolSource::Named(dialect) => {
                // Status 1 is read-only in every family, and answered on the family's own
                // identifier: a motor of another family is found out here.
                self.exchange_in(dialect, motor, &Request::ReadStatus1)?;
                Ok(MotorFamily::Known(match dialect {
                    Dialect::MyActuatorV3(firmware) if firmware.date.is_none() => {
                        Dialect::MyActuatorV3(V3Firmware {
                            date: Some(self.firmware_date(motor)?),
                            ..firmware
                        })
                    }
                    dialect => dialect,
                }))
            }
            ProtocolSource::Identify { lk_series } => {
                let identified = self.identify(motor)?;
                let identification = identified.identification;
                Ok(match identification.family {
                    ProtocolFamily::V161 => MotorFamily::Known(Dialect::V161),
                    ProtocolFamily::LkV23x => lk_series.map_or(MotorFamily::LkSeriesUnknown, |s| {
                        MotorFamily::Known(Dialect::LkV23x(s))
                    }),
                    ProtocolFamily::MyActuatorV3 => {
                        let date = match identified.firmware_date {
                            Some(date) => date,
                            None => self.firmware_date(motor)?,
                        };
                        MotorFamily::Known(Dialect::MyActuatorV3(V3Firmware::dated(date)))
                    }
                    ProtocolFamily::Unknown => {
                        return Err(match identification.evidence.finding {
                            Finding::NoAnswer => ExchangeError::NoReply {
                                motor,
                                command: Command::ReadStatus1,
                                timeout: self.policy.timeout,
                                attempts: self.policy.retries.saturating_add(1),
                                setup: self.policy.setup.clone(),
                                signs: Default::default(),
                            },
                            finding => ExchangeError::Unidentified { motor, finding },
                        });
                    }
                })
            }
        }
    }

    /// Identifies `motor`'s family from its answers to the read-only probes (0x9A, 0x9C; a
    /// motor answering as MyActuator V3 is then asked its model, 0xB5, and its firmware date,
    /// 0xB2, `None` if it does not answer it). Errors: the bus failed.
    pub(crate) fn identify(&mut self, motor: MotorId) -> Result<Identified, ExchangeError> {
        let timing = ProbeTiming {
            timeout: self.policy.timeout,
            retries: self.policy.retries,
        };
        let answers = probe(self.bus.as_mut(), &self.clock, timing, motor)?;
        let identification = identify(motor, &answers);
        let firmware_date = if identification.family == ProtocolFamily::MyActuatorV3 {
            match self.firmware_date(motor) {
                Ok(date) => Some(date),
                Err(error) if error.is_bus_failure() => return Err(error),
                Err(_) => None,
            }
        } else {
            None
        };
        Ok(Identified {
            identification,
            answers,
            firmware_date,
        })
    }

    /// A MyActuator V3 motor's firmware date (0xB2).
    fn firmware_date(&mut self, motor: MotorId) -> Result<FirmwareDate, ExchangeError> {
        let v3 = Dialect::MyActuatorV3(V3Firmware::default());
        match self.exchange_in(v3, motor, &Request::ReadFirmwareDate)? {
            Reply::ReadFirmwareDate(date) => Ok(date),
            // The codec takes only a reply to the pending command.
            other => Err(ExchangeError::Mismatch {
                motor,
                command: Command::ReadFirmwareDate,
                got: other.command(),
            }),
        }
    }

    /// One exchange in `dialect`.
    fn exchange_in(
        &mut self,
        dialect: Dialect,
        motor: MotorId,
        request: &Request,
    ) -> Result<Reply, ExchangeError> {
        exchange::request(
            self.bus.as_mut(),
            &self.clock,
            &self.policy,
            dialect,
            motor,
            request,
        )
    }

    /// Readies `motor` to move. A MyActuator V3 motor whose status 1 shows its brake locked
    /// gets it released (0x77: "this command cannot open the brake directly", V4.4 §2.18);
    /// [`motor_off`](Self::motor_off) locks it again. Other families have no brake command.
    pub(crate) fn release_brake_to_move(&mut self, motor: MotorId) -> Result<(), ExchangeError> {
        if self.family(motor)?.family() != ProtocolFamily::MyActuatorV3 {
            return Ok(());
        }
        let status = self.request(motor, &Request::ReadStatus1)?;
        if let Some(Status1::V3(s)) = status.status1()
            && !s.brake.is_released()
        {
            let timeout = self.policy.timeout;
            self.policy.timeout = timeout.max(BRAKE_RELEASE_TIME);
            let released = self.request(motor, &Request::BrakeRelease);
            self.policy.timeout = timeout;
            released?;
        }
        Ok(())
    }

    /// Turns `motor` off (0x80, confirmed by its echo): in its protocol if this command learned
    /// it, else in whichever answers (the frame and its echo are the same in every family).
    /// A MyActuator V3 motor then has its brake locked (0x78): the output is off, so a braked
    /// joint holds; a motor without a brake only notes it (V4.4 §2.29). The error says what
    /// was not confirmed.
    pub(crate) fn motor_off(&mut self, motor: MotorId) -> Result<MotorOff, String> {
        let known = self
            .families
            .get(&motor)
            .and_then(|f| f.dialect_for(Command::MotorOff));
        let (reply, dialect) = match known {
            Some(dialect) => (
                self.exchange_in(dialect, motor, &Request::MotorOff),
                dialect,
            ),
            None => match exchange::motor_off_any_family(
                self.bus.as_mut(),
                &self.clock,
                &self.policy,
                motor,
            ) {
                Ok((reply, dialect)) => (Ok(reply), dialect),
                Err(error) => (Err(error), Dialect::V161),
            },
        };
        match reply {
            Ok(Reply::MotorOff) => {}
            Ok(other) => {
                return Err(format!(
                    "motor {motor} answered motor-off with {}",
                    other.command()
                ));
            }
            Err(error) => return Err(error.to_string()),
        }
        if dialect.family() != ProtocolFamily::MyActuatorV3 {
            return Ok(MotorOff {
                brake_locked: false,
            });
        }
        match self.exchange_in(dialect, motor, &Request::BrakeLock) {
            Ok(Reply::BrakeLock) => Ok(MotorOff { brake_locked: true }),
            Ok(other) => Err(format!(
                "motor {motor} is off, and answered brake-lock with {}: its brake may be released",
                other.command()
            )),
            Err(error) => Err(format!(
                "motor {motor} is off, but {error}: its brake may be released"
            )),
        }
    }

    /// The bus, for commands that do their own sending and receiving.
    pub(crate) fn bus(&mut self) -> &mut dyn CanBus {
        self.bus.as_mut()
    }

    /// The clock of the bus.
    pub(crate) fn clock(&self) -> &MonotonicClock {
        &self.clock
    }

    /// The exchange policy.
    pub(crate) fn policy(&self) -> &Policy {
        &self.policy
    }

    /// Changes the reply timeout of the next requests.
    pub(crate) fn set_timeout(&mut self, timeout: Duration) {
        self.policy.timeout = timeout;
    }

    /// What the bus is.
    pub(crate) fn setup(&self) -> &Setup {
        &self.policy.setup
    }

    /// `rmd WORDS` with the options that reach these motors from a later command (the
    /// interface and protocol), or `None` for simulated motors, which end with this command
    /// (see [`hint`](crate::live::hint)).
    pub(crate) fn later(&self, words: &str) -> Option<String> {
        crate::live::hint::later(&self.policy.setup, &self.source, self.width, words)
    }

    /// The motors' encoder width.
    pub(crate) fn width(&self) -> EncoderWidth {
        self.width
    }

    /// Ends the connection: flushes the recording, if any, and says where it went (a stalled
    /// reader of the log is waited for at most [`FINISH_LIMIT`](crate::live::recording::FINISH_LIMIT)).
    /// Dropping a connection also flushes it, without the summary. An `--mcap` recording is
    /// decoded in the protocol of the lowest-id motor whose protocol this command learned
    /// (the commands with --mcap drive one motor).
    pub(crate) fn finish(self) -> Result<(), CliError> {
        let Self {
            bus,
            recording,
            frames_mcap,
            families,
            ..
        } = self;
        drop(bus);
        let logged = match recording {
            None => Ok(()),
            Some(recording) => recording.finish(),
        };
        let dialect = families.values().find_map(|family| match family {
            MotorFamily::Known(dialect) => Some(*dialect),
            MotorFamily::LkSeriesUnknown => None,
        });
        let mcap = frames_mcap.map_or(Ok(()), |mcap| mcap.finish(dialect.unwrap_or_default()));
        logged.and(mcap)
    }
}

/// Wraps `bus` in a recorder writing to `path` (created or truncated).
fn record_to(
    bus: Box<dyn CanBus>,
    path: &std::path::Path,
    interface: &str,
) -> Result<(Box<dyn CanBus>, Recording), String> {
    let sink = LogSink::create(path)?;
    let (bus, recording) = Recording::start(
        bus,
        MonotonicClock,
        sink,
        |sink| Box::new(sink),
        RecordOptions::new(interface),
    )?;
    Ok((Box::new(bus), recording))
}

/// Simulated motors `ids`, each running the firmware of `families` at the same position (v1.61
/// past its end), on a simulated 1 Mbit/s bus, in real time.
pub(crate) fn simulated_bus(
    ids: &IdList,
    width: EncoderWidth,
    families: &[FirmwareFamily],
) -> Result<SimBus<MonotonicClock>, String> {
    let mut config = SimConfig::with_motors(0);
    config.motors = ids
        .ids()
        .iter()
        .enumerate()
        .map(|(k, &id)| {
            let mut motor = SimMotorConfig::new(id);
            motor.firmware.encoder_width = width;
            motor.firmware.family = families.get(k).copied().unwrap_or_default();
            motor
        })
        .collect();
    SimBus::new(MonotonicClock, config).map_err(|e| format!("simulator: {e}"))
}

/// Which frames an interface delivers.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) enum Filter {
    /// The motors' ids, 0x141..=0x160, and the reply ids of MyActuator V3 firmware,
    /// 0x241..=0x260 (a host talking to motors, recognising V3 motors by their answers).
    Motors,
    /// Those and the 0x280 multi-motor frame (simulated motors answering a host).
    MotorsAndMulti,
    /// Every standard data frame (a logger).
    Everything,
}

/// Opens a SocketCAN interface.
#[cfg(target_os = "linux")]
pub(crate) fn open_interface(iface: &str, filter: Filter) -> Result<Box<dyn CanBus>, String> {
    use rmd_bus::socketcan::{SocketCanBus, SocketCanOptions};
    let options = match filter {
        Filter::Motors => SocketCanOptions::new().accept_ids(
            rmd_protocol::V3_REPLY_BASE_ID + 1
                ..=rmd_protocol::V3_REPLY_BASE_ID + u16::from(MotorId::MAX),
        ),
        Filter::MotorsAndMulti => {
            SocketCanOptions::new().accept_id(rmd_protocol::MULTI_TORQUE_CAN_ID)
        }
        Filter::Everything => SocketCanOptions::new().accept_masked(0, 0),
    };
    SocketCanBus::open(iface, &options)
        .map(|bus| Box::new(bus) as Box<dyn CanBus>)
        .map_err(|e| e.to_string())
}

/// Opens a SocketCAN interface: not on this system.
#[cfg(not(target_os = "linux"))]
pub(crate) fn open_interface(iface: &str, _filter: Filter) -> Result<Box<dyn CanBus>, String> {
    Err(format!(
        "cannot open {iface}: SocketCAN interfaces exist on Linux only (use --sim here)"
    ))
}
