//! The servo's refusals as the node counts them: each [`ServoError`] becomes a [`PortError`],
//! counted under the rejection kind that says what was wrong (the servo's own checks go
//! further than the node's: e.g. a trajectory whose motion leaves the position limits).

use rmd_servo::{ServoError, TrajectoryRefusal};

use crate::kind::RejectionKind;
use crate::port::PortError;

/// The port's error for a refusal of the servo.
pub(crate) fn port_error(error: ServoError) -> PortError {
    let invalid = |kind: RejectionKind, error: &dyn std::fmt::Display| PortError::Invalid {
        kind,
        reason: error.to_string(),
    };
    match &error {
        ServoError::Disabled => PortError::Estopped,
        ServoError::QueueFull { .. } => PortError::QueueFull,
        ServoError::EStopped | ServoError::Stopped | ServoError::NoState => {
            PortError::NotRunning(error.to_string())
        }
        ServoError::NoTrajectoryBuffer { .. } => PortError::Busy(error.to_string()),
        ServoError::UnknownJoint { .. } | ServoError::UnknownJointId { .. } => {
            invalid(RejectionKind::UnknownJoint, &error)
        }
        ServoError::NotFinite { .. } => invalid(RejectionKind::NotFinite, &error),
        ServoError::OutOfLimit { .. } => invalid(RejectionKind::OutOfLimit, &error),
        ServoError::DuplicateJoint { .. } => invalid(RejectionKind::DuplicateJoint, &error),
        ServoError::Trajectory(refusal) => invalid(trajectory_kind(refusal), &error),
    }
}

fn trajectory_kind(refusal: &TrajectoryRefusal) -> RejectionKind {
    match refusal {
        TrajectoryRefusal::NoJoints | TrajectoryRefusal::NoPoints => RejectionKind::Empty,
        TrajectoryRefusal::LengthMismatch { .. } => RejectionKind::LengthMismatch,
        TrajectoryRefusal::TimeNotIncreasing { .. } | TrajectoryRefusal::StartNotFinite(_) => {
            RejectionKind::BadTime
        }
        TrajectoryRefusal::NotFinite { .. } => RejectionKind::NotFinite,
        TrajectoryRefusal::OutOfLimit { .. } | TrajectoryRefusal::LeavesPositionLimits { .. } => {
            RejectionKind::OutOfLimit
        }
        TrajectoryRefusal::TooManyPoints { .. }
        | TrajectoryRefusal::EndsMoving { .. }
        | TrajectoryRefusal::Plan { .. } => RejectionKind::Infeasible,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_refusal_goes_to_the_counter_that_says_what_was_wrong() {
        let kind = |e: ServoError| port_error(e).kind();
        assert_eq!(port_error(ServoError::Disabled), PortError::Estopped);
        assert_eq!(
            port_error(ServoError::QueueFull { capacity: 4 }),
            PortError::QueueFull
        );
        assert!(matches!(
            port_error(ServoError::EStopped),
            PortError::NotRunning(_)
        ));
        assert!(matches!(
            port_error(ServoError::NoTrajectoryBuffer { count: 4 }),
            PortError::Busy(_)
        ));
        assert_eq!(kind(ServoError::Disabled), RejectionKind::PortRefused);
        assert_eq!(
            kind(ServoError::OutOfLimit {
                joint: "knee".into(),
                field: "position_rad",
                value: 3.0,
                min: -1.0,
                max: 1.0,
                key: "position_min_rad/max",
            }),
            RejectionKind::OutOfLimit
        );
        assert_eq!(
            kind(ServoError::Trajectory(
                TrajectoryRefusal::LeavesPositionLimits {
                    joint: "knee".into(),
                    point: 1,
                    reached: 1.2,
                    min: -1.0,
                    max: 1.0,
                }
            )),
            RejectionKind::OutOfLimit
        );
        assert_eq!(
            kind(ServoError::Trajectory(TrajectoryRefusal::EndsMoving {
                joint: "knee".into()
            })),
            RejectionKind::Infeasible
        );
        assert_eq!(
            kind(ServoError::Trajectory(TrajectoryRefusal::TooManyPoints {
                points: 300,
                max: 256
            })),
            RejectionKind::Infeasible
        );
        // The servo's words reach the diagnostics.
        let e = port_error(ServoError::Trajectory(TrajectoryRefusal::EndsMoving {
            joint: "knee".into(),
        }));
        assert!(e.to_string().contains("must end at rest"), "{e}");
    }
}
