//! Step 1, position interface: every time-optimal (extremal) profile of one axis.
//!
//! Solved in the "up" frame (first jerk pulse positive, cruise at `v_max`); the "down" profiles
//! are the up profiles of the mirrored problem. A profile is a sequence of ramps at ±j with
//! optional plateaus at the acceleration limits (phases 1 and 5) and an optional cruise at the
//! velocity limit (phase 3). Each combination of reached limits gives a small equation system:
//!
//! - cruise types: two independent velocity changes (to and from `v_max`), closed form;
//! - `Acc0Acc1`: both plateaus, no cruise: a quadratic in the first plateau's length;
//! - `Acc0`, `Acc1`, `None`: quartics in one phase duration.
//!
//! Polynomial roots are isolated in the physically possible range, polished by Newton steps on
//! the directly integrated position error, and every candidate is validated by
//! [`check`](crate::cand::check).

use crate::cand::{CandList, Failure, Problem, limits_of, uddu};
use crate::math::{Integrator, abs, max, sqrt};
use crate::profile::{Direction, ProfileKind};
use crate::roots::{eval, quartic_roots_in, roots_in};

/// Which extremal profiles a step-1 search must find.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Search {
    /// All of them (their durations bound the blocked intervals).
    All,
    /// The first valid one (target at rest: there is only one).
    First,
    /// The fastest one (no synchronization: blocked intervals are not needed), so candidates
    /// slower than the best found so far are skipped before validation.
    Fastest,
}

/// Collects the valid extremal profiles.
pub(crate) fn candidates(pb: &Problem, search: Search, out: &mut CandList<'_>) {
    let up_first = pb.d >= 0.0;
    let dirs = if up_first {
        [Direction::Up, Direction::Down]
    } else {
        [Direction::Down, Direction::Up]
    };
    let frames = dirs.map(|dir| match dir {
        Direction::Up => *pb,
        Direction::Down => pb.mirrored(),
    });
    if search == Search::First {
        for (dir, frame) in dirs.into_iter().zip(frames.iter()) {
            let mut sink = CandidateSink {
                out: &mut *out,
                dir,
                search,
            };
            if sink.run(frame, cruise)
                || sink.run(frame, quartic_types)
                || sink.run(frame, acc0_acc1)
            {
                return;
            }
        }
    } else {
        // Closed forms first: with `Fastest` they bound the quartics' search.
        for (dir, frame) in dirs.into_iter().zip(frames.iter()) {
            let mut sink = CandidateSink {
                out: &mut *out,
                dir,
                search,
            };
            sink.run(frame, cruise);
            sink.run(frame, acc0_acc1);
        }
        for (dir, frame) in dirs.into_iter().zip(frames.iter()) {
            let mut sink = CandidateSink {
                out: &mut *out,
                dir,
                search,
            };
            sink.run(frame, quartic_types);
        }
    }
    if out.n == 0 {
        // Degenerate shapes where the general equations are 0/0.
        for (dir, frame) in dirs.into_iter().zip(frames.iter()) {
            let mut sink = CandidateSink {
                out: &mut *out,
                dir,
                search: Search::First,
            };
            if sink.run(frame, degenerate) {
                return;
            }
        }
    }
}

/// Receives candidates in a frame and stores them in the caller's frame.
pub(crate) struct CandidateSink<'a, 'b> {
    pub(crate) out: &'a mut CandList<'b>,
    pub(crate) dir: Direction,
    pub(crate) search: Search,
}

impl CandidateSink<'_, '_> {
    /// The duration a new candidate must beat to matter (`Fastest`), else +∞.
    pub(crate) fn bound(&self) -> f64 {
        if self.search == Search::Fastest {
            self.out.min_total()
        } else {
            f64::INFINITY
        }
    }

    /// Validates phase times and adds the candidate if valid (skipping it unvalidated when it
    /// cannot beat the bound); returns true when the search should stop.
    pub(crate) fn offer(
        &mut self,
        pb: &Problem,
        t: [f64; 7],
        jerks: [f64; 7],
        kind: ProfileKind,
    ) -> bool {
        if !(t.iter().sum::<f64>() < self.bound() * (1.0 + 1e-9)) {
            return false;
        }
        let mirror = self.dir == Direction::Down;
        self.out.push_checked(pb, &t, &jerks, kind, mirror).is_ok() && self.search == Search::First
    }

    /// Like [`offer`](Self::offer) for the root `x` of a type's equation: checked as computed,
    /// and if that fails (e.g. a near-double root) again after Newton steps on the position error.
    pub(crate) fn offer_root(
        &mut self,
        pb: &Problem,
        x: f64,
        phases: &dyn Fn(f64) -> [f64; 7],
        jerks: &[f64; 7],
        slope: impl Fn(f64) -> f64,
        kind: ProfileKind,
    ) -> bool {
        let t = phases(x);
        if !(t.iter().sum::<f64>() < self.bound() * (1.0 + 1e-9)) {
            return false;
        }
        let mirror = self.dir == Direction::Down;
        // Polishing can only help when just the final state is off.
        let found = match self.out.push_checked(pb, &t, jerks, kind, mirror) {
            Ok(()) => true,
            Err(Failure::FinalState) => {
                let polished = phases(polish(x, pb, phases, jerks, slope));
                self.out
                    .push_checked(pb, &polished, jerks, kind, mirror)
                    .is_ok()
            }
            Err(Failure::Shape) => false,
        };
        found && self.search == Search::First
    }

    /// Runs a type solver; true when the search should stop.
    pub(crate) fn run(
        &mut self,
        pb: &Problem,
        f: fn(&Problem, &mut CandidateSink<'_, '_>) -> bool,
    ) -> bool {
        f(pb, self)
    }
}

fn kind(acc0: bool, vel: bool, acc1: bool) -> ProfileKind {
    ProfileKind::TimeOptimal {
        direction: Direction::Up,
        limits: limits_of(acc0, vel, acc1),
    }
}

/// Phases of the fastest change from (v0, a0) to (v_top, 0) rising: +j, plateau, −j.
/// Returns `(t0, t1, t2)` or `None` if impossible.
pub(crate) fn rise_to(v0: f64, a0: f64, v_top: f64, a_max: f64, j: f64) -> Option<(f64, f64, f64)> {
    let x = j * (v_top - v0) + a0 * a0 / 2.0;
    // Zero up to rounding (v_top is the velocity reached by ramping a0 to zero) is zero.
    let x = if x < 0.0 && x >= -8.0 * f64::EPSILON * (a0 * a0 + abs(j * (v_top - v0))) {
        0.0
    } else {
        x
    };
    if !(x >= 0.0) {
        return None;
    }
    let (mut t0, t1) = if x <= a_max * a_max {
        ((sqrt(x) - a0) / j, 0.0)
    } else {
        ((a_max - a0) / j, (x - a_max * a_max) / (j * a_max))
    };
    // A first ramp that is zero up to rounding is zero (the peak is a0 itself). A negative one
    // beyond that is impossible: `v_top` is exceeded by ramping a0 to zero. (Not left to the
    // validation, which would zero it with a tolerance relative to the whole duration after
    // `t2` was computed from it: the cruise would then start with a residual acceleration.)
    if t0 < 0.0 {
        if t0 >= -1e-12 * (abs(a0) / j + abs(t1)) {
            t0 = 0.0;
        } else {
            return None;
        }
    }
    // The ramp down ends at exactly the acceleration reached, so a following cruise has a = 0
    // up to the rounding of one product (not of the formula for the peak).
    let t2 = (a0 + j * t0) / j;
    Some((t0, t1, t2))
}

/// Phases of the fastest change from (v_top, 0) falling to (vf, af): −j, plateau at `a_min`, +j.
pub(crate) fn fall_from(
    v_top: f64,
    vf: f64,
    af: f64,
    a_min: f64,
    j: f64,
) -> Option<(f64, f64, f64)> {
    let y = j * (v_top - vf) + af * af / 2.0;
    let y = if y < 0.0 && y >= -8.0 * f64::EPSILON * (af * af + abs(j * (v_top - vf))) {
        0.0
    } else {
        y
    };
    if !(y >= 0.0) {
        return None;
    }
    if y <= a_min * a_min {
        let w = sqrt(y);
        Some((w / j, 0.0, (af + w) / j))
    } else {
        Some((
            -a_min / j,
            (y - a_min * a_min) / (-a_min * j),
            (af - a_min) / j,
        ))
    }
}

/// Cruise at `v_max` between two velocity changes.
fn cruise(pb: &Problem, sink: &mut CandidateSink<'_, '_>) -> bool {
    if !(pb.v_max > 0.0) {
        return false;
    }
    let j = pb.j;
    let Some((t0, t1, t2)) = rise_to(pb.v0, pb.a0, pb.v_max, pb.a_max, j) else {
        return false;
    };
    let Some((t4, t5, t6)) = fall_from(pb.v_max, pb.vf, pb.af, pb.a_min, j) else {
        return false;
    };
    let jj = uddu(j);
    let mut t = [t0, t1, t2, 0.0, t4, t5, t6];
    let mut left = Integrator::new(0.0, pb.v0, pb.a0, pb.a_snap);
    for i in 0..3 {
        left.step(t[i], jj[i]);
    }
    let mut right = Integrator::new(0.0, pb.v_max, 0.0, pb.a_snap);
    for i in 4..7 {
        right.step(t[i], jj[i]);
    }
    let (p, q) = (left.p, right.p);
    t[3] = (pb.d - p - q) / pb.v_max;
    // Most cruises are too long for the distance: a clearly negative cruise fails the validation
    // (which allows −1e-12 × the durations).
    let ramps = ((t0 + t1) + t2) + ((t4 + t5) + t6);
    if t[3] < -1e-9 * (ramps + pb.a_scale() / j) {
        return false;
    }
    sink.offer(pb, t, jj, kind(t1 > 0.0, true, t5 > 0.0))
}

/// Both acceleration plateaus, no cruise: quadratic in the first plateau's duration.
fn acc0_acc1(pb: &Problem, sink: &mut CandidateSink<'_, '_>) -> bool {
    let Problem {
        d,
        v0,
        a0,
        vf,
        af,
        a_max,
        a_min,
        j,
        ..
    } = *pb;
    if !(a_max > 0.0 && a_min < 0.0) {
        return false;
    }
    // Its four ramps alone take this long (the plateaus are non-negative).
    let ramps = (a_max - a0) / j + a_max / j - a_min / j + (af - a_min) / j;
    let bound = sink.bound() * (1.0 + 1e-9);
    if !(ramps < bound) {
        return false;
    }
    // With the velocity condition t5 = (r_v − a_max·t1)/a_min, and t5 ≥ 0 needs
    // t1 ≥ r_v/a_max. The peak velocity (end of phase 2, where a = 0),
    // v0 + (2·a_max² − a0²)/(2j) + a_max·t1 ≤ v_max, and the duration bound (the duration
    // ramps + r_v/a_min + t1·(1 − a_max/a_min) grows with t1) bound t1 from above. If no t1
    // fits, even with a margin far above the validation's tolerances, no candidate can pass:
    // skip the coefficients.
    let r_v = vf - v0 - (2.0 * a_max * a_max - 2.0 * a_min * a_min + af * af - a0 * a0) / (2.0 * j);
    let t1_lo = max(r_v / a_max, 0.0);
    let t1_hi_v = (pb.v_max - v0 - (2.0 * a_max * a_max - a0 * a0) / (2.0 * j)) / a_max;
    let t1_hi_b = (bound - ramps - r_v / a_min) / (1.0 - a_max / a_min);
    let margin =
        1e-7 * (abs(t1_lo) + abs(t1_hi_v) + ramps + (pb.a_scale() / j) + pb.v_scale() / a_max);
    let t1_hi = crate::math::min(t1_hi_v, t1_hi_b) + margin;
    if t1_lo > t1_hi {
        return false;
    }
    // The position error is a quadratic A·t1² + B·t1 + C: the rise (phases 0–2) to the peak
    // velocity vp = vp0 + a_max·t1 (a = 0 at the end of phase 2), then the fall (phases 4–6)
    // from it, whose plateau t5 = t50 + s·t1 shrinks as t1 grows (s = −a_max/a_min) and whose
    // last ramp starts at the fixed velocity v6.
    let (tau0, tau2, tau4, tau6) = ((a_max - a0) / j, a_max / j, -a_min / j, (af - a_min) / j);
    let v1 = v0 + (a_max * a_max - a0 * a0) / (2.0 * j);
    let vp0 = v1 + a_max * tau2 / 2.0;
    let v50 = vp0 + a_min * tau4 / 2.0;
    let t50 = r_v / a_min;
    let s = -a_max / a_min;
    let v6 = v50 + a_min * t50;
    let qa = 0.5 * a_max * (1.0 + s);
    let qb = v1 + a_max * (tau2 + tau4) + s * v50;
    let qc = tau0 * (v0 + tau0 * (a0 / 2.0 + tau0 * j / 6.0))
        + tau2 * (v1 + a_max * tau2 / 3.0)
        + tau4 * (vp0 - j * tau4 * tau4 / 6.0)
        + t50 * (v50 + a_min * t50 / 2.0)
        + tau6 * (v6 + tau6 * (a_min / 2.0 + j * tau6 / 6.0))
        - d;
    let jj = uddu(j);
    let phases = |t1: f64| -> [f64; 7] {
        [
            (a_max - a0) / j,
            t1,
            a_max / j,
            0.0,
            -a_min / j,
            (r_v - a_max * t1) / a_min,
            (af - a_min) / j,
        ]
    };
    let roots = roots_in(&[qa, qb, qc], -1e-9 * (abs(r_v / a_max) + a_max / j), 1e12);
    for &t1 in roots.as_slice() {
        // Outside the range above no candidate passes.
        if !(t1 >= t1_lo - margin && t1 <= t1_hi) {
            continue;
        }
        if sink.offer_root(
            pb,
            t1,
            &phases,
            &jj,
            |x| 2.0 * qa * x + qb,
            kind(true, false, true),
        ) {
            return true;
        }
    }
    false
}

/// Newton steps on the directly integrated position error of `phases(x)`; `slope` is the
/// derivative of that error with respect to `x` (from the polynomial).
pub(crate) fn polish(
    mut x: f64,
    pb: &Problem,
    phases: &dyn Fn(f64) -> [f64; 7],
    jerks: &[f64; 7],
    slope: impl Fn(f64) -> f64,
) -> f64 {
    let err = |x: f64| -> f64 {
        let t = phases(x);
        let mut it = Integrator::new(0.0, pb.v0, pb.a0, pb.a_snap);
        for i in 0..7 {
            it.step(t[i], jerks[i]);
        }
        it.p - pb.d
    };
    let mut r = err(x);
    for _ in 0..3 {
        if r == 0.0 || !r.is_finite() {
            break;
        }
        let s = slope(x);
        if !(s.is_finite() && s != 0.0) {
            break;
        }
        let xn = x - r / s;
        let rn = err(xn);
        if abs(rn) < abs(r) {
            x = xn;
            r = rn;
        } else {
            break;
        }
    }
    x
}

/// The parts of `[lo, hi]` where x(t)² ≥ k for the acceleration x(t) = x0 + dir·j·t (one
/// interval if k ≤ 0, else up to two: x ≥ √k and x ≤ −√k).
fn split_by_square(
    lo: f64,
    hi: f64,
    slack: f64,
    k: f64,
    x0: f64,
    dir: f64,
    j: f64,
) -> [Option<(f64, f64)>; 2] {
    let clip = |a: f64, b: f64| -> Option<(f64, f64)> {
        let (a, b) = (max(a, lo), crate::math::min(b, hi));
        if a <= b + slack { Some((a, b)) } else { None }
    };
    if !(k > 0.0) {
        return [clip(lo, hi), None];
    }
    let r = sqrt(k);
    // x0 + dir·j·t ≥ r and ≤ −r, as t-intervals.
    let t_hi_root = (r - x0) / (dir * j);
    let t_lo_root = (-r - x0) / (dir * j);
    let widen = 1e-9 * (abs(t_hi_root) + abs(t_lo_root)) + slack;
    if dir > 0.0 {
        [clip(t_hi_root - widen, hi), clip(lo, t_lo_root + widen)]
    } else {
        [clip(lo, t_hi_root + widen), clip(t_lo_root - widen, hi)]
    }
}

/// `None`, `Acc0` and `Acc1` types: quartics.
fn quartic_types(pb: &Problem, sink: &mut CandidateSink<'_, '_>) -> bool {
    none_type(pb, sink) || acc0_type(pb, sink) || acc1_type(pb, sink)
}

/// No plateau, no cruise: +j (to u), −j (to w), +j (to af). Variable: the middle ramp's
/// acceleration change τ = j·t (its duration t); u = (τ + K/τ)/2, w = (K/τ − τ)/2 with
/// K = u² − w². The quartics of the three types are written in τ (acceleration units), which
/// makes their coefficients free of divisions.
fn none_type(pb: &Problem, sink: &mut CandidateSink<'_, '_>) -> bool {
    let Problem {
        d,
        v0,
        a0,
        vf,
        af,
        a_max,
        a_min,
        j,
        ..
    } = *pb;
    let k = j * (vf - v0) + (a0 * a0 - af * af) / 2.0;
    // u ≤ a_max ⇔ τ² − 2·a_max·τ + K ≤ 0; w ≥ a_min ⇔ τ² + 2·a_min·τ − K ≤ 0.
    let (s1, s2) = (a_max * a_max - k, a_min * a_min + k);
    let tol_a = 1e-9 * (a_max * a_max + a_min * a_min + abs(k));
    if s1 < -tol_a || s2 < -tol_a {
        return false;
    }
    let (r1, r2) = (sqrt(max(s1, 0.0)), sqrt(max(s2, 0.0)));
    let lo = max(max(a0 - af, 0.0), max(a_max - r1, -a_min - r2));
    // The duration 2τ/j + (af − a0)/j must beat the bound.
    let hi = crate::math::min(
        crate::math::min(a_max - a_min, crate::math::min(a_max + r1, -a_min + r2)),
        (sink.bound() * (1.0 + 1e-9) * j - (af - a0)) / 2.0,
    );
    let slack = 1e-9 * (abs(hi) + abs(lo)) + 1e-9 * (a_max - a_min);
    if !(lo <= hi + slack) {
        return false;
    }
    let c2 = 2.0 * (-(a0 * a0) - (af * af) + 2.0 * j * (v0 + vf));
    let c1 = (4.0 / 3.0)
        * ((a0 * a0 * a0) - (af * af * af) - 3.0 * d * (j * j) + 3.0 * j * (-a0 * v0 + af * vf));
    let c0 = -(k * k);
    let jj = uddu(j);
    let phases = |tau: f64| -> [f64; 7] {
        let s = k / tau;
        let u = (tau + s) / 2.0;
        let w = (s - tau) / 2.0;
        [(u - a0) / j, 0.0, tau / j, 0.0, 0.0, 0.0, (af - w) / j]
    };
    let roots = quartic_roots_in(0.0, c2, c1, c0, max(lo - slack, 0.0), hi + slack);
    for &tau in roots.as_slice() {
        if !(tau > 0.0) {
            continue;
        }
        if sink.offer_root(
            pb,
            tau,
            &phases,
            &jj,
            |x| {
                let dp = [4.0, 0.0, 2.0 * c2, c1];
                eval(&dp, x) / (4.0 * j * j * x)
            },
            kind(false, false, false),
        ) {
            return true;
        }
    }
    false
}

/// Plateau at `a_max` in phase 1, no cruise, no second plateau. Variable: the acceleration
/// change τ = j·t of the ramp from `a_max` down to w = a_max − τ.
fn acc0_type(pb: &Problem, sink: &mut CandidateSink<'_, '_>) -> bool {
    let Problem {
        d,
        v0,
        a0,
        vf,
        af,
        a_max,
        a_min,
        j,
        ..
    } = *pb;
    if !(a_max > 0.0) {
        return false;
    }
    let lo = max(a_max - af, 0.0);
    // Duration ≥ (2τ + af − a0)/j must beat the bound.
    let hi = crate::math::min(
        a_max - a_min,
        (sink.bound() * (1.0 + 1e-9) * j - (af - a0)) / 2.0,
    );
    let slack = 1e-9 * (abs(hi) + abs(lo));
    // The plateau t1 ≥ 0 ⇔ w² ≥ K0 with w = a_max − τ.
    let k0 = a_max * a_max + (af * af - a0 * a0) / 2.0 - j * (vf - v0);
    let ranges = split_by_square(lo, hi, slack, k0, a_max, -1.0, 1.0);
    if ranges.iter().all(Option::is_none) {
        return false;
    }
    let c3 = -2.0 * a_max;
    let c2 = (a_max * a_max) - (af * af) + 2.0 * j * vf;
    let c0 = (1.0 / 12.0)
        * (-3.0 * (a0 * a0 * a0 * a0) + 8.0 * (a0 * a0 * a0) * a_max
            - 6.0 * (a0 * a0) * (a_max * a_max)
            + 6.0 * (a_max * a_max) * (af * af)
            - 8.0 * a_max * (af * af * af)
            + 3.0 * (af * af * af * af)
            + 12.0 * (j * j) * (-2.0 * a_max * d - (v0 * v0) + (vf * vf))
            + 12.0
                * j
                * ((a0 * a0) * v0 - 2.0 * a0 * a_max * v0 + (a_max * a_max) * v0
                    - (a_max * a_max) * vf
                    + 2.0 * a_max * af * vf
                    - (af * af) * vf));
    let jj = uddu(j);
    let phases = |tau: f64| -> [f64; 7] {
        let w = a_max - tau;
        let t1 =
            (vf - v0 - (2.0 * a_max * a_max - 2.0 * w * w + af * af - a0 * a0) / (2.0 * j)) / a_max;
        [(a_max - a0) / j, t1, tau / j, 0.0, 0.0, 0.0, (af - w) / j]
    };
    for &(lo, hi) in ranges.iter().flatten() {
        let roots = quartic_roots_in(c3, c2, 0.0, c0, max(lo - slack, 0.0), hi + slack);
        for &tau in roots.as_slice() {
            if sink.offer_root(
                pb,
                tau,
                &phases,
                &jj,
                |x| {
                    let dp = [4.0, 3.0 * c3, 2.0 * c2, 0.0];
                    eval(&dp, x) / (2.0 * a_max * j * j)
                },
                kind(true, false, false),
            ) {
                return true;
            }
        }
    }
    false
}

/// Plateau at `a_min` in phase 5, no cruise, no first plateau. Variable: the acceleration
/// change τ = j·t of the first ramp, u = a0 + τ.
fn acc1_type(pb: &Problem, sink: &mut CandidateSink<'_, '_>) -> bool {
    let Problem {
        d,
        v0,
        a0,
        vf,
        af,
        a_max,
        a_min,
        j,
        ..
    } = *pb;
    if !(a_min < 0.0) {
        return false;
    }
    let lo = max(a_min - a0, 0.0);
    // Duration ≥ (2τ + a0 + af − 2·a_min)/j must beat the bound.
    let hi = crate::math::min(
        a_max - a0,
        (sink.bound() * (1.0 + 1e-9) * j - (a0 + af - 2.0 * a_min)) / 2.0,
    );
    let slack = 1e-9 * (abs(hi) + abs(lo));
    // The plateau t5 ≥ 0 ⇔ u² ≥ K1 with u = a0 + τ.
    let k1 = j * (vf - v0) + a_min * a_min + (a0 * a0 - af * af) / 2.0;
    let ranges = split_by_square(lo, hi, slack, k1, a0, 1.0, 1.0);
    if ranges.iter().all(Option::is_none) {
        return false;
    }
    let c3 = 2.0 * (2.0 * a0 - a_min);
    let c2 = 5.0 * (a0 * a0) - 6.0 * a0 * a_min + (a_min * a_min) + 2.0 * j * v0;
    let c1 =
        2.0 * (a0 * ((a0 * a0) - 2.0 * a0 * a_min + (a_min * a_min)) + 2.0 * j * v0 * (a0 - a_min));
    let c0 = (1.0 / 12.0)
        * (3.0 * (a0 * a0 * a0 * a0) - 8.0 * (a0 * a0 * a0) * a_min
            + 6.0 * (a0 * a0) * (a_min * a_min)
            - 6.0 * (a_min * a_min) * (af * af)
            + 8.0 * a_min * (af * af * af)
            - 3.0 * (af * af * af * af)
            + 12.0 * (j * j) * (2.0 * a_min * d + (v0 * v0) - (vf * vf))
            + 12.0
                * j
                * ((a0 * a0) * v0 - 2.0 * a0 * a_min * v0
                    + (a_min * a_min) * v0
                    + (a_min * a_min) * vf
                    - 2.0 * a_min * af * vf
                    + (af * af) * vf));
    let jj = uddu(j);
    let phases = |tau: f64| -> [f64; 7] {
        let u = a0 + tau;
        let t5 =
            (vf - v0 - (2.0 * u * u - 2.0 * a_min * a_min + af * af - a0 * a0) / (2.0 * j)) / a_min;
        [
            tau / j,
            0.0,
            (u - a_min) / j,
            0.0,
            0.0,
            t5,
            (af - a_min) / j,
        ]
    };
    for &(lo, hi) in ranges.iter().flatten() {
        let roots = quartic_roots_in(c3, c2, c1, c0, max(lo - slack, 0.0), hi + slack);
        for &tau in roots.as_slice() {
            if sink.offer_root(
                pb,
                tau,
                &phases,
                &jj,
                |x| {
                    let dp = [4.0, 3.0 * c3, 2.0 * c2, c1];
                    -eval(&dp, x) / (2.0 * a_min * j * j)
                },
                kind(false, false, true),
            ) {
                return true;
            }
        }
    }
    false
}

/// Shapes where the general equations degenerate: a single ramp, or two ramps.
fn degenerate(pb: &Problem, sink: &mut CandidateSink<'_, '_>) -> bool {
    let Problem {
        v0, a0, vf, af, j, ..
    } = *pb;
    let jj = uddu(j);
    // Single ramp +j from a0 to af.
    let t = (af - a0) / j;
    if sink.offer(
        pb,
        [t, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        jj,
        kind(false, false, false),
    ) {
        return true;
    }
    // Two ramps: +j to u, −j to af.
    let x = (a0 * a0 + af * af) / 2.0 + j * (vf - v0);
    if x >= 0.0 {
        let u = sqrt(x);
        let t = [(u - a0) / j, 0.0, (u - af) / j, 0.0, 0.0, 0.0, 0.0];
        if sink.offer(pb, t, jj, kind(false, false, false)) {
            return true;
        }
    }
    false
}
