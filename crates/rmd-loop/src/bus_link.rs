//! One bus of the loop and the joints on it.

use core::ops::Range;

use crate::robot::{BusSpec, ExchangeKind};

/// The requests of one exchange on a bus (its [`ExchangeKind`], with a `multi-torque` bus's
/// motors beyond id 4 told apart once, so that sending is one dispatch).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) enum Requests {
    /// One 0x280 frame (`multi-torque`, ids 1..=4 only).
    Frame,
    /// One 0x280 frame, then an 0xA1 request for each motor beyond id 4 (`multi-torque`).
    FrameAndBeyond,
    /// One 0xA1 request per motor (`per-motor`).
    PerMotor,
    /// One motion-mode command per motor (`motion`).
    Motion,
}

/// A bus and the consecutive range of joints (motors) it carries.
#[derive(Debug)]
pub(crate) struct BusLink<B> {
    pub(crate) bus: B,
    pub(crate) joints: Range<usize>,
    /// How torque is exchanged on it.
    pub(crate) exchange: ExchangeKind,
    /// The requests of its exchange, as sending them goes.
    pub(crate) requests: Requests,
    /// Whether torque was ever sent on it (before that, nothing needs undoing).
    pub(crate) commanded: bool,
    /// The health rotation: the motor (index) whose status the next tick asks for; `None`: no
    /// rotation on this bus.
    pub(crate) health_next: Option<usize>,
}

impl<B> BusLink<B> {
    /// The link of `bus`, described by `spec`: nothing commanded yet, no health rotation.
    pub(crate) fn new(bus: B, spec: &BusSpec) -> Self {
        Self {
            bus,
            joints: spec.joint_range(),
            exchange: spec.exchange,
            requests: match spec.exchange {
                ExchangeKind::MultiTorque if spec.requests_per_exchange() > 1 => {
                    Requests::FrameAndBeyond
                }
                ExchangeKind::MultiTorque => Requests::Frame,
                ExchangeKind::PerMotor => Requests::PerMotor,
                ExchangeKind::Motion => Requests::Motion,
            },
            commanded: false,
            health_next: None,
        }
    }

    /// The joints on this bus, as indices in description order.
    pub(crate) fn joints(&self) -> Range<usize> {
        self.joints.clone()
    }
}
