//! Running a loop the way every program of rmd-rt does: on its own thread, stopped safely by
//! the project's signal policy, with a live status line, every tick's telemetry in the sinks
//! the flags ask for (CSV, MCAP, the Foxglove live server: see [`crate::telemetry`]), the report
//! at the end, and the standard exit codes.
//!
//! ```no_run
//! use rmd_rig::runner::Runner;
//! # fn demo(rt: rmd_loop::RtLoop<rmd_rig::AnyBus, rmd_rig::AnyClock, impl rmd_loop::Controller + 'static>) -> std::process::ExitCode {
//! let finished = match Runner::new().csv(Some("target/run.csv".as_ref())).mcap(Some("target/run.mcap".as_ref())).run(rt, rmd_loop::RunLimit::Forever) {
//!     Ok(finished) => finished,
//!     Err(e) => return rmd_rig::runner::exit_with_error("my-robot", &e),
//! };
//! finished.print_report(false);
//! finished.exit_code()
//! # }
//! ```

pub(crate) mod progress;

use std::io::Write;
use std::path::Path;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use rmd_bus::{CanBus, Clock};
use rmd_loop::{
    Controller, LoopOutcome, RtLoop, RunLimit,
    telemetry::{TelemetryDelivery, TelemetrySample},
};
use rmd_telemetry::LiveOptions;

pub use progress::Display;

use crate::args::OutputArgs;
use crate::error::RigError;
use crate::signals::{self, EXIT_INTERRUPTED};
use crate::telemetry::{TelemetryOutputs, TelemetryReport, TelemetrySinks, run_layout};

/// Exit status of a run that ended normally.
pub const EXIT_OK: u8 = 0;
/// Exit status of a run that ended on a fault, a panic or an emergency stop.
pub const EXIT_FAULT: u8 = 1;
/// Exit status of a program that could not start (bad arguments, description, interface).
pub const EXIT_USAGE: u8 = 2;

/// How often the runner takes the telemetry in (the loop's queue holds
/// `loop.telemetry_capacity` ticks: 4 s at 1 kHz by default, or far less in virtual time).
const DRAIN_EVERY: Duration = Duration::from_millis(5);
/// How often the status line is redrawn.
const SHOW_EVERY: Duration = Duration::from_millis(100);

/// A program's part of the status line: sees every tick's telemetry, shows the newest.
pub trait Status {
    /// Takes one tick's sample into account (every sample of the run, in order).
    fn observe(&mut self, sample: &TelemetrySample);
    /// The program's part of the status line, now.
    fn line(&self) -> String;
}

/// No part of the status line: the runner's own progress only.
impl Status for () {
    fn observe(&mut self, _: &TelemetrySample) {}
    fn line(&self) -> String {
        String::new()
    }
}

/// What a run produced.
#[derive(Debug)]
pub struct Finished<K> {
    /// The loop's report and the controller.
    pub outcome: LoopOutcome<K>,
    /// Whether a signal stopped it.
    pub interrupted: bool,
    /// What each telemetry sink got, if any was asked for.
    pub telemetry: Option<TelemetryReport>,
    /// How long it took on the wall clock.
    pub wall_time: Duration,
}

impl<K> Finished<K> {
    /// The exit status: [`EXIT_INTERRUPTED`] when a signal stopped the run, [`EXIT_OK`] when
    /// it ended normally and every telemetry sink wrote what it got, [`EXIT_FAULT`] otherwise
    /// (a fault, or a recording that failed: the user asked for it).
    pub fn exit_code(&self) -> ExitCode {
        ExitCode::from(self.exit_status())
    }

    /// [`exit_code`](Self::exit_code) as a number.
    pub fn exit_status(&self) -> u8 {
        exit_status(
            self.interrupted,
            &self.outcome.report,
            self.telemetry.as_ref(),
        )
    }

    /// Prints the report on standard output (as one JSON object with `json`), then what each
    /// telemetry sink got on standard error. A closed standard output is ignored.
    pub fn print_report(&self, json: bool) {
        let mut out = std::io::stdout();
        if json {
            let _ = writeln!(out, "{}", self.outcome.report.to_json());
        } else {
            let _ = write!(out, "{}", self.outcome.report);
        }
        if let Some(telemetry) = &self.telemetry {
            let _ = writeln!(std::io::stderr(), "{telemetry}");
        }
    }
}

/// The exit status of a run every program shares: [`EXIT_INTERRUPTED`] after a signal,
/// [`EXIT_FAULT`] after a fault or a failed telemetry sink (see [`TelemetryReport::failed`]),
/// [`EXIT_OK`] otherwise.
pub fn exit_status(
    interrupted: bool,
    report: &rmd_loop::LoopReport,
    telemetry: Option<&TelemetryReport>,
) -> u8 {
    if interrupted {
        EXIT_INTERRUPTED
    } else if !report.normal_stop || telemetry.is_some_and(TelemetryReport::failed) {
        EXIT_FAULT
    } else {
        EXIT_OK
    }
}

/// Prints `error` as `program: error` on standard error and returns [`EXIT_USAGE`].
pub fn exit_with_error(program: &str, error: &dyn std::fmt::Display) -> ExitCode {
    let _ = writeln!(std::io::stderr(), "{program}: {error}");
    ExitCode::from(EXIT_USAGE)
}

/// Runs loops: display, telemetry sinks, status, signals.
#[derive(Default)]
pub struct Runner<'a> {
    display: Option<Display>,
    telemetry: TelemetryOutputs,
    status: Option<&'a mut dyn Status>,
}

impl std::fmt::Debug for Runner<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Runner")
            .field("display", &self.display)
            .field("telemetry", &self.telemetry)
            .field("status", &self.status.is_some())
            .finish()
    }
}

impl<'a> Runner<'a> {
    /// A runner without display, telemetry or status.
    pub fn new() -> Self {
        Self::default()
    }

    /// A runner as the standard output flags say (`--csv`, `--mcap`, `--foxglove`, `--quiet`,
    /// `--json`).
    pub fn from_args(output: &OutputArgs) -> Self {
        Self::new()
            .display(output.display())
            .telemetry(output.telemetry.outputs())
    }

    /// How to show progress (default: nothing).
    pub fn display(mut self, display: Display) -> Self {
        self.display = Some(display);
        self
    }

    /// The telemetry sinks (replacing any set before).
    pub fn telemetry(mut self, outputs: TelemetryOutputs) -> Self {
        self.telemetry = outputs;
        self
    }

    /// Writes every tick to this CSV file (`None`: no CSV file).
    pub fn csv(mut self, path: Option<&Path>) -> Self {
        self.telemetry.csv = path.map(Path::to_path_buf);
        self
    }

    /// Records every tick to this MCAP file (`None`: no MCAP file).
    pub fn mcap(mut self, path: Option<&Path>) -> Self {
        self.telemetry.mcap = path.map(Path::to_path_buf);
        self
    }

    /// Serves the telemetry live to Foxglove (`None`: no server).
    pub fn foxglove(mut self, live: Option<LiveOptions>) -> Self {
        self.telemetry.live = live;
        self
    }

    /// The program's part of the status line.
    pub fn status(mut self, status: &'a mut dyn Status) -> Self {
        self.status = Some(status);
        self
    }

    /// Runs `rt` on its own thread until `limit` (or a signal, the controller, a fault) and
    /// returns what it produced. Prints nothing but progress: the caller prints the report.
    pub fn run<B, C, K>(
        self,
        mut rt: RtLoop<B, C, K>,
        limit: RunLimit,
    ) -> Result<Finished<K>, RigError>
    where
        B: CanBus + Send + 'static,
        C: Clock + Clone + 'static,
        K: Controller + 'static,
    {
        let signals = signals::install()?;
        let display = self.display.unwrap_or(Display::Quiet);
        let mut status = self.status;
        let robot = rt.robot().clone();
        let rate_hz = robot.settings().period.hz();
        // On virtual time nothing is lost: the loop and the sinks wait for each other.
        let lossless = rt.clock().is_virtual();
        let layout = run_layout(&robot, &rt.controller().signals())
            .map_err(|e| RigError::Telemetry(e.into()))?;
        let mut sinks = TelemetrySinks::start(&layout, &self.telemetry, lossless)?;
        let delivery = if lossless {
            TelemetryDelivery::Wait
        } else {
            TelemetryDelivery::Overwrite
        };
        // The loop publishes only if something takes its samples: the sinks or the status line.
        let mut receiver = None;
        if sinks.is_some() || status.is_some() {
            let rx = rt.telemetry_with(delivery);
            match sinks.take() {
                Some(s) => sinks = Some(s.with_receiver(rx)),
                None => receiver = Some(rx),
            }
        }
        if let (Some(addr), true) = (
            sinks.as_ref().and_then(TelemetrySinks::live_addr),
            display != Display::Quiet,
        ) {
            let _ = writeln!(
                std::io::stderr(),
                "telemetry: live on ws://{addr} (Foxglove: Open connection, Foxglove WebSocket)"
            );
        }
        let total_ticks = match limit {
            RunLimit::Ticks(n) => Some(n),
            RunLimit::Duration(d) => Some((d.as_secs_f64() * rate_hz) as u64),
            RunLimit::Forever => None,
        };
        let mut progress = progress::RunProgress::new(display, total_ticks, rate_hz);
        let started = Instant::now();
        let handle = rt.spawn(limit)?;
        let watch = signals.watch(handle.stopper());
        let drain = |sinks: &mut Option<TelemetrySinks>, status: &mut Option<&mut dyn Status>| {
            let mut observe = |sample: &TelemetrySample| {
                if let Some(status) = status.as_mut() {
                    status.observe(sample);
                }
            };
            if let Some(sinks) = sinks.as_mut() {
                sinks.pump(&mut observe);
            } else if let Some(rx) = &receiver {
                for sample in rx.drain() {
                    observe(&sample);
                }
            }
        };
        let mut last_show = Instant::now();
        while handle.is_running() {
            std::thread::sleep(DRAIN_EVERY);
            drain(&mut sinks, &mut status);
            if last_show.elapsed() >= SHOW_EVERY && progress.due() {
                last_show = Instant::now();
                if let Some(stats) = handle.snapshot(Duration::from_millis(50)) {
                    let line = status.as_ref().map(|s| s.line()).unwrap_or_default();
                    progress.show(&stats, &line);
                }
            }
        }
        let outcome = handle.join()?;
        drop(watch);
        drain(&mut sinks, &mut status);
        progress.finish();
        let telemetry = sinks.map(|s| s.finish(outcome.report.stats.telemetry_drops));
        Ok(Finished {
            outcome,
            interrupted: signals.interrupted(),
            telemetry,
            wall_time: started.elapsed(),
        })
    }
}
