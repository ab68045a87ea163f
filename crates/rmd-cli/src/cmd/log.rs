//! `rmd log --iface IFACE FILE`: record every frame on an interface to a candump -L file
//! (through the non-blocking recorder), until Ctrl-C, `--duration` or `--count`.

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::Ordering;
use std::time::Duration;

use clap::Args;
use rmd_bus::record::RecordOptions;
use rmd_bus::{BusError, BusMessage, CanBus, Clock, MonotonicClock};

use crate::live::connect::{Filter, open_interface};
use crate::live::interrupt;
use crate::live::recording::{LogSink, Recording};
use crate::output::console::WatchedSink;
use crate::output::errln;
use crate::output::progress::{self, Progress};
use crate::output::report::{self, CliError};
use rmd_rig::args::duration;

/// Arguments of `rmd log`.
#[derive(Args, Debug)]
pub(crate) struct LogArgs {
    /// The CAN interface to record (every standard data frame other programs send or receive
    /// on it).
    #[arg(long, value_name = "IFACE")]
    iface: String,
    /// The candump -L file to write (`-`: stdout, e.g. `| rmd decode`).
    #[arg(value_name = "FILE")]
    file: PathBuf,
    /// Stop after this long (e.g. 10s, 2m; a bare number is seconds).
    #[arg(long, visible_alias = "seconds", value_name = "DURATION", value_parser = duration::any, allow_hyphen_values = true)]
    duration: Option<Duration>,
    /// Stop after this many frames.
    #[arg(long, value_name = "N")]
    count: Option<u64>,
}

/// How long one wait for a frame lasts before looking at Ctrl-C and the limits again.
const SLICE: Duration = Duration::from_millis(50);

/// Runs `rmd log`.
pub(crate) fn run(args: LogArgs) -> ExitCode {
    report::exit(log(&args))
}

fn log(args: &LogArgs) -> Result<(), CliError> {
    let to_stdout = args.file.as_os_str() == "-";
    // Set when the reader of stdout goes away (`rmd log --iface can0 - | head`): the log ends.
    let mut reader_gone = None;
    // The interface first: one that cannot be opened leaves no empty file behind.
    let bus = open_interface(&args.iface, Filter::Everything)?;
    let sink = if to_stdout {
        LogSink::stdout()?
    } else {
        LogSink::create(&args.file)?
    };
    let clock = MonotonicClock;
    let (mut bus, recording) = Recording::start(
        bus,
        clock,
        sink,
        |sink| {
            if to_stdout {
                let (sink, closed) = WatchedSink::new(sink);
                reader_gone = Some(closed);
                Box::new(sink)
            } else {
                Box::new(sink)
            }
        },
        RecordOptions::new(&args.iface),
    )?;
    interrupt::install()?;
    errln!(
        "recording {} to {} (Ctrl-C stops)",
        args.iface,
        if to_stdout {
            "stdout".into()
        } else {
            args.file.display().to_string()
        }
    );
    let end = args.duration.map(|d| clock.now() + d);
    let mut frames = 0u64;
    let progress = match args.duration {
        Some(duration) => Progress::timer(duration, progress::shown(false)),
        None => Progress::spinner(progress::shown(false)),
    };
    progress.set_prefix(format!("{} ", args.iface));
    let start = clock.now();
    let outcome = loop {
        progress.set_elapsed(clock.now() - start);
        progress.set_message(format!("{frames} frames"));
        if reader_gone
            .as_ref()
            .is_some_and(|gone| gone.load(Ordering::Relaxed))
        {
            break Err(CliError::OutputClosed);
        }
        if interrupt::requested()
            || args.count.is_some_and(|n| frames >= n)
            || end.is_some_and(|end| clock.now() >= end)
        {
            break Ok(());
        }
        let deadline = end.map_or(clock.now() + SLICE, |end| end.min(clock.now() + SLICE));
        match bus.recv_until(deadline) {
            Ok(Some(received)) => {
                if let BusMessage::Frame(_) = received.message {
                    frames += 1;
                } else if let BusMessage::Event(event) = received.message {
                    progress.println(format!("bus event on {}: {event}", args.iface));
                }
            }
            Ok(None) => {}
            Err(BusError::InterfaceDown) => {
                break Err(CliError::Failed(format!(
                    "{} went down or away while recording: {}",
                    args.iface,
                    BusError::InterfaceDown
                )));
            }
            Err(error) => {
                break Err(CliError::Failed(format!(
                    "recording {}: {error}",
                    args.iface
                )));
            }
        }
    };
    drop(progress);
    drop(bus);
    if matches!(outcome, Err(CliError::OutputClosed)) {
        // The frames nobody could read are the reason, not news: end quietly.
        drop(recording);
        return outcome;
    }
    let finished = recording.finish();
    crate::live::recording::after(outcome, finished)
}
