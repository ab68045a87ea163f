//! Lock-free mailboxes between ordinary threads and the real-time loop.
//!
//! A mailbox is a bounded, lock-free queue (crossbeam's `ArrayQueue`) allocated once; sending and
//! receiving never allocate, lock or make a system call, so either end may sit on the real-time
//! thread. Use one to send setpoints or parameters to a controller, and receive the loop's
//! telemetry from another.
//!
//! Lock-free is not wait-free: an operation that meets another thread's operation half done on
//! the same slot (a value claimed but not yet written, or taken but not yet released) waits for
//! it to finish, spinning and then yielding. That is a few instructions of the other thread, as
//! long as it runs; when it is kept from running (a thread at normal priority on a loaded machine,
//! while the loop thread runs under SCHED_FIFO, where yielding gives way only to its own
//! priority), the wait lasts until it runs again. The loop's supervisor ends a tick held past its
//! stall bound.
//!
//! ```
//! use rmd_loop::mailbox::mailbox;
//!
//! let (to_controller, setpoints) = mailbox::<f64>(16);
//! to_controller.send(10.0).unwrap();
//! to_controller.send(20.0).unwrap();
//! // The controller (on the loop thread) takes the newest and discards the rest.
//! assert_eq!(setpoints.latest(), Some(20.0));
//! assert_eq!(setpoints.latest(), None);
//! ```

use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

use crossbeam_queue::ArrayQueue;

/// The queue and how many ends of each kind are alive.
#[derive(Debug)]
struct Inner<T> {
    queue: ArrayQueue<T>,
    senders: AtomicUsize,
    receivers: AtomicUsize,
}

/// Creates a mailbox holding up to `capacity` values (at least 1).
pub fn mailbox<T: Send>(capacity: usize) -> (Sender<T>, Receiver<T>) {
    let inner = Arc::new(Inner {
        queue: ArrayQueue::new(capacity.max(1)),
        senders: AtomicUsize::new(1),
        receivers: AtomicUsize::new(1),
    });
    (
        Sender {
            inner: Arc::clone(&inner),
        },
        Receiver { inner },
    )
}

/// The sending end of a mailbox. Clone it to send from several threads.
#[derive(Debug)]
pub struct Sender<T> {
    inner: Arc<Inner<T>>,
}

impl<T> Clone for Sender<T> {
    fn clone(&self) -> Self {
        self.inner.senders.fetch_add(1, Ordering::Relaxed);
        Self {
            inner: Arc::clone(&self.inner),
        }
    }
}

impl<T> Drop for Sender<T> {
    fn drop(&mut self) {
        self.inner.senders.fetch_sub(1, Ordering::Release);
    }
}

impl<T> Sender<T> {
    /// Whether a [`Receiver`] of this mailbox still exists (someone may take what is sent).
    /// One atomic load: no lock, no allocation.
    pub fn has_receivers(&self) -> bool {
        self.inner.receivers.load(Ordering::Acquire) > 0
    }

    /// Queues `value`; if the mailbox is full, gives it back.
    pub fn send(&self, value: T) -> Result<(), T> {
        self.inner.queue.push(value)
    }

    /// Queues `value`, discarding the oldest queued value if the mailbox is full; returns the
    /// discarded value.
    pub fn send_overwrite(&self, value: T) -> Option<T> {
        self.inner.queue.force_push(value)
    }

    /// Number of queued values.
    pub fn len(&self) -> usize {
        self.inner.queue.len()
    }

    /// Whether nothing is queued.
    pub fn is_empty(&self) -> bool {
        self.inner.queue.is_empty()
    }

    /// The mailbox's capacity.
    pub fn capacity(&self) -> usize {
        self.inner.queue.capacity()
    }
}

/// The receiving end of a mailbox. Clone it to receive from several threads (each value is
/// received once).
#[derive(Debug)]
pub struct Receiver<T> {
    inner: Arc<Inner<T>>,
}

impl<T> Clone for Receiver<T> {
    fn clone(&self) -> Self {
        self.inner.receivers.fetch_add(1, Ordering::Relaxed);
        Self {
            inner: Arc::clone(&self.inner),
        }
    }
}

impl<T> Drop for Receiver<T> {
    fn drop(&mut self) {
        self.inner.receivers.fetch_sub(1, Ordering::Release);
    }
}

impl<T> Receiver<T> {
    /// Whether a [`Sender`] of this mailbox still exists: once none does and the mailbox is
    /// empty, nothing more will come (the loop that published into it has finished).
    pub fn has_senders(&self) -> bool {
        self.inner.senders.load(Ordering::Acquire) > 0
    }

    /// The oldest queued value, if any.
    pub fn try_recv(&self) -> Option<T> {
        self.inner.queue.pop()
    }

    /// The newest queued value, discarding older ones; `None` if nothing was queued.
    pub fn latest(&self) -> Option<T> {
        self.latest_with(drop)
    }

    /// The newest queued value, handing each older one to `discard`; `None` if nothing was
    /// queued.
    pub fn latest_with(&self, mut discard: impl FnMut(T)) -> Option<T> {
        let mut last = None;
        while let Some(v) = self.inner.queue.pop() {
            if let Some(older) = last.replace(v) {
                discard(older);
            }
        }
        last
    }

    /// Takes every queued value, oldest first.
    pub fn drain(&self) -> impl Iterator<Item = T> + '_ {
        std::iter::from_fn(|| self.inner.queue.pop())
    }

    /// Number of queued values.
    pub fn len(&self) -> usize {
        self.inner.queue.len()
    }

    /// Whether nothing is queued.
    pub fn is_empty(&self) -> bool {
        self.inner.queue.is_empty()
    }

    /// The mailbox's capacity.
    pub fn capacity(&self) -> usize {
        self.inner.queue.capacity()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_full_mailbox_gives_the_value_back_or_overwrites_the_oldest() {
        let (tx, rx) = mailbox(2);
        assert_eq!(tx.send(1), Ok(()));
        assert_eq!(tx.send(2), Ok(()));
        assert_eq!(tx.send(3), Err(3));
        assert_eq!(tx.send_overwrite(4), Some(1));
        assert_eq!(rx.drain().collect::<Vec<_>>(), vec![2, 4]);
        assert!(rx.is_empty());
    }

    #[test]
    fn latest_hands_every_older_value_to_the_discard() {
        let (tx, rx) = mailbox(4);
        for v in 1..=3 {
            tx.send(v).unwrap();
        }
        assert_eq!(tx.capacity(), 4);
        let mut discarded = Vec::new();
        assert_eq!(rx.latest_with(|v| discarded.push(v)), Some(3));
        assert_eq!(discarded, vec![1, 2]);
        assert_eq!(rx.latest_with(|_| panic!("nothing queued")), None);
    }

    #[test]
    fn each_end_knows_whether_the_other_is_alive() {
        let (tx, rx) = mailbox::<u8>(1);
        let rx2 = rx.clone();
        assert!(tx.has_receivers() && rx.has_senders());
        drop(rx);
        assert!(tx.has_receivers(), "a clone still receives");
        drop(rx2);
        assert!(!tx.has_receivers());
        let (tx, rx) = mailbox::<u8>(1);
        tx.send(7).unwrap();
        let tx2 = tx.clone();
        drop(tx);
        assert!(rx.has_senders());
        drop(tx2);
        assert!(!rx.has_senders());
        assert_eq!(rx.try_recv(), Some(7), "what was sent stays receivable");
    }

    #[test]
    fn values_cross_threads_in_order() {
        let (tx, rx) = mailbox(1024);
        let producer = std::thread::spawn(move || {
            for i in 0..1000u32 {
                while tx.send(i).is_err() {
                    std::thread::yield_now();
                }
            }
        });
        let mut got = Vec::new();
        while got.len() < 1000 {
            got.extend(rx.drain());
        }
        producer.join().unwrap();
        assert_eq!(got, (0..1000).collect::<Vec<_>>());
    }
}
