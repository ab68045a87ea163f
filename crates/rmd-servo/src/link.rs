//! The link between the servo's handles and its controller on the loop thread: the atomics they
//! share (the enable level with its epoch, the estop latch, whether the servo runs, the
//! handle's refusal counters) and the messages the handles queue. Neither side waits for the
//! other (but for a mailbox operation half done on the same slot: see `rmd_loop::mailbox`).

use core::sync::atomic::{AtomicBool, AtomicU8, AtomicU64, Ordering};

use rmd_loop::robot::MAX_JOINTS;

use crate::setpoint::Setpoint;
use crate::trajectory::buffer::TrajectoryBuffer;

/// The servo's life: built, running, ended.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) enum Life {
    Built = 0,
    Running = 1,
    Ended = 2,
}

/// The enable level and its epoch: every enable or disable starts a new epoch, and the loop
/// thread drops messages sent in an earlier one (so that a setpoint sent before a disable never
/// applies after it, even if the servo was enabled again before the loop thread looked).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) struct Control {
    pub(crate) epoch: u64,
    pub(crate) enabled: bool,
}

impl Control {
    fn word(self) -> u64 {
        (self.epoch << 1) | u64::from(self.enabled)
    }

    fn from_word(word: u64) -> Self {
        Self {
            epoch: word >> 1,
            enabled: word & 1 == 1,
        }
    }
}

/// What the servo's handles and its controller share: the enable level with its epoch, the
/// estop latch, the servo's life and the refusal counters (atomics only).
#[derive(Debug)]
pub(crate) struct ServoLink {
    control: AtomicU64,
    estop: AtomicBool,
    life: AtomicU8,
    /// Refusals per joint.
    rejected: [AtomicU64; MAX_JOINTS],
    /// Refusals naming no joint of the robot.
    rejected_unattributed: AtomicU64,
}

impl ServoLink {
    pub(crate) fn new(enabled: bool) -> Self {
        Self {
            control: AtomicU64::new(Control { epoch: 0, enabled }.word()),
            estop: AtomicBool::new(false),
            life: AtomicU8::new(Life::Built as u8),
            rejected: [const { AtomicU64::new(0) }; MAX_JOINTS],
            rejected_unattributed: AtomicU64::new(0),
        }
    }

    pub(crate) fn control(&self) -> Control {
        Control::from_word(self.control.load(Ordering::Acquire))
    }

    /// Sets the enable level; a change starts a new epoch. Returns the new control.
    pub(crate) fn set_enabled(&self, enabled: bool) -> Control {
        let word = self
            .control
            .fetch_update(Ordering::AcqRel, Ordering::Acquire, |word| {
                let c = Control::from_word(word);
                (c.enabled != enabled).then(|| {
                    Control {
                        epoch: c.epoch + 1,
                        enabled,
                    }
                    .word()
                })
            })
            .map_or_else(
                |unchanged| unchanged,
                |previous| {
                    Control {
                        epoch: Control::from_word(previous).epoch + 1,
                        enabled,
                    }
                    .word()
                },
            );
        Control::from_word(word)
    }

    pub(crate) fn estop(&self) {
        self.estop.store(true, Ordering::Release);
    }

    pub(crate) fn estopped(&self) -> bool {
        self.estop.load(Ordering::Acquire)
    }

    pub(crate) fn life(&self) -> Life {
        match self.life.load(Ordering::Acquire) {
            0 => Life::Built,
            1 => Life::Running,
            _ => Life::Ended,
        }
    }

    pub(crate) fn set_life(&self, life: Life) {
        self.life.store(life as u8, Ordering::Release);
    }

    pub(crate) fn count_rejection(&self, joint: Option<usize>) {
        match joint.and_then(|j| self.rejected.get(j)) {
            Some(counter) => counter.fetch_add(1, Ordering::Relaxed),
            None => self.rejected_unattributed.fetch_add(1, Ordering::Relaxed),
        };
    }

    pub(crate) fn rejected(&self, joint: usize) -> u64 {
        self.rejected
            .get(joint)
            .map_or(0, |c| c.load(Ordering::Relaxed))
    }

    pub(crate) fn rejected_unattributed(&self) -> u64 {
        self.rejected_unattributed.load(Ordering::Relaxed)
    }
}

/// Setpoints for several joints, applied in one tick: entry `i` is joint `i`'s.
#[derive(Copy, Clone, Debug)]
pub(crate) struct Batch {
    pub(crate) entries: [Option<Setpoint>; MAX_JOINTS],
}

impl Batch {
    pub(crate) const EMPTY: Batch = Batch {
        entries: [None; MAX_JOINTS],
    };
}

/// A message to the loop thread. Stored by value in the preallocated queue (the batch is not
/// boxed: that would allocate per message).
#[derive(Debug)]
#[allow(clippy::large_enum_variant)]
pub(crate) enum Message {
    /// Setpoints, sent in `epoch`.
    Setpoints {
        /// The enable epoch it was sent in.
        epoch: u64,
        /// The setpoints.
        batch: Batch,
    },
    /// A planned trajectory (its buffer carries its epoch).
    Trajectory(Box<TrajectoryBuffer>),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_change_of_the_enable_level_starts_an_epoch() {
        let s = ServoLink::new(true);
        assert_eq!(
            s.control(),
            Control {
                epoch: 0,
                enabled: true
            }
        );
        assert_eq!(
            s.set_enabled(true),
            Control {
                epoch: 0,
                enabled: true
            }
        );
        assert_eq!(
            s.set_enabled(false),
            Control {
                epoch: 1,
                enabled: false
            }
        );
        assert_eq!(
            s.set_enabled(false),
            Control {
                epoch: 1,
                enabled: false
            }
        );
        assert_eq!(
            s.set_enabled(true),
            Control {
                epoch: 2,
                enabled: true
            }
        );
        assert_eq!(
            s.control(),
            Control {
                epoch: 2,
                enabled: true
            }
        );
    }

    #[test]
    fn refusals_are_counted_per_joint_or_unattributed() {
        let s = ServoLink::new(true);
        s.count_rejection(Some(2));
        s.count_rejection(Some(2));
        s.count_rejection(None);
        s.count_rejection(Some(MAX_JOINTS + 3));
        assert_eq!(s.rejected(2), 2);
        assert_eq!(s.rejected(0), 0);
        assert_eq!(s.rejected_unattributed(), 2);
    }
}
