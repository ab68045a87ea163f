//! The fields of every protocol, as errors name them.

use core::fmt;

/// A field of a frame, named in errors after the manual's variable (in snake_case).
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Field {
    /// `iqControl` of 0xA1 and 0x280.
    IqControl,
    /// `speedControl` of 0xA2.
    SpeedControl,
    /// `angleControl` of 0xA3 / 0xA4 (multi-turn, i32).
    AngleControl,
    /// `angleControl` of 0xA5 / 0xA6 (single-turn, 0..=35999).
    SingleTurnAngleControl,
    /// `maxSpeed` of 0xA4 / 0xA6.
    MaxSpeed,
    /// `spinDirection` of 0xA5 / 0xA6.
    SpinDirection,
    /// `Accel` of 0x33 / 0x34.
    Accel,
    /// An encoder value (`encoder`, `encoderRaw`, `encoderOffset`), checked against the width.
    EncoderValue,
    /// An encoder width in bits.
    EncoderWidth,
    /// `iq`, the torque current in replies.
    Iq,
    /// `speed`, the speed in replies.
    Speed,
    /// `temperature`.
    Temperature,
    /// `voltage`.
    Voltage,
    /// A phase current (`iA`, `iB`, `iC`).
    PhaseCurrent,
    /// `motorAngle` of the 0x92 reply.
    MotorAngle,
    /// `circleAngle` of the 0x94 reply.
    CircleAngle,
    /// `current`, the bus current of LK-TECH's 0x9A reply.
    BusCurrent,
    /// `maxTorque` of MyActuator V3's 0xA2 (percent of the rated current).
    MaxTorque,
    /// The function index of MyActuator V3's 0x20.
    FunctionIndex,
    /// The model-string index of MyActuator V3's 0xB5 (V4.4 form).
    ModelIndex,
    /// `p_des` / `p` of MyActuator V3's motion-mode frames.
    MitPosition,
    /// `v_des` / `v` of MyActuator V3's motion-mode frames.
    MitVelocity,
    /// `kp` of MyActuator V3's motion-mode command.
    MitKp,
    /// `kd` of MyActuator V3's motion-mode command.
    MitKd,
    /// `t_ff` / `t` of MyActuator V3's motion-mode frames.
    MitTorque,
    /// A motor's maximum torque, the motion-mode torque range of V4.4 firmware.
    MotorMaxTorque,
    /// The output-shaft angle of MyActuator V3's status 2 (whole degrees).
    OutputAngle,
}

impl Field {
    /// The field's name as used in messages and in the CLI's JSON (snake_case spec name).
    pub const fn name(self) -> &'static str {
        match self {
            Field::IqControl => "iq_control",
            Field::SpeedControl => "speed_control",
            Field::AngleControl | Field::SingleTurnAngleControl => "angle_control",
            Field::MaxSpeed => "max_speed",
            Field::SpinDirection => "spin_direction",
            Field::Accel => "accel",
            Field::EncoderValue => "encoder value",
            Field::EncoderWidth => "encoder width (bits)",
            Field::Iq => "iq",
            Field::Speed => "speed",
            Field::Temperature => "temperature",
            Field::Voltage => "voltage",
            Field::PhaseCurrent => "phase current",
            Field::MotorAngle => "motor_angle",
            Field::CircleAngle => "circle_angle",
            Field::BusCurrent => "bus_current",
            Field::MaxTorque => "max_torque",
            Field::FunctionIndex => "function_index",
            Field::ModelIndex => "model_index",
            Field::MitPosition => "p_des",
            Field::MitVelocity => "v_des",
            Field::MitKp => "kp",
            Field::MitKd => "kd",
            Field::MitTorque => "t_ff",
            Field::MotorMaxTorque => "motor max torque (milli-N·m)",
            Field::OutputAngle => "output_angle",
        }
    }
}

impl fmt::Display for Field {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}
