//! The frames of an exchange: the 0x280 torque frame out, and matching what comes back to the
//! bus's motors (one decode-and-match for the tick and the safe stop alike).

use core::ops::Range;

use rmd_protocol::{
    CanFrame, Command, IqControl, MULTI_TORQUE_MOTORS, MotorId, MultiTorque, Reply, decode_reply_to,
};

use super::motor::MotorLink;

/// One bus's torque commands, by slot (motor id - 1).
pub(crate) type TorqueSlots = [IqControl; MULTI_TORQUE_MOTORS];

/// No torque current.
const ZERO_IQ: IqControl = match IqControl::new(0) {
    Ok(zero) => zero,
    Err(_) => panic!("0 is a valid iqControl"),
};

/// Zero torque for every motor of a bus.
pub(crate) const ZERO_TORQUE: TorqueSlots = [ZERO_IQ; MULTI_TORQUE_MOTORS];

/// The 0x280 frame carrying `slots`.
pub(crate) fn torque_frame(slots: &TorqueSlots) -> CanFrame {
    MultiTorque::new(*slots).encode()
}

/// What a received frame is to the bus's motors.
#[derive(Copy, Clone, Debug, PartialEq)]
pub(crate) enum Incoming {
    /// A reply of motor `motor` (index in description order) to the expected command.
    Reply {
        /// The motor, as an index in description order.
        motor: usize,
        /// The decoded reply.
        reply: Reply,
    },
    /// A frame on the id of motor `motor` that is not a valid reply to the expected command.
    Bad {
        /// The motor, as an index in description order.
        motor: usize,
    },
    /// A frame of no motor on this bus (another id, a request, someone else's traffic).
    Foreign,
}

/// Decodes `frame` as a reply to `expect` and finds which of the motors `joints` sent it.
pub(crate) fn match_reply(
    frame: &CanFrame,
    expect: Command,
    motors: &[MotorLink],
    joints: Range<usize>,
) -> Incoming {
    let decoded = decode_reply_to(frame, expect);
    let id = match decoded {
        Ok((id, _)) => Some(id),
        Err(_) => MotorId::from_can_id(frame.id()).ok(),
    };
    let Some(motor) = id.and_then(|id| joints.clone().find(|&m| motors[m].id == id)) else {
        return Incoming::Foreign;
    };
    match decoded {
        Ok((_, reply)) => Incoming::Reply { motor, reply },
        Err(_) => Incoming::Bad { motor },
    }
}
