//! One bus of the loop and the joints on it.

use core::ops::Range;

/// A bus and the consecutive range of joints (motors) it carries.
#[derive(Debug)]
pub(crate) struct BusLink<B> {
    pub(crate) bus: B,
    pub(crate) joints: Range<usize>,
    /// Whether a 0x280 frame was ever sent on it (before that, nothing needs undoing).
    pub(crate) commanded: bool,
}

impl<B> BusLink<B> {
    /// The joints on this bus, as indices in description order.
    pub(crate) fn joints(&self) -> Range<usize> {
        self.joints.clone()
    }
}
