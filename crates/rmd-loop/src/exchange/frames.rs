//! The frames of an exchange: the 0x280 torque frame or the per-motor 0xA1 requests out, and
//! what each motor's reply looks like, decided once per motor ([`ReplyExpectation`]).

use rmd_protocol::{
    CanFrame, Command, CurrentScale, Dialect, MULTI_TORQUE_CAN_ID, MULTI_TORQUE_MOTORS, MotorId,
    MultiTorque, Request, ScaledCurrent, Status2, V3_MOTION_REPLY_BASE_ID,
};

use crate::robot::JointSpec;

/// One bus's torque commands as the data of its 0x280 frame: slot `i` (motor id `i + 1`) holds
/// its motor's raw command, in that motor's command scale, little-endian in bytes `2i..2i + 2`
/// (the layout of [`MultiTorque::to_data`]).
pub(crate) type TorqueSlots = [u8; 8];

/// No torque current (raw 0 is 0 A in every dialect).
const ZERO_IQ: ScaledCurrent = match ScaledCurrent::new(0, CurrentScale::V161_IQ_CONTROL) {
    Ok(zero) => zero,
    Err(_) => panic!("0 is a valid current"),
};

/// Zero torque for every motor of a bus.
pub(crate) const ZERO_TORQUE: TorqueSlots =
    MultiTorque::new([ZERO_IQ; MULTI_TORQUE_MOTORS]).to_data();

/// Puts `iq` in slot `slot` of `slots` (as [`MultiTorque::to_data`] does); a slot beyond the
/// frame's four is left alone.
#[inline]
pub(crate) fn set_torque_slot(slots: &mut TorqueSlots, slot: usize, iq: ScaledCurrent) {
    if let Some(bytes) = slots.get_mut(2 * slot..2 * slot + 2) {
        bytes.copy_from_slice(&iq.raw().to_le_bytes());
    }
}

/// The 0x280 frame carrying `slots`.
#[inline]
pub(crate) fn torque_frame(slots: &TorqueSlots) -> CanFrame {
    match CanFrame::with_data(MULTI_TORQUE_CAN_ID, *slots) {
        Ok(frame) => frame,
        Err(_) => unreachable!("0x280 is a standard CAN id"),
    }
}

/// The 0xA1 torque request of `iq` to `motor` in its `dialect` (`0x140 + id`). `iq` is in the
/// dialect's command scale (the loop builds it so); were it not, the frame would be motor-off,
/// never a current in another family's scale.
#[inline]
pub(crate) fn torque_request(dialect: Dialect, motor: MotorId, iq: ScaledCurrent) -> CanFrame {
    dialect
        .encode(motor, &Request::Torque { iq_control: iq })
        .unwrap_or_else(|_| dialect.motor_off(motor))
}

/// Zero torque in `dialect`'s command scale.
pub(crate) fn zero_iq(dialect: Dialect) -> ScaledCurrent {
    ScaledCurrent::saturating(0, dialect.iq_control_scale())
}

/// The expected command byte of a motor that sends no torque replies: no byte equals it.
const NO_TORQUE_REPLY: u16 = 0x100;

/// The reply a motor owes for a request, decided once when the loop is built: the CAN id it
/// comes on, the command byte in its DATA\[0\], and the dialect its status is read in. Matching
/// a received frame is then an id comparison per motor of the bus, and decoding it one check
/// of the command byte and the field ranges.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) struct ReplyExpectation {
    /// The CAN id of the motor's replies.
    pub(crate) can_id: u16,
    /// DATA\[0\] of the reply; [`NO_TORQUE_REPLY`] (no byte) when the motor's replies are not
    /// torque replies (a `motion` bus's).
    command: u16,
    /// The dialect its status is read in (the `iq` scale, what DATA\[6..=7\] holds).
    dialect: Dialect,
}

impl ReplyExpectation {
    /// What joint `joint`'s motor answers to a torque request (the 0x280 frame or its own
    /// 0xA1): the 0xA1 reply (status 2) on its dialect's reply id (`0x140 + id`, V3
    /// `0x240 + id`), with its dialect's `iq` scale.
    pub(crate) fn torque(joint: &JointSpec) -> Self {
        Self {
            can_id: joint.dialect.reply_id(joint.motor),
            command: u16::from(Command::Torque.code()),
            dialect: joint.dialect,
        }
    }

    /// What joint `joint`'s motor answers to a motion-mode command: `0x500 + id`, never a
    /// torque reply, whatever its DATA\[0\] ([`decode`](Self::decode) passes every frame by to
    /// the motion-mode decoder).
    pub(crate) fn motion(joint: &JointSpec) -> Self {
        Self {
            can_id: V3_MOTION_REPLY_BASE_ID + u16::from(joint.motor.get()),
            command: NO_TORQUE_REPLY,
            dialect: joint.dialect,
        }
    }

    /// The status in `frame` if it is the expected reply (8 bytes, the command byte, every field
    /// in range), else `None`: a bad frame on this motor's id.
    #[inline]
    pub(crate) fn decode(&self, frame: &CanFrame) -> Option<Status2> {
        let data = frame.data8()?;
        if u16::from(data[0]) != self.command {
            return None;
        }
        Status2::from_data(data, self.dialect).ok()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robot::{BusConfig, MotorConfig, Robot, RobotConfig};
    use rmd_protocol::{LkSeries, MotorId};

    #[test]
    fn staged_slots_make_the_frame_multi_torque_encodes() {
        let scales = [
            CurrentScale::V161_IQ_CONTROL,
            CurrentScale::LK_MF_IQ_CONTROL,
            CurrentScale::LK_MG_IQ_CONTROL,
            CurrentScale::MYACTUATOR_V3_IQ_CONTROL,
        ];
        for raw in [0i64, 1, -1, 255, -256, 1000, -2000, 2000, 2048, -2048] {
            let iq: [ScaledCurrent; MULTI_TORQUE_MOTORS] = core::array::from_fn(|i| {
                ScaledCurrent::saturating(raw * (i as i64 - 1), scales[i])
            });
            let mut slots = ZERO_TORQUE;
            for (slot, iq) in iq.iter().enumerate() {
                set_torque_slot(&mut slots, slot, *iq);
            }
            set_torque_slot(&mut slots, MULTI_TORQUE_MOTORS, iq[0]);
            assert_eq!(torque_frame(&slots), MultiTorque::new(iq).encode(), "{raw}");
        }
        assert_eq!(
            torque_frame(&ZERO_TORQUE),
            MultiTorque::new([ZERO_IQ; MULTI_TORQUE_MOTORS]).encode()
        );
    }

    fn joint(dialect: &str, series: Option<&str>) -> JointSpec {
        let motor = MotorConfig::new(3).protocol(dialect, series);
        let robot = Robot::try_from(
            RobotConfig::new(100.0).with_bus(BusConfig::new("can0").with_motor(motor)),
        )
        .unwrap();
        robot.joints()[0].clone()
    }

    /// Frames on motor 3's id: valid replies of several kinds, and broken ones.
    fn frames() -> Vec<CanFrame> {
        let mut frames = Vec::new();
        for command in [0xA1, 0x9C, 0xA2, 0x9A, 0x00, 0xFF] {
            for iq in [0i16, 100, -2048, 2048, 2049, -2049, i16::MAX] {
                for temperature in [30u8, 0x80] {
                    let [lo, hi] = iq.to_le_bytes();
                    let data = [command, temperature, lo, hi, 0x10, 0x00, 0x34, 0x12];
                    frames.push(CanFrame::new(0x143, &data).unwrap());
                    frames.push(CanFrame::new(0x143, &data[..7]).unwrap());
                }
            }
        }
        frames
    }

    #[test]
    fn a_motion_reply_is_never_read_as_a_torque_reply() {
        let motor = MotorConfig::new(3)
            .protocol("myactuator-v3", None)
            .torque_constant(2.0);
        let robot = Robot::try_from(
            RobotConfig::new(100.0).with_bus(
                BusConfig::new("can0")
                    .exchange(crate::robot::ExchangeKind::Motion)
                    .with_motor(motor),
            ),
        )
        .unwrap();
        let expect = ReplyExpectation::motion(&robot.joints()[0]);
        assert_eq!(expect.can_id, 0x503);
        // A motion reply whose DATA[0] was corrupted into 0xA1: valid as a V3 torque reply's
        // bytes, but not one.
        let corrupted = CanFrame::new(0x503, &[0xA1, 30, 0x10, 0, 0x10, 0, 0x34, 0x12]).unwrap();
        assert!(
            ReplyExpectation::torque(&robot.joints()[0])
                .decode(&corrupted)
                .is_some()
        );
        assert_eq!(expect.decode(&corrupted), None);
        for frame in frames() {
            assert_eq!(expect.decode(&frame), None, "{frame}");
        }
    }

    #[test]
    fn decoding_agrees_with_the_protocol_decoder_in_every_dialect() {
        for (name, series, dialect) in [
            ("v1.61", None, Dialect::V161),
            ("lk-v2.3x", Some("mf"), Dialect::LkV23x(LkSeries::Mf)),
            ("lk-v2.3x", Some("mg"), Dialect::LkV23x(LkSeries::Mg)),
        ] {
            let expect = ReplyExpectation::torque(&joint(name, series));
            assert_eq!(expect.can_id, MotorId::new(3).unwrap().can_id());
            for frame in frames() {
                let reference = dialect
                    .decode_reply_to(&frame, Command::Torque)
                    .ok()
                    .and_then(|(_, reply)| reply.status2());
                assert_eq!(expect.decode(&frame), reference, "{name} {frame}");
            }
        }
    }
}
