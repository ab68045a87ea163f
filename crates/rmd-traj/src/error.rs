//! Typed, allocation-free errors of the trajectory generator.

use core::fmt;

/// Which input quantity an [`InvalidInput`](TrajectoryError::InvalidInput) error is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum InputField {
    /// `current_position`.
    CurrentPosition,
    /// `current_velocity`.
    CurrentVelocity,
    /// `current_acceleration`.
    CurrentAcceleration,
    /// `target_position`.
    TargetPosition,
    /// `target_velocity`.
    TargetVelocity,
    /// `target_acceleration`.
    TargetAcceleration,
    /// `max_velocity`.
    MaxVelocity,
    /// `min_velocity`.
    MinVelocity,
    /// `max_acceleration`.
    MaxAcceleration,
    /// `min_acceleration`.
    MinAcceleration,
    /// `max_jerk`.
    MaxJerk,
}

impl InputField {
    /// The field's name as in [`Input`](crate::Input).
    pub const fn name(self) -> &'static str {
        match self {
            InputField::CurrentPosition => "current_position",
            InputField::CurrentVelocity => "current_velocity",
            InputField::CurrentAcceleration => "current_acceleration",
            InputField::TargetPosition => "target_position",
            InputField::TargetVelocity => "target_velocity",
            InputField::TargetAcceleration => "target_acceleration",
            InputField::MaxVelocity => "max_velocity",
            InputField::MinVelocity => "min_velocity",
            InputField::MaxAcceleration => "max_acceleration",
            InputField::MinAcceleration => "min_acceleration",
            InputField::MaxJerk => "max_jerk",
        }
    }
}

impl fmt::Display for InputField {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Why an axis's input was rejected.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum InvalidReason {
    /// The value is NaN or infinite.
    NotFinite(InputField),
    /// A maximum limit is negative.
    NegativeMaximum(InputField),
    /// A minimum limit is positive.
    PositiveMinimum(InputField),
    /// The target velocity or acceleration lies above its maximum limit.
    TargetAboveMaximum(InputField),
    /// The target velocity or acceleration lies below its minimum limit.
    TargetBelowMinimum(InputField),
    /// The target acceleration drives the velocity above `max_velocity` before it can be
    /// reduced to zero (`af < 0` and `vf + af²/(2 max_jerk) > max_velocity`): the target state can
    /// only be reached by a trajectory that violated the limit just before.
    TargetInevitablyAboveMaxVelocity,
    /// Mirror of [`TargetInevitablyAboveMaxVelocity`](Self::TargetInevitablyAboveMaxVelocity):
    /// `af > 0` and `vf − af²/(2 max_jerk) < min_velocity`.
    TargetInevitablyBelowMinVelocity,
}

impl fmt::Display for InvalidReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            InvalidReason::NotFinite(field) => write!(f, "{field} is not a finite number"),
            InvalidReason::NegativeMaximum(field) => write!(f, "{field} is negative"),
            InvalidReason::PositiveMinimum(field) => write!(f, "{field} is positive"),
            InvalidReason::TargetAboveMaximum(field) => {
                write!(f, "{field} exceeds its maximum limit")
            }
            InvalidReason::TargetBelowMinimum(field) => {
                write!(f, "{field} undercuts its minimum limit")
            }
            InvalidReason::TargetInevitablyAboveMaxVelocity => {
                f.write_str("the target state can only be reached after exceeding max_velocity")
            }
            InvalidReason::TargetInevitablyBelowMinVelocity => {
                f.write_str("the target state can only be reached after undercutting min_velocity")
            }
        }
    }
}

/// Why a trajectory-wide option was rejected.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum InvalidOption {
    /// `minimum_duration` is NaN, infinite or negative.
    MinimumDuration,
    /// The discretization period (or the online generator's cycle) is not a positive finite number.
    Period,
}

impl fmt::Display for InvalidOption {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            InvalidOption::MinimumDuration => {
                f.write_str("minimum_duration must be a finite number >= 0")
            }
            InvalidOption::Period => f.write_str("the period must be a finite number > 0"),
        }
    }
}

/// Everything that can go wrong when calculating a trajectory.
///
/// [`code`](Self::code) maps each variant to the result code of the reference implementation
/// (ruckig's `Result`), which the test vectors use.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TrajectoryError {
    /// The input of one axis makes no sense (code −100).
    InvalidInput {
        /// The axis (degree of freedom), from 0.
        axis: usize,
        /// What is wrong.
        reason: InvalidReason,
    },
    /// A trajectory-wide option makes no sense (code −100).
    InvalidOption(InvalidOption),
    /// The synchronized duration exceeds [`MAX_SYNCHRONIZED_DURATION`](crate::MAX_SYNCHRONIZED_DURATION)
    /// (code −101).
    DurationTooLong {
        /// The duration that was found.
        duration: f64,
    },
    /// A zero acceleration or jerk limit makes the target of this axis unreachable (code −104).
    ZeroLimits {
        /// The axis (degree of freedom), from 0.
        axis: usize,
    },
    /// No time-optimal profile exists for this axis, e.g. `max_velocity = 0` with a distance to go
    /// (code −110).
    NoProfile {
        /// The axis (degree of freedom), from 0.
        axis: usize,
    },
    /// No common duration could be realized by every axis, or this axis could not be stretched to
    /// it (code −111).
    Synchronization {
        /// The axis that failed, if known.
        axis: Option<usize>,
        /// The common duration that was attempted.
        duration: f64,
    },
}

impl fmt::Display for TrajectoryError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TrajectoryError::InvalidInput { axis, reason } => {
                write!(f, "invalid input on axis {axis}: {reason}")
            }
            TrajectoryError::InvalidOption(option) => write!(f, "invalid option: {option}"),
            TrajectoryError::DurationTooLong { duration } => {
                write!(
                    f,
                    "trajectory duration {duration} exceeds the maximum of 7600"
                )
            }
            TrajectoryError::ZeroLimits { axis } => {
                write!(f, "zero limits make the target of axis {axis} unreachable")
            }
            TrajectoryError::NoProfile { axis } => {
                write!(f, "no time-optimal profile found for axis {axis}")
            }
            TrajectoryError::Synchronization { axis, duration } => write!(
                f,
                "no synchronized profile of duration {duration} found (axis {axis:?})"
            ),
        }
    }
}

impl core::error::Error for TrajectoryError {}

impl TrajectoryError {
    /// The reference implementation's result code for this error (−100, −101, −104, −110, −111).
    pub const fn code(&self) -> i32 {
        match self {
            TrajectoryError::InvalidInput { .. } | TrajectoryError::InvalidOption(_) => -100,
            TrajectoryError::DurationTooLong { .. } => -101,
            TrajectoryError::ZeroLimits { .. } => -104,
            TrajectoryError::NoProfile { .. } => -110,
            TrajectoryError::Synchronization { .. } => -111,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_error_says_what_is_wrong_and_is_an_error() {
        let cases = [
            (
                TrajectoryError::InvalidInput {
                    axis: 2,
                    reason: InvalidReason::NotFinite(InputField::MaxJerk),
                },
                "invalid input on axis 2: max_jerk is not a finite number",
            ),
            (
                TrajectoryError::InvalidOption(InvalidOption::Period),
                "invalid option: the period must be a finite number > 0",
            ),
            (
                TrajectoryError::DurationTooLong { duration: 8000.5 },
                "trajectory duration 8000.5 exceeds the maximum of 7600",
            ),
            (
                TrajectoryError::ZeroLimits { axis: 1 },
                "zero limits make the target of axis 1 unreachable",
            ),
            (
                TrajectoryError::NoProfile { axis: 0 },
                "no time-optimal profile found for axis 0",
            ),
            (
                TrajectoryError::Synchronization {
                    axis: Some(4),
                    duration: 1.5,
                },
                "no synchronized profile of duration 1.5 found (axis Some(4))",
            ),
        ];
        for (error, text) in cases {
            assert_eq!(format!("{error}"), text);
            let as_error: &dyn core::error::Error = &error;
            assert!(as_error.source().is_none());
        }
    }
}
