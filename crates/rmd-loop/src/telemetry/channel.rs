//! The channel the loop publishes its samples through, without copying them.
//!
//! A [`TelemetrySample`] is sized for the largest robot (a few kilobytes), so moving one by value
//! through a queue costs several copies of it per tick. Instead the channel allocates, once, a
//! pool of boxed samples that travel between two [`mailbox`]es: `queued` (loop to receivers) and
//! `free` (receivers back to the loop). The loop takes a box from `free`, fills in only its
//! robot's joints and queues it (when the receivers have fallen behind, the oldest queued box is
//! pushed out: that sample is overwritten, and its box goes back to `free`); a receiver takes
//! one, copies the sample out on its own thread and gives the box back. Only pointers cross the
//! mailboxes: no allocation, no lock, no system call on the loop's side (and no wait, but for a
//! receiver's operation half done on the same slot: see [`crate::mailbox`]).

use super::TelemetrySample;
use crate::mailbox::{Receiver, Sender, mailbox};

/// Boxes beyond the channel's capacity: one the loop fills while `queued` is at capacity, and
/// some that receivers on several threads hold while they copy a sample out.
const SPARE_BOXES: usize = 4;

type Slot = Box<TelemetrySample>;

/// Creates a channel holding up to `capacity` samples (at least 1) of `joints` joints and
/// `signals` user signals. Allocates every box now.
pub(crate) fn channel(
    capacity: usize,
    joints: usize,
    signals: usize,
) -> (TelemetrySender, TelemetryReceiver) {
    let capacity = capacity.max(1);
    let boxes = capacity + SPARE_BOXES;
    let (queue, queued) = mailbox(capacity);
    let (give_back, free) = mailbox(boxes);
    for _ in 0..boxes {
        // Cannot fail: the mailbox holds exactly `boxes`.
        let _ = give_back.send(Box::new(TelemetrySample::new(joints, signals)));
    }
    (
        TelemetrySender {
            queue,
            free,
            spare: None,
        },
        TelemetryReceiver { queued, give_back },
    )
}

/// What became of a sample the loop published.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) enum Published {
    /// Queued, nothing lost.
    Queued,
    /// Queued in place of the oldest queued sample, which is lost.
    Overwrote,
    /// Not queued: no box was free (receivers hold them all) or, when asked not to overwrite,
    /// the channel is full.
    NotQueued,
}

/// The loop's end (one per loop: not `Clone`).
#[derive(Debug)]
pub(crate) struct TelemetrySender {
    queue: Sender<Slot>,
    free: Receiver<Slot>,
    /// The box of the sample last pushed out of `queue`, kept for the next one: while the
    /// receivers are behind, each publish is one queue operation, not three.
    spare: Option<Slot>,
}

impl TelemetrySender {
    /// Whether a receiver still exists.
    pub(crate) fn has_receivers(&self) -> bool {
        self.queue.has_receivers()
    }

    /// Fills a box with `fill` and queues it. With `overwrite`, a full channel loses its oldest
    /// sample; without, a full channel leaves `fill` uncalled and returns
    /// [`Published::NotQueued`].
    #[inline(always)]
    pub(crate) fn publish(
        &mut self,
        overwrite: bool,
        fill: impl FnOnce(&mut TelemetrySample),
    ) -> Published {
        // The loop is the only producer: once `queue` has room, only receivers touch it, and
        // they only make more.
        if !overwrite && self.queue.len() >= self.queue.capacity() {
            return Published::NotQueued;
        }
        let Some(mut slot) = self.spare.take().or_else(|| self.free.try_recv()) else {
            return Published::NotQueued;
        };
        fill(&mut slot);
        match self.queue.send_overwrite(slot) {
            None => Published::Queued,
            Some(oldest) => {
                self.spare = Some(oldest);
                Published::Overwrote
            }
        }
    }
}

/// The receiving end of the loop's telemetry ([`RtLoop::telemetry`](crate::RtLoop::telemetry)).
/// Clone it to receive on several threads (each sample is received once). Receiving copies the
/// sample out on the receiver's thread; it never allocates, locks or blocks.
///
/// ```
/// use rmd_loop::telemetry::TelemetryReceiver;
///
/// fn newest_tick(samples: &TelemetryReceiver) -> Option<u64> {
///     samples.latest().map(|sample| sample.tick)
/// }
/// ```
#[derive(Clone, Debug)]
pub struct TelemetryReceiver {
    queued: Receiver<Slot>,
    give_back: Sender<Slot>,
}

impl TelemetryReceiver {
    /// Whether the loop still publishes: once it does not and the channel is empty, nothing more
    /// will come (the loop has finished, or published to a newer receiver).
    pub fn has_senders(&self) -> bool {
        self.queued.has_senders()
    }

    /// The oldest queued sample, if any.
    pub fn try_recv(&self) -> Option<TelemetrySample> {
        self.queued.try_recv().map(|slot| self.copy_out(slot))
    }

    /// The newest queued sample, discarding older ones; `None` if nothing was queued.
    pub fn latest(&self) -> Option<TelemetrySample> {
        self.queued
            .latest_with(|older| {
                let _ = self.give_back.send(older);
            })
            .map(|slot| self.copy_out(slot))
    }

    /// Takes every queued sample, oldest first.
    pub fn drain(&self) -> impl Iterator<Item = TelemetrySample> + '_ {
        std::iter::from_fn(|| self.try_recv())
    }

    /// Number of queued samples.
    pub fn len(&self) -> usize {
        self.queued.len()
    }

    /// Whether nothing is queued.
    pub fn is_empty(&self) -> bool {
        self.queued.is_empty()
    }

    /// How many samples the channel holds before the loop overwrites (or waits).
    pub fn capacity(&self) -> usize {
        self.queued.capacity()
    }

    /// The sample in `slot`, the box given back to the loop.
    fn copy_out(&self, slot: Slot) -> TelemetrySample {
        let sample = *slot;
        // Cannot fail: `free` holds every box.
        let _ = self.give_back.send(slot);
        sample
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tick(sample: &TelemetrySample) -> u64 {
        sample.tick
    }

    fn publish(tx: &mut TelemetrySender, overwrite: bool, n: u64) -> Published {
        tx.publish(overwrite, |s| {
            s.tick = n;
            if let Some(last) = s.joints_mut().last_mut() {
                last.command_amps = n as f64;
            }
        })
    }

    #[test]
    fn samples_arrive_in_order_with_their_joints() {
        let (mut tx, rx) = channel(3, 2, 0);
        for n in 0..3 {
            assert_eq!(publish(&mut tx, true, n), Published::Queued);
        }
        let got: Vec<_> = rx.drain().collect();
        assert_eq!(got.iter().map(tick).collect::<Vec<_>>(), vec![0, 1, 2]);
        assert_eq!(got[2].joints().len(), 2);
        assert_eq!(got[2].joints()[1].command_amps, 2.0);
        assert_eq!(got[2].joints()[0].command_amps, 0.0, "only what was filled");
        assert!(rx.is_empty());
    }

    #[test]
    fn a_full_channel_overwrites_the_oldest_or_refuses() {
        let (mut tx, rx) = channel(2, 1, 0);
        assert_eq!(publish(&mut tx, true, 1), Published::Queued);
        assert_eq!(publish(&mut tx, true, 2), Published::Queued);
        assert_eq!(publish(&mut tx, false, 3), Published::NotQueued);
        assert_eq!(publish(&mut tx, true, 4), Published::Overwrote);
        assert_eq!(rx.drain().map(|s| s.tick).collect::<Vec<_>>(), vec![2, 4]);
        // Boxes went back to the pool: the channel keeps working long after its capacity.
        for n in 0..100 {
            assert_ne!(publish(&mut tx, true, n), Published::NotQueued);
        }
        assert_eq!(rx.latest().map(|s| s.tick), Some(99));
        assert_eq!(rx.len(), 0);
        // `latest` gave every box back, the discarded ones too; the loop keeps the one last
        // pushed out for its next sample.
        assert_eq!(
            tx.free.len() + usize::from(tx.spare.is_some()),
            2 + SPARE_BOXES
        );
    }

    #[test]
    fn each_end_knows_whether_the_other_is_alive() {
        let (tx, rx) = channel(1, 1, 0);
        let rx2 = rx.clone();
        assert!(tx.has_receivers() && rx.has_senders());
        drop(rx);
        assert!(tx.has_receivers(), "a clone still receives");
        drop(rx2);
        assert!(!tx.has_receivers());
        let (mut tx, rx) = channel(1, 1, 0);
        publish(&mut tx, true, 7);
        drop(tx);
        assert!(!rx.has_senders());
        assert_eq!(
            rx.try_recv().map(|s| s.tick),
            Some(7),
            "what was sent stays"
        );
    }

    #[test]
    fn samples_cross_threads_in_order_and_none_is_lost_without_overwriting() {
        let (mut tx, rx) = channel(8, 4, 2);
        let producer = std::thread::spawn(move || {
            for n in 0..2000u64 {
                while publish(&mut tx, false, n) == Published::NotQueued {
                    std::thread::yield_now();
                }
            }
        });
        let mut next = 0;
        while next < 2000 {
            if let Some(sample) = rx.try_recv() {
                assert_eq!(sample.tick, next);
                assert_eq!(sample.joints()[3].command_amps, next as f64);
                next += 1;
            } else {
                std::thread::yield_now();
            }
        }
        producer.join().unwrap();
    }
}
