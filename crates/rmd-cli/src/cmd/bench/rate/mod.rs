//! `rmd bench rate`: for each bus count, the highest loop rate with at most 0.1% of its ticks
//! missed (the headline) and the highest with none missed, each against the wire limit of the
//! frames actually sent, and what the loop adds to each exchange.
//!
//! A rate with zero misses over a trial is set by the longest stall of the machine during the
//! trial (a descheduled vCPU, a non-preemptible kernel section), not by the loop: the headline
//! allows a small share of missed ticks (`--miss-budget-pct`, default 0.1%) and so measures
//! the loop. A tick is missed when it misses its deadline or a motor's reply, or is skipped.
//! A missed tick whose reply a simulator thread handed over late while the loop was on time is
//! the simulator's, not the loop's ([`attribution`]): it is reported, not counted in the budget.
//!
//! The wire limit (see [`super::wire_limit`]) is 1 / the longest exchange of the trial's frames
//! on the simulated 1 Mbit/s wire: stuffed frame lengths plus the motors' turnaround. What the
//! loop adds per exchange is, in each tick with every reply, the time from the last reply's
//! arrival to the end of the tick's work (the loop is then ready to send the next frame): its
//! wake-up for the reply, the hand-off, decoding, the controller, statistics and telemetry.
//!
//! While it searches, each trial's line is followed by what the trials so far found. A bus count
//! that finds no rate within the budget says why and what to try ([`diagnosis`]: the machine's
//! load, stalls, the simulator's late replies); its zero-miss search is then not run (a rate with
//! no miss would be within the budget).
//!
//! In real time each simulated bus runs on its own thread (`--sim thread`, the default), as real
//! motors do, so that the loop thread is measured alone and the loop waits on every bus at
//! once; `--sim inline` runs them inside the loop's thread (the loop then also pays
//! for their firmware and physics); `--virtual-time` runs everything on a virtual clock.

mod attribution;
mod diagnosis;
mod search;
mod trial;

use core::time::Duration;
use std::process::ExitCode;

use clap::{Args, ValueEnum};
use serde_json::{Value, json};

use super::flags;
use super::wire_limit::{self, us};
use crate::args::timing;
use crate::output::errln;
use crate::output::progress::{self, Progress};
use crate::output::report;
use crate::output::table::{Align, TextTable};
use diagnosis::Machine;
use rmd_rig::args::RealtimeArgs;
use rmd_rig::args::duration::run_length;
use search::Search;
use trial::Trial;

/// Bit rate of the simulated buses.
const BITRATE: u32 = 1_000_000;
/// Longest turnaround of the simulator's default motor (200 us + up to 20 us of jitter).
const MAX_TURNAROUND: Duration = Duration::from_micros(220);
/// How many times the search steps down by 10% when its starting rate fails.
const MAX_STEPS_DOWN: u32 = 8;
/// Most runs spent confirming each result.
const MAX_CONFIRM_RUNS: u32 = 6;

/// Where the simulated buses run.
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub(crate) enum SimPlace {
    /// Each on its own thread, in real time (as real motors: the loop thread is measured alone).
    Thread,
    /// Inside the loop's thread, in real time (the loop also pays for the simulation).
    Inline,
    /// Inside the loop's thread, on a virtual clock (the loop costs no time).
    Virtual,
}

/// Arguments of `rmd bench rate`.
#[derive(Args, Debug, Clone)]
// `--spin-us` of `rmd_rig::args::RealtimeArgs`, with the CLI's parser: `-1` or `1e300` is a
// usage error naming the flag.
#[command(mut_arg("spin_us", |arg| arg.allow_hyphen_values(true).value_parser(timing::spin_us)))]
#[command(
    after_help = "Output: one line per trial, then per bus count the headline rate \
    (at most --miss-budget-pct of the ticks missed) and the zero-miss rate, each as a share of \
    the wire limit of its trial's frames, and the loop's added time per exchange (p50, p99). \
    JSON (--json): one object per bus count, one per line, with `buses`, `wire_limit_hz`, \
    `rate_hz` (the headline), `rate_of_wire_limit`, `zero_miss_rate_hz`, \
    `zero_miss_of_wire_limit`, `zero_miss_wire_limit_hz`, `loop_added_us` {p50, p99, ...} (of \
    the headline trial), and `trials` (one object per trial)."
)]
pub(crate) struct RateArgs {
    /// Simulated buses (1 Mbit/s each), 1..=8, exchanged in parallel by one loop; a list
    /// (`1,2,4,8`) searches each bus count in turn.
    #[arg(long, default_value = "1", value_delimiter = ',', value_parser = flags::buses)]
    buses: Vec<usize>,
    /// Motors per bus, 1..=8 (ids 1..=N; beyond 4 driven per motor, or with `--exchange
    /// multi-torque` the 0x280 frame for ids 1..=4 and 0xA1 requests beyond).
    #[arg(long, default_value = "4", value_parser = flags::motors)]
    motors: u8,
    /// The simulated motors' firmware: v1.61 (default; one 0x280 frame per bus and tick) or
    /// myactuator-v3 (one 0xA1 request per motor and tick: the per-motor exchange).
    #[arg(long, value_name = "FIRMWARE", default_value = "v1.61", value_parser = rate_firmware)]
    sim_firmware: rmd_protocol::ProtocolFamily,
    /// How every bus exchanges with its motors each tick: multi-torque (one 0x280 frame, v1.61),
    /// per-motor (one 0xA1 request per motor) or motion (MyActuator V3's motion mode: one
    /// 0x400 + id command per motor, the benchmark's PD law run in the motors). Default: per-motor
    /// for V3 motors and beyond 4 motors per bus, else multi-torque.
    #[arg(long, value_name = "KIND", value_parser = crate::args::parse::exchange)]
    exchange: Option<rmd_loop::robot::ExchangeKind>,
    /// Length of each trial (e.g. 10s, 500ms; a bare number is seconds).
    #[arg(long, visible_alias = "seconds", value_name = "DURATION", default_value = "10s", value_parser = run_length, allow_hyphen_values = true)]
    duration: Duration,
    #[command(flatten)]
    rt: RealtimeArgs,
    /// Receive each reply by sleeping until US microseconds before its arrival, then
    /// busy-waiting (a polling receive); 0 sleeps all the way (a blocking receive).
    #[arg(long, value_name = "US", value_parser = timing::spin_us, default_value = "0", allow_hyphen_values = true)]
    rx_spin_us: u64,
    /// Where the simulated buses run (real time: `thread` or `inline`).
    #[arg(
        long,
        value_enum,
        default_value = "thread",
        conflicts_with = "virtual_time"
    )]
    sim: SimPlace,
    /// The headline's budget: percent of a trial's ticks that may be missed.
    #[arg(long, value_name = "PCT", default_value = "0.1", value_parser = miss_budget)]
    miss_budget_pct: f64,
    /// Stop bisecting when the interval is narrower than this, percent of the rate.
    #[arg(long, value_name = "PCT", default_value = "0.5", value_parser = resolution)]
    resolution_pct: f64,
    /// Runs that must pass again at each rate found.
    #[arg(long, value_name = "N", default_value_t = 1)]
    confirm: u32,
    /// Run one trial per bus count at this rate instead of searching.
    #[arg(long, visible_alias = "rate-hz", value_name = "HZ", value_parser = flags::loop_rate, allow_hyphen_values = true)]
    rate: Option<f64>,
    /// Run on a virtual clock (the loop then costs no time: the search finds the wire limit).
    #[arg(long)]
    virtual_time: bool,
    /// Print one JSON object per bus count (one per line).
    #[arg(long)]
    json: bool,
}

impl RateArgs {
    /// The headline's budget, as a fraction.
    fn budget(&self) -> f64 {
        self.miss_budget_pct / 100.0
    }
}

/// `--sim-firmware` of `rmd bench rate`: the families its robot is described in.
fn rate_firmware(text: &str) -> Result<rmd_protocol::ProtocolFamily, String> {
    match crate::args::parse::sim_firmware(text)? {
        family @ (rmd_protocol::ProtocolFamily::V161
        | rmd_protocol::ProtocolFamily::MyActuatorV3) => Ok(family),
        other => Err(format!(
            "{other}: rmd bench rate runs v1.61 or myactuator-v3 motors"
        )),
    }
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

fn miss_budget(text: &str) -> Result<f64, String> {
    let pct: f64 = text
        .trim()
        .parse()
        .map_err(|_| format!("`{text}` is not a percentage"))?;
    if !(pct.is_finite() && (0.0..=10.0).contains(&pct)) {
        return Err(format!("{text}%: must be 0..=10"));
    }
    Ok(pct)
}

/// The results of one bus count.
struct ByBusCount<'a> {
    search: Search<'a>,
}

impl ByBusCount<'_> {
    fn headline(&self, args: &RateArgs) -> Option<(&Trial, u32)> {
        self.search.best(args.budget())
    }

    fn zero(&self) -> Option<(&Trial, u32)> {
        self.search.best(0.0)
    }
}

/// Runs `rmd bench rate`.
pub(crate) fn run(mut args: RateArgs) -> ExitCode {
    if args.rate.is_none() && args.confirm > MAX_CONFIRM_RUNS {
        return report::usage_error(format!(
            "--confirm {}: at most {MAX_CONFIRM_RUNS}",
            args.confirm
        ));
    }
    if args.virtual_time {
        args.sim = SimPlace::Virtual;
    }
    if !args.json {
        errln!("{}", setup_line(&args));
    }
    let progress = Progress::timer(args.duration, progress::shown(args.json));
    if let Err(e) = rmd_rig::signals::install() {
        return report::failure(e);
    }
    let machine = Machine::now();
    let started = std::time::Instant::now();
    let mut results = Vec::new();
    let mut offset = 0;
    for &buses in &args.buses {
        let mut search = Search::new(&args, buses, &progress, offset, started);
        let searched = match args.rate {
            Some(rate) => search.run(rate).map(|_| ()),
            // No rate within the budget: none has zero misses either (the stalls behind the
            // misses cost the same share at any rate), so that search is not run.
            None => search.find(args.budget()).and_then(|()| {
                if search.best(args.budget()).is_some() {
                    search.find(0.0)
                } else {
                    Ok(())
                }
            }),
        };
        offset += search.trials.len();
        match searched {
            Err(_) if rmd_rig::signals::interrupted() => {
                // What was measured before the signal is still reported.
                results.push(ByBusCount { search });
                break;
            }
            Err(e) => {
                progress.clear();
                return report::usage_error(e);
            }
            Ok(()) => results.push(ByBusCount { search }),
        }
    }
    progress.clear();
    let machine = machine.ended();
    let interrupted = rmd_rig::signals::interrupted();
    if interrupted {
        errln!("interrupted: the search stopped; what follows is from the trials run before");
    }
    let mut found_all = true;
    for r in &results {
        found_all &= r.headline(&args).is_some();
        let text = if args.json {
            format!("{}\n", summary_json(&args, r, &machine))
        } else {
            summary_text(&args, r, &machine)
        };
        if let Err(code) = super::emit(&text) {
            return code;
        }
    }
    if !args.json
        && results.len() > 1
        && let Err(code) = super::emit(&comparison(&args, &results))
    {
        return code;
    }
    if interrupted {
        ExitCode::from(rmd_rig::signals::EXIT_INTERRUPTED)
    } else if found_all || args.rate.is_some() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(report::FAILURE)
    }
}

fn setup_line(args: &RateArgs) -> String {
    let trials = if args.rate.is_some() {
        "one trial per bus count".to_owned()
    } else {
        // Measured: 9 trials per bus count in virtual time, up to 20 on a noisy machine.
        let trials = |n: u32| args.duration * n * args.buses.len() as u32;
        format!(
            "a search runs about 10 to 20 trials per bus count: {} to {} in all; --duration sets \
             a trial's length",
            minutes(trials(10)),
            minutes(trials(20))
        )
    };
    format!(
        "rmd bench rate: {} motor(s) x {} bus(es) at {} bit/s, {:.1} s per trial ({trials}), \
         spin {} us, cpu {}, SCHED_FIFO {}, simulated buses: {}{}, headline budget {}% of ticks",
        args.motors,
        args.buses
            .iter()
            .map(usize::to_string)
            .collect::<Vec<_>>()
            .join(","),
        BITRATE,
        args.duration.as_secs_f64(),
        args.rt.spin().as_micros(),
        args.rt.cpu.map_or("-".to_string(), |c| c.to_string()),
        args.rt.fifo.map_or("-".to_string(), |p| p.to_string()),
        match args.sim {
            SimPlace::Thread => "own threads, real time",
            SimPlace::Inline => "in the loop's thread, real time",
            SimPlace::Virtual => "virtual time",
        },
        if args.rx_spin_us > 0 {
            format!(", receive spin {} us", args.rx_spin_us)
        } else {
            String::new()
        },
        args.miss_budget_pct,
    )
}

/// `45 s` or `6.5 min`.
fn minutes(d: Duration) -> String {
    if d < Duration::from_secs(120) {
        format!("{:.0} s", d.as_secs_f64())
    } else {
        format!("{:.1} min", d.as_secs_f64() / 60.0)
    }
}

fn summary_json(args: &RateArgs, r: &ByBusCount<'_>, machine: &Machine) -> Value {
    let headline = r.headline(args);
    let diagnosis = headline
        .is_none()
        .then(|| diagnosis::diagnose(&r.search.trials, args, machine));
    let zero = r.zero();
    let ratio = |t: &Trial| t.wire_limit_hz().map(|w| t.rate_hz / w);
    json!({
        "buses": r.search.buses,
        "motors_per_bus": args.motors,
        "bitrate": BITRATE,
        "seconds_per_trial": args.duration.as_secs_f64(),
        "spin_us": args.rt.spin().as_micros() as u64,
        "cpu": args.rt.cpu,
        "fifo_priority": args.rt.fifo,
        "rx_spin_us": args.rx_spin_us,
        "sim": format!("{:?}", args.sim).to_lowercase(),
        "virtual_time": args.sim == SimPlace::Virtual,
        "resolution_pct": args.resolution_pct,
        "miss_budget_pct": args.miss_budget_pct,
        "wire_limit_hz": headline.and_then(|(t, _)| t.wire_limit_hz()),
        "rate_hz": headline.map(|(t, _)| t.rate_hz),
        "rate_of_wire_limit": headline.and_then(|(t, _)| ratio(t)),
        "rate_passes": headline.map(|(t, _)| passes(&r.search.trials, t.rate_hz, args.budget())),
        "rate_trials": headline.map(|(_, n)| n),
        "rate_missed_fraction": headline.and_then(|(t, _)| r.search.pooled(t.rate_hz)).map(|(m, _)| m),
        "zero_miss_rate_hz": zero.map(|(t, _)| t.rate_hz),
        "zero_miss_wire_limit_hz": zero.and_then(|(t, _)| t.wire_limit_hz()),
        "zero_miss_of_wire_limit": zero.and_then(|(t, _)| ratio(t)),
        "zero_miss_passes": zero.map(|(_, n)| n),
        "loop_added_us": headline.map(|(t, _)| t.loop_added),
        "flaky_rates_hz": r.search.flaky_rates(args.budget()),
        "load_average_start": machine.load_start,
        "load_average_end": machine.load_end,
        "cpus": machine.cpus,
        "why_no_rate": diagnosis.as_ref().map_or(Vec::new(), |d| d.reasons.clone()),
        "what_to_try": diagnosis.as_ref().map_or(Vec::new(), |d| {
            d.tries.iter().map(|t| json!({"flags": t.flags, "why": t.why})).collect()
        }),
        "trials": r.search.trials.iter().map(|t| t.to_json(args.budget())).collect::<Vec<_>>(),
    })
}

fn summary_text(args: &RateArgs, r: &ByBusCount<'_>, machine: &Machine) -> String {
    let buses = r.search.buses;
    let mut out = String::new();
    let of_limit = |t: &Trial| {
        t.wire_limit_hz().map_or("wire limit n/a".to_string(), |w| {
            format!("{:.1}% of the wire limit {w:.1} Hz", 100.0 * t.rate_hz / w)
        })
    };
    match r.headline(args) {
        Some((t, trials)) => {
            out += &format!(
                "{buses} bus(es): {:.1} Hz with at most {}% of ticks missed = {} ({:.3}% of the \
                 slots of {trials} trial(s) missed, worst trial {:.3}%)\n",
                t.rate_hz,
                args.miss_budget_pct,
                of_limit(t),
                100.0 * r.search.pooled(t.rate_hz).map_or(0.0, |(m, _)| m),
                100.0 * worst_missed(&r.search.trials, t.rate_hz),
            );
            if let Some(w) = t.wire {
                out += &format!(
                    "{buses} bus(es): wire limit of that trial's frames: 1 / longest exchange \
                     {:.1} us (frames {:.1} us + turnaround {:.1} us - intermission {:.1} us; \
                     mean exchange {:.1} us, frames {}..{} bits)\n",
                    us(w.max_cycle),
                    us(w.frames_at_max),
                    us(w.turnaround_at_max),
                    us(wire_limit::intermission(BITRATE)),
                    us(w.mean_cycle),
                    w.frame_bits.0,
                    w.frame_bits.1,
                );
            }
            out += &format!(
                "{buses} bus(es): loop added per exchange (last reply to ready for the next frame) \
                 p50 {:.2} us, p99 {:.2} us, max {:.1} us\n",
                t.loop_added.p50, t.loop_added.p99, t.loop_added.max
            );
        }
        None => {
            out += &format!(
                "{buses} bus(es): no rate within the budget ({}% of ticks missed) in {} trial(s)\n",
                args.miss_budget_pct,
                r.search.trials.len()
            );
            out += &diagnosis::diagnose(&r.search.trials, args, machine).text(buses);
        }
    }
    match (r.zero(), r.headline(args)) {
        (Some((t, passes)), _) => {
            out += &format!(
                "{buses} bus(es): {:.1} Hz with zero misses = {} (passed {passes} time(s))\n",
                t.rate_hz,
                of_limit(t)
            )
        }
        (None, Some(_)) => {
            out += &format!(
                "{buses} bus(es): no rate with zero misses: {}\n",
                diagnosis::why_no_zero(&r.search.trials)
            )
        }
        (None, None) if args.rate.is_none() => {
            out += &format!(
                "{buses} bus(es): no rate with zero misses (none within the budget, so not \
                 searched)\n"
            )
        }
        (None, None) => out += &format!("{buses} bus(es): no rate with zero misses\n"),
    }
    let flaky = r.search.flaky_rates(args.budget());
    if !flaky.is_empty() {
        let list: Vec<String> = flaky.iter().map(|r| format!("{r:.1}")).collect();
        out += &format!(
            "{buses} bus(es): within and beyond the budget at the same rate (noise): {} Hz\n",
            list.join(", ")
        );
    }
    out
}

/// How many trials at `rate_hz` were, each on its own, within `budget`.
fn passes(trials: &[Trial], rate_hz: f64, budget: f64) -> usize {
    trials
        .iter()
        .filter(|t| t.rate_hz == rate_hz && t.within(budget))
        .count()
}

/// The worst missed share among the trials at `rate_hz`.
fn worst_missed(trials: &[Trial], rate_hz: f64) -> f64 {
    trials
        .iter()
        .filter(|t| t.rate_hz == rate_hz)
        .map(Trial::missed_fraction)
        .fold(0.0, f64::max)
}

/// One row per bus count, with the headline against one bus's.
fn comparison(args: &RateArgs, results: &[ByBusCount<'_>]) -> String {
    let one_bus = results
        .iter()
        .find(|r| r.search.buses == 1)
        .and_then(|r| r.headline(args))
        .map(|(t, _)| t.rate_hz);
    let mut table = TextTable::new(&[
        ("buses", Align::Right),
        ("wire limit Hz", Align::Right),
        ("rate Hz", Align::Right),
        ("of limit", Align::Right),
        ("zero-miss Hz", Align::Right),
        ("of limit", Align::Right),
        ("added p50 us", Align::Right),
        ("added p99 us", Align::Right),
        ("vs 1 bus", Align::Right),
    ]);
    let pct = |x: Option<f64>| x.map_or("-".to_string(), |x| format!("{:.1}%", 100.0 * x));
    for r in results {
        let h = r.headline(args).map(|(t, _)| t);
        let z = r.zero().map(|(t, _)| t);
        let ratio = |t: Option<&Trial>| t.and_then(|t| t.wire_limit_hz().map(|w| t.rate_hz / w));
        table.row([
            r.search.buses.to_string(),
            h.and_then(Trial::wire_limit_hz)
                .map_or("-".to_string(), |w| format!("{w:.1}")),
            h.map_or("-".to_string(), |t| format!("{:.1}", t.rate_hz)),
            pct(ratio(h)),
            z.map_or("-".to_string(), |t| format!("{:.1}", t.rate_hz)),
            pct(ratio(z)),
            h.map_or("-".to_string(), |t| format!("{:.2}", t.loop_added.p50)),
            h.map_or("-".to_string(), |t| format!("{:.2}", t.loop_added.p99)),
            pct(h.zip(one_bus).map(|(t, one)| t.rate_hz / one)),
        ]);
    }
    let none: Vec<String> = results
        .iter()
        .filter(|r| r.headline(args).is_none())
        .map(|r| r.search.buses.to_string())
        .collect();
    let footnote = if none.is_empty() {
        String::new()
    } else {
        format!(
            "-: no rate within the budget for {} bus(es): why and what to try above\n",
            none.join(", ")
        )
    };
    format!(
        "by bus count (headline: at most {}% of ticks missed):\n{}{footnote}",
        args.miss_budget_pct,
        table.render()
    )
}
