//! Orchestration: validation, brake, step 1 per axis, synchronization, step 2 per axis.

use crate::block::{Block, make_block};
use crate::brake::{Brake, position_brake, velocity_brake_for_velocity_interface};
use crate::cand::{Cand, CandList, Free, MAX_CANDS, Problem, validate};
use crate::error::TrajectoryError;
use crate::input::{
    AxisInput, ControlInterface, DurationDiscretization, Synchronization, TrajectoryOptions,
};
use crate::math::{Integrator, abs, fmod, max, snap_scale};
use crate::position1::Search;
use crate::position2::Pieces;
use crate::profile::{AxisProfile, Phase, ProfileKind};
use crate::{position1, position2, velocity};

/// Durations above this are rejected on the synchronized path (as the reference does).
pub const MAX_SYNCHRONIZED_DURATION: f64 = 7600.0;

/// Per-axis intermediate results.
#[derive(Debug, Clone, Copy)]
pub(crate) struct AxisPlan {
    pub(crate) brake: Brake,
    pub(crate) brake_t: f64,
    pub(crate) pb: Problem,
    pub(crate) block: Block,
    /// Whether the blocked intervals are known (all extremal profiles were searched); if not,
    /// only `t_min` is.
    pub(crate) complete: bool,
}

impl AxisPlan {
    pub(crate) const EMPTY: AxisPlan = AxisPlan {
        brake: [Phase {
            duration: 0.0,
            jerk: 0.0,
        }; 2],
        brake_t: 0.0,
        pb: Problem {
            d: 0.0,
            v0: 0.0,
            a0: 0.0,
            vf: 0.0,
            af: 0.0,
            v_max: 0.0,
            v_min: 0.0,
            a_max: 0.0,
            a_min: 0.0,
            j: 0.0,
            position: true,
            a_snap: 0.0,
            v_sc: 0.0,
            a_sc: 0.0,
        },
        block: Block::EMPTY,
        complete: true,
    };
}

/// What the calculation found besides the profiles.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Summary {
    pub(crate) duration: f64,
    pub(crate) limiting_axis: Option<usize>,
}

fn has_zero_limits(ax: &AxisInput) -> bool {
    ax.a_max == 0.0 || ax.a_min == 0.0 || ax.j_max == 0.0
}

/// Step 1 for one axis: brake, then every extremal profile, then the block of durations, into
/// `out` (in place: the plan is large). On error `out` is partly overwritten.
pub(crate) fn plan_axis(
    ax: &AxisInput,
    axis: usize,
    interface: ControlInterface,
    all_profiles: bool,
    out: &mut AxisPlan,
) -> Result<(), TrajectoryError> {
    let position = interface == ControlInterface::Position;
    let brake = if position {
        position_brake(
            ax.v0, ax.a0, ax.v_max, ax.v_min, ax.a_max, ax.a_min, ax.j_max,
        )
    } else {
        velocity_brake_for_velocity_interface(ax.a0, ax.a_max, ax.a_min, ax.j_max)
    };
    let a_snap = snap_scale(ax.a0, ax.af, ax.a_max, ax.a_min);
    let mut it = Integrator::new(ax.p0, ax.v0, ax.a0, a_snap);
    let mut brake_t = 0.0;
    for ph in &brake {
        it.step(ph.duration, ph.jerk);
        brake_t += ph.duration;
    }
    let (p, v, a) = it.state();
    let pb = Problem {
        d: if position { ax.pf - p } else { 0.0 },
        v0: v,
        a0: a,
        vf: ax.vf,
        af: ax.af,
        v_max: if position { ax.v_max } else { f64::INFINITY },
        v_min: if position {
            ax.v_min
        } else {
            f64::NEG_INFINITY
        },
        a_max: ax.a_max,
        a_min: ax.a_min,
        j: ax.j_max,
        position,
        a_snap,
        v_sc: 0.0,
        a_sc: 0.0,
    }
    .with_scales();
    let rest = abs(ax.vf) < f64::EPSILON && abs(ax.af) < f64::EPSILON;
    let at_target = brake_t == 0.0 && pb.at_target();
    let search = if rest && !at_target {
        Search::First
    } else if all_profiles {
        Search::All
    } else {
        Search::Fastest
    };
    // Only the search for all profiles keeps more than the fastest one.
    let mut best_store = [Cand::ZERO; 2];
    let mut all_store;
    let mut cands = if search == Search::All {
        all_store = [Cand::ZERO; MAX_CANDS];
        CandList::all(&mut all_store)
    } else {
        CandList::best(&mut best_store)
    };
    if !(at_target && rest) && pb.j > 0.0 {
        if position {
            position1::candidates(&pb, search, &mut cands);
        } else {
            velocity::candidates(&pb, search, &mut cands);
        }
    }
    if at_target {
        // The zero-length profile replaces near-zero ones found by the equations (0/0 there).
        let tiny = 1e-9 * max(pb.a_scale() / pb.j, 0.0);
        cands.retain(|c| !(c.total() <= tiny));
        cands.push(Cand::ZERO);
    }
    let feasible = |t: f64| -> bool {
        if position {
            position2::feasible(&pb, t)
        } else {
            velocity::feasible(&pb, t)
        }
    };
    // Without all profiles only the fastest one is known: no blocked intervals.
    let complete = rest || all_profiles;
    if make_block(
        cands.as_mut_slice(),
        brake_t,
        !complete,
        &feasible,
        &mut out.block,
    ) {
        out.brake = brake;
        out.brake_t = brake_t;
        out.pb = pb;
        out.complete = complete;
        Ok(())
    } else if has_zero_limits(ax) {
        Err(TrajectoryError::ZeroLimits { axis })
    } else {
        Err(TrajectoryError::NoProfile { axis })
    }
}

/// Rounds `t` up to a multiple of `period` the way the reference does.
fn round_up(t: f64, period: f64) -> f64 {
    let r = fmod(t, period);
    if r > 0.0 { t + (period - r) } else { t }
}

/// Picks the common duration: the smallest candidate (an axis's `t_min`, the right end of a
/// blocked interval, or the minimum duration; rounded up to the period if discrete) that no
/// synchronized axis blocks. Returns the duration and the axis it came from with its profile.
fn synchronize(
    plans: &[AxisPlan],
    axes_sync: &dyn Fn(usize) -> Synchronization,
    opts: &TrajectoryOptions,
) -> Option<(f64, Option<(usize, Cand)>)> {
    let period = match opts.discretization {
        DurationDiscretization::Discrete { period } => Some(period),
        DurationDiscretization::Continuous => None,
    };
    let round = |t: f64| match period {
        Some(p) => round_up(t, p),
        None => t,
    };
    let min_d = opts.minimum_duration.unwrap_or(0.0);
    let valid = |t: f64| -> bool {
        t.is_finite()
            && t >= min_d
            && plans
                .iter()
                .enumerate()
                .all(|(i, pl)| axes_sync(i) == Synchronization::None || !pl.block.is_blocked(t))
    };
    let mut best: Option<(f64, Option<(usize, Cand)>)> = None;
    let mut offer = |t: f64, from: Option<(usize, Cand)>| {
        let t = round(t);
        if valid(t) {
            match best {
                Some((bt, _)) if bt <= t => {}
                _ => best = Some((t, from)),
            }
        }
    };
    for (i, pl) in plans.iter().enumerate() {
        if axes_sync(i) == Synchronization::None {
            offer(0.0, None);
            continue;
        }
        offer(pl.block.t_min, Some((i, pl.block.p_min)));
        for iv in pl.block.intervals() {
            offer(iv.right, Some((i, iv.profile)));
        }
    }
    if let Some(t) = opts.minimum_duration {
        offer(t, None);
    }
    best
}

/// Step 2 for one axis: a profile of total duration `t_profile` (brake excluded).
fn stretch(pl: &AxisPlan, t_profile: f64) -> Option<Pieces> {
    let tol = 4.0 * f64::EPSILON * max(t_profile, 0.0) + f64::MIN_POSITIVE;
    let b = &pl.block;
    if abs(b.t_min - pl.brake_t - t_profile) <= tol {
        return Some(b.p_min.into());
    }
    for iv in b.intervals() {
        if abs(iv.right - pl.brake_t - t_profile) <= tol {
            return Some(iv.profile.into());
        }
    }
    if pl.pb.position {
        position2::fixed_time(&pl.pb, t_profile)
    } else {
        velocity::fixed_time(&pl.pb, t_profile).map(Into::into)
    }
}

/// Phase synchronization: if the axes' boundary conditions are collinear, every axis follows
/// the limiting axis's phases with scaled jerk. Returns false (and leaves `out` alone) if not
/// possible.
fn phase_synchronize(
    axes: &[AxisInput],
    plans: &[AxisPlan],
    limiting: usize,
    lim_profile: &Pieces,
    duration: f64,
    out: &mut [Option<Pieces>],
) -> bool {
    // Reference vector: the first non-zero of (pd, v0, a0, vf, af) of the limiting axis.
    let vec = |ax: &AxisInput, pl: &AxisPlan| -> [f64; 5] {
        let pd = if pl.pb.position { ax.pf - ax.p0 } else { 0.0 };
        [pd, ax.v0, ax.a0, ax.vf, ax.af]
    };
    let r = vec(&axes[limiting], &plans[limiting]);
    let Some(k) = r.iter().position(|x| *x != 0.0) else {
        return false;
    };
    for (i, (ax, pl)) in axes.iter().zip(plans.iter()).enumerate() {
        if i == limiting {
            continue;
        }
        let x = vec(ax, pl);
        let s = x[k] / r[k];
        for m in 0..5 {
            if abs(x[m] - s * r[m]) > 1e-12 * (abs(x[m]) + abs(s * r[m])) + 1e-300 {
                return false;
            }
        }
        let t_profile = duration - pl.brake_t;
        let mut p = *lim_profile;
        for jm in &mut p.j[..p.n] {
            *jm *= s;
        }
        if p.j[..p.n].iter().any(|j| abs(*j) > pl.pb.j * (1.0 + 1e-12)) {
            return false;
        }
        let n = p.n;
        match validate(&pl.pb, &mut p.t[..n], &p.j[..n], Free::Nothing) {
            Some(c) if abs(c.total - t_profile) <= 1e-12 * max(duration, 1e-300) => {
                p.kind = ProfileKind::PhaseSynchronized;
                out[i] = Some(p);
            }
            _ => return false,
        }
    }
    true
}

/// The whole calculation over slices (one entry per axis).
pub(crate) fn calculate(
    axes: &[AxisInput],
    opts: &TrajectoryOptions,
    plans: &mut [AxisPlan],
    chosen: &mut [Option<Pieces>],
    out: &mut [AxisProfile],
) -> Result<Summary, TrajectoryError> {
    opts.validate()?;
    let n = axes.len();
    for (i, ax) in axes.iter().enumerate() {
        ax.validate(i, opts.control_interface)?;
    }
    let discrete = matches!(opts.discretization, DurationDiscretization::Discrete { .. });
    // Step 1 first finds each axis's fastest profile only. The blocked intervals of an axis are
    // computed (all its extremal profiles) only when the common duration turns out to be
    // infeasible for it, which step 2 detects; then the duration is chosen again.
    for (i, ax) in axes.iter().enumerate() {
        plan_axis(ax, i, opts.control_interface, false, &mut plans[i])?;
    }
    let sync = opts.synchronization;
    let axes_sync = |_: usize| sync;
    let mut duration;
    let mut limiting: Option<usize>;
    'plan: loop {
        for c in chosen.iter_mut() {
            *c = None;
        }
        if n == 1 && opts.minimum_duration.is_none() && !discrete {
            duration = plans[0].block.t_min;
            limiting = Some(0);
        } else {
            let Some((t, from)) = synchronize(plans, &axes_sync, opts) else {
                let duration = plans.iter().map(|p| p.block.t_min).fold(0.0, max);
                return Err(if let Some(axis) = axes.iter().position(has_zero_limits) {
                    TrajectoryError::ZeroLimits { axis }
                } else {
                    TrajectoryError::Synchronization {
                        axis: None,
                        duration,
                    }
                });
            };
            duration = t;
            limiting = from.map(|(i, _)| i);
            if let Some((i, c)) = from {
                chosen[i] = Some(c.into());
            }
            if sync == Synchronization::None {
                for (i, pl) in plans.iter().enumerate() {
                    chosen[i] = None;
                    if pl.block.t_min > duration {
                        duration = pl.block.t_min;
                        limiting = Some(i);
                    }
                }
            }
            if duration > MAX_SYNCHRONIZED_DURATION {
                return Err(TrajectoryError::DurationTooLong { duration });
            }
        }

        let finished = duration == 0.0 || (sync == Synchronization::None && !discrete);
        if duration == 0.0 {
            for c in chosen.iter_mut() {
                *c = None;
            }
        }
        let mut phase_done = false;
        if !finished
            && sync == Synchronization::Phase
            && let Some(lim) = limiting
            && let Some(lp) = chosen[lim]
        {
            phase_done = phase_synchronize(axes, plans, lim, &lp, duration, chosen);
        }
        if !finished && !phase_done {
            for i in 0..n {
                let pl = &plans[i];
                let skip = (Some(i) == limiting || sync == Synchronization::None) && !discrete;
                if skip {
                    continue;
                }
                if sync == Synchronization::TimeIfNecessary
                    && abs(pl.pb.vf) < f64::EPSILON
                    && abs(pl.pb.af) < f64::EPSILON
                {
                    chosen[i] = None;
                    continue;
                }
                match stretch(pl, duration - pl.brake_t) {
                    Some(p) => chosen[i] = Some(p),
                    None if !pl.complete => {
                        // Probably inside a blocked interval of this axis: find them all and
                        // choose the duration again.
                        plan_axis(&axes[i], i, opts.control_interface, true, &mut plans[i])?;
                        continue 'plan;
                    }
                    None => {
                        return Err(TrajectoryError::Synchronization {
                            axis: Some(i),
                            duration,
                        });
                    }
                }
            }
        }
        break;
    }
    for (i, (ax, pl)) in axes.iter().zip(plans.iter()).enumerate() {
        // `None`: the axis's own fastest profile.
        let (t, j, kind) = match &chosen[i] {
            Some(p) => (&p.t[..p.n], &p.j[..p.n], p.kind),
            None => {
                let c = &pl.block.p_min;
                (&c.t[..], &c.j[..], c.kind)
            }
        };
        let end = if pl.pb.position {
            Some((ax.pf, ax.vf, ax.af))
        } else {
            None
        };
        let a_snap = snap_scale(ax.a0, ax.af, ax.a_max, ax.a_min);
        out[i].build_into((ax.p0, ax.v0, ax.a0), &pl.brake, t, j, end, kind, a_snap);
        if !pl.pb.position {
            out[i].set_end_velocity(ax.vf, ax.af);
        }
    }
    Ok(Summary {
        duration,
        limiting_axis: limiting,
    })
}
