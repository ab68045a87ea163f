//! Online form for a control loop: keep the last trajectory, advance it by one period per
//! cycle, re-plan only when the input changes. No allocation.

use crate::error::{InvalidOption, TrajectoryError};
use crate::input::Input;
use crate::profile::AxisState;
use crate::trajectory::Trajectory;

/// Result of one cycle of [`OnlineGenerator::step`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum OnlineStatus {
    /// The trajectory is still running.
    Working,
    /// The target has been reached (the new state is the target state).
    Finished,
}

/// Cycle-by-cycle trajectory generation.
///
/// Each [`step`](Self::step) compares the input with the previous cycle's; if anything changed
/// (target, limits, options, or a current state that is not the one this generator produced) it
/// re-plans from the input's current state. Then it advances by one period and writes the new
/// state into the input's current state, ready for the next cycle.
///
/// ```
/// use rmd_traj::{Input, OnlineGenerator, OnlineStatus};
/// let mut input = Input::<1>::with_limits([10.0], [20.0], [100.0]);
/// input.target_position = [1.0];
/// let mut otg = OnlineGenerator::<1>::new(0.001)?;
/// let mut cycles = 0;
/// while otg.step(&mut input)? == OnlineStatus::Working {
///     cycles += 1; // send input.current_position to the motors here
/// }
/// assert!((input.current_position[0] - 1.0).abs() < 1e-9);
/// assert!(cycles > 0);
/// # Ok::<(), rmd_traj::TrajectoryError>(())
/// ```
#[derive(Debug, Clone, Copy)]
pub struct OnlineGenerator<const N: usize> {
    period: f64,
    trajectory: Trajectory<N>,
    last: Option<Input<N>>,
    time: f64,
    replans: u64,
}

impl<const N: usize> OnlineGenerator<N> {
    /// A generator for a control loop of the given period (> 0).
    pub fn new(period: f64) -> Result<Self, TrajectoryError> {
        if !(period.is_finite() && period > 0.0) {
            return Err(TrajectoryError::InvalidOption(InvalidOption::Period));
        }
        Ok(OnlineGenerator {
            period,
            trajectory: Trajectory::EMPTY,
            last: None,
            time: 0.0,
            replans: 0,
        })
    }

    /// One control cycle (see the type's documentation). On error the input is left unchanged
    /// and the next call re-plans.
    pub fn step(&mut self, input: &mut Input<N>) -> Result<OnlineStatus, TrajectoryError> {
        if self.last.as_ref() != Some(input) {
            self.last = None;
            self.trajectory.calculate(input)?;
            self.time = 0.0;
            self.replans += 1;
        }
        self.time += self.period;
        let states: [AxisState; N] = self.trajectory.state_at(self.time);
        for (i, s) in states.iter().enumerate() {
            input.current_position[i] = s.position;
            input.current_velocity[i] = s.velocity;
            input.current_acceleration[i] = s.acceleration;
        }
        self.last = Some(*input);
        Ok(if self.time >= self.trajectory.duration() {
            OnlineStatus::Finished
        } else {
            OnlineStatus::Working
        })
    }

    /// The trajectory being followed.
    pub fn trajectory(&self) -> &Trajectory<N> {
        &self.trajectory
    }

    /// Time since the last re-plan.
    pub fn time(&self) -> f64 {
        self.time
    }

    /// How many times the trajectory was (re-)planned.
    pub fn replans(&self) -> u64 {
        self.replans
    }

    /// The control period.
    pub fn period(&self) -> f64 {
        self.period
    }
}
