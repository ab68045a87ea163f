//! What a MyActuator V3 motor says of itself at start-up: its firmware's version date (0xB2,
//! which decides the V4.3 or V4.4 layouts and the motion-mode ranges) and its model (0xB5: the
//! whole model in V4.3's form, five characters at a time in V4.4's). Read-only requests, one at
//! a time, each waited for up to the identification's timeout; a motor that does not answer one
//! (older firmware) leaves that item unknown.

use core::time::Duration;

use rmd_bus::{BusMessage, CanBus, Clock};
use rmd_protocol::{Dialect, ModelIndex, ModelPart, MotorId, Reply, Request, V3Revision};

/// A V3 motor's version date and model, as far as it answered.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub(crate) struct V3Versions {
    /// The version date, `YYYYMMDDNN` as 0xB2 reports it.
    pub(crate) firmware_date: Option<u32>,
    /// The model text.
    pub(crate) model: Option<String>,
}

/// Asks motor `motor` (speaking `dialect`) on `bus` for its version date, then its model.
pub(crate) fn read_v3<B: CanBus, C: Clock>(
    bus: &mut B,
    clock: &C,
    dialect: Dialect,
    motor: MotorId,
    timeout: Duration,
) -> V3Versions {
    let mut ask = |request: Request| ask(bus, clock, dialect, motor, &request, timeout);
    let date = match ask(Request::ReadFirmwareDate) {
        Some(Reply::ReadFirmwareDate(date)) => Some(date),
        _ => None,
    };
    let parts: &[ModelPart] = match date.map(|d| d.revision()) {
        Some(V3Revision::V4_4) => &V4_4_PARTS,
        Some(V3Revision::V4_3) | None => &[ModelPart::Whole],
    };
    let mut model = String::new();
    for &part in parts {
        match ask(Request::ReadModel { part }) {
            Some(Reply::ReadModel(text)) => match text.text() {
                Some(text) => model.push_str(text),
                None => break,
            },
            _ => break,
        }
    }
    V3Versions {
        firmware_date: date.map(|d| d.raw()),
        model: (!model.is_empty()).then_some(model),
    }
}

/// The three parts of V4.4's model (checked at compile time).
const V4_4_PARTS: [ModelPart; 3] = [
    ModelPart::Chars(index(1)),
    ModelPart::Chars(index(2)),
    ModelPart::Chars(index(3)),
];

/// Model index `n` (1..=3), in constants.
const fn index(n: u8) -> ModelIndex {
    match ModelIndex::new(n) {
        Ok(index) => index,
        Err(_) => panic!("1..=3 are model indices"),
    }
}

/// Sends `request` and waits up to `timeout` for its answer (other frames are passed over: at
/// start-up nothing else is asked).
fn ask<B: CanBus, C: Clock>(
    bus: &mut B,
    clock: &C,
    dialect: Dialect,
    motor: MotorId,
    request: &Request,
    timeout: Duration,
) -> Option<Reply> {
    let frame = dialect.encode(motor, request).ok()?;
    bus.send(&frame).ok()?;
    let give_up = clock.now() + timeout;
    while let Ok(Some(received)) = bus.recv_until(give_up) {
        if let BusMessage::Frame(frame) = received.message
            && let Ok(reply) = dialect.decode_answer(&frame, motor, request.command())
        {
            return Some(reply);
        }
    }
    None
}
