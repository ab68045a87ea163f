//! Hints that name another `rmd` command: each is complete (the bus and protocol options that
//! reach the same motors) and given only where it can work.
//!
//! Simulated motors (`--sim`, `--robot FILE --sim`) live as long as the command that runs them:
//! a later command would talk to new motors. So a hint about the state a command leaves behind
//! (`rmd off` to release a held position, a read-back after a write) is given for motors on an
//! interface only ([`later`]); a hint that asks the motors afresh (what `rmd pid get` shows
//! before anything was written) works on the same simulated motors too ([`afresh`]).

use rmd_protocol::{Dialect, EncoderWidth};

use crate::args::bus::BusArgs;
use crate::live::exchange::Setup;
use crate::live::family::ProtocolSource;

/// `rmd WORDS --iface IFACE [protocol options]`, a later command to the motors of `setup`, or
/// `None` for simulated motors (they end with this command).
pub(crate) fn later(
    setup: &Setup,
    source: &ProtocolSource,
    width: EncoderWidth,
    words: &str,
) -> Option<String> {
    match setup {
        Setup::Interface(iface) => Some(format!(
            "rmd {words} --iface {iface}{}",
            protocol_options(source, width)
        )),
        Setup::Simulator(_) | Setup::Robot(_) => None,
    }
}

/// `rmd WORDS` with the bus options of `args` (`--iface can0`, or `--sim` with its motors and
/// firmware) and its protocol options, or `None` when `args` names no bus or a robot (whose
/// commands take joint names, not the motor ids of a hint).
pub(crate) fn afresh(args: &BusArgs, words: &str) -> Option<String> {
    if args.robot.is_some() {
        return None;
    }
    let mut command = match (&args.iface, args.sim) {
        (Some(iface), _) => format!("rmd {words} --iface {iface}"),
        (None, true) => {
            let mut sim = format!("rmd {words} --sim");
            let ids = args.sim_ids.to_string();
            if ids != DEFAULT_SIM_IDS {
                sim.push_str(&format!(" --sim-ids {ids}"));
            }
            if !args.sim_firmware.is_empty() {
                let names: Vec<&str> = args.sim_firmware.iter().map(|f| f.name()).collect();
                sim.push_str(&format!(" --sim-firmware {}", names.join(",")));
            }
            sim
        }
        (None, false) => return None,
    };
    if let Some(protocol) = args.protocol.protocol {
        command.push_str(&format!(" --protocol {}", protocol.name()));
    }
    if let Some(series) = args.protocol.lk_series {
        command.push_str(&format!(" --lk-series {}", series.name()));
    }
    if args.encoder_bits != EncoderWidth::DEFAULT {
        command.push_str(&format!(" --encoder-bits {}", args.encoder_bits.bits()));
    }
    Some(command)
}

/// `--sim-ids`' default, as [`IdList`](crate::args::ids::IdList) shows it.
const DEFAULT_SIM_IDS: &str = "1-4";

/// The options that reach motors of `source` with encoders of `width` the same way: the named
/// protocol (nothing for v1.61), or the LK-TECH series of identified motors; nothing for the
/// defaults (identified, 14 bits).
fn protocol_options(source: &ProtocolSource, width: EncoderWidth) -> String {
    let mut options = String::new();
    let series = match source {
        ProtocolSource::Named(dialect) => {
            if *dialect != Dialect::V161 {
                options.push_str(&format!(" --protocol {}", dialect.name()));
            }
            dialect.lk_series()
        }
        ProtocolSource::Identify { lk_series } => *lk_series,
    };
    if let Some(series) = series {
        options.push_str(&format!(" --lk-series {}", series.name()));
    }
    if width != EncoderWidth::DEFAULT {
        options.push_str(&format!(" --encoder-bits {}", width.bits()));
    }
    options
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::args::ids;
    use clap::Parser;
    use rmd_protocol::LkSeries;

    /// Parses a hint's command line with `rmd`'s own parser.
    fn parses(command: &str) {
        if let Err(e) = crate::Cli::try_parse_from(command.split_whitespace()) {
            panic!("`{command}` does not parse: {e}");
        }
    }

    /// The bus options of a command line (without `rmd` and the command).
    fn bus_of(options: &str) -> BusArgs {
        #[derive(clap::Parser)]
        struct Options {
            #[command(flatten)]
            bus: BusArgs,
        }
        Options::try_parse_from(std::iter::once("x").chain(options.split_whitespace()))
            .unwrap_or_else(|e| panic!("`{options}`: {e}"))
            .bus
    }

    #[test]
    fn a_later_command_reaches_an_interface_with_the_same_protocol() {
        let can0 = Setup::Interface("can0".into());
        let width = EncoderWidth::DEFAULT;
        assert_eq!(
            later(&can0, &ProtocolSource::Named(Dialect::V161), width, "off 3").as_deref(),
            Some("rmd off 3 --iface can0")
        );
        let lk = later(
            &can0,
            &ProtocolSource::Named(Dialect::LkV23x(LkSeries::Mf)),
            EncoderWidth::new(16).unwrap(),
            "encoder get 2",
        )
        .unwrap();
        assert_eq!(
            lk,
            "rmd encoder get 2 --iface can0 --protocol lk-v2.3x --lk-series mf --encoder-bits 16"
        );
        parses(&lk);
    }

    #[test]
    fn no_later_command_for_simulated_motors() {
        let sim = Setup::Simulator(ids::parse("1-4").unwrap());
        assert_eq!(
            later(
                &sim,
                &ProtocolSource::Named(Dialect::V161),
                EncoderWidth::DEFAULT,
                "off 1"
            ),
            None
        );
        let robot = Setup::Robot("leg.toml".into());
        assert_eq!(
            later(
                &robot,
                &ProtocolSource::Named(Dialect::V161),
                EncoderWidth::DEFAULT,
                "off 1"
            ),
            None
        );
    }

    #[test]
    fn a_fresh_command_repeats_the_bus_options() {
        let hint = |options: &str| afresh(&bus_of(options), "pid get 7");
        assert_eq!(
            hint("--sim --sim-ids 7 --sim-firmware lk-v2.3x --lk-series mf").as_deref(),
            Some("rmd pid get 7 --sim --sim-ids 7 --sim-firmware lk-v2.3x --lk-series mf")
        );
        assert_eq!(
            hint("--iface can1 --encoder-bits 18").as_deref(),
            Some("rmd pid get 7 --iface can1 --encoder-bits 18")
        );
        assert_eq!(
            hint("--iface can1 --protocol lk-v2.3x --lk-series mg").as_deref(),
            Some("rmd pid get 7 --iface can1 --protocol lk-v2.3x --lk-series mg")
        );
        assert_eq!(hint("--sim").as_deref(), Some("rmd pid get 7 --sim"));
        assert_eq!(hint(""), None);
        assert_eq!(hint("--robot leg.toml --sim"), None);
        for options in [
            "--sim --sim-ids 7 --sim-firmware lk-v2.3x --lk-series mf",
            "--iface can1 --protocol lk-v2.3x --lk-series mg",
        ] {
            parses(&hint(options).unwrap());
        }
    }
}
