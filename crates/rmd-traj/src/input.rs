//! The problem statement: current state, target state, limits and options.

use crate::error::{InputField, InvalidOption, InvalidReason, TrajectoryError};

/// What the trajectory has to reach.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum ControlInterface {
    /// Reach the target position, velocity and acceleration (default).
    #[default]
    Position,
    /// Reach the target velocity and acceleration only; the target position and the velocity
    /// limits are ignored (the position still evolves and is sampled).
    Velocity,
}

/// How the axes are made to arrive together.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Synchronization {
    /// Every axis arrives at the same, smallest common time (default).
    #[default]
    Time,
    /// Like [`Time`](Self::Time), but axes whose target velocity and acceleration are zero keep
    /// their own minimum-time profile and then rest.
    TimeIfNecessary,
    /// Straight-line motion when the problem allows it (displacement, initial and target
    /// velocity and acceleration collinear across the axes): every axis follows a scaled copy of
    /// the limiting axis. Falls back to [`Time`](Self::Time) otherwise.
    Phase,
    /// Every axis runs its own minimum-time profile; the duration is the longest of them. An axis
    /// that finishes early continues with constant acceleration.
    None,
}

/// Whether the duration must be a multiple of a period.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum DurationDiscretization {
    /// Any duration (default).
    #[default]
    Continuous,
    /// The duration is rounded up to a multiple of `period` (the control cycle), so that the
    /// target is reached exactly on a cycle.
    Discrete {
        /// The control cycle (same time unit as the limits), > 0.
        period: f64,
    },
}

/// A complete trajectory problem for `N` axes.
///
/// Units are free but must be consistent: rmd-rt uses degrees and seconds (deg, deg/s, deg/s²,
/// deg/s³). `min_velocity` / `min_acceleration` default to the negated maximum.
///
/// ```
/// use rmd_traj::Input;
/// let mut input = Input::<2>::with_limits([100.0, 50.0], [400.0, 300.0], [4000.0, 3000.0]);
/// input.target_position = [90.0, -30.0];
/// let trajectory = rmd_traj::calculate(&input).unwrap();
/// assert!(trajectory.duration() > 0.0);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Input<const N: usize> {
    /// Position or velocity interface.
    pub control_interface: ControlInterface,
    /// Synchronization strategy of the axes.
    pub synchronization: Synchronization,
    /// Continuous or discrete (multiple of a period) duration.
    pub duration_discretization: DurationDiscretization,
    /// Current position of each axis.
    pub current_position: [f64; N],
    /// Current velocity of each axis.
    pub current_velocity: [f64; N],
    /// Current acceleration of each axis.
    pub current_acceleration: [f64; N],
    /// Target position of each axis (ignored by the velocity interface).
    pub target_position: [f64; N],
    /// Target velocity of each axis.
    pub target_velocity: [f64; N],
    /// Target acceleration of each axis.
    pub target_acceleration: [f64; N],
    /// Maximum velocity of each axis, ≥ 0 (ignored by the velocity interface).
    pub max_velocity: [f64; N],
    /// Maximum acceleration of each axis, ≥ 0.
    pub max_acceleration: [f64; N],
    /// Maximum jerk of each axis, ≥ 0.
    pub max_jerk: [f64; N],
    /// Minimum velocity of each axis, ≤ 0; `None` means `-max_velocity`.
    pub min_velocity: Option<[f64; N]>,
    /// Minimum acceleration of each axis, ≤ 0; `None` means `-max_acceleration`.
    pub min_acceleration: Option<[f64; N]>,
    /// Optional lower bound on the duration.
    pub minimum_duration: Option<f64>,
}

impl<const N: usize> Input<N> {
    /// An input at rest at position 0 with the target at rest at position 0, the given symmetric
    /// limits and default options. Set the target (and current state) fields afterwards.
    pub const fn with_limits(
        max_velocity: [f64; N],
        max_acceleration: [f64; N],
        max_jerk: [f64; N],
    ) -> Self {
        Input {
            control_interface: ControlInterface::Position,
            synchronization: Synchronization::Time,
            duration_discretization: DurationDiscretization::Continuous,
            current_position: [0.0; N],
            current_velocity: [0.0; N],
            current_acceleration: [0.0; N],
            target_position: [0.0; N],
            target_velocity: [0.0; N],
            target_acceleration: [0.0; N],
            max_velocity,
            max_acceleration,
            max_jerk,
            min_velocity: None,
            min_acceleration: None,
            minimum_duration: None,
        }
    }

    /// The per-axis problem of axis `i` (limits with the minimum defaults resolved).
    pub(crate) fn axis(&self, i: usize) -> AxisInput {
        AxisInput {
            p0: self.current_position[i],
            v0: self.current_velocity[i],
            a0: self.current_acceleration[i],
            pf: self.target_position[i],
            vf: self.target_velocity[i],
            af: self.target_acceleration[i],
            v_max: self.max_velocity[i],
            v_min: match &self.min_velocity {
                Some(m) => m[i],
                None => -self.max_velocity[i],
            },
            a_max: self.max_acceleration[i],
            a_min: match &self.min_acceleration {
                Some(m) => m[i],
                None => -self.max_acceleration[i],
            },
            j_max: self.max_jerk[i],
        }
    }

    /// The trajectory-wide options.
    pub(crate) fn options(&self) -> TrajectoryOptions {
        TrajectoryOptions {
            control_interface: self.control_interface,
            synchronization: self.synchronization,
            discretization: self.duration_discretization,
            minimum_duration: self.minimum_duration,
        }
    }

    /// Checks every value; the first problem found is returned as an error.
    pub fn validate(&self) -> Result<(), TrajectoryError> {
        self.options().validate()?;
        for i in 0..N {
            self.axis(i).validate(i, self.control_interface)?;
        }
        Ok(())
    }
}

/// Trajectory-wide options, copied out of [`Input`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct TrajectoryOptions {
    pub(crate) control_interface: ControlInterface,
    pub(crate) synchronization: Synchronization,
    pub(crate) discretization: DurationDiscretization,
    pub(crate) minimum_duration: Option<f64>,
}

impl TrajectoryOptions {
    pub(crate) fn validate(&self) -> Result<(), TrajectoryError> {
        if let Some(t) = self.minimum_duration
            && !(t.is_finite() && t >= 0.0)
        {
            return Err(TrajectoryError::InvalidOption(
                InvalidOption::MinimumDuration,
            ));
        }
        if let DurationDiscretization::Discrete { period } = self.discretization
            && !(period.is_finite() && period > 0.0)
        {
            return Err(TrajectoryError::InvalidOption(InvalidOption::Period));
        }
        Ok(())
    }
}

/// One axis's problem: boundary states and limits (minimum limits resolved).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct AxisInput {
    pub(crate) p0: f64,
    pub(crate) v0: f64,
    pub(crate) a0: f64,
    pub(crate) pf: f64,
    pub(crate) vf: f64,
    pub(crate) af: f64,
    pub(crate) v_max: f64,
    pub(crate) v_min: f64,
    pub(crate) a_max: f64,
    pub(crate) a_min: f64,
    pub(crate) j_max: f64,
}

impl AxisInput {
    /// Rejects what makes no sense: non-finite values, limits of the wrong sign, targets outside
    /// the limits (including a target acceleration that forces a velocity beyond the limits
    /// just before the target). The current state is not restricted: it is braked into the limits.
    pub(crate) fn validate(
        &self,
        axis: usize,
        interface: ControlInterface,
    ) -> Result<(), TrajectoryError> {
        let position = interface == ControlInterface::Position;
        if position && self.plainly_valid() {
            return Ok(());
        }
        self.validate_in_detail(axis, position)
    }

    /// The usual position-interface input: every rule of
    /// [`validate_in_detail`](Self::validate_in_detail) met, tested without naming a field.
    fn plainly_valid(&self) -> bool {
        // 0·x is ±0 for a finite x and NaN otherwise (a sum that overflows also goes the
        // detailed way, which decides).
        let sum = self.p0
            + self.v0
            + self.a0
            + self.pf
            + self.vf
            + self.af
            + self.v_max
            + self.v_min
            + self.a_max
            + self.a_min
            + self.j_max;
        let swing = self.af * self.af / (2.0 * self.j_max);
        0.0 * sum == 0.0
            && self.j_max > 0.0
            && self.a_max >= 0.0
            && self.a_min <= 0.0
            && self.af <= self.a_max
            && self.af >= self.a_min
            && self.v_max >= 0.0
            && self.v_min <= 0.0
            && self.vf <= self.v_max
            && self.vf >= self.v_min
            && !(self.af < 0.0 && self.vf + swing > self.v_max)
            && !(self.af > 0.0 && self.vf - swing < self.v_min)
    }

    /// [`validate`](Self::validate), naming the first problem found.
    fn validate_in_detail(&self, axis: usize, position: bool) -> Result<(), TrajectoryError> {
        let err = |reason| Err(TrajectoryError::InvalidInput { axis, reason });
        let finite: [(f64, InputField, bool); 11] = [
            (self.p0, InputField::CurrentPosition, position),
            (self.v0, InputField::CurrentVelocity, true),
            (self.a0, InputField::CurrentAcceleration, true),
            (self.pf, InputField::TargetPosition, position),
            (self.vf, InputField::TargetVelocity, true),
            (self.af, InputField::TargetAcceleration, true),
            (self.v_max, InputField::MaxVelocity, position),
            (self.v_min, InputField::MinVelocity, position),
            (self.a_max, InputField::MaxAcceleration, true),
            (self.a_min, InputField::MinAcceleration, true),
            (self.j_max, InputField::MaxJerk, true),
        ];
        for (value, field, used) in finite {
            if used && !value.is_finite() {
                return err(InvalidReason::NotFinite(field));
            }
        }
        if self.j_max < 0.0 {
            return err(InvalidReason::NegativeMaximum(InputField::MaxJerk));
        }
        if self.a_max < 0.0 {
            return err(InvalidReason::NegativeMaximum(InputField::MaxAcceleration));
        }
        if self.a_min > 0.0 {
            return err(InvalidReason::PositiveMinimum(InputField::MinAcceleration));
        }
        if self.af > self.a_max {
            return err(InvalidReason::TargetAboveMaximum(
                InputField::TargetAcceleration,
            ));
        }
        if self.af < self.a_min {
            return err(InvalidReason::TargetBelowMinimum(
                InputField::TargetAcceleration,
            ));
        }
        if !position {
            return Ok(());
        }
        if self.v_max < 0.0 {
            return err(InvalidReason::NegativeMaximum(InputField::MaxVelocity));
        }
        if self.v_min > 0.0 {
            return err(InvalidReason::PositiveMinimum(InputField::MinVelocity));
        }
        if self.vf > self.v_max {
            return err(InvalidReason::TargetAboveMaximum(
                InputField::TargetVelocity,
            ));
        }
        if self.vf < self.v_min {
            return err(InvalidReason::TargetBelowMinimum(
                InputField::TargetVelocity,
            ));
        }
        if self.j_max > 0.0 {
            let swing = self.af * self.af / (2.0 * self.j_max);
            if self.af < 0.0 && self.vf + swing > self.v_max {
                return err(InvalidReason::TargetInevitablyAboveMaxVelocity);
            }
            if self.af > 0.0 && self.vf - swing < self.v_min {
                return err(InvalidReason::TargetInevitablyBelowMinVelocity);
            }
        }
        Ok(())
    }
}
