//! Step 2, position interface: a profile of one axis with a prescribed duration.
//!
//! For a fixed duration `T` the final positions reachable with the prescribed final velocity and
//! acceleration form an interval `[p_lo(T), p_hi(T)]`: the dynamics are linear and the limits
//! are convex constraints, so any convex combination of two feasible jerk functions is feasible.
//! The interval ends are attained by extremal profiles (jerk pattern +,−,+ with plateaus at the
//! acceleration limits and a cruise at the velocity limit, maximizing the position; mirrored for
//! the minimum) that have closed forms once `T` is fixed. So:
//!
//! - `T` is feasible for the axis ⇔ `p_lo(T) ≤ pf ≤ p_hi(T)` ([`feasible`]), which also
//!   classifies the gaps between step-1 durations into blocked and free intervals;
//! - a profile for `T` is, in order of preference: an extremal one if `pf` is on the boundary;
//!   a member of the cruise family (fastest change to a cruise velocity `vc`, cruise, fastest
//!   change to the target) found by a bracketed search over `vc`; otherwise the blend
//!   `λ·j₁ + (1−λ)·j₂` of two feasible profiles whose final positions bracket `pf`.

use crate::cand::{Cand, Free, Problem, check, check_free, validate};
use crate::math::{Integrator, abs, max, min, sqrt};
use crate::position1::{fall_from, rise_to};
use crate::profile::{Direction, MAX_PHASES, ProfileKind};

/// A profile with up to [`MAX_PHASES`] phases.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Pieces {
    pub(crate) t: [f64; MAX_PHASES],
    pub(crate) j: [f64; MAX_PHASES],
    pub(crate) n: usize,
    pub(crate) kind: ProfileKind,
}

impl From<Cand> for Pieces {
    fn from(c: Cand) -> Self {
        let mut p = Pieces {
            t: [0.0; MAX_PHASES],
            j: [0.0; MAX_PHASES],
            n: 7,
            kind: c.kind,
        };
        p.t[..7].copy_from_slice(&c.t);
        p.j[..7].copy_from_slice(&c.j);
        p
    }
}

const EXTREMAL_UP: ProfileKind = ProfileKind::FixedTimeExtremal {
    direction: Direction::Up,
};

/// The profile of duration `tt` ending at (vf, af) with the largest final position, in the
/// problem's own frame ("up"), with that position.
fn max_position(pb: &Problem, tt: f64) -> Option<(Cand, f64)> {
    let Problem {
        v0,
        a0,
        vf,
        af,
        v_max,
        a_max,
        a_min,
        j,
        ..
    } = *pb;
    if !(tt >= 0.0) || !(j > 0.0) {
        return None;
    }
    let jj = [j, 0.0, -j, 0.0, -j, 0.0, j];
    let mut best: Option<(Cand, f64)> = None;
    let mut consider = |t: [f64; 7]| {
        if let Some((c, p)) = check_free(pb, t, jj, EXTREMAL_UP)
            && abs(c.total() - tt) <= 1e-12 * max(tt, 1e-300) + 1e-300
        {
            match best {
                Some((_, bp)) if bp >= p => {}
                _ => best = Some((c, p)),
            }
        }
    };
    // Cruise at v_max.
    if v_max > 0.0
        && let (Some((t0, t1, t2)), Some((t4, t5, t6))) = (
            rise_to(v0, a0, v_max, a_max, j),
            fall_from(v_max, vf, af, a_min, j),
        )
    {
        let t3 = tt - (t0 + t1 + t2 + t4 + t5 + t6);
        consider([t0, t1, t2, t3, t4, t5, t6]);
    }
    let dv = vf - v0;
    // No plateau: u − w = s, u + w = K/s.
    let s = (j * tt + a0 - af) / 2.0;
    if s > 0.0 {
        let k = j * dv + (a0 * a0 - af * af) / 2.0;
        let u = (s + k / s) / 2.0;
        let w = (k / s - s) / 2.0;
        consider([(u - a0) / j, 0.0, (u - w) / j, 0.0, 0.0, 0.0, (af - w) / j]);
    }
    // Plateau at a_max.
    if a_max > 0.0 {
        let c = a_max * j * tt - a_max * (2.0 * a_max - a0 + af)
            + (2.0 * a_max * a_max - a0 * a0 + af * af) / 2.0
            - j * dv;
        let disc = a_max * a_max + c;
        if disc >= 0.0 {
            // a_max − √(a_max² + c) without cancellation.
            let w = -c / (a_max + sqrt(disc));
            let t1 = tt - (2.0 * a_max - a0 + af - 2.0 * w) / j;
            consider([
                (a_max - a0) / j,
                t1,
                (a_max - w) / j,
                0.0,
                0.0,
                0.0,
                (af - w) / j,
            ]);
        }
    }
    // Plateau at a_min.
    if a_min < 0.0 {
        let e = a_min * j * tt + a_min * (a0 + 2.0 * a_min - af)
            - (a0 * a0 + 2.0 * a_min * a_min - af * af) / 2.0
            - j * dv;
        let disc = a_min * a_min - e;
        if disc >= 0.0 {
            // a_min + √(a_min² − e) without cancellation.
            let u = -e / (sqrt(disc) - a_min);
            let t5 = tt - (2.0 * u - a0 - 2.0 * a_min + af) / j;
            consider([
                (u - a0) / j,
                0.0,
                (u - a_min) / j,
                0.0,
                0.0,
                t5,
                (af - a_min) / j,
            ]);
        }
    }
    // Both plateaus.
    if a_max > 0.0 && a_min < 0.0 {
        let sum = tt - ((a_max - a0) + (a_max - a_min) + (af - a_min)) / j;
        let r = dv - (2.0 * a_max * a_max - 2.0 * a_min * a_min + af * af - a0 * a0) / (2.0 * j);
        let t1 = (r - a_min * sum) / (a_max - a_min);
        let t5 = sum - t1;
        consider([
            (a_max - a0) / j,
            t1,
            (a_max - a_min) / j,
            0.0,
            0.0,
            t5,
            (af - a_min) / j,
        ]);
    }
    best
}

/// The profiles of duration `tt` with the smallest and the largest final position.
fn extremes(pb: &Problem, tt: f64) -> Option<((Cand, f64), (Cand, f64))> {
    let hi = max_position(pb, tt)?;
    let (lo, p_lo) = max_position(&pb.mirrored(), tt)?;
    Some(((lo.mirrored(), -p_lo), hi))
}

/// Can the axis reach its target in exactly `tt`?
pub(crate) fn feasible(pb: &Problem, tt: f64) -> bool {
    match extremes(pb, tt) {
        Some(((c_lo, lo), (c_hi, hi))) => {
            let tol = max(c_lo.p_tol, c_hi.p_tol);
            pb.d >= lo - tol && pb.d <= hi + tol
        }
        None => false,
    }
}

/// The two velocity changes of the cruise family for cruise velocity `vc`: phases and jerk sign
/// of the change from the start to (vc, 0) and of the change from (vc, 0) to the target.
type Halves = ((f64, f64, f64), f64, (f64, f64, f64), f64);

fn halves(pb: &Problem, vc: f64) -> Option<Halves> {
    let Problem {
        v0,
        a0,
        vf,
        af,
        a_max,
        a_min,
        j,
        ..
    } = *pb;
    let v0_star = v0 + a0 * abs(a0) / (2.0 * j);
    let (l, jl) = if vc >= v0_star {
        (rise_to(v0, a0, vc, a_max, j)?, j)
    } else {
        (rise_to(-v0, -a0, -vc, -a_min, j)?, -j)
    };
    let vf_star = vf - af * abs(af) / (2.0 * j);
    let (r, jr) = if vc >= vf_star {
        (fall_from(vc, vf, af, a_min, j)?, -j)
    } else {
        (fall_from(-vc, -vf, -af, -a_max, j)?, j)
    };
    Some((l, jl, r, jr))
}

/// Duration of the two velocity changes (the cruise takes the rest).
fn changes_duration(h: &Halves) -> f64 {
    let (l, _, r, _) = h;
    l.0 + l.1 + l.2 + r.0 + r.1 + r.2
}

/// A member of the cruise family, not yet validated: cruise velocity, phases, final position.
#[derive(Debug, Clone, Copy)]
struct Member {
    vc: f64,
    t: [f64; 7],
    j: [f64; 7],
    p: f64,
}

/// The cruise-family member with cruise velocity `vc` and duration `tt` (cheap: no validation),
/// or `None` if its velocity changes do not fit into `tt`.
fn member(pb: &Problem, tt: f64, vc: f64) -> Option<Member> {
    let h = halves(pb, vc)?;
    let (l, jl, r, jr) = h;
    let t3 = tt - changes_duration(&h);
    if t3 < -1e-12 * tt {
        return None;
    }
    let t = [l.0, l.1, l.2, max(t3, 0.0), r.0, r.1, r.2];
    let j = [jl, 0.0, -jl, 0.0, jr, 0.0, -jr];
    let mut it = Integrator::new(0.0, pb.v0, pb.a0, pb.a_snap);
    for k in 0..7 {
        it.step(t[k], j[k]);
    }
    Some(Member { vc, t, j, p: it.p })
}

/// d²p/dvc² of the cruise family at a member (Halley's correction): each velocity change
/// contributes −σ·3/(4s) without plateau (s its peak acceleration) and −σ/a with a plateau at a,
/// σ = +1 when the change grows with vc (rise before, fall after the cruise), −1 otherwise.
fn curvature(pb: &Problem, m: &Member) -> f64 {
    let part = |sigma: f64, ramp: f64, plateau: f64| -> f64 {
        let s = pb.j * ramp;
        if plateau > 0.0 {
            -sigma / s
        } else {
            -sigma * 0.75 / s
        }
    };
    let sigma_l = if m.j[0] > 0.0 { 1.0 } else { -1.0 };
    let sigma_r = if m.j[4] < 0.0 { 1.0 } else { -1.0 };
    part(sigma_l, m.t[2], m.t[1]) + part(sigma_r, m.t[4], m.t[5])
}

/// The validated profile of a member, with its final position.
fn validated(pb: &Problem, m: &Member) -> Option<(Cand, f64)> {
    check_free(pb, m.t, m.j, ProfileKind::Cruise)
}

/// The validated profile of a member that reaches the target position (the same test as
/// [`validated`] followed by [`hits`], through the full validation's fast path).
fn reaching(pb: &Problem, m: &Member) -> Option<Cand> {
    check(pb, m.t, m.j, ProfileKind::Cruise)
}

/// Between a cruise velocity whose changes fit into `tt` and one whose changes do not, the
/// velocity where they just fit (no cruise): regula falsi (Illinois) on their duration.
fn fit_boundary(pb: &Problem, tt: f64, mut v_in: f64, mut v_out: f64) -> f64 {
    let g = |v: f64| halves(pb, v).map(|h| changes_duration(&h) - tt);
    let Some(mut g_in) = g(v_in) else {
        return v_in;
    };
    // Where the changes do not exist at all, count them as not fitting (+∞): bisection then.
    let mut g_out = g(v_out).unwrap_or(f64::INFINITY);
    let mut side = 0i32;
    for _ in 0..100 {
        let mut v = (v_in * g_out - v_out * g_in) / (g_out - g_in);
        if !(v > min(v_in, v_out) && v < max(v_in, v_out)) {
            v = 0.5 * (v_in + v_out);
        }
        if v == v_in || v == v_out {
            break;
        }
        let gv = g(v).unwrap_or(f64::INFINITY);
        if gv <= 0.0 {
            v_in = v;
            g_in = gv;
            if side == -1 {
                g_out /= 2.0;
            }
            side = -1;
        } else {
            v_out = v;
            g_out = gv;
            if side == 1 {
                g_in /= 2.0;
            }
            side = 1;
        }
        if -g_in <= 4.0 * f64::EPSILON * tt {
            break;
        }
    }
    v_in
}

/// A profile of duration `tt` for the axis, or `None` if `tt` is infeasible.
pub(crate) fn fixed_time(pb: &Problem, tt: f64) -> Option<Pieces> {
    // The cruise family first: when it reaches the target (the usual case) that also proves
    // the duration feasible, and the extremal profiles are not needed.
    let trigger = 1e-9 * (abs(pb.d) + pb.v_scale() * tt);
    let (mut lo_m, mut hi_m) = (None, None);
    if let Some(found) = cruise_search(pb, tt, trigger, &mut lo_m, &mut hi_m) {
        return Some(found.into());
    }
    let ((c_lo, p_lo), (c_hi, p_hi)) = extremes(pb, tt)?;
    let tol = max(c_lo.p_tol, c_hi.p_tol);
    let d = pb.d;
    if d > p_hi + tol || d < p_lo - tol {
        return None;
    }
    if hits(pb, &c_hi, p_hi) {
        return Some(c_hi.into());
    }
    if hits(pb, &c_lo, p_lo) {
        return Some(c_lo.into());
    }
    // Bracket: best known feasible profiles below and above the target position.
    let mut below = (c_lo, p_lo);
    let mut above = (c_hi, p_hi);
    for x in [lo_m, hi_m].into_iter().flatten() {
        note(&mut below, &mut above, x, d);
    }
    blend(pb, &below, &above, tt)
}

/// Searches the cruise family for a profile ending at the target (within `tol`, then validated);
/// updates the bracket with the members that bracket the target best (validated at the end).
fn cruise_search(
    pb: &Problem,
    tt: f64,
    tol: f64,
    below: &mut Option<(Cand, f64)>,
    above: &mut Option<(Cand, f64)>,
) -> Option<Cand> {
    let (lo_v, hi_v) = (pb.v_min, pb.v_max);
    if !(lo_v <= hi_v) {
        return None;
    }
    let j = pb.j;
    let mut breaks = [0.0; 5];
    let mut nb = 0;
    for v in [
        lo_v,
        hi_v,
        pb.v0 + pb.a0 * abs(pb.a0) / (2.0 * j),
        pb.vf - pb.af * abs(pb.af) / (2.0 * j),
        0.0,
    ] {
        let v = min(max(v, lo_v), hi_v);
        if v.is_finite() {
            breaks[nb] = v;
            nb += 1;
        }
    }
    sort(&mut breaks[..nb]);
    const SUB: usize = 2;
    let mut pts = [0.0; 5 * SUB + 1];
    let mut np = 0;
    for k in 0..nb {
        if k > 0 && breaks[k] <= breaks[k - 1] {
            continue;
        }
        if k > 0 {
            let (a, b) = (pts[np - 1], breaks[k]);
            for s in 1..SUB {
                pts[np] = a + (b - a) * s as f64 / SUB as f64;
                np += 1;
            }
        }
        pts[np] = breaks[k];
        np += 1;
    }
    let d = pb.d;
    // Fast path: Newton on the cruise velocity from the average velocity. The final position of
    // the family grows with vc at the rate dp/dvc = t3 + (t2 + t4)/2 (the cruise plus half of
    // each ramp adjacent to it: moving the cruise level shifts each velocity change's area by
    // half its ramp at the cruise), so the steps are exact Newton steps; they stay inside the
    // bracket once one is known (otherwise a secant or bisection step).
    {
        let clamp_v = |v: f64| min(max(v, lo_v), hi_v);
        let mut m = member(pb, tt, clamp_v(d / tt));
        let (mut below_m, mut above_m): (Option<Member>, Option<Member>) = (None, None);
        for _ in 0..12 {
            let Some(cur) = m else { break };
            let f = cur.p - d;
            if abs(f) <= 0.1 * crate::cand::FINAL_REL * max(abs(d), abs(cur.vc) * cur.t[3]) {
                if let Some(c) = reaching(pb, &cur) {
                    return Some(c);
                }
                break;
            }
            if f < 0.0 {
                below_m = Some(cur);
            } else {
                above_m = Some(cur);
            }
            let slope = cur.t[3] + 0.5 * (cur.t[2] + cur.t[4]);
            let curv = curvature(pb, &cur);
            let den = 2.0 * slope * slope - f * curv;
            let mut vn = if den > slope * slope && curv.is_finite() {
                cur.vc - 2.0 * f * slope / den
            } else {
                cur.vc - f / slope
            };
            if let (Some(b), Some(a)) = (below_m, above_m) {
                let (l, h) = (min(b.vc, a.vc), max(b.vc, a.vc));
                if !(vn > l && vn < h) {
                    // Secant between the bracket's ends, or its middle.
                    vn = b.vc - (b.p - d) * (a.vc - b.vc) / (a.p - b.p);
                    if !(vn > l && vn < h) {
                        vn = 0.5 * (l + h);
                    }
                }
                if vn == b.vc || vn == a.vc {
                    break;
                }
            }
            let vn = clamp_v(vn);
            if vn == cur.vc {
                break;
            }
            m = member(pb, tt, vn);
        }
    }
    // Walk the samples in order of vc; where the family's feasibility changes between two
    // samples, insert the boundary member (changes just fit, no cruise): that is where the family
    // meets the extremal profiles. Refine between consecutive members that bracket the target.
    let mut prev: Option<Member> = None;
    let mut prev_v: Option<f64> = None;
    let mut fits_prev = false;
    let (mut lo_m, mut hi_m): (Option<Member>, Option<Member>) = (None, None);
    for &vc in &pts[..np] {
        let cur = member(pb, tt, vc);
        let fits = cur.is_some();
        let mut members = [None, None];
        if let Some(pv) = prev_v
            && fits != fits_prev
        {
            let vb = if fits_prev {
                fit_boundary(pb, tt, pv, vc)
            } else {
                fit_boundary(pb, tt, vc, pv)
            };
            members[0] = member(pb, tt, vb);
            if !fits_prev {
                prev = None;
            }
        }
        members[1] = cur;
        for m in members.into_iter().flatten() {
            if m.p <= d && lo_m.is_none_or(|x| m.p > x.p) {
                lo_m = Some(m);
            }
            if m.p >= d && hi_m.is_none_or(|x| m.p < x.p) {
                hi_m = Some(m);
            }
            if let Some(pm) = prev
                && ((pm.p < d) != (m.p < d) || abs(m.p - d) <= tol)
                && let Some(found) = refine(pb, tt, pm, m, &mut lo_m, &mut hi_m)
            {
                return Some(found);
            }
            prev = Some(m);
        }
        if !fits {
            prev = None;
        }
        prev_v = Some(vc);
        fits_prev = fits;
    }
    // No exact member: the closest validated members below and above, for the blend.
    *below = lo_m.and_then(|m| validated(pb, &m));
    *above = hi_m.and_then(|m| validated(pb, &m));
    None
}

/// Does a profile ending at `p` reach the target position (within its rounding)?
fn hits(pb: &Problem, c: &Cand, p: f64) -> bool {
    abs(p - pb.d) <= c.p_tol
}

/// Keeps the tightest bracket around the target position.
fn note(below: &mut (Cand, f64), above: &mut (Cand, f64), x: (Cand, f64), d: f64) {
    if x.1 <= d && x.1 > below.1 {
        *below = x;
    }
    if x.1 >= d && x.1 < above.1 {
        *above = x;
    }
}

/// Regula falsi (Illinois) on the cruise velocity between two members whose final positions
/// bracket the target, narrowed as far as the arithmetic allows; the closest member is validated
/// and returned if it reaches the target.
fn refine(
    pb: &Problem,
    tt: f64,
    a: Member,
    b: Member,
    lo_m: &mut Option<Member>,
    hi_m: &mut Option<Member>,
) -> Option<Cand> {
    let d = pb.d;
    let (mut va, mut fa) = (a.vc, a.p - d);
    let (mut vb, mut fb) = (b.vc, b.p - d);
    let mut best = if abs(fa) <= abs(fb) { a } else { b };
    let mut side = 0i32;
    for _ in 0..100 {
        // Close enough for sure: the member's own tolerance is at least FINAL_REL × its path
        // length, which is at least max(|d|, |vc|·t_cruise).
        if abs(best.p - d) <= 0.1 * crate::cand::FINAL_REL * max(abs(d), abs(best.vc) * best.t[3]) {
            break;
        }
        if fa == 0.0 || fb == 0.0 || (fa < 0.0) == (fb < 0.0) {
            break;
        }
        let mut vc = (va * fb - vb * fa) / (fb - fa);
        if !(vc > min(va, vb) && vc < max(va, vb)) {
            vc = 0.5 * (va + vb);
        }
        if vc == va || vc == vb {
            break;
        }
        let Some(m) = member(pb, tt, vc) else {
            break;
        };
        let f = m.p - d;
        if f <= 0.0 && lo_m.is_none_or(|x| m.p > x.p) {
            *lo_m = Some(m);
        }
        if f >= 0.0 && hi_m.is_none_or(|x| m.p < x.p) {
            *hi_m = Some(m);
        }
        if abs(f) < abs(best.p - d) {
            best = m;
        }
        // Anderson–Björck: when the same end is replaced twice in a row, the other end's value
        // is scaled by 1 − f/f_replaced (or halved, Illinois, if that is not positive).
        if (f < 0.0) == (fa < 0.0) {
            if side == -1 {
                let m = 1.0 - f / fa;
                fb *= if m > 0.0 { m } else { 0.5 };
            }
            va = vc;
            fa = f;
            side = -1;
        } else {
            if side == 1 {
                let m = 1.0 - f / fb;
                fa *= if m > 0.0 { m } else { 0.5 };
            }
            vb = vc;
            fb = f;
            side = 1;
        }
    }
    reaching(pb, &best)
}

fn sort(x: &mut [f64]) {
    for i in 1..x.len() {
        let mut k = i;
        while k > 0 && x[k - 1] > x[k] {
            x.swap(k - 1, k);
            k -= 1;
        }
    }
}

/// `λ·a + (1−λ)·b` with λ chosen so that the final position is the target. The pieces are
/// merged from the two phase lists with local remaining times (not cumulative sums, whose
/// rounding would perturb short phases late in a long profile).
fn blend(pb: &Problem, a: &(Cand, f64), b: &(Cand, f64), tt: f64) -> Option<Pieces> {
    let (ca, pa) = a;
    let (cb, p_b) = b;
    let span = p_b - pa;
    if !(span > 0.0) {
        return None;
    }
    let lam_b = (pb.d - pa) / span;
    let lam_a = 1.0 - lam_b;
    let mut out = Pieces {
        t: [0.0; MAX_PHASES],
        j: [0.0; MAX_PHASES],
        n: 0,
        kind: ProfileKind::Blend,
    };
    let (mut ia, mut ib) = (0usize, 0usize);
    let (mut ra, mut rb) = (ca.t[0], cb.t[0]);
    loop {
        while ia < 7 && ra <= 0.0 {
            ia += 1;
            ra = if ia < 7 { ca.t[ia] } else { 0.0 };
        }
        while ib < 7 && rb <= 0.0 {
            ib += 1;
            rb = if ib < 7 { cb.t[ib] } else { 0.0 };
        }
        if ia >= 7 && ib >= 7 {
            break;
        }
        // One profile may end a rounding error earlier: continue the other one alone.
        let (dt, ja, jb) = match (ia < 7, ib < 7) {
            (true, true) => (min(ra, rb), ca.j[ia], cb.j[ib]),
            (true, false) => (ra, ca.j[ia], 0.0),
            _ => (rb, 0.0, cb.j[ib]),
        };
        if out.n >= MAX_PHASES {
            return None;
        }
        out.t[out.n] = dt;
        out.j[out.n] = lam_a * ja + lam_b * jb;
        out.n += 1;
        if dt == ra {
            ra = 0.0;
        } else {
            ra -= dt;
        }
        if dt == rb {
            rb = 0.0;
        } else {
            rb -= dt;
        }
    }
    let n = out.n;
    let total = validate(pb, &mut out.t[..n], &out.j[..n], Free::Nothing)?.total;
    if abs(total - tt) > 1e-12 * tt {
        return None;
    }
    Some(out)
}
