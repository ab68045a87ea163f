//! Trajectory calculation time (`cargo bench --bench trajectory`).
//!
//! Inputs are drawn like the reference vectors (`crates/rmd-traj-vectors/tests/data/SCHEMA.md`):
//! limits log-uniform (vMax in [0.5, 500], vMax/aMax in [0.01, 5], aMax/jMax in [0.002, 2]),
//! distance |pf − p0|/vMax in [0.001, 50], positions in ±360, 20 % of the current states outside the limits,
//! 15 % asymmetric minimum limits, non-zero target velocity/acceleration; 6 axes: 40 % all rest to
//! rest, 40 % the same limits on every axis. They are generated before the timed region; the
//! "fresh" benchmarks cycle through 4096 different inputs, the "repeated" ones use one input.
//!
//! `RMD_TRAJ_BENCH_DUMP=DIR cargo bench --bench trajectory` writes these inputs to
//! `DIR/{fresh1,fresh6,repeated1,repeated6}.txt` instead of measuring (one input per line: per
//! axis p0 v0 a0 pf vf af vmax vmin amax amin jmax, shortest round-trip decimal), so that another
//! implementation can be timed on exactly the same problems.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use rmd_rt::traj::{Input, Trajectory};

/// xorshift64* — deterministic, no dependency.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next()
    }
    fn log_uniform(&mut self, lo: f64, hi: f64) -> f64 {
        self.uniform(lo.ln(), hi.ln()).exp()
    }
    fn chance(&mut self, p: f64) -> bool {
        self.next() < p
    }
}

/// Limits of one axis: (vmax, amax, jmax, vmin, amin).
fn limits(rng: &mut Rng) -> (f64, f64, f64, f64, f64) {
    let v_max = rng.log_uniform(0.5, 500.0);
    let a_max = v_max / rng.log_uniform(0.01, 5.0);
    let j_max = a_max / rng.log_uniform(0.002, 2.0);
    let v_min = if rng.chance(0.15) {
        -v_max * rng.log_uniform(0.2, 5.0)
    } else {
        -v_max
    };
    let a_min = if rng.chance(0.15) {
        -a_max * rng.log_uniform(0.2, 5.0)
    } else {
        -a_max
    };
    (v_max, a_max, j_max, v_min, a_min)
}

/// One axis: (p0, v0, a0, pf, vf, af).
fn axis(rng: &mut Rng, lim: (f64, f64, f64, f64, f64), rest: bool) -> [f64; 6] {
    let (v_max, a_max, j_max, v_min, a_min) = lim;
    let p0 = rng.uniform(-360.0, 360.0);
    let pf = p0 + v_max * rng.log_uniform(0.001, 50.0) * if rng.chance(0.5) { 1.0 } else { -1.0 };
    if rest {
        return [p0, 0.0, 0.0, pf, 0.0, 0.0];
    }
    let mut v0 = rng.uniform(v_min, v_max);
    let mut a0 = if rng.chance(0.5) {
        rng.uniform(a_min, a_max)
    } else {
        0.0
    };
    if rng.chance(0.2) {
        let f = rng.uniform(1.01, 3.0);
        if rng.chance(0.5) {
            v0 = if rng.chance(0.5) { v_max } else { v_min } * f;
        } else {
            a0 = if rng.chance(0.5) { a_max } else { a_min } * f;
        }
    }
    // A valid target: ramping af back to zero stays within the velocity limits.
    loop {
        let vf = rng.uniform(v_min, v_max);
        let af = if rng.chance(0.5) {
            rng.uniform(a_min, a_max)
        } else {
            0.0
        };
        let swing = af * af / (2.0 * j_max);
        if !((af < 0.0 && vf + swing > v_max) || (af > 0.0 && vf - swing < v_min)) {
            return [p0, v0, a0, pf, vf, af];
        }
    }
}

fn input<const N: usize>(rng: &mut Rng) -> Input<N> {
    let same_limits = N > 1 && rng.chance(0.4);
    let all_rest = N > 1 && rng.chance(0.4);
    let first = limits(rng);
    let lims: [(f64, f64, f64, f64, f64); N] =
        core::array::from_fn(|_| if same_limits { first } else { limits(rng) });
    let axes: [[f64; 6]; N] = core::array::from_fn(|i| axis(rng, lims[i], all_rest));
    let mut inp = Input::<N>::with_limits(lims.map(|l| l.0), lims.map(|l| l.1), lims.map(|l| l.2));
    inp.min_velocity = Some(lims.map(|l| l.3));
    inp.min_acceleration = Some(lims.map(|l| l.4));
    inp.current_position = axes.map(|a| a[0]);
    inp.current_velocity = axes.map(|a| a[1]);
    inp.current_acceleration = axes.map(|a| a[2]);
    inp.target_position = axes.map(|a| a[3]);
    inp.target_velocity = axes.map(|a| a[4]);
    inp.target_acceleration = axes.map(|a| a[5]);
    inp
}

/// `count` inputs that have a solution (inputs the generator makes unsolvable, e.g. a
/// synchronized duration above the 7600 cap, are redrawn).
fn inputs<const N: usize>(count: usize, seed: u64) -> Vec<Input<N>> {
    let mut rng = Rng(seed);
    let mut out = Vec::with_capacity(count);
    let mut traj = Trajectory::<N>::EMPTY;
    while out.len() < count {
        let inp = input::<N>(&mut rng);
        if traj.calculate(&inp).is_ok() {
            out.push(inp);
        }
    }
    out
}

fn bench_fresh<const N: usize>(c: &mut Criterion, name: &str, seed: u64) {
    let inputs = inputs::<N>(4096, seed);
    let mut traj = Trajectory::<N>::EMPTY;
    let mut k = 0usize;
    c.bench_function(name, |b| {
        b.iter(|| {
            k = (k + 1) & 4095;
            black_box(traj.calculate(black_box(&inputs[k])).is_ok())
        })
    });
}

fn bench_repeated<const N: usize>(c: &mut Criterion, name: &str, seed: u64) {
    let input = inputs::<N>(1, seed)[0];
    let mut traj = Trajectory::<N>::EMPTY;
    c.bench_function(name, |b| {
        b.iter(|| black_box(traj.calculate(black_box(&input)).is_ok()))
    });
}

/// Writes `inputs` to `path` in the format described in the module documentation.
fn dump<const N: usize>(path: &std::path::Path, inputs: &[Input<N>]) {
    use std::fmt::Write as _;
    let mut s = String::new();
    for inp in inputs {
        let v_min = inp.min_velocity.unwrap_or(inp.max_velocity.map(|v| -v));
        let a_min = inp
            .min_acceleration
            .unwrap_or(inp.max_acceleration.map(|a| -a));
        for i in 0..N {
            let row = [
                inp.current_position[i],
                inp.current_velocity[i],
                inp.current_acceleration[i],
                inp.target_position[i],
                inp.target_velocity[i],
                inp.target_acceleration[i],
                inp.max_velocity[i],
                v_min[i],
                inp.max_acceleration[i],
                a_min[i],
                inp.max_jerk[i],
            ];
            for x in row {
                write!(s, "{x:?} ").unwrap();
            }
        }
        s.pop();
        s.push('\n');
    }
    std::fs::write(path, s).unwrap();
}

fn trajectory(c: &mut Criterion) {
    if let Some(dir) = std::env::var_os("RMD_TRAJ_BENCH_DUMP") {
        let dir = std::path::Path::new(&dir);
        std::fs::create_dir_all(dir).unwrap();
        dump(&dir.join("fresh1.txt"), &inputs::<1>(4096, 1));
        dump(&dir.join("fresh6.txt"), &inputs::<6>(4096, 2));
        dump(&dir.join("repeated1.txt"), &inputs::<1>(1, 3));
        dump(&dir.join("repeated6.txt"), &inputs::<6>(1, 4));
        eprintln!("inputs written to {}", dir.display());
        return;
    }
    bench_fresh::<1>(c, "calculate/1 axis/fresh random", 1);
    bench_fresh::<6>(c, "calculate/6 axes/fresh random", 2);
    bench_repeated::<1>(c, "calculate/1 axis/repeated input", 3);
    bench_repeated::<6>(c, "calculate/6 axes/repeated input", 4);
    let input = inputs::<6>(1, 5)[0];
    let mut traj = Trajectory::<6>::EMPTY;
    traj.calculate(&input).ok();
    let mut t = 0.0;
    let d = traj.duration();
    c.bench_function("sample/6 axes", |b| {
        b.iter(|| {
            t += 0.001;
            if t > d {
                t = 0.0;
            }
            black_box(traj.state_at(black_box(t)))
        })
    });
}

criterion_group!(benches, trajectory);
criterion_main!(benches);
