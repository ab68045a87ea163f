//! Velocity interface: reach a target velocity and acceleration (no position target).
//!
//! Step 1: a profile is +j to a peak acceleration u (held if u = `a_max`), then −j to `af`
//! (mirrored: −j, plateau at `a_min`, +j); closed forms. Step 2 (prescribed duration): the same
//! shape with a plateau at any acceleration level, or "hold a0, ramp, hold af"; together these
//! cover every reachable final velocity continuously.

use crate::cand::{Cand, CandList, Free, Problem, check, check_with};
use crate::math::{abs, max, sqrt};
use crate::position1::{CandidateSink, Search};
use crate::profile::{Direction, ProfileKind, ReachedLimits};

const fn up_kind(limits: ReachedLimits) -> ProfileKind {
    ProfileKind::TimeOptimal {
        direction: Direction::Up,
        limits,
    }
}

/// Collects the valid minimum-time profiles (both directions).
pub(crate) fn candidates(pb: &Problem, search: Search, out: &mut CandList<'_>) {
    let up_first = pb.vf >= pb.v0;
    let dirs = if up_first {
        [Direction::Up, Direction::Down]
    } else {
        [Direction::Down, Direction::Up]
    };
    for dir in dirs {
        let frame = match dir {
            Direction::Up => *pb,
            Direction::Down => pb.mirrored(),
        };
        let mut sink = CandidateSink {
            out: &mut *out,
            dir,
            search,
        };
        if up_profiles(&frame, &mut sink) {
            return;
        }
    }
}

fn up_profiles(pb: &Problem, sink: &mut CandidateSink<'_, '_>) -> bool {
    let Problem {
        v0,
        a0,
        vf,
        af,
        a_max,
        j,
        ..
    } = *pb;
    let jj = [j, 0.0, -j, 0.0, 0.0, 0.0, 0.0];
    let x = j * (vf - v0) + (a0 * a0 + af * af) / 2.0;
    // Plateau at a_max.
    if a_max > 0.0 {
        let t1 = (x - a_max * a_max) / (j * a_max);
        let t = [(a_max - a0) / j, t1, (a_max - af) / j, 0.0, 0.0, 0.0, 0.0];
        if sink.offer(pb, t, jj, up_kind(ReachedLimits::Acc0)) {
            return true;
        }
    }
    // No plateau: u² = x.
    if x >= 0.0 {
        let r = sqrt(x);
        for u in [r, -r] {
            let t = [(u - a0) / j, 0.0, (u - af) / j, 0.0, 0.0, 0.0, 0.0];
            if sink.offer(pb, t, jj, up_kind(ReachedLimits::None)) {
                return true;
            }
            if r == 0.0 {
                break;
            }
        }
    }
    false
}

/// Velocities reachable in exactly `tt` (ending with `af`): the largest, in the problem's frame.
fn max_velocity(pb: &Problem, tt: f64) -> Option<(Cand, f64)> {
    let Problem {
        a0, af, a_max, j, ..
    } = *pb;
    if !(tt >= 0.0) || !(j > 0.0) {
        return None;
    }
    let jj = [j, 0.0, -j, 0.0, 0.0, 0.0, 0.0];
    let u = (j * tt + a0 + af) / 2.0;
    let t = if u <= a_max {
        [(u - a0) / j, 0.0, (u - af) / j, 0.0, 0.0, 0.0, 0.0]
    } else {
        let t1 = tt - (2.0 * a_max - a0 - af) / j;
        [(a_max - a0) / j, t1, (a_max - af) / j, 0.0, 0.0, 0.0, 0.0]
    };
    let (c, _) = check_with(
        pb,
        t,
        jj,
        ProfileKind::FixedTimeExtremal {
            direction: Direction::Up,
        },
        Free::Velocity,
    )?;
    let v = c.end(pb).1;
    Some((c, v))
}

/// Can the axis reach its target velocity (and acceleration) in exactly `tt`?
pub(crate) fn feasible(pb: &Problem, tt: f64) -> bool {
    let (Some((_, hi)), Some((_, lo))) = (max_velocity(pb, tt), max_velocity(&pb.mirrored(), tt))
    else {
        return false;
    };
    let tol = 1e-11 * max(pb.v_scale(), pb.a_scale() * tt);
    pb.vf <= hi + tol && pb.vf >= -lo - tol
}

/// A profile of duration `tt` reaching the target velocity and acceleration.
pub(crate) fn fixed_time(pb: &Problem, tt: f64) -> Option<Cand> {
    if !(pb.j > 0.0) {
        return None;
    }
    let right_length = |c: &Cand| abs(c.total() - tt) <= 8.0 * f64::EPSILON * tt;
    if let Some(c) = plateau_up(pb, tt).filter(right_length) {
        return Some(c);
    }
    if let Some(c) = plateau_up(&pb.mirrored(), tt).filter(right_length) {
        return Some(c.mirrored());
    }
    hold_ramp_hold(pb, tt).filter(right_length)
}

/// +j to u, hold u, −j to af, with total duration `tt`.
fn plateau_up(pb: &Problem, tt: f64) -> Option<Cand> {
    let Problem {
        v0, a0, vf, af, j, ..
    } = *pb;
    let b = j * tt + a0 + af;
    let disc = b * b - 2.0 * (a0 * a0 + af * af) - 4.0 * j * (vf - v0);
    if disc < 0.0 {
        return None;
    }
    // Smaller root of u² − b·u + c = 0, without cancellation.
    let c = (a0 * a0 + af * af) / 2.0 + j * (vf - v0);
    let u = if b > 0.0 {
        2.0 * c / (b + sqrt(disc))
    } else {
        (b - sqrt(disc)) / 2.0
    };
    let h = tt - (2.0 * u - a0 - af) / j;
    let t = [(u - a0) / j, h, (u - af) / j, 0.0, 0.0, 0.0, 0.0];
    check(
        pb,
        t,
        [j, 0.0, -j, 0.0, 0.0, 0.0, 0.0],
        ProfileKind::VelocityPlateau,
    )
}

/// Hold a0, ramp to af, hold af, with total duration `tt`.
fn hold_ramp_hold(pb: &Problem, tt: f64) -> Option<Cand> {
    let Problem {
        v0, a0, vf, af, j, ..
    } = *pb;
    let ramp = abs(af - a0) / j;
    let s = tt - ramp;
    let r = (vf - v0) - (a0 + af) / 2.0 * ramp;
    // x·a0 + y·af = r, x + y = s; each solved directly (no cancellation in s − x).
    let (x, y) = if a0 != af {
        ((r - af * s) / (a0 - af), (r - a0 * s) / (af - a0))
    } else {
        (s, 0.0)
    };
    let jr = if af >= a0 { j } else { -j };
    let t = [x, ramp, y, 0.0, 0.0, 0.0, 0.0];
    check(
        pb,
        t,
        [0.0, jr, 0.0, 0.0, 0.0, 0.0, 0.0],
        ProfileKind::VelocityPlateau,
    )
}
