//! Where the motors are, and how to talk to them: the bus options every live command flattens
//! in (`--iface` or `--sim`, encoder width, timeout, retries, `--log`), and the protocol options
//! (`--protocol`, `--lk-series`, `--firmware-date`, `--motor-max-torque`) that `rmd encode` and
//! `rmd decode` take too.

use std::path::PathBuf;

use clap::Args;
use rmd_protocol::{
    Dialect, EncoderWidth, FirmwareDate, LkSeries, MotorMaxTorque, ProtocolFamily, V3Firmware,
};
use rmd_sim::FirmwareFamily;

use super::ids::{self, IdList};
use super::parse;
use crate::live::family::ProtocolSource;

/// Where the motors are, and how to talk to them (flattened into every live command).
#[derive(Args, Debug, Clone)]
pub(crate) struct BusArgs {
    /// The robot description (TOML) whose joints to talk to, by name and in joint units
    /// (status, monitor, move, off, stop, run; the other commands refuse it);
    /// each bus on the interface the description names (`--sim`: simulated motors matching
    /// it; `--iface`: other interfaces, by bus order or `BUS=IFACE`).
    #[arg(long, value_name = "FILE")]
    pub(crate) robot: Option<PathBuf>,
    /// SocketCAN interface of the motors (e.g. can0; vcan0 with `rmd sim`); with --robot, the
    /// interface of each bus (`can0,can1` in bus order, or `BUS=IFACE`).
    #[arg(long, value_name = "IFACE", conflicts_with = "sim")]
    pub(crate) iface: Option<String>,
    /// Talk to simulated motors in this process (real time) instead of an interface.
    #[arg(long)]
    pub(crate) sim: bool,
    /// Motor ids the in-process simulator runs (with --sim).
    #[arg(long, value_name = "IDS", value_parser = ids::parse, default_value = "1-4")]
    pub(crate) sim_ids: IdList,
    /// Width of the motors' encoders in bits (12..=18), for encoder angles.
    #[arg(long, value_name = "BITS", value_parser = parse::encoder_width, default_value = "14")]
    pub(crate) encoder_bits: EncoderWidth,
    /// How long to wait for each reply, milliseconds [default: 50; scan: 20].
    #[arg(long, value_name = "MS", value_parser = super::timing::reply_timeout_ms, allow_hyphen_values = true)]
    pub(crate) timeout_ms: Option<u64>,
    /// How many times to send a request again after a timeout [default: 2; scan: 0].
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(0..=100))]
    pub(crate) retries: Option<u32>,
    /// Also record every frame sent and received to this candump -L file.
    #[arg(long = "log", value_name = "FILE")]
    pub(crate) log: Option<PathBuf>,
    /// The firmware the simulated motors of --sim run: v1.61, lk-v2.3x (an MG motor, or the
    /// series of --lk-series) or myactuator-v3 (answers on 0x240 + id); one for every motor, or
    /// a comma-separated list with one per --sim-ids motor, in id order (a mixed bus).
    #[arg(long, value_name = "FIRMWARE", value_parser = parse::sim_firmware, value_delimiter = ',', requires = "sim", conflicts_with = "robot")]
    pub(crate) sim_firmware: Vec<ProtocolFamily>,
    #[command(flatten)]
    pub(crate) protocol: ProtocolArgs,
}

/// The protocol the motors speak (`--protocol`, `--lk-series`), for `encode`, `decode` and every
/// live command.
#[derive(Args, Debug, Clone, Copy)]
pub(crate) struct ProtocolArgs {
    /// The motors' protocol: v1.61 (GYEMS / MyActuator RMD), lk-v2.3x (LK-TECH MF / MG
    /// motors, with --lk-series) or myactuator-v3 (MyActuator's V3 driver: replies on
    /// 0x240 + id, 0.01 A per LSB). It decides the layouts and the current scales. Live
    /// commands without it identify each motor from its answers to read-only requests before
    /// sending anything else; `encode` and `decode` take v1.61 without it.
    #[arg(long, value_name = "PROTOCOL", value_parser = parse::protocol, global = true)]
    pub(crate) protocol: Option<ProtocolFamily>,
    /// The LK-TECH motor series, on which the current scale depends (with --protocol
    /// lk-v2.3x, or for the motors a live command identifies as LK-TECH): mf (16.5/2048 A per
    /// LSB, ±16.5 A) or mg (33/2048 A per LSB, ±33 A).
    #[arg(long, value_name = "SERIES", value_parser = parse::lk_series, global = true)]
    pub(crate) lk_series: Option<LkSeries>,
    /// The MyActuator V3 firmware's version date, as 0xB2 reports it (with --protocol
    /// myactuator-v3): from 2026042402 on, the V4.4 layouts of 0x94 and the V4.4 motion-mode
    /// ranges; before (and by default), V4.3's.
    #[arg(long, value_name = "DATE", value_parser = parse::firmware_date, global = true)]
    pub(crate) firmware_date: Option<FirmwareDate>,
    /// The MyActuator V3 motor's maximum torque, N·m: the motion-mode torque range of V4.4
    /// firmware (with --protocol myactuator-v3).
    #[arg(long, value_name = "NM", value_parser = parse::positive, global = true)]
    pub(crate) motor_max_torque: Option<f64>,
}

impl ProtocolArgs {
    /// The dialect named (v1.61 when `--protocol` is not given), or a usage message:
    /// `lk-v2.3x` needs `--lk-series`; `--lk-series` with another protocol is refused unless
    /// `series_used_elsewhere` (the simulated LK motors use it).
    pub(crate) fn dialect_or(&self, series_used_elsewhere: bool) -> Result<Dialect, String> {
        let protocol = self.protocol.unwrap_or(ProtocolFamily::V161);
        if let Some(flag) = self.v3_flag()
            && protocol != ProtocolFamily::MyActuatorV3
        {
            return Err(format!(
                "{flag} applies to MyActuator V3 motors: add --protocol myactuator-v3"
            ));
        }
        if protocol == ProtocolFamily::MyActuatorV3 {
            let max_torque = self
                .motor_max_torque
                .map(MotorMaxTorque::from_nm)
                .transpose()
                .map_err(|e| format!("--motor-max-torque: {e}"))?;
            return Ok(Dialect::MyActuatorV3(V3Firmware {
                date: self.firmware_date,
                max_torque,
            }));
        }
        match (protocol, self.lk_series) {
            (ProtocolFamily::LkV23x, Some(series)) => Ok(Dialect::LkV23x(series)),
            (ProtocolFamily::LkV23x, None) => Err(
                "--protocol lk-v2.3x needs the motors' series, --lk-series mf or --lk-series mg: \
                 the current scale depends on it (MF ±16.5 A, MG ±33 A over ±2048)"
                    .to_owned(),
            ),
            (_, Some(series)) if !series_used_elsewhere => Err(format!(
                "--lk-series {} applies to LK-TECH motors: add --protocol lk-v2.3x",
                series.name()
            )),
            _ => Ok(Dialect::V161),
        }
    }

    /// The dialect named (see [`dialect_or`](Self::dialect_or)).
    pub(crate) fn dialect(&self) -> Result<Dialect, String> {
        self.dialect_or(false)
    }

    /// The first option given that only MyActuator V3 motors take.
    fn v3_flag(&self) -> Option<&'static str> {
        match (self.firmware_date, self.motor_max_torque) {
            (Some(_), _) => Some("--firmware-date"),
            (None, Some(_)) => Some("--motor-max-torque"),
            (None, None) => None,
        }
    }
}

impl BusArgs {
    /// Whether a bus was named (`--iface`, `--sim` or `--robot`).
    pub(crate) fn has_target(&self) -> bool {
        self.sim || self.iface.is_some() || self.robot.is_some()
    }

    /// The firmware of each simulated motor of `--sim`, in the order of `--sim-ids` (v1.61
    /// unless `--sim-firmware` says otherwise; LK-TECH motors of the `--lk-series`, MG by
    /// default), or a usage message when the list does not fit the motors.
    pub(crate) fn sim_families(&self) -> Result<Vec<FirmwareFamily>, String> {
        let count = self.sim_ids.ids().len();
        let one = |family: ProtocolFamily| match family {
            ProtocolFamily::LkV23x => {
                FirmwareFamily::LkV23x(self.protocol.lk_series.unwrap_or(LkSeries::Mg))
            }
            ProtocolFamily::MyActuatorV3 => FirmwareFamily::MyActuatorV3,
            _ => FirmwareFamily::V161,
        };
        match self.sim_firmware.as_slice() {
            [] => Ok(vec![FirmwareFamily::V161; count]),
            [family] => Ok(vec![one(*family); count]),
            list if list.len() == count => Ok(list.iter().copied().map(one).collect()),
            list => Err(format!(
                "--sim-firmware lists {} firmware families for {count} simulated motors \
                 (--sim-ids {}): give one for all, or one per motor",
                list.len(),
                self.sim_ids
            )),
        }
    }

    /// How the live commands learn each motor's protocol: the one `--protocol` names (with
    /// its `--lk-series`, `--firmware-date`, `--motor-max-torque`), or, without it, each
    /// motor identified from its answers (LK-TECH motors of the `--lk-series` given); or a
    /// usage message.
    pub(crate) fn protocol_source(&self) -> Result<ProtocolSource, String> {
        let series_for_sim = self.sim_firmware.contains(&ProtocolFamily::LkV23x);
        if self.protocol.protocol.is_some() {
            return self
                .protocol
                .dialect_or(series_for_sim)
                .map(ProtocolSource::Named);
        }
        if let Some(flag) = self.protocol.v3_flag() {
            return Err(format!(
                "{flag} applies to MyActuator V3 motors: add --protocol myactuator-v3"
            ));
        }
        Ok(ProtocolSource::Identify {
            lk_series: self.protocol.lk_series,
        })
    }
}
