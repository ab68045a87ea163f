//! Where the motors are, and how to talk to them: the bus options every live command flattens
//! in (`--iface` or `--sim`, encoder width, timeout, retries, `--log`).

use std::path::PathBuf;

use clap::Args;
use rmd_protocol::EncoderWidth;

use super::ids::{self, IdList};
use super::parse;

/// Where the motors are, and how to talk to them (flattened into every live command).
#[derive(Args, Debug, Clone)]
pub(crate) struct BusArgs {
    /// The robot description (TOML) whose joints to talk to, by name and in joint units;
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
}

impl BusArgs {
    /// Whether a bus was named (`--iface`, `--sim` or `--robot`).
    pub(crate) fn has_target(&self) -> bool {
        self.sim || self.iface.is_some() || self.robot.is_some()
    }
}
