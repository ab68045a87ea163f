//! Opening the bus every live command talks to: `--iface IFACE` (SocketCAN) or `--sim`
//! (simulated motors in this process, in real time, running the firmware of `--sim-firmware`),
//! optionally recorded with `--log FILE`, speaking the protocol of `--protocol`.

use std::time::Duration;

use rmd_bus::record::RecordOptions;
use rmd_bus::{CanBus, MonotonicClock};
use rmd_protocol::{EncoderWidth, MotorId, Reply, Request};
use rmd_sim::{FirmwareFamily, MotorConfig, SimBus, SimConfig};

use crate::args::bus::BusArgs;
use crate::args::ids::IdList;
use crate::live::exchange::{self, ExchangeError, Policy, Setup};
use crate::live::frames_mcap::FramesMcap;
use crate::live::recording::{LogSink, Recording};
use crate::output::report::CliError;

/// Default reply timeout of a request.
pub(crate) const DEFAULT_TIMEOUT: Duration = Duration::from_millis(50);
/// Default retries of a request.
pub(crate) const DEFAULT_RETRIES: u32 = 2;

/// An open bus: the bus (recorded if asked), its clock, and the exchange policy.
pub(crate) struct Connection {
    bus: Box<dyn CanBus>,
    clock: MonotonicClock,
    policy: Policy,
    width: EncoderWidth,
    recording: Option<Recording>,
    frames_mcap: Option<FramesMcap>,
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
        let dialect = args.dialect().map_err(CliError::Usage)?;
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
                dialect,
            },
            width,
            recording,
            frames_mcap: None,
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
        let (bus, mcap) =
            FramesMcap::start(bus, &name, path.to_owned(), self.policy.dialect, self.width)?;
        self.bus = bus;
        self.frames_mcap = Some(mcap);
        Ok(())
    }

    /// Sends `request` to `motor` and returns its reply.
    pub(crate) fn request(
        &mut self,
        motor: MotorId,
        request: &Request,
    ) -> Result<Reply, ExchangeError> {
        exchange::request(self.bus.as_mut(), &self.clock, &self.policy, motor, request)
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
        crate::live::hint::later(&self.policy.setup, self.policy.dialect, self.width, words)
    }

    /// The motors' encoder width.
    pub(crate) fn width(&self) -> EncoderWidth {
        self.width
    }

    /// Ends the connection: flushes the recording, if any, and says where it went (a stalled
    /// reader of the log is waited for at most [`FINISH_LIMIT`](crate::live::recording::FINISH_LIMIT)).
    /// Dropping a connection also flushes it, without the summary.
    pub(crate) fn finish(self) -> Result<(), CliError> {
        let Self {
            bus,
            recording,
            frames_mcap,
            ..
        } = self;
        drop(bus);
        let logged = match recording {
            None => Ok(()),
            Some(recording) => recording.finish(),
        };
        let mcap = frames_mcap.map_or(Ok(()), FramesMcap::finish);
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
            let mut motor = MotorConfig::new(id);
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
