//! The result of a calculation: one profile per axis and the common duration.

use crate::calculator::{self, AxisPlan};
use crate::error::TrajectoryError;
use crate::input::Input;
use crate::position2::Pieces;
use crate::profile::{AxisProfile, AxisState};

/// A synchronized trajectory of `N` axes.
///
/// ```
/// use rmd_traj::{calculate, Input};
/// let mut input = Input::<1>::with_limits([1.0], [1.0], [1.0]);
/// input.target_position = [1.0];
/// let traj = calculate(&input).unwrap();
/// let end = traj.state_at(traj.duration());
/// assert!((end[0].position - 1.0).abs() < 1e-9);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Trajectory<const N: usize> {
    profiles: [AxisProfile; N],
    duration: f64,
    independent_min_durations: [f64; N],
    limiting_axis: Option<usize>,
}

impl<const N: usize> Default for Trajectory<N> {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl<const N: usize> Trajectory<N> {
    /// A trajectory of duration 0 with every axis at rest at position 0.
    pub const EMPTY: Trajectory<N> = Trajectory {
        profiles: [AxisProfile::EMPTY; N],
        duration: 0.0,
        independent_min_durations: [0.0; N],
        limiting_axis: None,
    };

    /// Calculates the trajectory for `input` into `self` (no allocation; on error `self` is
    /// left unchanged).
    pub fn calculate(&mut self, input: &Input<N>) -> Result<(), TrajectoryError> {
        let axes: [crate::input::AxisInput; N] = core::array::from_fn(|i| input.axis(i));
        let mut plans = [AxisPlan::EMPTY; N];
        let mut chosen: [Option<Pieces>; N] = [None; N];
        let mut profiles = [AxisProfile::EMPTY; N];
        let summary = calculator::calculate(
            &axes,
            &input.options(),
            &mut plans,
            &mut chosen,
            &mut profiles,
        )?;
        self.profiles = profiles;
        self.duration = summary.duration;
        self.limiting_axis = summary.limiting_axis;
        for i in 0..N {
            self.independent_min_durations[i] = plans[i].block.t_min;
        }
        Ok(())
    }

    /// The common duration: every axis has reached its target by then.
    pub fn duration(&self) -> f64 {
        self.duration
    }

    /// Each axis's own minimum duration (brake included), before synchronization.
    pub fn independent_min_durations(&self) -> &[f64; N] {
        &self.independent_min_durations
    }

    /// The axis whose time-optimal (or blocked-interval-end) profile set the duration; `None`
    /// when the duration came from the minimum duration option.
    pub fn limiting_axis(&self) -> Option<usize> {
        self.limiting_axis
    }

    /// Every axis's profile.
    pub fn profiles(&self) -> &[AxisProfile; N] {
        &self.profiles
    }

    /// The profile of one axis.
    pub fn profile(&self, axis: usize) -> Option<&AxisProfile> {
        self.profiles.get(axis)
    }

    /// The state of every axis at time `t` (from the start). After the duration the axes continue
    /// with constant acceleration (zero at a target at rest).
    pub fn state_at(&self, t: f64) -> [AxisState; N] {
        core::array::from_fn(|i| self.profiles[i].state_at(t))
    }

    /// Like [`state_at`](Self::state_at), writing into `out` (useful with dynamic axis counts).
    pub fn state_at_into(&self, t: f64, out: &mut [AxisState; N]) {
        for (o, p) in out.iter_mut().zip(self.profiles.iter()) {
            *o = p.state_at(t);
        }
    }
}

/// Calculates the time-optimal synchronized trajectory for `input`.
pub fn calculate<const N: usize>(input: &Input<N>) -> Result<Trajectory<N>, TrajectoryError> {
    let mut t = Trajectory::EMPTY;
    t.calculate(input)?;
    Ok(t)
}
