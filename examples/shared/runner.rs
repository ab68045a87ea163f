//! Running an example's loop: on its own thread, stopped safely by Ctrl-C, with a live status
//! line, the controller's telemetry written to a CSV file, and the loop report at the end.
//!
//! The controller publishes one sample per tick through a [`Recorder`] (a lock-free mailbox:
//! nothing on the loop thread allocates, locks or waits); this thread drains it every 100 ms
//! into the CSV file and shows the newest sample with the loop's statistics and, from the loop's
//! own telemetry, the largest torque current and temperature of any motor.

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use rmd_rt::bus::{CanBus, Clock};
use rmd_rt::rt::mailbox::{Receiver, Sender, mailbox};
use rmd_rt::rt::{StatsSummary, TelemetrySample};
use rmd_rt::{Controller, LoopOutcome, RtLoop, RunLimit, connect};

/// How the run shows its progress.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) enum Display {
    /// One status line, rewritten in place (a terminal).
    Terminal,
    /// One status line per second of wall time (logs, CI).
    Lines,
    /// Nothing until the final report.
    Quiet,
}

/// A controller's per-tick telemetry, as a CSV row.
pub(crate) trait Sample: Copy + Send + 'static {
    /// The CSV header line (without the line break).
    fn csv_header() -> &'static str;
    /// Writes one CSV row (without the line break).
    fn write_csv(&self, out: &mut dyn Write) -> io::Result<()>;
}

/// The controller's end of the telemetry mailbox: never blocks; when the reader falls behind the
/// oldest sample is overwritten and counted.
#[derive(Debug)]
pub(crate) struct Recorder<S> {
    tx: Sender<S>,
    /// Samples overwritten before they were read.
    pub(crate) dropped: u64,
}

impl<S: Send> Recorder<S> {
    /// Publishes one sample.
    pub(crate) fn record(&mut self, sample: S) {
        if self.tx.send_overwrite(sample).is_some() {
            self.dropped += 1;
        }
    }
}

/// A telemetry mailbox holding up to `capacity` samples.
pub(crate) fn recorder<S: Send>(capacity: usize) -> (Recorder<S>, Receiver<S>) {
    let (tx, rx) = mailbox(capacity);
    (Recorder { tx, dropped: 0 }, rx)
}

/// The mailbox capacity for a run of `limit` at `rate_hz`: every sample of a bounded run (so a
/// virtual-time run, faster than the reader, loses none), at most 2^21; 4 s of samples otherwise.
pub(crate) fn capacity_for(limit: RunLimit, rate_hz: f64) -> usize {
    let ticks = match limit {
        RunLimit::Ticks(n) => n as f64,
        RunLimit::Duration(d) => d.as_secs_f64() * rate_hz,
        RunLimit::Forever => 4.0 * rate_hz,
    };
    (ticks.ceil() as usize + 16).min(1 << 21)
}

/// Why an example could not run.
#[derive(Debug)]
pub(crate) enum RunError {
    /// The CSV file could not be created.
    Csv(PathBuf, io::Error),
    /// The loop thread could not be started or died.
    Loop(String),
}

impl std::fmt::Display for RunError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RunError::Csv(path, e) => write!(f, "cannot write {}: {e}", path.display()),
            RunError::Loop(e) => f.write_str(e),
        }
    }
}

/// What a run produced.
#[derive(Debug)]
pub(crate) struct Finished<K> {
    /// The loop's report and the controller.
    pub(crate) outcome: LoopOutcome<K>,
    /// CSV rows written.
    pub(crate) csv_rows: u64,
    /// The first error writing the CSV file, if any (the run went on).
    pub(crate) csv_error: Option<io::Error>,
}

/// The example's part of the status line: sees every sample, shows the newest.
pub(crate) trait Status<S> {
    /// Takes one sample into account (every sample of the run, in order).
    fn observe(&mut self, sample: &S);
    /// The example's part of the status line, for the newest sample.
    fn line(&self, latest: &S) -> String;
}

/// The example-specific part of a run.
pub(crate) struct Monitor<'a, S> {
    /// The controller's telemetry.
    pub(crate) samples: Receiver<S>,
    /// Where to write it.
    pub(crate) csv: Option<&'a Path>,
    /// How to show progress.
    pub(crate) display: Display,
    /// The example's part of the status line.
    pub(crate) status: &'a mut dyn Status<S>,
}

/// Runs `rt` on its own thread until `limit` (or Ctrl-C, the controller, a fault), showing
/// progress and writing the telemetry; returns the outcome. Prints nothing but progress: the
/// caller prints the report.
pub(crate) fn run<B, C, K, S>(
    rt: RtLoop<B, C, K>,
    limit: RunLimit,
    monitor: Monitor<'_, S>,
) -> Result<Finished<K>, RunError>
where
    B: CanBus + Send + 'static,
    C: Clock + 'static,
    K: Controller + 'static,
    S: Sample,
{
    let mut csv = match monitor.csv {
        Some(path) => Some(CsvFile::create::<S>(path)?),
        None => None,
    };
    let rate_hz = rt.config().loop_config.rate_hz;
    let total_ticks = match limit {
        RunLimit::Ticks(n) => Some(n),
        RunLimit::Duration(d) => Some((d.as_secs_f64() * rate_hz) as u64),
        RunLimit::Forever => None,
    };
    let loop_telemetry = rt.telemetry();
    let mut motors = MotorExtremes::default();
    if let Err(e) = connect::stop_on_ctrl_c(rt.stopper()) {
        eprintln!("warning: {e}; Ctrl-C will not stop the motors safely");
    }
    let handle = rt.spawn(limit).map_err(|e| RunError::Loop(e.to_string()))?;
    let started = Instant::now();
    let mut last_line: Option<Instant> = None;
    let mut latest: Option<S> = None;
    let status = monitor.status;
    while handle.is_running() {
        std::thread::sleep(Duration::from_millis(100));
        for sample in monitor.samples.drain() {
            if let Some(csv) = csv.as_mut() {
                csv.write(&sample);
            }
            status.observe(&sample);
            latest = Some(sample);
        }
        for sample in loop_telemetry.drain() {
            motors.add(&sample);
        }
        let show = match monitor.display {
            Display::Quiet => false,
            Display::Terminal => true,
            Display::Lines => last_line.is_none_or(|t| t.elapsed() >= Duration::from_secs(1)),
        };
        if show && let Some(stats) = handle.snapshot(Duration::from_millis(50)) {
            let line = status_line(
                &stats,
                rate_hz,
                total_ticks,
                latest.as_ref(),
                &*status,
                &motors,
            );
            match monitor.display {
                Display::Terminal => {
                    say_raw!("\r\x1b[2K{line}");
                    let _ = io::stdout().flush();
                }
                _ => say!("{line}"),
            }
            last_line = Some(Instant::now());
        }
    }
    let outcome = handle.join().map_err(|e| RunError::Loop(e.to_string()))?;
    for sample in monitor.samples.drain() {
        if let Some(csv) = csv.as_mut() {
            csv.write(&sample);
        }
    }
    if monitor.display == Display::Terminal {
        say!();
    }
    if monitor.display != Display::Quiet {
        say!(
            "ran {:.1} s of loop time in {:.1} s of wall time",
            outcome.report.duration_s,
            started.elapsed().as_secs_f64()
        );
    }
    let (csv_rows, csv_error) = match csv {
        Some(csv) => csv.finish(),
        None => (0, None),
    };
    Ok(Finished {
        outcome,
        csv_rows,
        csv_error,
    })
}

/// `[#####.....]  50%   5.0 / 10.0 s | <example status> | misses 0  missing 0  wake p99 40 us`
fn status_line<S>(
    stats: &StatsSummary,
    rate_hz: f64,
    total_ticks: Option<u64>,
    latest: Option<&S>,
    status: &dyn Status<S>,
    motors: &MotorExtremes,
) -> String {
    let t = stats.ticks as f64 / rate_hz;
    let progress = match total_ticks {
        Some(total) if total > 0 => {
            let done = (stats.ticks as f64 / total as f64).clamp(0.0, 1.0);
            let width = 20;
            let filled = (done * width as f64).floor() as usize;
            format!(
                "[{}{}] {:3.0}%  {:5.1} / {:.1} s",
                "#".repeat(filled),
                ".".repeat(width - filled),
                done * 100.0,
                t,
                total as f64 / rate_hz
            )
        }
        _ => format!("{t:7.1} s"),
    };
    let example = latest.map(|s| status.line(s)).unwrap_or_default();
    format!(
        "{progress} | {example} | |iq| <= {:.1} A  {:.0} degC | misses {}  missing {}  wake p99 {:.0} us",
        motors.max_abs_iq_amps,
        motors.max_temperature_celsius,
        stats.deadline_misses,
        stats.missing_replies,
        stats.wake_latency_us.p99
    )
}

/// The largest torque current and temperature of any motor so far.
#[derive(Copy, Clone, Debug, Default)]
struct MotorExtremes {
    max_abs_iq_amps: f64,
    max_temperature_celsius: f64,
}

impl MotorExtremes {
    fn add(&mut self, sample: &TelemetrySample) {
        for j in sample.joints() {
            self.max_abs_iq_amps = self.max_abs_iq_amps.max(j.iq_amps.abs());
            self.max_temperature_celsius = self.max_temperature_celsius.max(j.temperature_celsius);
        }
    }
}

/// A CSV file being written; write errors are remembered, not fatal.
struct CsvFile {
    out: BufWriter<File>,
    rows: u64,
    error: Option<io::Error>,
}

impl CsvFile {
    fn create<S: Sample>(path: &Path) -> Result<Self, RunError> {
        let fail = |e| RunError::Csv(path.to_path_buf(), e);
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(fail)?;
        }
        let mut out = BufWriter::new(File::create(path).map_err(fail)?);
        writeln!(out, "{}", S::csv_header()).map_err(fail)?;
        Ok(Self {
            out,
            rows: 0,
            error: None,
        })
    }

    fn write<S: Sample>(&mut self, sample: &S) {
        if self.error.is_some() {
            return;
        }
        match sample
            .write_csv(&mut self.out)
            .and_then(|()| writeln!(self.out))
        {
            Ok(()) => self.rows += 1,
            Err(e) => self.error = Some(e),
        }
    }

    fn finish(mut self) -> (u64, Option<io::Error>) {
        if self.error.is_none()
            && let Err(e) = self.out.flush()
        {
            self.error = Some(e);
        }
        (self.rows, self.error)
    }
}

/// Writes `values` as CSV fields with `decimals` decimals, each preceded by a comma.
pub(crate) fn write_fields(out: &mut dyn Write, values: &[f64], decimals: usize) -> io::Result<()> {
    for v in values {
        write!(out, ",{v:.decimals$}")?;
    }
    Ok(())
}
