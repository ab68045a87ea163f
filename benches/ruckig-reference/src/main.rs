//! Timing harness for rmd-traj on the inputs dumped by the rmd-rt bench
//! (`RMD_TRAJ_BENCH_DUMP=DIR cargo bench --bench trajectory`, format in benches/trajectory.rs).
//!
//! `rmd-traj-harness DIR SECONDS [fresh1|fresh6|repeated1|repeated6|all]` prints, per benchmark,
//! the mean time per call over the timed region and the median of the batch means: the same loop
//! and the same output format as `harness.cpp` (the reference), so that run.sh can alternate the
//! two binaries. `SECONDS = 0`: one untimed pass over the inputs (for callgrind).

use std::hint::black_box;
use std::process::ExitCode;
use std::time::Instant;

use rmd_traj::{Input, Trajectory};

/// Reads one input per line: per axis p0 v0 a0 pf vf af vmax vmin amax amin jmax.
fn load<const N: usize>(path: &str) -> Result<Vec<Input<N>>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("cannot read {path}: {e}"))?;
    let mut out = Vec::new();
    for (line_no, line) in text.lines().enumerate() {
        let x: Vec<f64> = line
            .split_whitespace()
            .map(str::parse)
            .collect::<Result<_, _>>()
            .map_err(|e| format!("{path}:{}: {e}", line_no + 1))?;
        if x.len() != 11 * N {
            return Err(format!(
                "{path}:{}: expected {} numbers per line, found {}",
                line_no + 1,
                11 * N,
                x.len()
            ));
        }
        let column = |k: usize| -> [f64; N] { core::array::from_fn(|i| x[11 * i + k]) };
        let mut inp = Input::<N>::with_limits(column(6), column(8), column(10));
        inp.min_velocity = Some(column(7));
        inp.min_acceleration = Some(column(9));
        inp.current_position = column(0);
        inp.current_velocity = column(1);
        inp.current_acceleration = column(2);
        inp.target_position = column(3);
        inp.target_velocity = column(4);
        inp.target_acceleration = column(5);
        out.push(inp);
    }
    if out.is_empty() {
        return Err(format!("{path}: no inputs"));
    }
    Ok(out)
}

/// Times `Trajectory::calculate` on `ins` for `secs` seconds after a 0.5 s warm-up.
///
/// Not inlined: callgrind's `--toggle-collect='rmd_traj_harness::run*'` counts exactly this.
#[inline(never)]
fn run<const N: usize>(name: &str, ins: &[Input<N>], secs: f64, repeated: bool) {
    let mut traj = Trajectory::<N>::EMPTY;
    let fails = ins.iter().filter(|i| traj.calculate(i).is_err()).count();
    let n = ins.len();
    if secs == 0.0 {
        println!("ours {name}: one pass, {fails} failed");
        return;
    }
    let batch = if repeated { 1000 } else { 4096 };
    let mut k = 0usize;
    let w0 = Instant::now();
    while w0.elapsed().as_secs_f64() < 0.5 {
        for _ in 0..batch {
            k = (k + 1) % n;
            black_box(traj.calculate(black_box(&ins[k])).is_ok());
        }
    }
    let mut per_call = vec![];
    let (mut total_ns, mut calls) = (0.0, 0usize);
    let t0 = Instant::now();
    while t0.elapsed().as_secs_f64() < secs {
        let a = Instant::now();
        for _ in 0..batch {
            k = (k + 1) % n;
            black_box(traj.calculate(black_box(&ins[k])).is_ok());
        }
        let ns = a.elapsed().as_nanos() as f64;
        per_call.push(ns / batch as f64);
        total_ns += ns;
        calls += batch;
    }
    per_call.sort_by(f64::total_cmp);
    println!(
        "ours {name:<10} mean {:.3} us  median(batch) {:.3} us  ({calls} calls, {fails} of {n} inputs failed)",
        total_ns / calls as f64 / 1000.0,
        per_call[per_call.len() / 2] / 1000.0
    );
}

/// Loads `DIR/NAME.txt` and times it.
fn bench<const N: usize>(dir: &str, name: &str, secs: f64, repeated: bool) -> Result<(), String> {
    let ins = load::<N>(&format!("{dir}/{name}.txt"))?;
    run::<N>(name, &ins, secs, repeated);
    Ok(())
}

fn main() -> ExitCode {
    const USAGE: &str =
        "usage: rmd-traj-harness DIR SECONDS [fresh1|fresh6|repeated1|repeated6|all]";
    let args: Vec<String> = std::env::args().collect();
    let dir = args.get(1).map_or("inputs", String::as_str);
    let secs: f64 = match args.get(2).map_or(Ok(3.0), |s| s.parse()) {
        Ok(s) if s >= 0.0 => s,
        _ => {
            eprintln!("{USAGE}");
            return ExitCode::from(2);
        }
    };
    let which = args.get(3).map_or("all", String::as_str);
    if !["all", "fresh1", "fresh6", "repeated1", "repeated6"].contains(&which) {
        eprintln!("{USAGE}");
        return ExitCode::from(2);
    }
    let on = |name: &str| which == "all" || which == name;
    let result = (|| {
        if on("fresh1") {
            bench::<1>(dir, "fresh1", secs, false)?;
        }
        if on("fresh6") {
            bench::<6>(dir, "fresh6", secs, false)?;
        }
        if on("repeated1") {
            bench::<1>(dir, "repeated1", secs, true)?;
        }
        if on("repeated6") {
            bench::<6>(dir, "repeated6", secs, true)?;
        }
        Ok::<(), String>(())
    })();
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("{e}");
            ExitCode::from(2)
        }
    }
}
