//! `--mcap FILE` of the commands that move motors (`rmd torque`, `rmd speed`, `rmd move`): the
//! frames the command exchanges, recorded as it runs (the same lock-free recorder as `--log`,
//! into memory), then decoded as `rmd decode --mcap` decodes a log, with the direction markers
//! pairing each reply with its request.
//!
//! These commands do not run the real-time loop, so they have no per-tick telemetry: their
//! `--foxglove` and `--csv` are refused with a message saying so ([`FramesTelemetryArgs::check`]).

use std::io::Cursor;
use std::net::SocketAddr;
use std::path::PathBuf;

use clap::Args;
use rmd_bus::record::{LogWriter, RecordOptions, record};
use rmd_bus::{CanBus, MonotonicClock};
use rmd_protocol::{Dialect, EncoderWidth};

use crate::cmd::decode::mcap::McapFrames;
use crate::cmd::decode::{DecodeOutput, Ended, Mode, decode_all};
use crate::output::errln;
use crate::output::report::CliError;

/// The telemetry flags of a command that moves motors without the loop.
#[derive(Args, Debug, Clone, Default)]
pub(crate) struct FramesTelemetryArgs {
    /// Record the command's frames, decoded, to this MCAP file (per motor: its requests and the
    /// readings it answered with, as `rmd decode --mcap` writes them); open it in Foxglove or
    /// PlotJuggler.
    #[arg(long, value_name = "FILE")]
    pub(crate) mcap: Option<PathBuf>,
    /// Refused: this command does not run the real-time loop (see --mcap).
    #[arg(long, value_name = "ADDR", num_args = 0..=1, default_missing_value = "127.0.0.1:8765", hide = true, value_parser = rmd_rig::args::live_addr)]
    pub(crate) foxglove: Option<SocketAddr>,
    /// Refused: this command does not run the real-time loop (see --mcap).
    #[arg(long, value_name = "FILE", hide = true)]
    pub(crate) csv: Option<PathBuf>,
}

impl FramesTelemetryArgs {
    /// Refuses `--foxglove` and `--csv`, naming what to use instead.
    pub(crate) fn check(&self, command: &str) -> Result<(), CliError> {
        let flag = match (self.foxglove.is_some(), self.csv.is_some()) {
            (true, _) => "--foxglove",
            (false, true) => "--csv",
            (false, false) => return Ok(()),
        };
        Err(CliError::Usage(format!(
            "{flag}: `rmd {command}` does not run the real-time loop, so it has no per-tick \
             telemetry to serve live or write as CSV; --mcap FILE records its frames decoded (open \
             it in Foxglove), --log FILE as a candump log. For live plots, run the loop: `rmd \
             bench loop --foxglove`, an example with --foxglove, or `rmd monitor` in the terminal"
        )))
    }
}

/// A bus being recorded for `--mcap`.
pub(crate) struct FramesMcap {
    path: PathBuf,
    writer: LogWriter<Vec<u8>>,
    width: EncoderWidth,
}

impl FramesMcap {
    /// Wraps `bus` (on `interface`) in a recorder; the frames become `path` at
    /// [`finish`](Self::finish).
    pub(crate) fn start(
        bus: Box<dyn CanBus>,
        interface: &str,
        path: PathBuf,
        width: EncoderWidth,
    ) -> Result<(Box<dyn CanBus>, Self), CliError> {
        // Fail before anything moves if the file cannot be written.
        std::fs::File::create(&path)
            .map_err(|e| CliError::Usage(format!("--mcap {}: {e}", path.display())))?;
        let (bus, writer) = record(
            bus,
            MonotonicClock,
            Vec::new(),
            RecordOptions::new(interface),
        )
        .map_err(|e| CliError::Failed(e.to_string()))?;
        Ok((
            Box::new(bus),
            Self {
                path,
                writer,
                width,
            },
        ))
    }

    /// Writes the MCAP file, its frames decoded in `dialect` (stop using the bus first), and
    /// says on stderr what it holds.
    pub(crate) fn finish(self, dialect: Dialect) -> Result<(), CliError> {
        let (stats, log) = self
            .writer
            .finish_into_inner()
            .map_err(|e| CliError::Failed(format!("--mcap {}: {e}", self.path.display())))?;
        let mcap = McapFrames::create(
            &self.path,
            &[
                ("source", "recorded by rmd".to_owned()),
                ("protocol", dialect.name().to_owned()),
                ("encoder_bits", self.width.bits().to_string()),
            ],
        )?;
        let ended = decode_all(
            Box::new(Cursor::new(log)),
            Mode::Auto,
            self.width,
            dialect,
            DecodeOutput::Mcap(mcap),
        );
        let Ended::Done {
            out: DecodeOutput::Mcap(mcap),
            ..
        } = ended
        else {
            return Err(CliError::Failed(format!(
                "--mcap {}: the recorded frames could not be decoded",
                self.path.display()
            )));
        };
        let summary = mcap.finish()?;
        if stats.dropped > 0 {
            errln!(
                "{summary} ({} frames not recorded: the recorder's queue was full)",
                stats.dropped
            );
        } else {
            errln!("{summary}");
        }
        Ok(())
    }
}
