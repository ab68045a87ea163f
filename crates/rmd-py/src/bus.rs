//! `Bus`'s native side: a SocketCAN interface or simulated motors behind a mutex, one
//! request and its reply at a time, with the GIL released while waiting; Ctrl-C interrupts the
//! wait (Python's signal handlers run every few milliseconds meanwhile). A bus belongs to the
//! process that opened it: a forked child shares its socket, and requests from there would
//! take the parent's replies.

use std::sync::{Mutex, PoisonError};

use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use rmd_bus::{CanFrame, Clock};
use rmd_frames::json::FrameJson;
use rmd_protocol::{EncoderWidth, FIRST_MOTOR_CAN_ID, MotorId, Reply};
use rmd_rig::{AnyBus, AnyClock, SharedSim, SimTime};
use rmd_sim::{SimBus, SimConfig, SimMotorConfig};

use crate::args;
use crate::errors::{
    ArgumentError, BusError, ConfigError, NoReplyError, ProtocolError, RomWriteNotConfirmed, guard,
};
use crate::exchange::{RequestError, RequestPolicy, RequestReplies, exchange};
use crate::process::Owner;
use crate::protocol::{build_frame, command_name, writes_rom};
use crate::sim::{SimBusView, Simulator};
use crate::wait::signals_raised;

/// The longest wait for one reply, s.
const MAX_TIMEOUT_S: f64 = 60.0;
/// The most retries of one request.
const MAX_RETRIES: u32 = 100;

/// The bus and its clock: what the mutex guards.
struct Link {
    bus: AnyBus,
    clock: AnyClock,
}

/// One bus of motors, for one request and its reply at a time from any number of threads.
/// Build it with `Bus.socketcan(...)` or `Bus.simulated(...)` (the Python class wraps this).
#[pyclass(module = "rmd_rt._native", frozen)]
pub(crate) struct NativeBus {
    owner: Owner,
    link: Mutex<Link>,
    policy: RequestPolicy,
    width: EncoderWidth,
    sim: Option<SharedSim>,
    /// What to check when a motor does not answer.
    advice: String,
    name: String,
}

fn policy(
    protocol: &str,
    lk_series: Option<&str>,
    timeout_s: f64,
    retries: i64,
) -> PyResult<RequestPolicy> {
    let dialect = args::dialect(protocol, lk_series).map_err(ConfigError::new_err)?;
    let timeout = args::seconds("timeout_s", timeout_s, MAX_TIMEOUT_S)?;
    if timeout.is_zero() {
        return Err(ArgumentError::new_err(
            "timeout_s = 0: give the wait for each reply, above 0".to_owned(),
        ));
    }
    let retries = u32::try_from(retries)
        .ok()
        .filter(|&r| r <= MAX_RETRIES)
        .ok_or_else(|| {
            ArgumentError::new_err(format!("retries = {retries}: must be 0..={MAX_RETRIES}"))
        })?;
    Ok(RequestPolicy {
        timeout,
        retries,
        dialect,
    })
}

/// The reply of `command` from `can_id` as `decode` shows it.
fn reply_dict<'py>(
    py: Python<'py>,
    can_id: u16,
    reply: &Reply,
    width: EncoderWidth,
) -> PyResult<Bound<'py, PyAny>> {
    let value = FrameJson::new(None, None, can_id, "reply", reply.command().name(), width)
        .checking_encoder_width()
        .reply(reply)
        .into_value();
    Ok(pythonize::pythonize(py, &value)?)
}

fn request_error(error: RequestError) -> PyErr {
    match error {
        RequestError::NoReply { .. } => NoReplyError::new_err(error.to_string()),
        RequestError::Bus(_)
        | RequestError::BusOff { .. }
        | RequestError::OtherFamily { .. }
        | RequestError::NotARequest(_)
        | RequestError::Interrupted => BusError::new_err(error.to_string()),
    }
}

#[pymethods]
impl NativeBus {
    /// Opens the SocketCAN interface `iface` (up, at the motors' bit rate).
    #[staticmethod]
    #[pyo3(signature = (iface, protocol="v1.61", lk_series=None, encoder_bits=14, timeout_s=0.05, retries=2))]
    fn socketcan(
        iface: &str,
        protocol: &str,
        lk_series: Option<&str>,
        encoder_bits: i64,
        timeout_s: f64,
        retries: i64,
    ) -> PyResult<Self> {
        guard(|| {
            let policy = policy(protocol, lk_series, timeout_s, retries)?;
            let width = args::encoder_width(encoder_bits).map_err(ConfigError::new_err)?;
            let bus = open_socketcan(iface)?;
            Ok(Self {
                owner: Owner::here(),
                link: Mutex::new(Link {
                    bus,
                    clock: AnyClock::new(SimTime::Real),
                }),
                policy,
                width,
                sim: None,
                advice: format!(
                    "check that the motor is powered and wired to {iface}, that its CAN id is the \
                 one asked, and that {iface} runs at the motor's bit rate (1 Mbit/s by default; \
                 `ip -details link show {iface}`)"
                ),
                name: iface.to_owned(),
            })
        })
    }

    /// Simulated motors `ids` (1..=32) of the firmware `protocol` speaks, in real time or in
    /// virtual time (each wait advances the simulator's clock at once).
    #[staticmethod]
    #[pyo3(signature = (ids, virtual_time=false, seed=1, protocol="v1.61", lk_series=None, encoder_bits=14, timeout_s=0.05, retries=2))]
    #[allow(clippy::too_many_arguments)]
    fn simulated(
        ids: Vec<i64>,
        virtual_time: bool,
        seed: u64,
        protocol: &str,
        lk_series: Option<&str>,
        encoder_bits: i64,
        timeout_s: f64,
        retries: i64,
    ) -> PyResult<Self> {
        guard(|| {
            let policy = policy(protocol, lk_series, timeout_s, retries)?;
            let width = args::encoder_width(encoder_bits).map_err(ConfigError::new_err)?;
            let mut firmware = rmd_sim::FirmwareParams::default();
            firmware.speak(policy.dialect);
            let family = firmware.family;
            let mut config = SimConfig::with_motors(0).seed(seed);
            for id in &ids {
                let motor = u8::try_from(*id)
                    .ok()
                    .and_then(|id| MotorId::new(id).ok())
                    .ok_or_else(|| {
                        ConfigError::new_err(format!("invalid motor id {id}: must be 1..=32"))
                    })?;
                let mut sim = SimMotorConfig::new(motor);
                sim.firmware.encoder_width = width;
                sim.firmware.family = family;
                config.motors.push(sim);
            }
            let time = if virtual_time {
                SimTime::Virtual
            } else {
                SimTime::Real
            };
            let clock = AnyClock::new(time);
            let sim = SharedSim::new(
                SimBus::new(clock.clone(), config)
                    .map_err(|e| ConfigError::new_err(format!("simulator: {e}")))?,
            );
            let list = ids
                .iter()
                .map(i64::to_string)
                .collect::<Vec<_>>()
                .join(", ");
            Ok(Self {
                owner: Owner::here(),
                link: Mutex::new(Link {
                    bus: AnyBus::Sim(sim.clone()),
                    clock,
                }),
                policy,
                width,
                sim: Some(sim),
                advice: format!("the simulated motors are {list}"),
                name: "simulated".to_owned(),
            })
        })
    }

    /// Sends `command` (an `rmd encode` command name) to motor `id` with `fields` and returns
    /// the reply as `decode` shows it (a dict); for `"multi-torque"` a list of the replies of
    /// motors 1..=4 (None where a motor did not answer). ROM writes need
    /// `confirm_rom_write=True`.
    #[pyo3(signature = (command, id=None, fields=None, confirm_rom_write=false))]
    fn request<'py>(
        &self,
        py: Python<'py>,
        command: &str,
        id: Option<i64>,
        fields: Option<&Bound<'py, PyDict>>,
        confirm_rom_write: bool,
    ) -> PyResult<Bound<'py, PyAny>> {
        guard(|| {
            self.owner.check("bus")?;
            let command = command_name(command).map_err(ProtocolError::new_err)?;
            let frame = build_frame(command, id, fields, self.policy.dialect)
                .map_err(ProtocolError::new_err)?;
            if writes_rom(command, self.policy.dialect) && !confirm_rom_write {
                return Err(RomWriteNotConfirmed::new_err(format!(
                    "{command} writes the motor's ROM (flash, which wears out{}): nothing was sent; \
                 pass confirm_rom_write=True to do it",
                    if command == "write-zero-rom" {
                        "; the new zero takes effect after a power cycle"
                    } else {
                        ""
                    }
                )));
            }
            let mut raised = None;
            let replies = py.detach(|| {
                self.exchange(&frame, &mut || {
                    raised = signals_raised();
                    raised.is_some()
                })
            });
            if let Some(error) = raised {
                return Err(error); // Ctrl-C: KeyboardInterrupt
            }
            let replies = replies.map_err(request_error)?;
            match replies {
                RequestReplies::One(motor, reply) => {
                    let can_id = self.policy.dialect.reply_id(motor);
                    reply_dict(py, can_id, &reply, self.width)
                }
                RequestReplies::Multi(replies) => {
                    let list = PyList::empty(py);
                    for (k, reply) in replies.iter().enumerate() {
                        match reply {
                            Some(reply) => {
                                let can_id = FIRST_MOTOR_CAN_ID + k as u16;
                                list.append(reply_dict(py, can_id, reply, self.width)?)?;
                            }
                            None => list.append(py.None())?,
                        }
                    }
                    Ok(list.into_any())
                }
            }
        })
    }

    /// The simulated motors (ground truth), or None on SocketCAN.
    fn simulator(&self) -> PyResult<Option<Simulator>> {
        self.owner.check("bus")?;
        Ok(self.sim.as_ref().map(|bus| {
            let view = SimBusView {
                bus: bus.clone(),
                joints: Vec::new(),
            };
            Simulator::new(vec![view], self.owner)
        }))
    }

    /// The clock of the bus, seconds (the simulator's in virtual time).
    fn now_s(&self) -> PyResult<f64> {
        self.owner.check("bus")?;
        let link = self.link.lock().unwrap_or_else(PoisonError::into_inner);
        Ok(link.clock.now().as_nanos() as f64 * 1e-9)
    }

    fn __repr__(&self) -> String {
        format!("<rmd_rt.Bus {} ({})>", self.name, self.policy.dialect)
    }
}

impl NativeBus {
    fn exchange(
        &self,
        frame: &CanFrame,
        interrupted: &mut impl FnMut() -> bool,
    ) -> Result<RequestReplies, RequestError> {
        let mut link = self.link.lock().unwrap_or_else(PoisonError::into_inner);
        let Link { bus, clock } = &mut *link;
        exchange(bus, &*clock, frame, &self.policy, &self.advice, interrupted)
    }
}

#[cfg(target_os = "linux")]
fn open_socketcan(iface: &str) -> PyResult<AnyBus> {
    use rmd_bus::socketcan::{SocketCanBus, SocketCanOptions};
    let options = SocketCanOptions::new().accept_ids(
        rmd_protocol::V3_REPLY_BASE_ID + u16::from(MotorId::MIN)
            ..=rmd_protocol::V3_REPLY_BASE_ID + u16::from(MotorId::MAX),
    );
    SocketCanBus::open(iface, &options)
        .map(|bus| AnyBus::SocketCan(Box::new(bus)))
        .map_err(|e| BusError::new_err(format!("cannot open {iface}: {e}")))
}

#[cfg(not(target_os = "linux"))]
fn open_socketcan(iface: &str) -> PyResult<AnyBus> {
    Err(BusError::new_err(format!(
        "cannot open {iface}: SocketCAN exists on Linux only"
    )))
}
