//! Recording a bus to a `candump -L` log without ever blocking the caller.
//!
//! [`record`] wraps any [`CanBus`] in a [`Recorder`], which is itself a `CanBus`: every frame
//! sent through it (once the inner bus accepted it) and every data frame received from it is
//! stamped, tagged with its direction and pushed onto a bounded lock-free queue
//! ([`crossbeam_queue::ArrayQueue`]). A separate, non-real-time writer thread ([`LogWriter`])
//! pops the queue and writes one `candump -L` line per frame
//! (`(seconds.micros) interface ID#DATA T|R`, see [`LogLine`]). The caller's `send` and
//! `recv_until` never wait for the writer, never take a lock and never allocate: when the queue
//! is full the frame is not recorded and counted as dropped ([`RecordStats::dropped`]).
//! Bus events (error frames) are not recorded.
//!
//! ```
//! use core::time::Duration;
//! use rmd_bus::record::{record, RecordOptions};
//! use rmd_bus::{BusError, CanBus, CanFrame, Received, Timestamp, VirtualClock};
//!
//! // Any bus; here one that accepts every frame and never receives anything.
//! struct Sink;
//! impl CanBus for Sink {
//!     fn send(&mut self, _: &CanFrame) -> Result<(), BusError> { Ok(()) }
//!     fn recv_until(&mut self, _: Timestamp) -> Result<Option<Received>, BusError> { Ok(None) }
//! }
//!
//! let clock = VirtualClock::new();
//! clock.advance(Duration::from_millis(1500));
//! let options = RecordOptions::new("can0").time_offset(Duration::ZERO); // virtual time: no wall clock
//! let (mut bus, writer) = record(Sink, clock, Vec::new(), options)?;
//! bus.send(&CanFrame::with_data(0x141, [0x9C, 0, 0, 0, 0, 0, 0, 0]).unwrap()).unwrap();
//! drop(bus);
//! let (stats, log) = writer.finish_into_inner()?;
//! assert_eq!((stats.recorded, stats.written, stats.dropped), (1, 1, 0));
//! assert_eq!(String::from_utf8(log).unwrap(), "(0000000001.500000) can0 141#9C00000000000000 T\n");
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use core::time::Duration;
use std::io::{self, Write};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::thread::JoinHandle;
use std::time::{SystemTime, UNIX_EPOCH};

use crossbeam_queue::ArrayQueue;

use crate::candump::{FrameDirection, LogLine};
use crate::{BusError, BusMessage, CanBus, CanFrame, Clock, MonotonicClock, Received, Timestamp};

/// Default capacity of the queue between the bus and the writer, in frames (a 1 kHz loop of
/// four motors produces 5 000 frames per second).
pub const DEFAULT_QUEUE_CAPACITY: usize = 8192;

/// Default time the writer sleeps when it finds the queue empty.
pub const DEFAULT_POLL_INTERVAL: Duration = Duration::from_millis(2);

/// One frame as the recorder saw it.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct RecordedFrame {
    /// When it was sent (the clock's time when the inner bus accepted it) or received (the
    /// bus's receive timestamp), on the bus's clock.
    pub at: Timestamp,
    /// Sent by the caller ([`FrameDirection::Tx`]) or received ([`FrameDirection::Rx`]).
    pub direction: FrameDirection,
    /// The frame.
    pub frame: CanFrame,
}

/// How a recording is written.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RecordOptions {
    interface: String,
    capacity: usize,
    time_offset: Option<Duration>,
    directions: bool,
    poll_interval: Duration,
}

impl RecordOptions {
    /// Lines name `interface`; a [`DEFAULT_QUEUE_CAPACITY`] queue; timestamps on the wall clock
    /// (see [`time_offset`](Self::time_offset)); direction markers on.
    pub fn new(interface: &str) -> Self {
        Self {
            interface: interface.to_owned(),
            capacity: DEFAULT_QUEUE_CAPACITY,
            time_offset: None,
            directions: true,
            poll_interval: DEFAULT_POLL_INTERVAL,
        }
    }

    /// Capacity of the queue, in frames (at least 1).
    #[must_use]
    pub fn capacity(mut self, frames: usize) -> Self {
        self.capacity = frames.max(1);
        self
    }

    /// What to add to a frame's [`Timestamp`] to get its log timestamp (time since the Unix
    /// epoch, as candump writes it). By default the offset between the wall clock and
    /// [`MonotonicClock`], measured when recording starts ([`wall_clock_offset`]), which suits a
    /// bus on the monotonic clock (SocketCAN, the simulator in real time). For a
    /// [`VirtualClock`](crate::VirtualClock), pass `Duration::ZERO`: the log then counts seconds
    /// from the virtual epoch.
    #[must_use]
    pub fn time_offset(mut self, offset: Duration) -> Self {
        self.time_offset = Some(offset);
        self
    }

    /// Whether lines end with candump's direction marker (` T` sent, ` R` received), as
    /// `candump -L -x` writes them (default on). `rmd decode` uses it to tell requests from
    /// replies.
    #[must_use]
    pub fn directions(mut self, on: bool) -> Self {
        self.directions = on;
        self
    }

    /// How long the writer sleeps when the queue is empty (default [`DEFAULT_POLL_INTERVAL`]).
    #[must_use]
    pub fn poll_interval(mut self, interval: Duration) -> Self {
        self.poll_interval = interval;
        self
    }

    /// The interface name written on each line.
    pub fn interface(&self) -> &str {
        &self.interface
    }
}

/// The offset from [`MonotonicClock`] to the wall clock (time since the Unix epoch), measured
/// now: add it to a monotonic [`Timestamp`] to get a candump log timestamp. It changes if the
/// wall clock is stepped (NTP, manual setting).
pub fn wall_clock_offset() -> Duration {
    let before = MonotonicClock.now();
    let wall = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .unwrap_or(Duration::ZERO);
    let after = MonotonicClock.now();
    let mono = Duration::from_nanos(before.as_nanos() / 2 + after.as_nanos() / 2);
    wall.saturating_sub(mono)
}

/// Counters of a recording.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct RecordStats {
    /// Frames queued for the writer.
    pub recorded: u64,
    /// Frames not recorded because the queue was full (the writer fell behind), or not
    /// written because writing failed.
    pub dropped: u64,
    /// Lines written to the sink (counted when a flush confirms them; the writer flushes
    /// whenever it has emptied the queue).
    pub written: u64,
}

/// Why a recording could not be written completely.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    /// Writing the log failed; frames after the failure were dropped.
    #[error("writing the CAN log failed after {} lines: {source}", stats.written)]
    Write {
        /// The write error.
        #[source]
        source: io::Error,
        /// The counters at the end.
        stats: RecordStats,
    },
    /// The writer thread could not be started.
    #[error("cannot start the CAN log writer thread: {0}")]
    Spawn(#[source] io::Error),
    /// The writer thread panicked (a bug, or a panicking sink).
    #[error("the CAN log writer thread panicked")]
    WriterPanicked,
}

/// State shared by the recorder, its writer thread and the writer's handle.
#[derive(Debug)]
struct Shared {
    queue: ArrayQueue<RecordedFrame>,
    recorded: AtomicU64,
    dropped: AtomicU64,
    written: AtomicU64,
    stop: AtomicBool,
}

impl Shared {
    fn stats(&self) -> RecordStats {
        RecordStats {
            recorded: self.recorded.load(Ordering::Relaxed),
            dropped: self.dropped.load(Ordering::Relaxed),
            written: self.written.load(Ordering::Relaxed),
        }
    }

    /// Queues one frame, or counts it as dropped. Lock-free, allocation-free.
    fn push(&self, item: RecordedFrame) {
        if self.queue.push(item).is_ok() {
            self.recorded.fetch_add(1, Ordering::Relaxed);
        } else {
            self.dropped.fetch_add(1, Ordering::Relaxed);
        }
    }
}

/// Starts recording `bus` to `sink`: returns the recording bus to use in place of `bus`, and
/// the handle of the writer thread (call [`LogWriter::finish`] when done to flush the log and
/// get the counters).
///
/// `clock` stamps sent frames; it must be the bus's clock (received frames keep the bus's own
/// receive timestamps).
///
/// Errors: [`RecordError::Spawn`] if the writer thread cannot be started.
pub fn record<B, C, W>(
    bus: B,
    clock: C,
    sink: W,
    options: RecordOptions,
) -> Result<(Recorder<B, C>, LogWriter<W>), RecordError>
where
    B: CanBus,
    C: Clock,
    W: Write + Send + 'static,
{
    let shared = Arc::new(Shared {
        queue: ArrayQueue::new(options.capacity.max(1)),
        recorded: AtomicU64::new(0),
        dropped: AtomicU64::new(0),
        written: AtomicU64::new(0),
        stop: AtomicBool::new(false),
    });
    let offset = options.time_offset.unwrap_or_else(wall_clock_offset);
    let thread_shared = Arc::clone(&shared);
    let thread = std::thread::Builder::new()
        .name("rmd-record".into())
        .spawn(move || write_loop(&thread_shared, sink, &options, offset))
        .map_err(RecordError::Spawn)?;
    Ok((
        Recorder {
            inner: bus,
            clock,
            shared: Arc::clone(&shared),
        },
        LogWriter {
            shared,
            thread: Some(thread),
        },
    ))
}

/// The writer thread: pops the queue and writes lines until asked to stop and the queue is
/// empty. Returns the sink (flushed) or the first write error.
fn write_loop<W: Write>(
    shared: &Shared,
    sink: W,
    options: &RecordOptions,
    offset: Duration,
) -> Result<W, io::Error> {
    let mut out = io::BufWriter::with_capacity(64 * 1024, sink);
    // Lines handed to the buffer but not yet confirmed by a flush.
    let mut unflushed: u64 = 0;
    let fail = |error: io::Error, lost: u64| {
        // Lines not confirmed, and everything still queued or still coming, are dropped.
        shared.dropped.fetch_add(lost, Ordering::Relaxed);
        drain_as_dropped(shared);
        Err(error)
    };
    loop {
        match shared.queue.pop() {
            Some(item) => {
                let timestamp = Duration::from_nanos(item.at.as_nanos()) + offset;
                let mut line = LogLine::new(timestamp, &options.interface, item.frame);
                if options.directions {
                    line = line.with_direction(item.direction);
                }
                if let Err(error) = writeln!(out, "{line}") {
                    return fail(error, unflushed + 1);
                }
                unflushed += 1;
            }
            None => {
                if unflushed > 0 {
                    if let Err(error) = out.flush() {
                        return fail(error, unflushed);
                    }
                    shared.written.fetch_add(unflushed, Ordering::Relaxed);
                    unflushed = 0;
                }
                if shared.stop.load(Ordering::Acquire) {
                    // The stop flag is set after the recorder's last push: one more pass sees
                    // everything it queued.
                    if shared.queue.is_empty() {
                        break;
                    }
                    continue;
                }
                std::thread::sleep(options.poll_interval);
            }
        }
    }
    out.into_inner().map_err(|e| e.into_error())
}

/// After a write error: empties the queue into the drop count until stopped.
fn drain_as_dropped(shared: &Shared) {
    loop {
        while shared.queue.pop().is_some() {
            shared.dropped.fetch_add(1, Ordering::Relaxed);
        }
        if shared.stop.load(Ordering::Acquire) && shared.queue.is_empty() {
            return;
        }
        std::thread::sleep(DEFAULT_POLL_INTERVAL);
    }
}

/// A [`CanBus`] that records every frame through it (see the [module docs](self)).
#[derive(Debug)]
pub struct Recorder<B, C> {
    inner: B,
    clock: C,
    shared: Arc<Shared>,
}

impl<B, C> Recorder<B, C> {
    /// The recorded bus.
    pub fn inner(&self) -> &B {
        &self.inner
    }

    /// The recorded bus, mutably (frames sent or received directly on it are not recorded).
    pub fn inner_mut(&mut self) -> &mut B {
        &mut self.inner
    }

    /// Stops recording and returns the bus.
    pub fn into_inner(self) -> B {
        self.inner
    }

    /// The counters so far.
    pub fn stats(&self) -> RecordStats {
        self.shared.stats()
    }
}

impl<B: CanBus, C: Clock> CanBus for Recorder<B, C> {
    fn send(&mut self, frame: &CanFrame) -> Result<(), BusError> {
        self.inner.send(frame)?;
        self.shared.push(RecordedFrame {
            at: self.clock.now(),
            direction: FrameDirection::Tx,
            frame: *frame,
        });
        Ok(())
    }

    fn recv_until(&mut self, deadline: Timestamp) -> Result<Option<Received>, BusError> {
        let received = self.inner.recv_until(deadline)?;
        if let Some(Received {
            at,
            message: BusMessage::Frame(frame),
        }) = received
        {
            self.shared.push(RecordedFrame {
                at,
                direction: FrameDirection::Rx,
                frame,
            });
        }
        Ok(received)
    }
}

/// The handle of a recording's writer thread.
///
/// Dropping it stops the writer after it has written what is queued (errors are then lost;
/// call [`finish`](Self::finish) to see them).
#[derive(Debug)]
pub struct LogWriter<W> {
    shared: Arc<Shared>,
    thread: Option<JoinHandle<Result<W, io::Error>>>,
}

impl<W> LogWriter<W> {
    /// The counters so far (the writer keeps running).
    pub fn stats(&self) -> RecordStats {
        self.shared.stats()
    }

    /// Stops the writer once the queue is empty, flushes the log, and returns the counters.
    /// Frames the recorder queues after this call are dropped (stop using it first).
    pub fn finish(self) -> Result<RecordStats, RecordError> {
        self.finish_into_inner().map(|(stats, _)| stats)
    }

    /// Like [`finish`](Self::finish), and also returns the sink.
    pub fn finish_into_inner(mut self) -> Result<(RecordStats, W), RecordError> {
        let result = self.stop_and_join();
        let stats = self.shared.stats();
        match result {
            Some(Ok(sink)) => Ok((stats, sink)),
            Some(Err(source)) => Err(RecordError::Write { source, stats }),
            None => Err(RecordError::WriterPanicked),
        }
    }

    fn stop_and_join(&mut self) -> Option<Result<W, io::Error>> {
        self.shared.stop.store(true, Ordering::Release);
        self.thread.take().and_then(|thread| thread.join().ok())
    }
}

impl<W> Drop for LogWriter<W> {
    fn drop(&mut self) {
        if self.thread.is_some() {
            let _ = self.stop_and_join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::VirtualClock;
    use crate::candump::parse_line;

    /// A bus that accepts everything and yields the frames it was given, one per call, stamped
    /// 1 ms apart from its clock's time.
    struct Script {
        clock: VirtualClock,
        rx: Vec<CanFrame>,
    }

    impl CanBus for Script {
        fn send(&mut self, _: &CanFrame) -> Result<(), BusError> {
            Ok(())
        }
        fn recv_until(&mut self, deadline: Timestamp) -> Result<Option<Received>, BusError> {
            if self.rx.is_empty() {
                self.clock.sleep_until(deadline);
                return Ok(None);
            }
            self.clock.advance(Duration::from_millis(1));
            Ok(Some(Received {
                at: self.clock.now(),
                message: BusMessage::Frame(self.rx.remove(0)),
            }))
        }
    }

    fn frame(id: u16, b0: u8) -> CanFrame {
        CanFrame::with_data(id, [b0, 1, 2, 3, 4, 5, 6, 7]).unwrap()
    }

    #[test]
    fn sent_and_received_frames_become_log_lines_in_order() {
        let clock = VirtualClock::new();
        let bus = Script {
            clock: clock.clone(),
            rx: vec![frame(0x141, 0x9C), frame(0x142, 0x9C)],
        };
        let options = RecordOptions::new("vcan3").time_offset(Duration::from_secs(1_000));
        let (mut rec, writer) = record(bus, clock.clone(), Vec::new(), options).unwrap();
        rec.send(&frame(0x141, 0x9C)).unwrap();
        let far = clock.now() + Duration::from_secs(1);
        assert!(rec.recv_until(far).unwrap().is_some());
        assert!(rec.recv_until(far).unwrap().is_some());
        assert!(rec.recv_until(far).unwrap().is_none());
        assert_eq!(rec.stats().recorded, 3);
        drop(rec);
        let (stats, log) = writer.finish_into_inner().unwrap();
        assert_eq!(
            stats,
            RecordStats {
                recorded: 3,
                dropped: 0,
                written: 3
            }
        );
        let text = String::from_utf8(log).unwrap();
        let lines: Vec<_> = text.lines().collect();
        assert_eq!(
            lines,
            [
                "(0000001000.000000) vcan3 141#9C01020304050607 T",
                "(0000001000.001000) vcan3 141#9C01020304050607 R",
                "(0000001000.002000) vcan3 142#9C01020304050607 R",
            ]
        );
        for line in lines {
            assert!(parse_line(line).is_ok());
        }
    }

    #[test]
    fn refused_sends_are_not_recorded() {
        struct Full;
        impl CanBus for Full {
            fn send(&mut self, _: &CanFrame) -> Result<(), BusError> {
                Err(BusError::TxQueueFull)
            }
            fn recv_until(&mut self, _: Timestamp) -> Result<Option<Received>, BusError> {
                Ok(None)
            }
        }
        let options = RecordOptions::new("can0").time_offset(Duration::ZERO);
        let (mut rec, writer) = record(Full, VirtualClock::new(), Vec::new(), options).unwrap();
        assert_eq!(rec.send(&frame(0x141, 0x80)), Err(BusError::TxQueueFull));
        drop(rec);
        let (stats, log) = writer.finish_into_inner().unwrap();
        assert_eq!(stats, RecordStats::default());
        assert!(log.is_empty());
    }

    #[test]
    fn without_direction_markers_lines_are_plain_candump_l() {
        let clock = VirtualClock::new();
        let options = RecordOptions::new("can0")
            .time_offset(Duration::ZERO)
            .directions(false);
        let bus = Script {
            clock: clock.clone(),
            rx: vec![],
        };
        let (mut rec, writer) = record(bus, clock, Vec::new(), options).unwrap();
        rec.send(&frame(0x280, 0)).unwrap();
        drop(rec);
        let (_, log) = writer.finish_into_inner().unwrap();
        assert_eq!(
            String::from_utf8(log).unwrap(),
            "(0000000000.000000) can0 280#0001020304050607\n"
        );
    }

    #[test]
    fn a_failing_sink_is_reported_with_what_was_lost() {
        struct Broken;
        impl Write for Broken {
            fn write(&mut self, _: &[u8]) -> io::Result<usize> {
                Err(io::Error::other("disk full"))
            }
            fn flush(&mut self) -> io::Result<()> {
                Err(io::Error::other("disk full"))
            }
        }
        let clock = VirtualClock::new();
        let bus = Script {
            clock: clock.clone(),
            rx: vec![],
        };
        let options = RecordOptions::new("can0").time_offset(Duration::ZERO);
        let (mut rec, writer) = record(bus, clock, Broken, options).unwrap();
        for _ in 0..10 {
            rec.send(&frame(0x141, 0x9A)).unwrap();
        }
        drop(rec);
        match writer.finish() {
            Err(RecordError::Write { source, stats }) => {
                assert!(source.to_string().contains("disk full"));
                assert_eq!(stats.recorded, 10);
                // The lines went into the buffer, then the flush failed: nothing reached the
                // sink, and the counters say so rather than claiming they were written.
                assert_eq!((stats.written, stats.dropped), (0, 10), "{stats:?}");
            }
            other => panic!("expected a write error, got {other:?}"),
        }
    }
}
