//! Why a controller's command was not taken as given: the rejections the loop counts per
//! joint, and by default a fault ([`Fault::RejectedCommand`](crate::Fault::RejectedCommand)).

/// Why a command was not taken as given.
#[derive(Copy, Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum Rejection {
    /// NaN or an infinity.
    #[error("the command is not a finite number")]
    NotFinite,
    /// A torque command for a joint without `torque_constant_nm_per_amp` in the description.
    #[error(
        "a torque was commanded but the joint has no torque_constant_nm_per_amp: command it in amperes or describe the constant"
    )]
    NoTorqueConstant,
    /// A [`JointId`](crate::JointId) that does not belong to this robot.
    #[error("no such joint in this robot")]
    UnknownJoint,
    /// A motion setpoint for a joint whose bus is not `exchange = "motion"`.
    #[error(
        "a motion setpoint was given to a joint whose bus has no motion mode: describe its bus with exchange = \"motion\" (MyActuator V3) or command currents"
    )]
    NoMotionMode,
    /// A motion setpoint beyond the joint's position limits or velocity limit.
    #[error("the motion setpoint is beyond the joint's position or velocity limits")]
    BeyondJointLimits,
    /// A motion field beyond what the motor's firmware can carry (kp, kd below zero or above
    /// their range, a position or velocity beyond the motion-mode range).
    #[error(
        "a motion field is beyond the firmware's motion-mode ranges (see `rmd_protocol::MitRanges`): lower the gains or the setpoint"
    )]
    OutOfMotionRange,
}
