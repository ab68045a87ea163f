//! A simulated bus on a thread of its own, as real motors are: the firmware and the physics run
//! there, and the threads that use the bus (the loop, its supervisor) only exchange frames with
//! it through lock-free queues. So a benchmark measures the loop thread alone, and a loop with
//! several simulated buses scales like one with several real ones.
//!
//! [`ThreadedSim::spawn`] moves a [`SimBus`] (on the [`MonotonicClock`]) to a new thread and
//! returns one [`SimPort`] per user. A port is a [`CanBus`]:
//!
//! - [`send`](CanBus::send) stamps the frame with the real time, puts it in a lock-free queue
//!   (full: [`BusError::TxQueueFull`]) and rings the simulator's [`Doorbell`]; the simulator
//!   queues it on the wire at that time (or after the latest event it already simulated);
//! - the simulator computes each reply as soon as the frame reaches the motors on the simulated
//!   wire, up to [`LOOKAHEAD`] ahead of the real clock, and hands it to every port's lock-free
//!   queue stamped with its arrival on the wire, then rings the port's doorbell;
//! - [`recv_until`](CanBus::recv_until) returns an item only once the real clock has reached
//!   its arrival: it sleeps until then (the last `receive_spin` busy-waiting) on the calling
//!   thread's own timer, so a reply reaches the loop when it would on a real bus and the
//!   simulator thread's own wake-up latency never delays it;
//! - [`readiness`](CanBus::readiness) tells the loop the next arrival, or the doorbell to
//!   watch: the loop waits on all its buses in one `ppoll` ([`rmd_bus::ready::wait_any`]).
//!
//! Like sockets on one CAN interface, every port receives every frame the motors send (and the
//! bus events), and none receives the frames another port sent. After a bus-off event a port
//! refuses to send until a sign of recovery, as the SocketCAN backend does. Nothing allocates
//! after the start, on either side.
//!
//! ```
//! use core::time::Duration;
//! use rmd_bus::{BusMessage, CanBus, Clock, MonotonicClock};
//! use rmd_protocol::{IqControl, MultiTorque};
//! use rmd_sim::threaded::{ThreadOptions, ThreadedSim};
//! use rmd_sim::{SimBus, SimConfig};
//!
//! let bus = SimBus::new(MonotonicClock, SimConfig::with_motors(4))?;
//! let (sim, mut ports) = ThreadedSim::spawn(bus, &ThreadOptions::default(), || {})?;
//! let port = &mut ports[0];
//! port.send(&MultiTorque::new([IqControl::from_amps(0.5).unwrap().into(); 4]).encode())?;
//! let deadline = MonotonicClock.now() + Duration::from_millis(50);
//! let mut replies = 0;
//! while replies < 4 && let Some(rx) = port.recv_until(deadline)? {
//!     assert!(MonotonicClock.now() >= rx.at); // never before its time on the wire
//!     replies += matches!(rx.message, BusMessage::Frame(_)) as usize;
//! }
//! assert_eq!(replies, 4);
//! let bus = sim.stop()?; // the simulated bus back, to look at its motors and trace
//! assert_eq!(bus.stats().motor_frames, 4);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use core::time::Duration;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::thread::JoinHandle;

use crossbeam_queue::ArrayQueue;
use rmd_bus::ready::Doorbell;
use rmd_bus::{
    BusError, BusEvent, BusMessage, CanBus, Clock, MonotonicClock, Readiness, Received, Timestamp,
    WaitOn,
};
use rmd_protocol::CanFrame;

use crate::SimBus;

/// How far ahead of the real clock the simulator thread computes (replies are handed over
/// this early at most, and delivered at their time).
pub const LOOKAHEAD: Duration = Duration::from_millis(2);

/// Longest sleep of an idle simulator thread between looks at its stop flag.
const IDLE: Duration = Duration::from_millis(20);

/// How many late items' arrivals [`ThreadedSim::late_arrivals`] keeps (the first ones; all are
/// counted in [`Lateness`]).
pub const LATE_LOG_LEN: usize = 16_384;

/// How a [`ThreadedSim`] runs.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ThreadOptions {
    /// Ports to create (one per thread that uses the bus: the loop, its supervisor); at least 1.
    pub ports: usize,
    /// Each port's receive sleeps until this long before an item's arrival, then busy-waits
    /// (zero: sleeps all the way, as a blocking receive).
    pub receive_spin: Duration,
    /// Frames a port can hold for the simulator, and items for its user.
    pub queue_len: usize,
    /// The thread's name.
    pub name: String,
}

impl Default for ThreadOptions {
    fn default() -> Self {
        Self {
            ports: 1,
            receive_spin: Duration::ZERO,
            queue_len: 256,
            name: "rmd-sim".to_string(),
        }
    }
}

/// One user's queues: frames to the simulator, items to the user.
#[derive(Debug)]
struct Queues {
    to_sim: ArrayQueue<(Timestamp, CanFrame)>,
    to_user: ArrayQueue<Received>,
    /// Rung by the simulator when it put something in `to_user`.
    bell: Doorbell,
    /// The simulator had to drop an item the user had not taken (the queue was full).
    overflowed: AtomicBool,
}

/// What the simulator thread and its ports share.
#[derive(Debug)]
struct Shared {
    /// Rung by a port when it put a frame in its `to_sim`, and to stop.
    bell: Doorbell,
    stop: AtomicBool,
    /// Items handed over after their arrival time (the simulator thread was late).
    late_items: AtomicU64,
    /// The latest of them, nanoseconds after its arrival.
    max_late_ns: AtomicU64,
    /// The arrivals of the first [`LATE_LOG_LEN`] of them and how late each was (nanoseconds),
    /// written by the simulator thread only; `late_logged` are valid.
    late_log: Box<[(AtomicU64, AtomicU64)]>,
    late_logged: AtomicUsize,
}

impl Shared {
    /// Counts an item handed over `late` after its arrival `at` (the simulator thread only).
    fn record_late(&self, at: Timestamp, late: Duration) {
        self.late_items.fetch_add(1, Ordering::Relaxed);
        self.max_late_ns
            .fetch_max(late.as_nanos() as u64, Ordering::Relaxed);
        let n = self.late_logged.load(Ordering::Relaxed);
        if let Some((arrival, by)) = self.late_log.get(n) {
            arrival.store(at.as_nanos(), Ordering::Relaxed);
            by.store(late.as_nanos() as u64, Ordering::Relaxed);
            self.late_logged.store(n + 1, Ordering::Release);
        }
    }
}

/// How well the simulator thread kept up with the real clock.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct Lateness {
    /// Items (replies, events) handed to the ports after their arrival on the wire: a receive
    /// got them late because the simulator thread was (its CPU was busy), not the receiver.
    pub late_items: u64,
    /// How late the latest of them was.
    pub max_late: Duration,
}

/// A simulated bus running on its own thread; [`stop`](Self::stop) (or drop) ends the thread.
#[derive(Debug)]
pub struct ThreadedSim {
    shared: Arc<Shared>,
    thread: Option<JoinHandle<SimBus<MonotonicClock>>>,
}

/// The simulator thread panicked.
#[derive(Debug, thiserror::Error)]
#[error("the simulator thread panicked (a bug in rmd-sim: please report it)")]
pub struct SimThreadPanicked;

impl ThreadedSim {
    /// Moves `bus` to a new thread, which first runs `setup` (e.g. to pin itself or set its
    /// priority), and returns the ports onto it.
    ///
    /// Errors: the doorbells or the thread could not be created.
    pub fn spawn(
        bus: SimBus<MonotonicClock>,
        options: &ThreadOptions,
        setup: impl FnOnce() + Send + 'static,
    ) -> std::io::Result<(Self, Vec<SimPort>)> {
        let shared = Arc::new(Shared {
            bell: Doorbell::new()?,
            stop: AtomicBool::new(false),
            late_items: AtomicU64::new(0),
            max_late_ns: AtomicU64::new(0),
            late_log: (0..LATE_LOG_LEN)
                .map(|_| (AtomicU64::new(0), AtomicU64::new(0)))
                .collect(),
            late_logged: AtomicUsize::new(0),
        });
        let queues = (0..options.ports.max(1))
            .map(|_| {
                Ok(Arc::new(Queues {
                    to_sim: ArrayQueue::new(options.queue_len.max(1)),
                    to_user: ArrayQueue::new(options.queue_len.max(1)),
                    bell: Doorbell::new()?,
                    overflowed: AtomicBool::new(false),
                }))
            })
            .collect::<std::io::Result<Vec<_>>>()?;
        let ports = queues
            .iter()
            .map(|q| SimPort {
                queues: Arc::clone(q),
                shared: Arc::clone(&shared),
                head: None,
                stash: None,
                bus_off: false,
                spin: options.receive_spin,
            })
            .collect();
        let thread_shared = Arc::clone(&shared);
        let thread = std::thread::Builder::new()
            .name(options.name.clone())
            .spawn(move || {
                setup();
                simulate(bus, &queues, &thread_shared)
            })?;
        Ok((
            Self {
                shared,
                thread: Some(thread),
            },
            ports,
        ))
    }

    /// How well the simulator thread has kept up so far.
    pub fn lateness(&self) -> Lateness {
        Lateness {
            late_items: self.shared.late_items.load(Ordering::Relaxed),
            max_late: Duration::from_nanos(self.shared.max_late_ns.load(Ordering::Relaxed)),
        }
    }

    /// The items handed over late (the first [`LATE_LOG_LEN`]): when each was due to arrive,
    /// and how late it was handed over. A benchmark tells the ticks whose replies the simulator
    /// was late with from those the loop missed on its own.
    pub fn late_arrivals(&self) -> Vec<(Timestamp, Duration)> {
        let n = self.shared.late_logged.load(Ordering::Acquire);
        self.shared.late_log[..n]
            .iter()
            .map(|(at, by)| {
                (
                    Timestamp::from_nanos(at.load(Ordering::Relaxed)),
                    Duration::from_nanos(by.load(Ordering::Relaxed)),
                )
            })
            .collect()
    }

    /// Stops the thread (frames sent after this are never simulated) and returns the bus, to
    /// look at its motors, counters and trace.
    pub fn stop(mut self) -> Result<SimBus<MonotonicClock>, SimThreadPanicked> {
        self.shared.stop.store(true, Ordering::Release);
        self.shared.bell.ring();
        match self.thread.take() {
            Some(thread) => thread.join().map_err(|_| SimThreadPanicked),
            None => Err(SimThreadPanicked),
        }
    }
}

impl Drop for ThreadedSim {
    fn drop(&mut self) {
        if let Some(thread) = self.thread.take() {
            self.shared.stop.store(true, Ordering::Release);
            self.shared.bell.ring();
            let _ = thread.join();
        }
    }
}

/// The simulator thread: frames in, the simulation run ahead to `LOOKAHEAD`, items out.
fn simulate(
    mut bus: SimBus<MonotonicClock>,
    queues: &[Arc<Queues>],
    shared: &Shared,
) -> SimBus<MonotonicClock> {
    let clock = MonotonicClock;
    loop {
        let stopping = shared.stop.load(Ordering::Acquire);
        // Clear before looking: a frame queued after this rings again.
        shared.bell.clear();
        for q in queues {
            while let Some((at, frame)) = q.to_sim.pop() {
                // Refusals (bus-off, a full transmit queue) are counted in the bus's stats.
                let _ = bus.send_at(&frame, at);
            }
        }
        if stopping {
            return bus;
        }
        let now = clock.now();
        let mut handed = false;
        while let Some(item) = bus.next_received(now + LOOKAHEAD) {
            let late = clock.now() - item.at;
            if !late.is_zero() {
                shared.record_late(item.at, late);
            }
            for q in queues {
                if q.to_user.force_push(item).is_some() {
                    q.overflowed.store(true, Ordering::Release);
                }
            }
            handed = true;
        }
        if handed {
            for q in queues {
                q.bell.ring();
            }
        }
        // Sleep until the next event is within the lookahead, or a frame comes.
        let wake = bus
            .next_event()
            .map_or(now + IDLE, |t| t.saturating_sub(LOOKAHEAD))
            .min(now + IDLE);
        let timeout = wake - clock.now();
        if !timeout.is_zero() {
            let _ = shared.bell.wait(timeout);
        }
    }
}

/// One user's way onto a [`ThreadedSim`]: a [`CanBus`] (see the [module](self) documentation).
#[derive(Debug)]
pub struct SimPort {
    queues: Arc<Queues>,
    shared: Arc<Shared>,
    /// The next item, taken from the queue (its arrival may be in the future).
    head: Option<Received>,
    /// The item after `head`, when an overflow report was put before it.
    stash: Option<Received>,
    /// A bus-off event was received and no sign of recovery since.
    bus_off: bool,
    spin: Duration,
}

impl SimPort {
    /// The next item, if the simulator handed one over (whatever its arrival). No system call:
    /// the doorbell is only cleared before a wait on it ([`Self::peek_before_wait`]).
    fn peek(&mut self) -> Option<Received> {
        if self.head.is_none() {
            let next = self.queues.to_user.pop();
            if self.queues.overflowed.swap(false, Ordering::AcqRel) {
                self.stash = next;
                self.head = next.map(|item| Received {
                    at: item.at,
                    message: BusMessage::Event(BusEvent::RxOverflow),
                });
            } else {
                self.head = next;
            }
        }
        self.head
    }

    /// [`Self::peek`], clearing the doorbell first when nothing is there: when this returns
    /// `None`, an item handed over later rings it (earlier rings, for items already taken,
    /// are gone and cannot wake a wait for nothing).
    fn peek_before_wait(&mut self) -> Option<Received> {
        if self.peek().is_none() {
            self.queues.bell.clear();
            return self.peek();
        }
        self.head
    }

    fn take(&mut self) -> Option<Received> {
        let item = self.head.take();
        self.head = self.stash.take();
        if let Some(item) = item {
            self.bus_off = match item.message {
                BusMessage::Event(BusEvent::BusOff) => true,
                BusMessage::Event(
                    BusEvent::Restarted
                    | BusEvent::ErrorActive
                    | BusEvent::ErrorWarning
                    | BusEvent::ErrorPassive
                    | BusEvent::RxOverflow,
                )
                | BusMessage::Frame(_) => false,
                BusMessage::Event(_) => self.bus_off,
            };
        }
        item
    }
}

impl CanBus for SimPort {
    fn send(&mut self, frame: &CanFrame) -> Result<(), BusError> {
        if self.bus_off {
            return Err(BusError::BusOff);
        }
        self.queues
            .to_sim
            .push((MonotonicClock.now(), *frame))
            .map_err(|_| BusError::TxQueueFull)?;
        self.shared.bell.ring();
        Ok(())
    }

    fn recv_until(&mut self, deadline: Timestamp) -> Result<Option<Received>, BusError> {
        let clock = MonotonicClock;
        loop {
            let now = clock.now();
            match self.peek() {
                Some(item) if item.at <= now => return Ok(self.take()),
                Some(item) if item.at <= deadline => {
                    clock.wait_until(item.at, self.spin);
                    return Ok(self.take());
                }
                // Later items arrive later still.
                Some(_) => {
                    if deadline > now {
                        clock.sleep_until(deadline);
                    }
                    return Ok(None);
                }
                None if now >= deadline => return Ok(None),
                None => {
                    if self.peek_before_wait().is_none() {
                        self.queues.bell.wait(deadline - now)?;
                    }
                }
            }
        }
    }

    fn readiness(&mut self) -> Readiness<'_> {
        match self.peek_before_wait() {
            Some(item) if item.at <= MonotonicClock.now() => Readiness::Ready,
            Some(item) => Readiness::Pending(WaitOn::arrival(item.at, self.spin)),
            None => Readiness::Pending(WaitOn::readable(self.queues.bell.as_fd())),
        }
    }
}
