//! Runs the loop-alone scenario for `benches/tick-instructions.sh`: builds and starts a loop of
//! `--buses` buses of four motors, runs `--warm-up` ticks, then `--ticks` ticks inside
//! [`rmd_tick_bench::measured_ticks`], the one function the script has callgrind count.
//!
//! With `--time R` it times the measured ticks instead, `R` rounds of them, and prints the
//! fastest and the median round in nanoseconds per tick (what the machine did with the
//! instructions callgrind counted).
//!
//! With `--rate HZ` the loop runs at that rate instead of 1 kHz: at 800 Hz every bus also
//! carries the health rotation (one status request and reply per tick), whose cost this counts.
//!
//! ```text
//! tick-instructions --buses 4 --warm-up 10000 --ticks 25000
//! tick-instructions --buses 4 --warm-up 10000 --ticks 25000 --time 7
//! tick-instructions --buses 4 --warm-up 10000 --ticks 25000 --rate 800
//! ```

use std::process::ExitCode;
use std::time::Instant;

/// What the command line asks for.
struct Args {
    buses: usize,
    warm_up: u64,
    ticks: u64,
    /// Rounds to time; `None`: just run (under callgrind).
    time_rounds: Option<usize>,
    /// The loop's rate, Hz.
    rate_hz: f64,
}

const USAGE: &str =
    "usage: tick-instructions --buses N --warm-up TICKS --ticks TICKS [--time ROUNDS] [--rate HZ]";

fn parse(mut args: impl Iterator<Item = String>) -> Result<Args, String> {
    let (mut buses, mut warm_up, mut ticks, mut time_rounds) = (None, None, None, None);
    let mut rate_hz = rmd_tick_bench::RATE_HZ;
    while let Some(flag) = args.next() {
        let value = args.next().ok_or_else(|| format!("{flag} needs a value"))?;
        let number = |what: &str| {
            value
                .parse::<u64>()
                .map_err(|_| format!("{what} must be a whole number, not {value:?}"))
        };
        match flag.as_str() {
            "--buses" => buses = Some(number("--buses")?),
            "--warm-up" => warm_up = Some(number("--warm-up")?),
            "--ticks" => ticks = Some(number("--ticks")?),
            "--time" => time_rounds = Some(number("--time")?),
            "--rate" => {
                let hz = number("--rate")?;
                if !(1..=1000).contains(&hz) {
                    return Err(format!("--rate must be 1..=1000 Hz, not {hz}"));
                }
                rate_hz = hz as f64;
            }
            other => return Err(format!("unknown argument {other:?}")),
        }
    }
    let buses = buses.ok_or("--buses is required")?;
    if !(1..=rmd_loop::robot::MAX_BUSES as u64).contains(&buses) {
        return Err(format!(
            "--buses must be 1..={}, not {buses}",
            rmd_loop::robot::MAX_BUSES
        ));
    }
    Ok(Args {
        buses: buses as usize,
        warm_up: warm_up.ok_or("--warm-up is required")?,
        ticks: ticks.ok_or("--ticks is required")?,
        time_rounds: time_rounds.map(|r| r.max(1) as usize),
        rate_hz,
    })
}

fn main() -> ExitCode {
    let args = match parse(std::env::args().skip(1)) {
        Ok(args) => args,
        Err(message) => {
            eprintln!("tick-instructions: {message}\n{USAGE}");
            return ExitCode::from(2);
        }
    };
    let (mut rt, _telemetry) = rmd_tick_bench::loop_alone_at(args.buses, args.rate_hz);
    for _ in 0..args.warm_up {
        assert!(
            rt.step().is_continue(),
            "the loop-alone scenario never stops"
        );
    }
    match args.time_rounds {
        None => rmd_tick_bench::measured_ticks(&mut rt, args.ticks),
        Some(rounds) => {
            let mut per_tick: Vec<f64> = (0..rounds)
                .map(|_| {
                    let start = Instant::now();
                    rmd_tick_bench::measured_ticks(&mut rt, args.ticks);
                    start.elapsed().as_nanos() as f64 / args.ticks.max(1) as f64
                })
                .collect();
            per_tick.sort_by(f64::total_cmp);
            println!(
                "ns_per_tick_min {:.1}\nns_per_tick_median {:.1}",
                per_tick[0],
                per_tick[per_tick.len() / 2]
            );
        }
    }
    let stats = rt.stats();
    if stats.missed_ticks != 0 || stats.missing_replies() != 0 {
        eprintln!(
            "tick-instructions: the scenario went wrong: {} missed ticks, {} missing replies",
            stats.missed_ticks,
            stats.missing_replies()
        );
        return ExitCode::FAILURE;
    }
    ExitCode::SUCCESS
}
