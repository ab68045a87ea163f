//! The telemetry flags of every program that runs the loop: `--csv FILE`, `--mcap FILE`,
//! `--foxglove [ADDR]`, `--foxglove-rate HZ` and `--foxglove-clients N`.

use std::net::{IpAddr, Ipv4Addr, SocketAddr};
use std::path::PathBuf;

use rmd_telemetry::{DEFAULT_LIVE_ADDR, DEFAULT_LIVE_RATE_HZ, DEFAULT_MAX_CLIENTS, LiveOptions};

/// The most clients `--foxglove-clients` admits.
pub const MAX_LIVE_CLIENTS: usize = 64;

use crate::telemetry::TelemetryOutputs;

/// Where a run's telemetry goes (see docs/telemetry.md).
///
/// ```
/// use clap::Parser;
/// use rmd_rig::args::TelemetryArgs;
///
/// #[derive(Parser)]
/// struct Args {
///     #[command(flatten)]
///     telemetry: TelemetryArgs,
/// }
/// let args = Args::parse_from(["leg", "--mcap", "run.mcap", "--foxglove"]);
/// let outputs = args.telemetry.outputs();
/// assert_eq!(outputs.mcap.as_deref(), Some(std::path::Path::new("run.mcap")));
/// assert_eq!(outputs.live.unwrap().addr.to_string(), "127.0.0.1:8765");
/// let args = Args::parse_from(["leg", "--foxglove", "9000", "--foxglove-rate", "50"]);
/// let live = args.telemetry.outputs().live.unwrap();
/// assert_eq!((live.addr.to_string(), live.rate_hz), ("127.0.0.1:9000".to_owned(), 50.0));
/// ```
#[derive(clap::Args, Debug, Clone, Default, PartialEq)]
pub struct TelemetryArgs {
    /// Write every tick to this CSV file: time, each joint's state and command, the user
    /// signals, the loop timing.
    #[arg(long, value_name = "FILE")]
    pub csv: Option<PathBuf>,
    /// Record every tick to this MCAP file (ROS 2 /joint_states and /diagnostics, motor
    /// states, loop timing, user signals): open it in Foxglove or PlotJuggler.
    #[arg(long, value_name = "FILE")]
    pub mcap: Option<PathBuf>,
    /// Serve the telemetry live to Foxglove (WebSocket) on ADDR [default: 127.0.0.1:8765; a
    /// bare port: 127.0.0.1:PORT]. 0.0.0.0:PORT opens it to the network, without
    /// authentication (a warning says so at the start).
    #[arg(long, value_name = "ADDR", num_args = 0..=1, default_missing_value = "127.0.0.1:8765", value_parser = live_addr)]
    pub foxglove: Option<SocketAddr>,
    /// Messages per second on each live channel (decimated from the loop rate) [default: 100].
    #[arg(long, value_name = "HZ", value_parser = live_rate, requires = "foxglove")]
    pub foxglove_rate: Option<f64>,
    /// Live clients served at once, 1..=64 [default: 8]; one more is refused (HTTP 503) and
    /// counted in the report.
    #[arg(long, value_name = "N", value_parser = live_clients, requires = "foxglove")]
    pub foxglove_clients: Option<usize>,
}

impl TelemetryArgs {
    /// The sinks the flags ask for.
    pub fn outputs(&self) -> TelemetryOutputs {
        TelemetryOutputs {
            csv: self.csv.clone(),
            mcap: self.mcap.clone(),
            live: self.foxglove.map(|addr| LiveOptions {
                addr,
                rate_hz: self.foxglove_rate.unwrap_or(DEFAULT_LIVE_RATE_HZ),
                max_clients: self.foxglove_clients.unwrap_or(DEFAULT_MAX_CLIENTS),
                ..LiveOptions::default()
            }),
        }
    }

    /// Whether any sink is asked for.
    pub fn any(&self) -> bool {
        !self.outputs().is_empty()
    }
}

/// `--foxglove ADDR`: `IP:PORT` (`127.0.0.1:8765`, `0.0.0.0:8765`, `[::1]:8765`) or a bare port
/// on loopback.
pub fn live_addr(text: &str) -> Result<SocketAddr, String> {
    let text = text.trim();
    if let Ok(port) = text.parse::<u16>() {
        return Ok(SocketAddr::new(IpAddr::V4(Ipv4Addr::LOCALHOST), port));
    }
    text.parse().map_err(|_| {
        format!(
            "`{text}` is not an address to serve on: give IP:PORT (e.g. {DEFAULT_LIVE_ADDR}, or \
             0.0.0.0:8765 for every interface) or a port"
        )
    })
}

/// `--foxglove-rate HZ`: a positive rate up to 10 kHz.
pub fn live_rate(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(hz) if hz.is_finite() && hz > 0.0 && hz <= 10_000.0 => Ok(hz),
        _ => Err(format!(
            "`{text}` is not a live rate: give messages per second, above 0 and up to 10000"
        )),
    }
}

/// `--foxglove-clients N`: 1..=[`MAX_LIVE_CLIENTS`].
pub fn live_clients(text: &str) -> Result<usize, String> {
    match text.trim().parse::<usize>() {
        Ok(n) if (1..=MAX_LIVE_CLIENTS).contains(&n) => Ok(n),
        _ => Err(format!(
            "`{text}` is not a number of live clients: give a whole number from 1 to \
             {MAX_LIVE_CLIENTS}"
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn addresses_and_rates_are_checked() {
        assert_eq!(live_addr("9000").unwrap().to_string(), "127.0.0.1:9000");
        assert_eq!(live_addr("0.0.0.0:1").unwrap().to_string(), "0.0.0.0:1");
        assert_eq!(live_addr("[::1]:80").unwrap().to_string(), "[::1]:80");
        for bad in ["localhost", "1.2.3.4", "70000", ":80", ""] {
            assert!(live_addr(bad).unwrap_err().contains("IP:PORT"), "{bad}");
        }
        assert_eq!(live_rate("200"), Ok(200.0));
        for bad in ["0", "-1", "nan", "inf", "1e5", "x"] {
            assert!(live_rate(bad).is_err(), "{bad}");
        }
        assert_eq!(live_clients("2"), Ok(2));
        for bad in ["0", "-1", "65", "1.5", "x"] {
            assert!(live_clients(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn no_flag_means_no_sink() {
        assert!(!TelemetryArgs::default().any());
        assert!(TelemetryArgs::default().outputs().is_empty());
    }
}
