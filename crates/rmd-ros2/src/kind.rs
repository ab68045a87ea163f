//! [`RejectionKind`]: the counters of refused network input, shared by the validator, the port
//! and the node's statistics.

/// The kinds of [`MessageRejection`](crate::MessageRejection), plus the failures that are not about a
/// message's values as the node checks them (undecodable samples, inputs the port refused or
/// found infeasible); used to count them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum RejectionKind {
    /// [`crate::MessageRejection::Empty`].
    Empty,
    /// [`crate::MessageRejection::UnknownJoint`].
    UnknownJoint,
    /// [`crate::MessageRejection::DuplicateJoint`].
    DuplicateJoint,
    /// [`crate::MessageRejection::LengthMismatch`] and [`crate::MessageRejection::MissingField`].
    LengthMismatch,
    /// [`crate::MessageRejection::NotFinite`].
    NotFinite,
    /// [`crate::MessageRejection::OutOfLimit`].
    OutOfLimit,
    /// [`crate::MessageRejection::TimeNotIncreasing`] and [`crate::MessageRejection::BadTime`].
    BadTime,
    /// [`crate::MessageRejection::Unsupported`].
    Unsupported,
    /// A trajectory the robot cannot follow as given, found by the robot's own checks
    /// ([`crate::PortError::Invalid`]): too many points, not ending at rest, no motion within
    /// the joint's limits reaching a point.
    Infeasible,
    /// A sample DDS delivered but that did not decode as the topic's type.
    Malformed,
    /// A valid input the port refused ([`crate::PortError`]).
    PortRefused,
    /// A sample over the node's [`crate::InputLimits`]: a string or array too long (refused
    /// while decoding, [`crate::Oversize`]), or a sample too large (dropped by the DDS layer
    /// before it was reassembled).
    Oversized,
}

impl RejectionKind {
    /// Every kind, in a fixed order (the order of [`crate::NodeStats::rejections`]).
    pub const ALL: [RejectionKind; 12] = [
        RejectionKind::Empty,
        RejectionKind::UnknownJoint,
        RejectionKind::DuplicateJoint,
        RejectionKind::LengthMismatch,
        RejectionKind::NotFinite,
        RejectionKind::OutOfLimit,
        RejectionKind::BadTime,
        RejectionKind::Unsupported,
        RejectionKind::Infeasible,
        RejectionKind::Malformed,
        RejectionKind::PortRefused,
        RejectionKind::Oversized,
    ];

    /// A short snake_case name (the key in diagnostics).
    pub fn name(self) -> &'static str {
        match self {
            RejectionKind::Empty => "empty",
            RejectionKind::UnknownJoint => "unknown_joint",
            RejectionKind::DuplicateJoint => "duplicate_joint",
            RejectionKind::LengthMismatch => "length_mismatch",
            RejectionKind::NotFinite => "not_finite",
            RejectionKind::OutOfLimit => "out_of_limit",
            RejectionKind::BadTime => "bad_time",
            RejectionKind::Unsupported => "unsupported",
            RejectionKind::Infeasible => "infeasible",
            RejectionKind::Malformed => "malformed",
            RejectionKind::PortRefused => "port_refused",
            RejectionKind::Oversized => "oversized",
        }
    }

    /// Position in [`RejectionKind::ALL`].
    pub(crate) fn index(self) -> usize {
        self as usize
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_kind_has_a_distinct_name_and_index() {
        for (i, k) in RejectionKind::ALL.iter().enumerate() {
            assert_eq!(k.index(), i);
            assert_eq!(
                RejectionKind::ALL
                    .iter()
                    .filter(|o| o.name() == k.name())
                    .count(),
                1
            );
        }
    }
}
