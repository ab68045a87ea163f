//! Property tests: arbitrary inputs never panic; random valid problems give trajectories that
//! respect the limits, reach the target, and are never slower than a simple valid baseline
//! (stop, rest-to-rest move, accelerate to the target state) built independently here.

use proptest::prelude::*;
use rmd_traj::{
    AxisProfile, ControlInterface, DurationDiscretization, Input, Synchronization, Trajectory,
    calculate,
};

// ---------------------------------------------------------------------------------------------
// Independent reference constructions (no code shared with the crate).

/// Time and displacement of the fastest jerk-limited change of velocity by `dv` (≥ 0) starting
/// and ending at zero acceleration, with acceleration limit `a` and jerk `j`.
fn s_curve(dv: f64, a: f64, j: f64) -> (f64, f64) {
    if dv <= 0.0 {
        return (0.0, 0.0);
    }
    let t = if dv <= a * a / j {
        2.0 * (dv / j).sqrt()
    } else {
        dv / a + a / j
    };
    // Symmetric S-curve: average velocity is half the change.
    (t, dv * t / 2.0)
}

/// Duration of a valid (not necessarily optimal) trajectory for one axis inside the limits:
/// ramp the acceleration to zero, S-curve to rest, rest-to-rest move (with cruise), S-curve from
/// rest to the velocity that ramping to `af` ends at `vf`, ramp to `af`.
fn baseline(axis: [f64; 9]) -> f64 {
    let [p0, v0, a0, pf, vf, af, vmax, amax, j] = axis;
    // 1. Acceleration to zero.
    let t1 = a0.abs() / j;
    let v1 = v0 + a0 * a0.abs() / (2.0 * j);
    let d1 = v0 * t1 + a0 * t1 * t1 / 2.0 - a0.signum() * j * t1 * t1 * t1 / 6.0;
    // 2. Velocity to zero.
    let (t2, d2) = s_curve(v1.abs(), amax, j);
    let d2 = d2 * v1.signum();
    // 5. Last ramp (from 0 to af), 4. S-curve from rest to v4.
    let t5 = af.abs() / j;
    let v4 = vf - af * af.abs() / (2.0 * j);
    let d5 = v4 * t5 + af.signum() * j * t5 * t5 * t5 / 6.0;
    let (t4, d4) = s_curve(v4.abs(), amax, j);
    let d4 = d4 * v4.signum();
    // 3. Rest-to-rest move: accelerate to vp ≤ vmax, cruise, decelerate.
    let dist = (pf - p0 - d1 - d2 - d4 - d5).abs();
    let (tv, dv) = s_curve(vmax, amax, j);
    let t3 = if dist >= 2.0 * dv {
        2.0 * tv + (dist - 2.0 * dv) / vmax
    } else {
        // Peak velocity by bisection on the S-curve distance (monotone in the peak).
        let (mut lo, mut hi) = (0.0, vmax);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if 2.0 * s_curve(mid, amax, j).1 < dist {
                lo = mid
            } else {
                hi = mid
            }
        }
        2.0 * s_curve(hi, amax, j).0
    };
    t1 + t2 + t3 + t4 + t5
}

/// Independent validity check of one axis: integrate the published phases (plain constant-jerk
/// integration); after the brake the velocity and acceleration stay within the limits; the end
/// state is the target.
fn check_axis(
    prof: &AxisProfile,
    start: (f64, f64, f64),
    target: (f64, f64, f64),
    limits: (f64, f64, f64, f64, f64),
    position_interface: bool,
) -> Result<(), String> {
    let (vmax, vmin, amax, amin, jmax) = limits;
    let (mut p, mut v, mut a) = start;
    let n_brake = prof.brake().count();
    let scale_p = 1f64
        .max(start.0.abs())
        .max(target.0.abs())
        .max(vmax.abs() * prof.duration());
    let scale_v = 1f64.max(vmax.abs()).max(vmin.abs()).max(start.1.abs());
    let scale_a = 1f64.max(amax.abs()).max(amin.abs()).max(start.2.abs());
    let (tv, ta) = (1e-9 * scale_v, 1e-9 * scale_a);
    let mut inside = false;
    for (k, ph) in prof.brake().chain(prof.phases()).enumerate() {
        if ph.jerk.abs() > jmax * (1.0 + 1e-12) {
            return Err(format!("phase {k}: jerk {} > {jmax}", ph.jerk));
        }
        let (t, j) = (ph.duration, ph.jerk);
        let v1 = v + t * (a + t * j / 2.0);
        let a1 = a + t * j;
        if k >= n_brake {
            if a1 > amax + ta || a1 < amin - ta {
                return Err(format!("phase {k}: acceleration {a1}"));
            }
            if position_interface {
                let mut vs = vec![v, v1];
                if j != 0.0 && (a < 0.0) != (a1 < 0.0) {
                    vs.insert(1, v - a * a / (2.0 * j));
                }
                for x in vs {
                    let ok = x <= vmax + tv && x >= vmin - tv;
                    inside |= ok;
                    if inside && !ok {
                        return Err(format!("phase {k}: velocity {x} outside [{vmin}, {vmax}]"));
                    }
                }
            }
        }
        p += t * (v + t * (a / 2.0 + t * j / 6.0));
        v = v1;
        a = a1;
    }
    if position_interface && (p - target.0).abs() > 1e-8f64.max(1e-9 * scale_p) {
        return Err(format!("final position {p} vs {}", target.0));
    }
    if (v - target.1).abs() > 1e-8f64.max(1e-9 * scale_v) {
        return Err(format!("final velocity {v} vs {}", target.1));
    }
    if (a - target.2).abs() > 1e-10f64.max(1e-9 * scale_a) {
        return Err(format!("final acceleration {a} vs {}", target.2));
    }
    Ok(())
}

fn check_all<const N: usize>(input: &Input<N>, traj: &Trajectory<N>) -> Result<(), String> {
    for i in 0..N {
        let limits = (
            input.max_velocity[i],
            input.min_velocity.map_or(-input.max_velocity[i], |m| m[i]),
            input.max_acceleration[i],
            input
                .min_acceleration
                .map_or(-input.max_acceleration[i], |m| m[i]),
            input.max_jerk[i],
        );
        let start = (
            input.current_position[i],
            input.current_velocity[i],
            input.current_acceleration[i],
        );
        let target = (
            input.target_position[i],
            input.target_velocity[i],
            input.target_acceleration[i],
        );
        let prof = &traj.profiles()[i];
        check_axis(
            prof,
            start,
            target,
            limits,
            input.control_interface == ControlInterface::Position,
        )
        .map_err(|e| format!("axis {i}: {e}"))?;
        if prof.duration() > traj.duration() * (1.0 + 1e-12) + 1e-12 {
            return Err(format!(
                "axis {i} lasts {} > {}",
                prof.duration(),
                traj.duration()
            ));
        }
        // The sampler is continuous and agrees with the end state.
        let end = traj.state_at(traj.duration())[i];
        if input.control_interface == ControlInterface::Position
            && prof.duration() == traj.duration()
            && end.position != input.target_position[i]
        {
            return Err(format!("axis {i}: sampled end {} != target", end.position));
        }
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// Strategies.

/// Log-uniform positive value.
fn logu(lo: f64, hi: f64) -> impl Strategy<Value = f64> {
    (lo.ln()..hi.ln()).prop_map(f64::exp)
}

/// One axis inside its limits (no brake needed) with a valid target: (p0, v0, a0, pf, vf, af,
/// vmax, amax, jmax).
fn valid_axis() -> impl Strategy<Value = [f64; 9]> {
    (logu(0.5, 500.0), logu(0.01, 5.0), logu(0.002, 2.0)).prop_flat_map(|(vmax, acc_t, jerk_t)| {
        let amax = vmax / acc_t;
        let jmax = amax / jerk_t;
        (
            -360.0..360.0f64,
            -1.0..1.0f64,
            -1.0..1.0f64,
            prop_oneof![Just(0.0), -1.0..1.0f64],
            prop_oneof![Just(0.0), -1.0..1.0f64],
            prop_oneof![Just(0.0), -1.0..1.0f64],
            logu(0.001, 50.0),
            any::<bool>(),
        )
            .prop_map(move |(p0, v0s, a0s, vfs, afs, dir, dist_t, rest)| {
                // Current state: the velocity reached when the acceleration is ramped to zero
                // (v0 + a0·|a0|/2j) is inside the limits, so no brake is needed.
                let mut a0 = a0s * amax;
                let mut swing = a0 * a0.abs() / (2.0 * jmax);
                if swing.abs() > 0.5 * vmax {
                    a0 = 0.0;
                    swing = 0.0;
                }
                let v0 = v0s * 0.49 * vmax - swing;
                // Target: ramping its acceleration back to zero stays inside the limits too.
                let mut af = afs * amax;
                let mut swing_f = af * af.abs() / (2.0 * jmax);
                if swing_f.abs() > 0.5 * vmax {
                    af = 0.0;
                    swing_f = 0.0;
                }
                let vf = vfs * 0.49 * vmax + swing_f;
                let (v0, a0, vf, af) = if rest {
                    (0.0, 0.0, 0.0, 0.0)
                } else {
                    (v0, a0, vf, af)
                };
                let pf = p0 + dir.signum() * dist_t * vmax;
                [p0, v0, a0, pf, vf, af, vmax, amax, jmax]
            })
    })
}

fn input_from<const N: usize>(axes: &[[f64; 9]]) -> Input<N> {
    let g = |k: usize| -> [f64; N] { core::array::from_fn(|i| axes[i][k]) };
    let mut input = Input::<N>::with_limits(g(6), g(7), g(8));
    input.current_position = g(0);
    input.current_velocity = g(1);
    input.current_acceleration = g(2);
    input.target_position = g(3);
    input.target_velocity = g(4);
    input.target_acceleration = g(5);
    input
}

/// Any f64, with a strong bias to special values.
fn any_f64() -> impl Strategy<Value = f64> {
    prop_oneof![
        Just(f64::NAN),
        Just(f64::INFINITY),
        Just(f64::NEG_INFINITY),
        Just(0.0),
        Just(-0.0),
        Just(f64::MIN_POSITIVE),
        Just(f64::MAX),
        Just(f64::MIN),
        Just(1e-300),
        Just(1e300),
        -1e3..1e3f64,
        any::<f64>(),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 3000, ..ProptestConfig::default() })]

    /// Whatever the numbers and options, `calculate` returns without panicking, and a trajectory
    /// it returns has a finite duration and finite samples.
    #[test]
    fn arbitrary_input_never_panics(
        vals in proptest::collection::vec(any_f64(), 33),
        opts in (0u8..4, 0u8..2, 0u8..3, any_f64(), any_f64()),
    ) {
        let mut input = Input::<3>::with_limits(
            [vals[0], vals[1], vals[2]], [vals[3], vals[4], vals[5]], [vals[6], vals[7], vals[8]],
        );
        input.current_position = [vals[9], vals[10], vals[11]];
        input.current_velocity = [vals[12], vals[13], vals[14]];
        input.current_acceleration = [vals[15], vals[16], vals[17]];
        input.target_position = [vals[18], vals[19], vals[20]];
        input.target_velocity = [vals[21], vals[22], vals[23]];
        input.target_acceleration = [vals[24], vals[25], vals[26]];
        if vals[27] > 0.0 { input.min_velocity = Some([vals[28], vals[29], vals[30]]); }
        if vals[31] > 0.0 { input.min_acceleration = Some([vals[28], vals[30], vals[32]]); }
        input.synchronization = [Synchronization::Time, Synchronization::TimeIfNecessary,
            Synchronization::Phase, Synchronization::None][opts.0 as usize];
        if opts.1 == 1 { input.control_interface = ControlInterface::Velocity; }
        match opts.2 {
            1 => input.duration_discretization = DurationDiscretization::Discrete { period: opts.3 },
            2 => input.minimum_duration = Some(opts.4),
            _ => {}
        }
        if let Ok(traj) = calculate(&input) {
            prop_assert!(traj.duration().is_finite() && traj.duration() >= 0.0);
            for f in [0.0, 0.3, 0.7, 1.0, 1.5] {
                for s in traj.state_at(traj.duration() * f) {
                    prop_assert!(s.position.is_finite() && s.velocity.is_finite()
                        && s.acceleration.is_finite() && s.jerk.is_finite(), "{s:?}");
                }
            }
        }
    }

    /// Arbitrary (finite, moderate) states outside the limits: still a valid trajectory that
    /// stays within the limits once the brake is over (or a typed error for invalid targets).
    #[test]
    fn states_outside_limits_are_braked(axis in valid_axis(), f in (-3.0..3.0f64, -3.0..3.0f64)) {
        let mut axis = axis;
        axis[1] = f.0 * axis[6];
        axis[2] = f.1 * axis[7];
        let input = input_from::<1>(&[axis]);
        let traj = calculate(&input).map_err(|e| TestCaseError::fail(format!("{e}")))?;
        check_all(&input, &traj).map_err(TestCaseError::fail)?;
    }

    /// One axis from a state inside the limits: valid, reaches the target, never slower than the
    /// baseline.
    #[test]
    fn one_axis_valid_and_not_slower_than_baseline(axis in valid_axis()) {
        let input = input_from::<1>(&[axis]);
        let traj = calculate(&input).map_err(|e| TestCaseError::fail(format!("{e}")))?;
        check_all(&input, &traj).map_err(TestCaseError::fail)?;
        let base = baseline(axis);
        prop_assert!(traj.duration() <= base * (1.0 + 1e-9) + 1e-12,
            "duration {} > baseline {}", traj.duration(), base);
    }

    /// Three synchronized axes: valid, all arrive together, not slower than the slowest
    /// baseline (each axis can realize any duration above its baseline by waiting at rest).
    #[test]
    fn three_axes_synchronized(axes in proptest::collection::vec(valid_axis(), 3)) {
        let input = input_from::<3>(&axes);
        let traj = calculate(&input).map_err(|e| TestCaseError::fail(format!("{e}")))?;
        check_all(&input, &traj).map_err(TestCaseError::fail)?;
        for p in traj.profiles() {
            prop_assert!((p.duration() - traj.duration()).abs() <= 1e-9 * traj.duration().max(1.0));
        }
        let slowest = axes.iter().map(|a| baseline(*a))
            .fold(0.0, f64::max);
        prop_assert!(traj.duration() <= slowest * (1.0 + 1e-9) + 1e-12,
            "duration {} > baseline {}", traj.duration(), slowest);
    }
}
