//! The channel the loop publishes its samples through, without copying them.
//!
//! A [`TelemetrySample`] is sized for the largest robot (a few kilobytes), so moving one by value
//! through a queue costs several copies of it per tick. Instead the channel allocates, once, a
//! pool of boxed samples that travel between two lock-free queues (crossbeam's `ArrayQueue`):
//! `free` and `full`. The loop takes a box from `free` (or, when the receiver has fallen behind,
//! the oldest from `full`: that sample is overwritten), fills in only its robot's joints, and
//! pushes it onto `full`; a receiver pops one, copies the sample out on its own thread and
//! returns the box to `free`. Only pointers cross the queues: no allocation, no lock, no wait on
//! the loop's side.

use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

use crossbeam_queue::ArrayQueue;

use super::TelemetrySample;

/// Boxes beyond the channel's capacity: one the loop fills while `full` is at capacity, and
/// some that receivers on several threads hold while they copy a sample out.
const SPARE_BOXES: usize = 4;

/// The pool and how many receivers are alive.
#[derive(Debug)]
struct Pool {
    full: ArrayQueue<Box<TelemetrySample>>,
    free: ArrayQueue<Box<TelemetrySample>>,
    senders: AtomicUsize,
    receivers: AtomicUsize,
}

/// Creates a channel holding up to `capacity` samples (at least 1) of `joints` joints and
/// `signals` user signals. Allocates every box now.
pub(crate) fn channel(
    capacity: usize,
    joints: usize,
    signals: usize,
) -> (TelemetrySender, TelemetryReceiver) {
    let capacity = capacity.max(1);
    let boxes = capacity + SPARE_BOXES;
    let free = ArrayQueue::new(boxes);
    for _ in 0..boxes {
        // Cannot fail: the queue holds exactly `boxes`.
        let _ = free.push(Box::new(TelemetrySample::new(joints, signals)));
    }
    let pool = Arc::new(Pool {
        full: ArrayQueue::new(capacity),
        free,
        senders: AtomicUsize::new(1),
        receivers: AtomicUsize::new(1),
    });
    (
        TelemetrySender {
            pool: Arc::clone(&pool),
        },
        TelemetryReceiver { pool },
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
    pool: Arc<Pool>,
}

impl Drop for TelemetrySender {
    fn drop(&mut self) {
        self.pool.senders.fetch_sub(1, Ordering::Release);
    }
}

impl TelemetrySender {
    /// Whether a receiver still exists.
    pub(crate) fn has_receivers(&self) -> bool {
        self.pool.receivers.load(Ordering::Acquire) > 0
    }

    /// Fills a box with `fill` and queues it. With `overwrite`, a full channel loses its oldest
    /// sample; without, a full channel leaves `fill` uncalled and returns
    /// [`Published::NotQueued`].
    pub(crate) fn publish(
        &self,
        overwrite: bool,
        fill: impl FnOnce(&mut TelemetrySample),
    ) -> Published {
        let pool = &*self.pool;
        // The loop is the only producer: once `full` has room, only receivers touch it, and they
        // only make more.
        if !overwrite && pool.full.is_full() {
            return Published::NotQueued;
        }
        // A full channel gives up its oldest box at once (rather than taking a free one and
        // pushing out the oldest): the cheaper path through the queue.
        let oldest = if overwrite && pool.full.is_full() {
            pool.full.pop()
        } else {
            None
        };
        let mut lost = oldest.is_some();
        let Some(mut slot) = oldest.or_else(|| pool.free.pop()) else {
            return Published::NotQueued;
        };
        fill(&mut slot);
        if let Some(oldest) = pool.full.force_push(slot) {
            lost = true;
            // Cannot fail: `free` holds every box.
            let _ = pool.free.push(oldest);
        }
        if lost {
            Published::Overwrote
        } else {
            Published::Queued
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
#[derive(Debug)]
pub struct TelemetryReceiver {
    pool: Arc<Pool>,
}

impl Clone for TelemetryReceiver {
    fn clone(&self) -> Self {
        self.pool.receivers.fetch_add(1, Ordering::Relaxed);
        Self {
            pool: Arc::clone(&self.pool),
        }
    }
}

impl Drop for TelemetryReceiver {
    fn drop(&mut self) {
        self.pool.receivers.fetch_sub(1, Ordering::Release);
    }
}

impl TelemetryReceiver {
    /// Whether the loop still publishes: once it does not and the channel is empty, nothing more
    /// will come (the loop has finished, or published to a newer receiver).
    pub fn has_senders(&self) -> bool {
        self.pool.senders.load(Ordering::Acquire) > 0
    }

    /// The oldest queued sample, if any.
    pub fn try_recv(&self) -> Option<TelemetrySample> {
        let slot = self.pool.full.pop()?;
        let sample = *slot;
        // Cannot fail: `free` holds every box.
        let _ = self.pool.free.push(slot);
        Some(sample)
    }

    /// The newest queued sample, discarding older ones; `None` if nothing was queued.
    pub fn latest(&self) -> Option<TelemetrySample> {
        let mut newest = self.pool.full.pop()?;
        while let Some(next) = self.pool.full.pop() {
            let _ = self.pool.free.push(std::mem::replace(&mut newest, next));
        }
        let sample = *newest;
        let _ = self.pool.free.push(newest);
        Some(sample)
    }

    /// Takes every queued sample, oldest first.
    pub fn drain(&self) -> impl Iterator<Item = TelemetrySample> + '_ {
        std::iter::from_fn(|| self.try_recv())
    }

    /// Number of queued samples.
    pub fn len(&self) -> usize {
        self.pool.full.len()
    }

    /// Whether nothing is queued.
    pub fn is_empty(&self) -> bool {
        self.pool.full.is_empty()
    }

    /// How many samples the channel holds before the loop overwrites (or waits).
    pub fn capacity(&self) -> usize {
        self.pool.full.capacity()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tick(sample: &TelemetrySample) -> u64 {
        sample.tick
    }

    fn publish(tx: &TelemetrySender, overwrite: bool, n: u64) -> Published {
        tx.publish(overwrite, |s| {
            s.tick = n;
            if let Some(last) = s.joints_mut().last_mut() {
                last.command_amps = n as f64;
            }
        })
    }

    #[test]
    fn samples_arrive_in_order_with_their_joints() {
        let (tx, rx) = channel(3, 2, 0);
        for n in 0..3 {
            assert_eq!(publish(&tx, true, n), Published::Queued);
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
        let (tx, rx) = channel(2, 1, 0);
        assert_eq!(publish(&tx, true, 1), Published::Queued);
        assert_eq!(publish(&tx, true, 2), Published::Queued);
        assert_eq!(publish(&tx, false, 3), Published::NotQueued);
        assert_eq!(publish(&tx, true, 4), Published::Overwrote);
        assert_eq!(rx.drain().map(|s| s.tick).collect::<Vec<_>>(), vec![2, 4]);
        // Boxes went back to the pool: the channel keeps working long after its capacity.
        for n in 0..100 {
            assert_ne!(publish(&tx, true, n), Published::NotQueued);
        }
        assert_eq!(rx.latest().map(|s| s.tick), Some(99));
        assert_eq!(rx.len(), 0);
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
        let (tx, rx) = channel(1, 1, 0);
        publish(&tx, true, 7);
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
        let (tx, rx) = channel(8, 4, 2);
        let producer = std::thread::spawn(move || {
            for n in 0..2000u64 {
                while publish(&tx, false, n) == Published::NotQueued {
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
