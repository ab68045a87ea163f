//! One axis's trajectory: an optional brake pre-trajectory followed by constant-jerk phases.

use crate::math::{Integrator, integrate};

/// Most phases of a profile after the brake: 7 for time-optimal and cruise profiles, up to 13
/// for a blend of two 7-phase profiles (see [`ProfileKind::Blend`]).
pub const MAX_PHASES: usize = 14;
/// Most pieces of the brake pre-trajectory.
pub const MAX_BRAKE_PHASES: usize = 2;
const MAX_SEGMENTS: usize = MAX_PHASES + MAX_BRAKE_PHASES;

/// A piece of constant jerk.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Phase {
    /// Duration (≥ 0).
    pub duration: f64,
    /// Jerk during the piece.
    pub jerk: f64,
}

/// The kinematic state of one axis at one time.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AxisState {
    /// Position.
    pub position: f64,
    /// Velocity.
    pub velocity: f64,
    /// Acceleration.
    pub acceleration: f64,
    /// Jerk (right-continuous: at a phase boundary, the jerk of the phase that starts there).
    pub jerk: f64,
}

/// Direction of a time-optimal profile.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Direction {
    /// Solved with the limits as given: the first jerk pulse is positive.
    Up,
    /// Solved with mirrored limits: the first jerk pulse is negative.
    Down,
}

/// Which limits a time-optimal profile reaches (in its own direction): `Acc0` is the
/// acceleration plateau of the first pulse, `Acc1` the one of the last, `Vel` a cruise at the
/// velocity limit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[allow(missing_docs)]
pub enum ReachedLimits {
    Acc0Acc1Vel,
    Acc0Vel,
    Acc1Vel,
    Vel,
    Acc0Acc1,
    Acc0,
    Acc1,
    None,
}

/// How an axis profile was obtained.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ProfileKind {
    /// The axis is already at its target state; nothing moves.
    AtTarget,
    /// A time-optimal (extremal) profile: the fastest one, or one that ends a blocked interval.
    TimeOptimal {
        /// Direction of the first jerk pulse.
        direction: Direction,
        /// Limits reached.
        limits: ReachedLimits,
    },
    /// For a prescribed duration: the profile that ends furthest in `direction`
    /// (`Up`: largest final position). Used when the target lies on that boundary.
    FixedTimeExtremal {
        /// Which boundary.
        direction: Direction,
    },
    /// For a prescribed duration: fastest change to a cruise velocity, cruise, fastest change to
    /// the target velocity and acceleration (up to 7 phases, jerk at ±limit).
    Cruise,
    /// For a prescribed duration: jerk = λ·j₁(t) + (1−λ)·j₂(t) of two valid profiles of that
    /// duration. Feasible because the limits are convex constraints; up to 13 phases.
    Blend,
    /// For a prescribed duration, velocity interface: acceleration change, constant acceleration,
    /// acceleration change.
    VelocityPlateau,
    /// Scaled copy of the limiting axis's profile (phase synchronization).
    PhaseSynchronized,
}

/// One axis of a trajectory: brake pre-trajectory (0–2 pieces), then up to [`MAX_PHASES`]
/// phases of constant jerk, then rest at the target (constant acceleration extrapolation).
///
/// The state at each phase boundary is integrated from the start with one convention: a jerk
/// phase whose final acceleration is zero up to rounding (|a| ≤ 16·eps·max(A, |j·t|) with
/// A = max(|a0|, |af|, `max_acceleration`, |`min_acceleration`|) of the axis) ends at exactly zero
/// acceleration, so that cruises do not drift. The state after the last phase is the exact target
/// (position interface) or the exact target velocity and acceleration (velocity interface).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisProfile {
    /// Segment durations: brake pieces first.
    t: [f64; MAX_SEGMENTS],
    j: [f64; MAX_SEGMENTS],
    /// Start time and state of each segment; index `n` is the end.
    t0: [f64; MAX_SEGMENTS + 1],
    p: [f64; MAX_SEGMENTS + 1],
    v: [f64; MAX_SEGMENTS + 1],
    a: [f64; MAX_SEGMENTS + 1],
    n_brake: u8,
    n: u8,
    kind: ProfileKind,
}

impl AxisProfile {
    /// An axis at rest at position 0 (placeholder before a calculation).
    pub const EMPTY: AxisProfile = AxisProfile {
        t: [0.0; MAX_SEGMENTS],
        j: [0.0; MAX_SEGMENTS],
        t0: [0.0; MAX_SEGMENTS + 1],
        p: [0.0; MAX_SEGMENTS + 1],
        v: [0.0; MAX_SEGMENTS + 1],
        a: [0.0; MAX_SEGMENTS + 1],
        n_brake: 0,
        n: 0,
        kind: ProfileKind::AtTarget,
    };

    /// Builds the profile in place from its start state, brake pieces and phases (durations `t`,
    /// jerks `j`). `end` replaces the integrated end state (the exact target, to avoid
    /// accumulated rounding); `None` keeps it. Entries past the last segment are zero (a profile
    /// equals a freshly built one): only those the previous profile used are cleared.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn build_into(
        &mut self,
        start: (f64, f64, f64),
        brake: &[Phase],
        t: &[f64],
        j: &[f64],
        end: Option<(f64, f64, f64)>,
        kind: ProfileKind,
        a_snap: f64,
    ) {
        let out = self;
        let old_n = out.n as usize;
        out.kind = kind;
        let (p, v, a) = start;
        let mut it = Integrator::new(p, v, a, a_snap);
        let mut time = 0.0;
        let mut n = 0usize;
        out.t0[0] = 0.0;
        out.p[0] = p;
        out.v[0] = v;
        out.a[0] = a;
        // At most 2 brake pieces and MAX_PHASES phases: MAX_SEGMENTS slots.
        let (brake, t) = (
            &brake[..brake.len().min(MAX_BRAKE_PHASES)],
            &t[..t.len().min(MAX_PHASES)],
        );
        for ph in brake {
            if ph.duration > 0.0 {
                out.t[n] = ph.duration;
                out.j[n] = ph.jerk;
                it.step(ph.duration, ph.jerk);
                time += ph.duration;
                n += 1;
                out.t0[n] = time;
                (out.p[n], out.v[n], out.a[n]) = it.state();
            }
        }
        let n_brake = n as u8;
        for (&duration, &jerk) in t.iter().zip(j) {
            if duration > 0.0 {
                out.t[n] = duration;
                out.j[n] = jerk;
                it.step(duration, jerk);
                time += duration;
                n += 1;
                out.t0[n] = time;
                (out.p[n], out.v[n], out.a[n]) = it.state();
            }
        }
        if let Some((pe, ve, ae)) = end {
            out.p[n] = pe;
            out.v[n] = ve;
            out.a[n] = ae;
        }
        if n < old_n {
            out.t[n..old_n].fill(0.0);
            out.j[n..old_n].fill(0.0);
            for x in [&mut out.t0, &mut out.p, &mut out.v, &mut out.a] {
                x[n + 1..old_n + 1].fill(0.0);
            }
        }
        out.n = n as u8;
        out.n_brake = n_brake;
    }

    /// Replaces the end velocity and acceleration (velocity interface: the exact target).
    pub(crate) fn set_end_velocity(&mut self, v: f64, a: f64) {
        let n = self.n as usize;
        self.v[n] = v;
        self.a[n] = a;
    }

    /// The profile's own duration (brake included). An axis may finish before the trajectory's
    /// duration (synchronization `None` / `TimeIfNecessary`); it then continues with constant
    /// acceleration.
    pub fn duration(&self) -> f64 {
        self.t0[self.n as usize]
    }

    /// How the profile was obtained.
    pub fn kind(&self) -> ProfileKind {
        self.kind
    }

    /// The brake pre-trajectory pieces (empty if the initial state was within the limits).
    pub fn brake(&self) -> impl Iterator<Item = Phase> + '_ {
        (0..self.n_brake as usize).map(|i| Phase {
            duration: self.t[i],
            jerk: self.j[i],
        })
    }

    /// The phases after the brake (zero-length phases removed).
    pub fn phases(&self) -> impl Iterator<Item = Phase> + '_ {
        (self.n_brake as usize..self.n as usize).map(|i| Phase {
            duration: self.t[i],
            jerk: self.j[i],
        })
    }

    /// Total duration of the brake pieces.
    pub fn brake_duration(&self) -> f64 {
        self.t0[self.n_brake as usize]
    }

    /// The state at the start (t = 0).
    pub fn start_state(&self) -> AxisState {
        AxisState {
            position: self.p[0],
            velocity: self.v[0],
            acceleration: self.a[0],
            jerk: if self.n > 0 { self.j[0] } else { 0.0 },
        }
    }

    /// The state at the end of the profile (jerk 0).
    pub fn end_state(&self) -> AxisState {
        let n = self.n as usize;
        AxisState {
            position: self.p[n],
            velocity: self.v[n],
            acceleration: self.a[n],
            jerk: 0.0,
        }
    }

    /// The state at time `t` (from the start of the profile). Before 0 the start state is
    /// returned; after the end the state continues with constant acceleration (jerk 0).
    pub fn state_at(&self, t: f64) -> AxisState {
        let n = self.n as usize;
        if !(t > 0.0) {
            return self.start_state();
        }
        if t >= self.t0[n] {
            let dt = t - self.t0[n];
            let (position, velocity, acceleration) =
                integrate(dt, self.p[n], self.v[n], self.a[n], 0.0);
            return AxisState {
                position,
                velocity,
                acceleration,
                jerk: 0.0,
            };
        }
        let mut i = 0;
        while i + 1 < n && t >= self.t0[i + 1] {
            i += 1;
        }
        let dt = t - self.t0[i];
        let (position, velocity, acceleration) =
            integrate(dt, self.p[i], self.v[i], self.a[i], self.j[i]);
        AxisState {
            position,
            velocity,
            acceleration,
            jerk: self.j[i],
        }
    }
}
