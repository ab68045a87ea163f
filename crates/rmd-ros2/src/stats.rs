//! Counters of what the node published, accepted and rejected, shared between its DDS thread
//! and its handle.

use std::sync::atomic::{AtomicU64, Ordering};

use crate::kind::RejectionKind;

/// Which input topic a rejection or an acceptance came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InputTopic {
    /// `joint_commands`.
    JointCommands,
    /// `joint_trajectory`.
    JointTrajectory,
    /// The enable / estop topic.
    Enable,
}

#[derive(Debug, Default)]
pub(crate) struct Counters {
    joint_states: AtomicU64,
    diagnostics: AtomicU64,
    publish_errors: AtomicU64,
    accepted: [AtomicU64; 3],
    rejected: [AtomicU64; RejectionKind::ALL.len()],
}

impl Counters {
    pub(crate) fn joint_state_published(&self) {
        self.joint_states.fetch_add(1, Ordering::Relaxed);
    }

    pub(crate) fn diagnostics_published(&self) {
        self.diagnostics.fetch_add(1, Ordering::Relaxed);
    }

    pub(crate) fn publish_failed(&self) {
        self.publish_errors.fetch_add(1, Ordering::Relaxed);
    }

    pub(crate) fn accepted(&self, input: InputTopic) {
        self.accepted[input as usize].fetch_add(1, Ordering::Relaxed);
    }

    pub(crate) fn rejected(&self, kind: RejectionKind) {
        self.rejected[kind.index()].fetch_add(1, Ordering::Relaxed);
    }

    pub(crate) fn snapshot(&self) -> NodeStats {
        let load = |a: &AtomicU64| a.load(Ordering::Relaxed);
        NodeStats {
            joint_states_published: load(&self.joint_states),
            diagnostics_published: load(&self.diagnostics),
            publish_errors: load(&self.publish_errors),
            commands_accepted: load(&self.accepted[InputTopic::JointCommands as usize]),
            trajectories_accepted: load(&self.accepted[InputTopic::JointTrajectory as usize]),
            enables_accepted: load(&self.accepted[InputTopic::Enable as usize]),
            rejections: RejectionKind::ALL.map(|k| (k, load(&self.rejected[k.index()]))),
        }
    }
}

/// A snapshot of the node's counters.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NodeStats {
    /// `joint_states` messages published.
    pub joint_states_published: u64,
    /// `diagnostics` messages published.
    pub diagnostics_published: u64,
    /// Publications DDS refused (counted, never retried).
    pub publish_errors: u64,
    /// `joint_commands` messages passed to the port.
    pub commands_accepted: u64,
    /// `joint_trajectory` messages passed to the port.
    pub trajectories_accepted: u64,
    /// Enable / estop messages passed to the port.
    pub enables_accepted: u64,
    /// Rejected inputs per kind, in the order of [`RejectionKind::ALL`].
    pub rejections: [(RejectionKind, u64); RejectionKind::ALL.len()],
}

impl NodeStats {
    /// Rejections of one kind.
    pub fn rejected(&self, kind: RejectionKind) -> u64 {
        self.rejections[kind.index()].1
    }

    /// Rejections of all kinds.
    pub fn rejected_total(&self) -> u64 {
        self.rejections.iter().map(|(_, n)| n).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_land_in_their_own_slots() {
        let c = Counters::default();
        c.joint_state_published();
        c.joint_state_published();
        c.diagnostics_published();
        c.accepted(InputTopic::JointTrajectory);
        c.rejected(RejectionKind::NotFinite);
        c.rejected(RejectionKind::NotFinite);
        c.rejected(RejectionKind::PortRefused);
        let s = c.snapshot();
        assert_eq!(s.joint_states_published, 2);
        assert_eq!(s.diagnostics_published, 1);
        assert_eq!(s.commands_accepted, 0);
        assert_eq!(s.trajectories_accepted, 1);
        assert_eq!(s.rejected(RejectionKind::NotFinite), 2);
        assert_eq!(s.rejected(RejectionKind::PortRefused), 1);
        assert_eq!(s.rejected(RejectionKind::Empty), 0);
        assert_eq!(s.rejected_total(), 3);
    }
}
