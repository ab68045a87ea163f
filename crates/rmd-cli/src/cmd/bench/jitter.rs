//! `rmd bench jitter`: the wake latency of the loop's own timer, measured as `cyclictest`
//! measures the kernel's (actual wake minus the absolute deadline, every tick), with no bus and
//! no controller, on the loop's own scheduler ([`rmd_loop::jitter`]). A signal
//! (`rmd_rig::signals`) ends the measurement: the ticks measured so far are reported, exit
//! status 130.

use core::time::Duration;
use std::process::ExitCode;
use std::time::Instant;

use clap::Args;
use rmd_loop::jitter::{self, JitterConfig, JitterReport};
use rmd_loop::os::CpuLatencyStatus;
use rmd_loop::schedule::Period;
use serde_json::{Value, json};

use super::histogram;
use crate::args::timing;
use rmd_rig::args::RealtimeArgs;
use rmd_rig::args::duration::run_length;

/// Stack pre-faulted by the measuring thread (as the loop does).
const PREFAULT_STACK_BYTES: usize = 512 * 1024;
use crate::output::errln;
use crate::output::progress::{self, Progress};
use crate::output::report;

/// Arguments of `rmd bench jitter`.
#[derive(Args, Debug)]
// `--spin-us` of `rmd_rig::args::RealtimeArgs`, with the CLI's parser: `-1` or `1e300` is a
// usage error naming the flag.
#[command(mut_arg("spin_us", |arg| arg.allow_hyphen_values(true).value_parser(timing::spin_us)))]
#[command(after_help = "Output: a cyclictest-like summary line \
    (T: 0 (pid) P:prio I:period_us C:ticks Min: Avg: Max:, whole microseconds truncated as \
    cyclictest does) and the percentiles. JSON (--json): {ticks, deadline_misses, \
    wake_latency_us: {count, min, mean, p50, p90, p99, p999, max}, period_us, spin_us, cpu, \
    fifo_priority, cpu_dma_latency_us (held, or null), realtime, realtime_warnings, \
    histogram_us: [[k, count], ...]} where bucket k counts latencies of k to k+1 us, as \
    cyclictest -h. With --cpu or --fifo the measuring thread holds /dev/cpu_dma_latency at 0 \
    (as cyclictest does) unless --cpu-dma-latency says otherwise.")]
pub(crate) struct JitterArgs {
    /// Tick period in microseconds (10..=10000000).
    #[arg(long, value_name = "P", default_value = "1000", value_parser = period_us, allow_hyphen_values = true)]
    period_us: Period,
    /// How long to measure (e.g. 10s, 2m; a bare number is seconds).
    #[arg(long, visible_alias = "seconds", value_name = "DURATION", default_value = "10s", value_parser = run_length, allow_hyphen_values = true)]
    duration: Duration,
    #[command(flatten)]
    rt: RealtimeArgs,
    /// Print one JSON object.
    #[arg(long)]
    json: bool,
}

fn period_us(text: &str) -> Result<Period, String> {
    let us: u64 = text
        .trim()
        .parse()
        .map_err(|_| format!("`{text}` is not a whole number of microseconds"))?;
    Period::new(Duration::from_micros(us)).map_err(|e| e.to_string())
}

/// Runs `rmd bench jitter`.
pub(crate) fn run(args: JitterArgs) -> ExitCode {
    let period = args.period_us.get();
    if args.rt.spin() >= period {
        return report::usage_error(format!(
            "--spin-us {} must be shorter than the period ({} us)",
            args.rt.spin().as_micros(),
            period.as_micros()
        ));
    }
    let config = JitterConfig {
        period: args.period_us,
        duration: args.duration,
        spin_margin: args.rt.spin(),
        rt: args.rt.request(PREFAULT_STACK_BYTES),
    };
    let signals = match rmd_rig::signals::install() {
        Ok(signals) => signals,
        Err(e) => return report::failure(e),
    };
    let result = match measure(config, progress::shown(args.json)) {
        Ok(r) => r,
        Err(e) => return report::failure(e),
    };
    for warning in result.rt.warnings() {
        errln!("warning: {warning}");
    }
    if args.json {
        if let Err(code) = super::emit(&format!("{}\n", to_json(&result, &args.rt))) {
            return code;
        }
    } else {
        if let Err(code) = super::emit(&human(&result, &args.rt)) {
            return code;
        }
    }
    if signals.interrupted() {
        ExitCode::from(rmd_rig::signals::EXIT_INTERRUPTED)
    } else {
        ExitCode::SUCCESS
    }
}

/// Measures on the loop's own measuring thread; meanwhile this thread shows the progress (only
/// if shown: otherwise it just waits, so that nothing else wakes up during the measurement).
fn measure(config: JitterConfig, show: bool) -> Result<JitterReport, String> {
    let duration = config.duration;
    let start = Instant::now();
    let measuring = std::thread::Builder::new()
        .name("rmd-bench-jitter".to_string())
        .spawn(move || jitter::measure_real_time_while(config, || !rmd_rig::signals::interrupted()))
        .map_err(|e| format!("cannot start the measurement: {e}"))?;
    if show {
        let progress = Progress::timer(duration, true);
        progress.set_prefix("bench jitter ");
        while !measuring.is_finished() {
            progress.set_elapsed(start.elapsed());
            std::thread::sleep(Duration::from_millis(100));
        }
    }
    measuring
        .join()
        .map_err(|_| "the measuring thread panicked".to_string())?
        .map_err(|e| e.to_string())
}

fn to_json(r: &JitterReport, rt: &RealtimeArgs) -> Value {
    json!({
        "ticks": r.ticks,
        "deadline_misses": r.deadline_misses,
        "wake_latency_us": r.wake_latency_us,
        "period_us": r.period_us,
        "spin_us": r.spin_us,
        "cpu": rt.cpu,
        "fifo_priority": rt.fifo,
        "cpu_dma_latency_us": match r.rt.cpu_latency {
            CpuLatencyStatus::Held { us } => Some(us),
            _ => None,
        },
        "realtime": r.rt.to_string(),
        "realtime_warnings": r.rt.warnings().collect::<Vec<_>>(),
        "histogram_us": histogram::to_json(&histogram::whole_us_buckets(&r.histogram)),
    })
}

fn human(r: &JitterReport, rt: &RealtimeArgs) -> String {
    let p = &r.wake_latency_us;
    // cyclictest prints whole microseconds, truncated.
    let whole = |us: f64| us.max(0.0).trunc() as u64;
    format!(
        "T: 0 ({:>6}) P:{} I:{} C:{:>8} Min:{:>7} Avg:{:>5} Max:{:>8}\n\
         wake latency (us): min {:.2}  p50 {:.2}  p90 {:.2}  p99 {:.2}  p99.9 {:.2}  max {:.2}\n\
         ticks {}  deadline misses {}  period {} us  spin margin {} us\n\
         real-time: {}\n",
        std::process::id(),
        rt.fifo.unwrap_or(0),
        r.period_us.round() as u64,
        r.ticks,
        whole(p.min),
        whole(p.mean),
        whole(p.max),
        p.min,
        p.p50,
        p.p90,
        p.p99,
        p.p999,
        p.max,
        r.ticks,
        r.deadline_misses,
        r.period_us.round() as u64,
        r.spin_us.round() as u64,
        r.rt,
    )
}
