//! One bus of the loop and the joints on it.

use core::ops::Range;

use crate::robot::ExchangeKind;

/// A bus and the consecutive range of joints (motors) it carries.
#[derive(Debug)]
pub(crate) struct BusLink<B> {
    pub(crate) bus: B,
    pub(crate) joints: Range<usize>,
    /// How torque is exchanged on it.
    pub(crate) exchange: ExchangeKind,
    /// Whether torque was ever sent on it (before that, nothing needs undoing).
    pub(crate) commanded: bool,
    /// The health rotation: the motor (index) whose status the next tick asks for; `None`: no
    /// rotation on this bus.
    pub(crate) health_next: Option<usize>,
}

impl<B> BusLink<B> {
    /// The joints on this bus, as indices in description order.
    pub(crate) fn joints(&self) -> Range<usize> {
        self.joints.clone()
    }
}
