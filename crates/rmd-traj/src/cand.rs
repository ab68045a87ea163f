//! Candidate 7-phase profiles in the solver's frame, their validation with tolerances relative
//! to the problem's scale, and small fixed-capacity collections of them.

use crate::math::{Integrator, abs, max};
use crate::profile::{Direction, ProfileKind, ReachedLimits};

/// Relative floor of the final-state tolerances (× the magnitudes summed to get them).
pub(crate) const FINAL_REL: f64 = 1e-11;
/// Relative tolerance for limit overshoot inside a candidate (× the limit's scale).
pub(crate) const LIMIT_REL: f64 = 1e-12;
/// Relative tolerance for (negative) phase durations (× the profile's duration scale).
pub(crate) const TIME_REL: f64 = 1e-12;

/// One axis's problem after the brake, relative to the (post-brake) start position.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Problem {
    /// Displacement to go (`pf − p0`); unused by the velocity interface.
    pub(crate) d: f64,
    pub(crate) v0: f64,
    pub(crate) a0: f64,
    pub(crate) vf: f64,
    pub(crate) af: f64,
    pub(crate) v_max: f64,
    pub(crate) v_min: f64,
    pub(crate) a_max: f64,
    pub(crate) a_min: f64,
    pub(crate) j: f64,
    /// Position interface (check position and velocity limits) or velocity interface.
    pub(crate) position: bool,
    /// Acceleration scale of the zero-acceleration convention of [`Integrator`].
    pub(crate) a_snap: f64,
    /// [`v_scale`](Self::v_scale) and [`a_scale`](Self::a_scale), set by
    /// [`with_scales`](Self::with_scales).
    pub(crate) v_sc: f64,
    pub(crate) a_sc: f64,
}

impl Problem {
    /// The same problem seen in the negative direction.
    pub(crate) fn mirrored(&self) -> Problem {
        Problem {
            d: -self.d,
            v0: -self.v0,
            a0: -self.a0,
            vf: -self.vf,
            af: -self.af,
            v_max: -self.v_min,
            v_min: -self.v_max,
            a_max: -self.a_min,
            a_min: -self.a_max,
            j: self.j,
            position: self.position,
            a_snap: self.a_snap,
            // Symmetric under the mirroring.
            v_sc: self.v_sc,
            a_sc: self.a_sc,
        }
    }

    /// The problem with its cached scales computed (call after setting the other fields).
    pub(crate) fn with_scales(mut self) -> Problem {
        let mut s = max(abs(self.v0), abs(self.vf));
        if self.position {
            s = max(s, max(abs(self.v_max), abs(self.v_min)));
        }
        self.v_sc = s;
        self.a_sc = max(
            max(abs(self.a0), abs(self.af)),
            max(abs(self.a_max), abs(self.a_min)),
        );
        self
    }

    /// Velocity scale: the largest of |v0|, |vf| and (position interface) the velocity limits.
    #[inline]
    pub(crate) fn v_scale(&self) -> f64 {
        self.v_sc
    }

    /// Acceleration scale: the largest of |a0|, |af| and the acceleration limits.
    #[inline]
    pub(crate) fn a_scale(&self) -> f64 {
        self.a_sc
    }

    /// Is the start state already the target state?
    pub(crate) fn at_target(&self) -> bool {
        let vs = self.v_scale();
        let as_ = self.a_scale();
        (!self.position || self.d == 0.0)
            && abs(self.vf - self.v0) <= 4.0 * f64::EPSILON * vs
            && abs(self.af - self.a0) <= 4.0 * f64::EPSILON * as_
    }
}

/// A 7-phase profile (jerks given) in the frame it was solved in.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Cand {
    pub(crate) t: [f64; 7],
    pub(crate) j: [f64; 7],
    /// Tolerance of the final position (propagated rounding bound).
    pub(crate) p_tol: f64,
    pub(crate) kind: ProfileKind,
}

impl Cand {
    /// The zero-length profile.
    pub(crate) const ZERO: Cand = Cand {
        t: [0.0; 7],
        j: [0.0; 7],
        p_tol: 0.0,
        kind: ProfileKind::AtTarget,
    };

    /// Total duration.
    #[inline]
    pub(crate) fn total(&self) -> f64 {
        total7(&self.t)
    }

    /// The same profile seen in the other direction (jerks negated).
    pub(crate) fn mirrored(mut self) -> Cand {
        for j in &mut self.j {
            *j = -*j;
        }
        self.kind = mirrored_kind(self.kind);
        self
    }

    /// Final position, velocity, acceleration from the problem's start.
    pub(crate) fn end(&self, pb: &Problem) -> (f64, f64, f64) {
        let mut it = Integrator::new(0.0, pb.v0, pb.a0, pb.a_snap);
        for i in 0..7 {
            it.step(self.t[i], self.j[i]);
        }
        it.state()
    }
}

/// The kind of a profile seen in the other direction.
pub(crate) fn mirrored_kind(kind: ProfileKind) -> ProfileKind {
    let flip = |d: Direction| match d {
        Direction::Up => Direction::Down,
        Direction::Down => Direction::Up,
    };
    match kind {
        ProfileKind::TimeOptimal { direction, limits } => ProfileKind::TimeOptimal {
            direction: flip(direction),
            limits,
        },
        ProfileKind::FixedTimeExtremal { direction } => ProfileKind::FixedTimeExtremal {
            direction: flip(direction),
        },
        other => other,
    }
}

/// Total of 7 phase durations, summed as [`Cand::total`] does.
#[inline]
pub(crate) fn total7(t: &[f64; 7]) -> f64 {
    ((t[0] + t[1]) + (t[2] + t[3])) + ((t[4] + t[5]) + t[6])
}

/// UDDU jerk pattern with jerk `j`.
pub(crate) const fn uddu(j: f64) -> [f64; 7] {
    [j, 0.0, -j, 0.0, -j, 0.0, j]
}

/// Safety factor on the propagated rounding-error bound when judging a computed final state:
/// the candidates come from polished roots and closed forms whose residual is a few roundings.
pub(crate) const ROUND_K: f64 = 1024.0;

/// What [`validate`] found.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Checked {
    /// Total duration.
    pub(crate) total: f64,
    /// Final position (relative to the start).
    pub(crate) p: f64,
    /// Tolerance of the final position: the larger of the propagated rounding bound
    /// (× [`ROUND_K`]) and [`FINAL_REL`] × the path length (∫|v| dt).
    pub(crate) p_tol: f64,
}

/// Which final quantities a validation leaves free.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Free {
    /// The final position, velocity and acceleration must be the target's.
    Nothing,
    /// The final position is free (fixed-duration extremes of the position interface).
    Position,
    /// The final position and velocity are free (fixed-duration extremes of the velocity
    /// interface).
    Velocity,
}

/// Why [`validate_why`] rejected a candidate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Failure {
    /// Negative phase, non-finite value or a limit exceeded: no small correction helps.
    Shape,
    /// Only the final state is off: a more accurate root may pass.
    FinalState,
}

/// [`validate_why`] without the reason.
pub(crate) fn validate(pb: &Problem, t: &mut [f64], jerks: &[f64], free: Free) -> Option<Checked> {
    validate_why(pb, t, jerks, free).ok()
}

/// Validates phase times `t` with jerks `jerks` for `pb`: non-negative times (tiny negative
/// values within tolerance are set to 0), limits respected, final velocity and acceleration
/// reached (unless left `free`) and the final position too.
///
/// Tolerances follow the scale of the problem instead of fixed epsilons: the larger of a
/// forward bound of the integration's rounding errors (errors of p, v, a carried through every
/// phase, × [`ROUND_K`]) and [`FINAL_REL`] × the magnitudes summed (path length ∫|v| dt for the
/// position, ∫|a| dt for the velocity). So a long cruise after a fast ramp, a huge velocity
/// swing after a brake, or a microscopic distance each get the tolerance their arithmetic
/// warrants.
pub(crate) fn validate_why(
    pb: &Problem,
    t: &mut [f64],
    jerks: &[f64],
    free: Free,
) -> Result<Checked, Failure> {
    const E: f64 = f64::EPSILON;
    // One pass for the usual case (all durations finite and non-negative): the sum of the
    // absolute values is then the total and is finite.
    let mut raw = 0.0;
    let mut negative = false;
    for &ti in t.iter() {
        raw += abs(ti);
        negative |= ti < 0.0;
    }
    if !raw.is_finite() {
        return Err(Failure::Shape);
    }
    let j_abs = abs(pb.j);
    let as_ = pb.a_scale();
    let vs = pb.v_scale();
    let total = if negative {
        let t_tol = TIME_REL * (raw + if j_abs > 0.0 { as_ / j_abs } else { 0.0 });
        let mut total = 0.0;
        for ti in t.iter_mut() {
            if *ti < 0.0 {
                if *ti < -t_tol {
                    return Err(Failure::Shape);
                }
                *ti = 0.0;
            }
            total += *ti;
        }
        total
    } else {
        raw
    };
    if !(total <= 1e12) {
        return Err(Failure::Shape);
    }
    if free == Free::Nothing {
        match validate_fast(pb, t, jerks, total) {
            Fast::Accept(c) => return Ok(c),
            Fast::Reject => return Err(Failure::Shape),
            Fast::Undecided => {}
        }
    }
    let mut it = Integrator::new(0.0, pb.v0, pb.a0, pb.a_snap);
    let (mut p, mut v, mut a) = it.state();
    let (mut ep, mut ev, mut ea) = (0.0, E * abs(v), E * abs(a));
    // A start velocity outside the limits (possible after a brake that could not avoid the
    // violation) must return into them; from the first time it is inside it must stay inside.
    let (mut path, mut a_area) = (0.0, 0.0);
    let mut below = v < pb.v_min - LIMIT_REL * vs;
    let mut above = v > pb.v_max + LIMIT_REL * vs;
    for (&ti, &j) in t.iter().zip(jerks.iter()) {
        if ti == 0.0 {
            continue;
        }
        it.step(ti, j);
        let (p1, v1, a1) = it.state();
        let v_ext = if j != 0.0 && (a < 0.0) != (a1 < 0.0) && a != 0.0 && a1 != 0.0 {
            v - a * a / (2.0 * j)
        } else {
            v
        };
        path += max(max(abs(v), abs(v1)), abs(v_ext)) * ti;
        a_area += max(abs(a), abs(a1)) * ti;
        let (at, jt) = (abs(a) * ti, abs(j) * ti);
        // Rounding of the arithmetic, plus the resolution of the phase duration itself: a ramp's
        // duration comes from accelerations (±eps·a/j); a cruise's may come from a difference of
        // times of the size of the whole duration (±eps·total, which only moves the position).
        let dt = if j != 0.0 {
            E * (as_ / abs(j) + ti)
        } else {
            E * ti
        };
        let dt_p = if j != 0.0 { dt } else { E * total };
        ep += ev * ti
            + ea * ti * ti / 2.0
            + E * (abs(p) + abs(v) * ti + at * ti / 2.0 + jt * ti * ti / 6.0)
            + abs(v) * dt_p;
        ev += ea * ti + E * (abs(v) + at + jt * ti / 2.0) + abs(a) * dt;
        ea = if a1 == 0.0 && j != 0.0 {
            0.0
        } else {
            ea + E * (abs(a) + jt) + abs(j) * dt
        };
        let a_tol = LIMIT_REL * as_ + ROUND_K * ea;
        if !(a1 <= pb.a_max + a_tol && a1 >= pb.a_min - a_tol) {
            return Err(Failure::Shape);
        }
        if pb.position {
            let v_tol = LIMIT_REL * vs + ROUND_K * ev;
            let (v_hi, v_lo) = (pb.v_max + v_tol, pb.v_min - v_tol);
            // Monotone pieces: up to the velocity extremum (where a = 0), then to the end.
            for (x, y) in [(v, v_ext), (v_ext, v1)] {
                if (!below && crate::math::min(x, y) < v_lo) || (!above && max(x, y) > v_hi) {
                    return Err(Failure::Shape);
                }
                below = below && y < v_lo;
                above = above && y > v_hi;
            }
        }
        (p, v, a) = (p1, v1, a1);
    }
    let tiny = f64::MIN_POSITIVE;
    let v_end_tol = max(
        ROUND_K * ev,
        FINAL_REL * max(max(abs(pb.v0), abs(pb.vf)), a_area),
    ) + tiny;
    let a_end_tol = max(ROUND_K * ea, FINAL_REL * as_) + tiny;
    let v_ok = free == Free::Velocity || abs(v - pb.vf) <= v_end_tol;
    if !(v_ok && abs(a - pb.af) <= a_end_tol) {
        return Err(Failure::FinalState);
    }
    let p_tol = max(ROUND_K * ep, FINAL_REL * max(abs(pb.d), path)) + tiny;
    if free == Free::Nothing && pb.position && !(abs(p - pb.d) <= p_tol) {
        return Err(Failure::FinalState);
    }
    if !p.is_finite() {
        return Err(Failure::Shape);
    }
    Ok(Checked { total, p, p_tol })
}

/// What [`validate_fast`] decided.
enum Fast {
    /// Accepted: the full test accepts too.
    Accept(Checked),
    /// A limit is exceeded by more than any tolerance of the full test: it rejects too.
    Reject,
    /// Only the full test can tell.
    Undecided,
}

/// The acceptance test of [`validate_why`] (target fully prescribed) with only the tolerance
/// floors, which need no rounding-error propagation: [`LIMIT_REL`] × the scale on the limits,
/// [`FINAL_REL`] × the magnitudes on the final state. Those floors are at most the full
/// tolerances, so a candidate accepted here is accepted there (same integration, same
/// comparisons). A candidate whose limit overshoot exceeds an upper bound of the full test's
/// tolerance at that phase ([`full_tolerance_bounds`]) is rejected here; otherwise the full test
/// decides. Most candidates are decided here.
fn validate_fast(pb: &Problem, t: &[f64], jerks: &[f64], total: f64) -> Fast {
    let vs = pb.v_scale();
    let as_ = pb.a_scale();
    let a_tol = LIMIT_REL * as_;
    let v_tol = LIMIT_REL * vs;
    let (a_hi, a_lo) = (pb.a_max + a_tol, pb.a_min - a_tol);
    let (v_hi, v_lo) = (pb.v_max + v_tol, pb.v_min - v_tol);
    let mut it = Integrator::new(0.0, pb.v0, pb.a0, pb.a_snap);
    let (mut v, mut a) = (pb.v0, pb.a0);
    let (mut path, mut a_area) = (0.0, 0.0);
    // A start outside the velocity limits (after a brake) is left to the full test: its
    // "return, then stay inside" rule depends on the tolerance.
    if pb.position && !(v >= v_lo && v <= v_hi) {
        return Fast::Undecided;
    }
    for (i, (&ti, &j)) in t.iter().zip(jerks.iter()).enumerate() {
        if ti == 0.0 {
            continue;
        }
        it.step(ti, j);
        let (v1, a1) = (it.v, it.a);
        let v_ext = if j != 0.0 && (a < 0.0) != (a1 < 0.0) && a != 0.0 && a1 != 0.0 {
            v - a * a / (2.0 * j)
        } else {
            v
        };
        path += max(max(abs(v), abs(v1)), abs(v_ext)) * ti;
        a_area += max(abs(a), abs(a1)) * ti;
        let a_bad = !(a1 <= a_hi && a1 >= a_lo);
        let (v_top, v_bottom) = (max(v_ext, v1), crate::math::min(v_ext, v1));
        let v_bad = pb.position && !(v_bottom >= v_lo && v_top <= v_hi);
        if a_bad || v_bad {
            let (ua, uv) = full_tolerance_bounds(pb, &t[..=i], &jerks[..=i]);
            let a_full = a_tol + ROUND_K * ua;
            let v_full = v_tol + ROUND_K * uv;
            let a_out = !(a1 <= pb.a_max + a_full && a1 >= pb.a_min - a_full);
            let v_out = !(v_bottom >= pb.v_min - v_full && v_top <= pb.v_max + v_full);
            return if (a_bad && a_out) || (!a_bad && v_out) {
                Fast::Reject
            } else {
                Fast::Undecided
            };
        }
        (v, a) = (v1, a1);
    }
    let tiny = f64::MIN_POSITIVE;
    let v_end_tol = FINAL_REL * max(max(abs(pb.v0), abs(pb.vf)), a_area) + tiny;
    let a_end_tol = FINAL_REL * as_ + tiny;
    let p_tol = FINAL_REL * max(abs(pb.d), path) + tiny;
    let p = it.p;
    let ok = abs(v - pb.vf) <= v_end_tol
        && abs(a - pb.af) <= a_end_tol
        && (!pb.position || abs(p - pb.d) <= p_tol)
        && p.is_finite();
    if ok {
        Fast::Accept(Checked { total, p, p_tol })
    } else {
        Fast::Undecided
    }
}

/// Upper bounds of the propagated rounding bounds `ea` and `ev` of [`validate_why`]'s full
/// test after the phases `t` (its last one is the phase being checked), for a start velocity
/// inside the limits and phases that passed [`validate_fast`]'s limit tests before the last one
/// (so every phase starts with |a| ≤ A and |v| ≤ V, A and V the scales plus a margin).
///
/// Per phase i (duration tᵢ, jerk jᵢ, start a, v) the full test adds to `ea` at most
/// eps·(|a| + 2|jᵢ|tᵢ + A) and to `ev` at most ea·tᵢ + eps·(|v| + |a|tᵢ + |jᵢ|tᵢ²/2) + |a|·dtᵢ
/// with dtᵢ = eps·(A/|jᵢ| + tᵢ) (eps·tᵢ without jerk), starting from eps·|a0| and eps·|v0|.
/// Summed with the start values bounded by A and V, and doubled for the rounding of this
/// evaluation itself.
fn full_tolerance_bounds(pb: &Problem, t: &[f64], jerks: &[f64]) -> (f64, f64) {
    const E: f64 = f64::EPSILON;
    let a_cap = pb.a_scale() * (1.0 + 1e-9);
    let v_cap = pb.v_scale() * (1.0 + 1e-9);
    let (mut m, mut s, mut sj, mut sjt, mut sa) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for (&ti, &j) in t.iter().zip(jerks) {
        if ti == 0.0 {
            continue;
        }
        let ja = abs(j);
        m += 1.0;
        s += ti;
        sj += ja * ti;
        sjt += ja * ti * ti;
        if ja > 0.0 {
            sa += pb.a_scale() / ja;
        }
    }
    let ua = E * (a_cap + m * (a_cap + pb.a_scale()) + 2.0 * sj);
    let uv = E * (v_cap * (1.0 + m) + 2.0 * a_cap * s + sjt / 2.0 + a_cap * sa) + ua * s;
    (2.0 * ua, 2.0 * uv)
}

/// [`validate`] for a 7-phase candidate that must reach the target.
pub(crate) fn check(
    pb: &Problem,
    mut t: [f64; 7],
    jerks: [f64; 7],
    kind: ProfileKind,
) -> Option<Cand> {
    let c = validate(pb, &mut t, &jerks, Free::Nothing)?;
    Some(Cand {
        t,
        j: jerks,
        p_tol: c.p_tol,
        kind,
    })
}

/// [`validate`] for a 7-phase candidate with a free final position; returns it too.
pub(crate) fn check_free(
    pb: &Problem,
    t: [f64; 7],
    jerks: [f64; 7],
    kind: ProfileKind,
) -> Option<(Cand, f64)> {
    check_with(pb, t, jerks, kind, Free::Position)
}

/// [`validate`] for a 7-phase candidate with the given final quantities free; returns it and
/// its final position.
pub(crate) fn check_with(
    pb: &Problem,
    mut t: [f64; 7],
    jerks: [f64; 7],
    kind: ProfileKind,
    free: Free,
) -> Option<(Cand, f64)> {
    let c = validate(pb, &mut t, &jerks, free)?;
    Some((
        Cand {
            t,
            j: jerks,
            p_tol: c.p_tol,
            kind,
        },
        c.p,
    ))
}

/// Limits label from which plateaus / cruise are present.
pub(crate) fn limits_of(acc0: bool, vel: bool, acc1: bool) -> ReachedLimits {
    match (acc0, vel, acc1) {
        (true, true, true) => ReachedLimits::Acc0Acc1Vel,
        (true, true, false) => ReachedLimits::Acc0Vel,
        (false, true, true) => ReachedLimits::Acc1Vel,
        (false, true, false) => ReachedLimits::Vel,
        (true, false, true) => ReachedLimits::Acc0Acc1,
        (true, false, false) => ReachedLimits::Acc0,
        (false, false, true) => ReachedLimits::Acc1,
        (false, false, false) => ReachedLimits::None,
    }
}

/// Most candidates kept in step 1.
pub(crate) const MAX_CANDS: usize = 16;

/// A fixed-capacity list of candidates in storage owned by the caller: every valid candidate
/// (blocked intervals need them all), or only the fastest one (`best_only`: two slots, the best
/// and the one being validated; a tie keeps the earlier one, as a stable sort would).
#[derive(Debug)]
pub(crate) struct CandList<'a> {
    pub(crate) c: &'a mut [Cand],
    pub(crate) n: usize,
    best_only: bool,
}

impl<'a> CandList<'a> {
    /// A list keeping every candidate, up to `storage.len()`.
    pub(crate) fn all(storage: &'a mut [Cand]) -> Self {
        CandList {
            c: storage,
            n: 0,
            best_only: false,
        }
    }

    /// A list keeping only the fastest candidate (`storage` has two slots).
    pub(crate) fn best(storage: &'a mut [Cand; 2]) -> Self {
        CandList {
            c: storage,
            n: 0,
            best_only: true,
        }
    }

    pub(crate) fn push(&mut self, c: Cand) {
        if self.best_only && self.n == 1 {
            if c.total() < self.c[0].total() {
                self.c[0] = c;
            }
        } else if self.n < self.c.len() {
            self.c[self.n] = c;
            self.n += 1;
        }
    }

    /// Validates phase times `t` with `jerks` and keeps the candidate if valid (and, keeping
    /// only the best, if faster than the one kept: a tie keeps the earlier one, as a stable sort
    /// would), negating its jerks if `mirror`.
    pub(crate) fn push_checked(
        &mut self,
        pb: &Problem,
        t: &[f64; 7],
        jerks: &[f64; 7],
        kind: ProfileKind,
        mirror: bool,
    ) -> Result<(), Failure> {
        let challenger = self.best_only && self.n == 1;
        if !self.best_only && self.n >= self.c.len() {
            return Err(Failure::Shape);
        }
        let mut tt = *t;
        let c = validate_why(pb, &mut tt, jerks, Free::Nothing)?;
        if challenger && !(total7(&tt) < self.c[0].total()) {
            return Ok(());
        }
        let slot = &mut self.c[if challenger { 0 } else { self.n }];
        slot.t = tt;
        slot.p_tol = c.p_tol;
        if mirror {
            for (s, j) in slot.j.iter_mut().zip(jerks) {
                *s = -*j;
            }
            slot.kind = mirrored_kind(kind);
        } else {
            slot.j = *jerks;
            slot.kind = kind;
        }
        if !challenger {
            self.n += 1;
        }
        Ok(())
    }

    /// The smallest duration in the list (+∞ if empty).
    pub(crate) fn min_total(&self) -> f64 {
        self.c[..self.n].iter().fold(
            f64::INFINITY,
            |m, c| if c.total() < m { c.total() } else { m },
        )
    }

    /// Keeps only the candidates for which `keep` is true.
    pub(crate) fn retain(&mut self, keep: impl Fn(&Cand) -> bool) {
        let mut k = 0;
        for i in 0..self.n {
            if keep(&self.c[i]) {
                self.c[k] = self.c[i];
                k += 1;
            }
        }
        self.n = k;
    }

    pub(crate) fn as_mut_slice(&mut self) -> &mut [Cand] {
        &mut self.c[..self.n]
    }
}
