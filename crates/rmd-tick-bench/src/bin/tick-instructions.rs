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
//! With `--exchange per-motor` it runs the per-motor scenario instead: buses of three MyActuator
//! V3 motors, one 0xA1 request per motor and tick ([`rmd_tick_bench::per_motor_loop`]), its
//! measured ticks inside [`measured_ticks_per_motor`] (this binary's own function, so that the
//! library's loop-alone code is compiled as it is without it).
//!
//! ```text
//! tick-instructions --buses 4 --warm-up 10000 --ticks 25000
//! tick-instructions --buses 4 --warm-up 10000 --ticks 25000 --time 7
//! tick-instructions --buses 4 --warm-up 10000 --ticks 25000 --rate 800
//! tick-instructions --buses 4 --warm-up 10000 --ticks 25000 --exchange per-motor
//! ```

use std::process::ExitCode;
use std::time::Instant;

use rmd_loop::Running;
use rmd_tick_bench::PerMotorLoop;

/// What the command line asks for.
struct Args {
    buses: usize,
    warm_up: u64,
    ticks: u64,
    /// Rounds to time; `None`: just run (under callgrind).
    time_rounds: Option<usize>,
    /// The loop's rate, Hz.
    rate_hz: f64,
    /// The per-motor scenario rather than the loop-alone (multi-torque) one.
    per_motor: bool,
}

const USAGE: &str = "usage: tick-instructions --buses N --warm-up TICKS --ticks TICKS \
                     [--time ROUNDS] [--rate HZ | --exchange multi-torque|per-motor]";

fn parse(mut args: impl Iterator<Item = String>) -> Result<Args, String> {
    let (mut buses, mut warm_up, mut ticks, mut time_rounds) = (None, None, None, None);
    let mut rate_hz = rmd_tick_bench::RATE_HZ;
    let mut per_motor = false;
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
            "--exchange" => {
                per_motor = match value.as_str() {
                    "multi-torque" => false,
                    "per-motor" => true,
                    other => {
                        return Err(format!(
                            "--exchange must be multi-torque or per-motor, not {other:?}"
                        ));
                    }
                }
            }
            other => return Err(format!("unknown argument {other:?}")),
        }
    }
    let buses = buses.ok_or("--buses is required")?;
    if per_motor && rate_hz != rmd_tick_bench::RATE_HZ {
        return Err("--rate is for the multi-torque scenario (per-motor runs at 1 kHz)".into());
    }
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
        per_motor,
    })
}

/// [`rmd_tick_bench::measured_ticks`] of the per-motor scenario. Never inlined: callgrind
/// counts this function and what it calls (`--toggle-collect`).
#[inline(never)]
pub fn measured_ticks_per_motor(rt: &mut PerMotorLoop, ticks: u64) {
    for _ in 0..ticks {
        assert!(
            rt.step().is_continue(),
            "the per-motor scenario never stops"
        );
    }
}

/// Runs a scenario's loop as asked: `warm_up` ticks, then `ticks` ticks in `measured` (timed
/// `time_rounds` times when asked); its missed ticks and missing replies at the end.
fn run<B: rmd_bus::CanBus>(
    rt: &mut Running<B, rmd_bus::VirtualClock, rmd_tick_bench::NoOp>,
    args: &Args,
    measured: fn(&mut Running<B, rmd_bus::VirtualClock, rmd_tick_bench::NoOp>, u64),
) -> (u64, u64) {
    for _ in 0..args.warm_up {
        assert!(rt.step().is_continue(), "the scenario never stops");
    }
    match args.time_rounds {
        None => measured(rt, args.ticks),
        Some(rounds) => {
            let mut per_tick: Vec<f64> = (0..rounds)
                .map(|_| {
                    let start = Instant::now();
                    measured(rt, args.ticks);
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
    (stats.missed_ticks, stats.missing_replies())
}

fn main() -> ExitCode {
    let args = match parse(std::env::args().skip(1)) {
        Ok(args) => args,
        Err(message) => {
            eprintln!("tick-instructions: {message}\n{USAGE}");
            return ExitCode::from(2);
        }
    };
    let (missed_ticks, missing_replies) = if args.per_motor {
        let (mut rt, _telemetry) = rmd_tick_bench::per_motor_loop(args.buses);
        run(&mut rt, &args, measured_ticks_per_motor)
    } else {
        let (mut rt, _telemetry) = rmd_tick_bench::loop_alone_at(args.buses, args.rate_hz);
        run(&mut rt, &args, rmd_tick_bench::measured_ticks)
    };
    if missed_ticks != 0 || missing_replies != 0 {
        eprintln!(
            "tick-instructions: the scenario went wrong: {missed_ticks} missed ticks, \
             {missing_replies} missing replies"
        );
        return ExitCode::FAILURE;
    }
    ExitCode::SUCCESS
}
