//! `rmd bench rate`: the highest loop rate the simulated 1 Mbit/s bus sustains with zero deadline
//! misses, found by bisection, against the wire limit of the frames actually sent.
//!
//! A trial runs the loop (PD controller on moving targets, as `rmd bench loop`) for `--duration`
//! at one rate, with the reply deadline at the end of the period (the loop waits for replies as
//! long as the period allows) and the wire-budget check off (`allow_over_budget`: the search
//! looks for the real limit, beyond the worst-case budget). It passes when every tick ran on time
//! with every reply: no deadline miss, no skipped tick, no missing or late reply.
//!
//! The search starts at the rate of the worst-case budget (every frame 135 bits, 220 us
//! turnaround), which must pass; the wire limit of that run's frames (see [`super::wire_limit`])
//! bounds it from above; it bisects until the interval is narrower than `--resolution-pct`, then
//! runs the best rate again `--confirm` times (stepping down on a failure).
//!
//! Each trial also measures where the period goes: wake latency and work per tick (the loop's
//! statistics), when the last reply of the tick arrived relative to the tick's start, and the
//! hand-off from that arrival to the controller (measured by the controller on the real clock).

use core::time::Duration;
use std::process::ExitCode;

use clap::Args;
use rmd_bus::wire::exchange_budget;
use rmd_bus::{Clock, MonotonicClock, Timestamp, VirtualClock};
use rmd_loop::stats::Percentiles;
use rmd_loop::{RtLoop, RunLimit};
use serde_json::{Value, json};

use super::flags;
use super::pd::MovingTargetPd;
use super::robot;
use super::wire_limit::{self, WireLimit, us};
use crate::args::timing;
use crate::output::errln;
use crate::output::progress::{self, Progress};
use crate::output::report;
use crate::output::table::{Align, TextTable};
use rmd_rig::args::RealtimeArgs;
use rmd_rig::args::duration::run_length;

/// Bit rate of the simulated buses.
const BITRATE: u32 = 1_000_000;
/// Longest turnaround of the simulator's default motor (200 us + up to 20 us of jitter).
const MAX_TURNAROUND: Duration = Duration::from_micros(220);
/// Stack of the trial thread (as the loop's own thread).
const TRIAL_STACK_BYTES: usize = 8 * 1024 * 1024;
/// How many times the search steps down by 10% when the starting rate fails.
const MAX_STEPS_DOWN: u32 = 8;
/// Most runs spent confirming the result.
const MAX_CONFIRM_RUNS: u32 = 6;

/// Arguments of `rmd bench rate`.
#[derive(Args, Debug, Clone)]
// `--spin-us` of `rmd_rig::args::RealtimeArgs`, with the CLI's parser: `-1` or `1e300` is a
// usage error naming the flag.
#[command(mut_arg("spin_us", |arg| arg.allow_hyphen_values(true).value_parser(timing::spin_us)))]
#[command(
    after_help = "Output: one line per trial, then the highest rate that passed, the wire \
    limit of that run's frames (1 / longest exchange: 0x280 start to the end of the last reply) \
    and their ratio, and where the period went. JSON (--json): one object with `best_rate_hz`, \
    `wire_limit` (of the best run), `ratio_to_wire_limit` and every trial."
)]
pub(crate) struct RateArgs {
    /// Simulated buses (1 Mbit/s each), 1..=8, exchanged in parallel by one loop.
    #[arg(long, default_value = "1", value_parser = flags::buses)]
    buses: usize,
    /// Motors per bus, 1..=4.
    #[arg(long, default_value = "4", value_parser = flags::motors)]
    motors: u8,
    /// Length of each trial (e.g. 10s, 500ms; a bare number is seconds).
    #[arg(long, visible_alias = "seconds", value_name = "DURATION", default_value = "10s", value_parser = run_length, allow_hyphen_values = true)]
    duration: Duration,
    #[command(flatten)]
    rt: RealtimeArgs,
    /// Let the simulated bus busy-wait the last US microseconds before each frame it delivers
    /// (a polling receive) instead of sleeping all the way (a blocking receive, the default).
    #[arg(long, value_name = "US", value_parser = timing::spin_us, default_value = "0", allow_hyphen_values = true)]
    rx_spin_us: u64,
    /// Stop bisecting when the interval is narrower than this, percent of the rate.
    #[arg(long, value_name = "PCT", default_value = "0.5", value_parser = resolution)]
    resolution_pct: f64,
    /// Runs that must pass again at the rate found.
    #[arg(long, value_name = "N", default_value_t = 1)]
    confirm: u32,
    /// Run one trial at this rate instead of searching.
    #[arg(long, visible_alias = "rate-hz", value_name = "HZ", value_parser = flags::loop_rate, allow_hyphen_values = true)]
    rate: Option<f64>,
    /// Run on a virtual clock (the loop then costs no time: the search finds the wire limit).
    #[arg(long)]
    virtual_time: bool,
    /// Print one JSON object.
    #[arg(long)]
    json: bool,
}

fn resolution(text: &str) -> Result<f64, String> {
    let pct: f64 = text
        .trim()
        .parse()
        .map_err(|_| format!("`{text}` is not a percentage"))?;
    if !(pct.is_finite() && (0.01..=50.0).contains(&pct)) {
        return Err(format!("{text}%: must be 0.01..=50"));
    }
    Ok(pct)
}

/// The outcome of one trial.
#[derive(Clone, Debug)]
struct Trial {
    rate_hz: f64,
    period: Duration,
    passed: bool,
    stop_reason: String,
    ticks: u64,
    expected_ticks: u64,
    deadline_misses: u64,
    skipped_ticks: u64,
    missing_replies: u64,
    late_replies: u64,
    wake: Percentiles,
    round_trip: Percentiles,
    work: Percentiles,
    last_reply: Percentiles,
    handoff: Percentiles,
    wire: Option<WireLimit>,
    warnings: Vec<String>,
}

impl Trial {
    fn to_json(&self) -> Value {
        json!({
            "rate_hz": self.rate_hz,
            "period_us": us(self.period),
            "passed": self.passed,
            "stop_reason": self.stop_reason,
            "ticks": self.ticks,
            "expected_ticks": self.expected_ticks,
            "deadline_misses": self.deadline_misses,
            "skipped_ticks": self.skipped_ticks,
            "missing_replies": self.missing_replies,
            "late_replies": self.late_replies,
            "wake_latency_us": self.wake,
            "round_trip_us": self.round_trip,
            "work_us": self.work,
            "last_reply_after_start_us": self.last_reply,
            "reply_to_controller_us": self.handoff,
            "wire_limit": self.wire.map(WireLimit::to_json),
        })
    }

    fn line(&self, n: usize) -> String {
        format!(
            "trial {n:>2}: {:>8.1} Hz  period {:>7.1} us  {}  misses {} skipped {} missing {} late {}  \
             wake p99 {:.1} max {:.1}  last reply max {:.1}  reply->controller max {:.1}  work max {:.1} us  \
             wire limit {}",
            self.rate_hz,
            us(self.period),
            if self.passed { "PASS" } else { "FAIL" },
            self.deadline_misses,
            self.skipped_ticks,
            self.missing_replies,
            self.late_replies,
            self.wake.p99,
            self.wake.max,
            self.last_reply.max,
            self.handoff.max,
            self.work.max,
            self.wire
                .map_or("n/a".to_string(), |w| format!("{:.1} Hz", w.rate_hz())),
        )
    }
}

/// A receive clock for the simulated buses in real time: the monotonic clock, whose waits sleep
/// until `spin` before the deadline and busy-wait the rest.
#[derive(Copy, Clone, Debug)]
struct ReceiveClock {
    spin: Duration,
}

impl Clock for ReceiveClock {
    fn now(&self) -> Timestamp {
        MonotonicClock.now()
    }

    fn sleep_until(&self, deadline: Timestamp) {
        MonotonicClock.wait_until(deadline, self.spin);
    }
}

/// Runs one trial at `rate_hz` on a thread of its own (the loop pins and prioritises it).
fn trial(args: &RateArgs, rate_hz: f64, progress: &Progress) -> Result<Trial, String> {
    let args = args.clone();
    let thread = std::thread::Builder::new()
        .name("rmd-bench-rate".to_string())
        .stack_size(TRIAL_STACK_BYTES)
        .spawn(move || {
            if args.virtual_time {
                let clock = VirtualClock::new();
                run_trial(&args, rate_hz, clock.clone(), clock)
            } else {
                run_trial(
                    &args,
                    rate_hz,
                    MonotonicClock,
                    ReceiveClock {
                        spin: Duration::from_micros(args.rx_spin_us),
                    },
                )
            }
        })
        .map_err(|e| format!("cannot start the trial thread: {e}"))?;
    // The progress of the trial, while it runs (in real time; a virtual-time trial is quick).
    let start = std::time::Instant::now();
    while progress.is_shown() && !thread.is_finished() {
        progress.set_elapsed(start.elapsed());
        std::thread::sleep(Duration::from_millis(50));
    }
    thread
        .join()
        .map_err(|_| "the trial thread panicked".to_string())?
}

fn run_trial<L: Clock + Clone + 'static, S: Clock + Clone>(
    args: &RateArgs,
    rate_hz: f64,
    loop_clock: L,
    sim_clock: S,
) -> Result<Trial, String> {
    let mut config = robot::robot(rate_hz, args.buses, args.motors);
    args.rt.apply(&mut config);
    let period = rmd_loop::schedule::Period::from_hz(rate_hz)
        .map_err(|e| e.to_string())?
        .get();
    let l = &mut config.loop_config;
    l.allow_over_budget = true;
    // Wait for replies as long as the period allows: the loop adds no gap of its own.
    l.reply_deadline_us = Some((period.as_nanos() / 1000) as u64);
    let robot = rmd_loop::Robot::try_from(config).map_err(|e| e.to_string())?;
    let expected_ticks = (args.duration.as_nanos() / period.as_nanos()) as u64;
    let mut sims = robot::sim_buses(&sim_clock, args.buses, args.motors)
        .map_err(|e| format!("simulator: {e}"))?;
    let frames_per_exchange = usize::from(args.motors) + 1;
    for sim in &mut sims {
        // Start-up probes, every tick, and the safe stop (zero torque, motor-off and replies).
        sim.record_trace((expected_ticks as usize + 64) * frames_per_exchange + 64);
    }
    let rt = RtLoop::new(
        robot,
        loop_clock,
        sims.iter_mut().collect::<Vec<_>>(),
        MovingTargetPd::new(!args.virtual_time),
    )
    .map_err(|e| e.to_string())?;
    let outcome = rt.run(RunLimit::Duration(args.duration));
    // The ticks' exchanges only: not the start-up probes nor the safe stop (zero-torque frames,
    // the longest there are).
    let (first, last) = outcome
        .controller
        .ticks_due
        .unwrap_or((Timestamp::ZERO, Timestamp::ZERO));
    let exchanges: Vec<_> = sims
        .iter()
        .flat_map(|s| wire_limit::exchanges(s.trace(), usize::from(args.motors), BITRATE))
        .filter(|e| e.start >= first && e.start < last + period)
        .collect();
    let r = &outcome.report;
    let s = &r.stats;
    let passed = r.normal_stop
        && s.ticks == expected_ticks
        && s.deadline_misses == 0
        && s.skipped_ticks == 0
        && s.missing_replies == 0
        && s.late_replies == 0;
    Ok(Trial {
        rate_hz,
        period,
        passed,
        stop_reason: r.stop_reason.to_string(),
        ticks: s.ticks,
        expected_ticks,
        deadline_misses: s.deadline_misses,
        skipped_ticks: s.skipped_ticks,
        missing_replies: s.missing_replies,
        late_replies: s.late_replies,
        wake: s.wake_latency_us,
        round_trip: s.round_trip_us,
        work: s.work_us,
        last_reply: outcome.controller.last_reply.percentiles(),
        handoff: outcome.controller.handoff.percentiles(),
        wire: WireLimit::of(&exchanges),
        warnings: r.realtime_warnings.clone(),
    })
}

/// The search and its result.
struct Search {
    trials: Vec<Trial>,
    /// Index of the last trial at the best rate: the highest rate that passed every time it was
    /// run.
    best: Option<usize>,
    /// Passing runs at the best rate beyond the first.
    confirmations: u32,
    /// The running trial, on a terminal.
    progress: Progress,
}

impl Search {
    fn run(&mut self, args: &RateArgs, rate_hz: f64) -> Result<&Trial, String> {
        self.progress.restart_timer(args.duration);
        self.progress.set_prefix(format!(
            "trial {} at {rate_hz:.1} Hz ",
            self.trials.len() + 1
        ));
        let t = trial(args, rate_hz, &self.progress)?;
        if !args.json {
            self.progress.println(t.line(self.trials.len() + 1));
            for w in &t.warnings {
                self.progress.println(format!("  warning: {w}"));
            }
        }
        self.trials.push(t);
        Ok(&self.trials[self.trials.len() - 1])
    }

    /// Passes and failures at exactly `rate_hz`.
    fn tally(&self, rate_hz: f64) -> (u32, u32) {
        self.trials
            .iter()
            .filter(|t| t.rate_hz == rate_hz)
            .fold(
                (0, 0),
                |(p, f), t| if t.passed { (p + 1, f) } else { (p, f + 1) },
            )
    }

    /// Rates that passed at least once and failed at least once.
    fn flaky_rates(&self) -> Vec<f64> {
        let mut rates: Vec<f64> = self
            .trials
            .iter()
            .map(|t| t.rate_hz)
            .filter(|&r| matches!(self.tally(r), (p, f) if p > 0 && f > 0))
            .collect();
        rates.sort_by(f64::total_cmp);
        rates.dedup();
        rates
    }

    /// Picks the highest rate that passed every time it ran.
    fn settle(&mut self) {
        self.best = None;
        self.confirmations = 0;
        let mut best_rate = f64::NEG_INFINITY;
        for (i, t) in self.trials.iter().enumerate() {
            let (passes, fails) = self.tally(t.rate_hz);
            if passes > 0 && fails == 0 && t.rate_hz >= best_rate {
                best_rate = t.rate_hz;
                self.best = Some(i);
                self.confirmations = passes - 1;
            }
        }
    }
}

fn search(args: &RateArgs) -> Result<Search, String> {
    let mut s = Search {
        trials: Vec::new(),
        best: None,
        confirmations: 0,
        progress: Progress::timer(args.duration, progress::shown(args.json)),
    };
    if let Some(rate) = args.rate {
        s.run(args, rate)?;
        s.settle();
        return Ok(s);
    }
    let budget = exchange_budget(u32::from(args.motors), BITRATE, MAX_TURNAROUND);
    let mut lo = 1.0 / budget.as_secs_f64();
    let mut steps = 0;
    while !s.run(args, lo)?.passed {
        steps += 1;
        if steps > MAX_STEPS_DOWN {
            s.settle();
            return Ok(s);
        }
        lo *= 0.9;
    }
    let mut hi = s.trials[s.trials.len() - 1]
        .wire
        .map_or(lo, |w| w.rate_hz())
        .max(lo);
    let res = args.resolution_pct / 100.0;
    while (hi - lo) / hi > res {
        let mid = 0.5 * (lo + hi);
        if s.run(args, mid)?.passed {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    // Confirm: the rate must pass `confirm` more times and never fail; on a failure, step down.
    let mut runs = 0;
    while runs < MAX_CONFIRM_RUNS {
        let (passes, fails) = s.tally(lo);
        if fails > 0 {
            lo *= 1.0 - res;
            continue;
        }
        if passes > args.confirm {
            break;
        }
        runs += 1;
        s.run(args, lo)?;
    }
    s.settle();
    Ok(s)
}

/// Runs `rmd bench rate`.
pub(crate) fn run(args: RateArgs) -> ExitCode {
    if args.rate.is_none() && args.confirm > MAX_CONFIRM_RUNS {
        return report::usage_error(format!(
            "--confirm {}: at most {MAX_CONFIRM_RUNS}",
            args.confirm
        ));
    }
    if !args.json {
        errln!(
            "rmd bench rate: {} motor(s) x {} bus(es) at {} bit/s, {:.1} s per trial, spin {} us, \
             cpu {}, SCHED_FIFO {}, {}{}",
            args.motors,
            args.buses,
            BITRATE,
            args.duration.as_secs_f64(),
            args.rt.spin().as_micros(),
            args.rt.cpu.map_or("-".to_string(), |c| c.to_string()),
            args.rt.fifo.map_or("-".to_string(), |p| p.to_string()),
            if args.virtual_time {
                "virtual time"
            } else {
                "real time"
            },
            if args.rx_spin_us > 0 {
                format!(", receive spin {} us", args.rx_spin_us)
            } else {
                String::new()
            }
        );
    }
    let s = match search(&args) {
        Ok(s) => s,
        Err(e) => return report::usage_error(e),
    };
    s.progress.clear();
    let best = s.best.map(|i| &s.trials[i]);
    if args.json {
        if let Err(code) = super::emit(&format!("{}\n", summary_json(&args, &s, best))) {
            return code;
        }
    } else {
        if let Err(code) = super::emit(&summary_text(&args, &s, best)) {
            return code;
        }
    }
    if best.is_some() || args.rate.is_some() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(report::FAILURE)
    }
}

fn summary_json(args: &RateArgs, s: &Search, best: Option<&Trial>) -> Value {
    let limit = best.and_then(|b| b.wire);
    json!({
        "buses": args.buses,
        "motors_per_bus": args.motors,
        "bitrate": BITRATE,
        "seconds_per_trial": args.duration.as_secs_f64(),
        "spin_us": args.rt.spin_us,
        "cpu": args.rt.cpu,
        "fifo_priority": args.rt.fifo,
        "rx_spin_us": args.rx_spin_us,
        "virtual_time": args.virtual_time,
        "resolution_pct": args.resolution_pct,
        "best_rate_hz": best.map(|b| b.rate_hz),
        "best_period_us": best.map(|b| us(b.period)),
        "confirmations": s.confirmations,
        "flaky_rates_hz": s.flaky_rates(),
        "wire_limit": limit.map(WireLimit::to_json),
        "ratio_to_wire_limit": best.zip(limit).map(|(b, w)| b.rate_hz / w.rate_hz()),
        "trials": s.trials.iter().map(Trial::to_json).collect::<Vec<_>>(),
    })
}

/// Every trial, one row each (times in microseconds; maxima unless named).
fn trials_table(s: &Search) -> String {
    let mut table = TextTable::new(&[
        ("trial", Align::Right),
        ("rate Hz", Align::Right),
        ("period", Align::Right),
        ("result", Align::Left),
        ("misses", Align::Right),
        ("skipped", Align::Right),
        ("missing", Align::Right),
        ("late", Align::Right),
        ("wake p99", Align::Right),
        ("wake", Align::Right),
        ("last reply", Align::Right),
        ("reply->ctrl", Align::Right),
        ("work", Align::Right),
        ("wire limit Hz", Align::Right),
    ]);
    for (n, t) in s.trials.iter().enumerate() {
        table.row([
            (n + 1).to_string(),
            format!("{:.1}", t.rate_hz),
            format!("{:.1}", us(t.period)),
            if t.passed { "PASS" } else { "FAIL" }.to_string(),
            t.deadline_misses.to_string(),
            t.skipped_ticks.to_string(),
            t.missing_replies.to_string(),
            t.late_replies.to_string(),
            format!("{:.1}", t.wake.p99),
            format!("{:.1}", t.wake.max),
            format!("{:.1}", t.last_reply.max),
            format!("{:.1}", t.handoff.max),
            format!("{:.1}", t.work.max),
            t.wire
                .map_or("n/a".to_string(), |w| format!("{:.1}", w.rate_hz())),
        ]);
    }
    format!(
        "trials (times in us; maxima unless named p99):\n{}",
        table.render()
    )
}

fn summary_text(args: &RateArgs, s: &Search, best: Option<&Trial>) -> String {
    let mut out = trials_table(s);
    let Some(b) = best else {
        out += &if args.rate.is_some() {
            format!(
                "the rate did not pass ({})\n",
                s.trials
                    .first()
                    .map_or("no trial", |t| t.stop_reason.as_str())
            )
        } else {
            "no rate passed\n".to_string()
        };
        return out;
    };
    out += &format!(
        "highest rate with zero misses: {:.1} Hz (period {:.1} us, {} ticks), passed {} time(s), \
         never failed\n",
        b.rate_hz,
        us(b.period),
        b.ticks,
        s.confirmations + 1
    );
    let flaky = s.flaky_rates();
    if !flaky.is_empty() {
        let list: Vec<String> = flaky.iter().map(|r| format!("{r:.1}")).collect();
        out += &format!(
            "passed and failed at the same rate (noise): {} Hz\n",
            list.join(", ")
        );
    }
    if let Some(w) = b.wire {
        let gap = b.period.saturating_sub(w.max_cycle);
        out += &format!(
            "wire limit of that run's frames: {:.1} Hz = 1 / longest exchange {:.1} us (frames \
             {:.1} us + turnaround {:.1} us - intermission {:.1} us; mean exchange {:.1} us, frames \
             {}..{} bits, longest turnaround {:.1} us)\n\
             ratio to the wire limit: {:.1}%  (the loop needs {:.1} us beyond the longest exchange)\n",
            w.rate_hz(),
            us(w.max_cycle),
            us(w.frames_at_max),
            us(w.turnaround_at_max),
            us(wire_limit::intermission(BITRATE)),
            us(w.mean_cycle),
            w.frame_bits.0,
            w.frame_bits.1,
            us(w.max_turnaround),
            100.0 * b.rate_hz / w.rate_hz(),
            us(gap),
        );
    }
    out += &format!(
        "where the period goes (p50 / p99 / max, us): wake latency {:.1} / {:.1} / {:.1}; last \
         reply arrives after the tick's start {:.1} / {:.1} / {:.1}; reply to controller {:.1} / \
         {:.1} / {:.1}; work per tick (wake to end) {:.1} / {:.1} / {:.1}\n",
        b.wake.p50,
        b.wake.p99,
        b.wake.max,
        b.last_reply.p50,
        b.last_reply.p99,
        b.last_reply.max,
        b.handoff.p50,
        b.handoff.p99,
        b.handoff.max,
        b.work.p50,
        b.work.p99,
        b.work.max,
    );
    out
}
