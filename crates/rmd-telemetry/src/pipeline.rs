//! The pipeline: a producer that never waits, one intake queue, a fan-out thread, and one
//! bounded queue and thread per sink.
//!
//! ```text
//! producer (real-time) ──push──▶ intake queue ──▶ fan-out thread ──▶ sink queue ──▶ sink thread
//!                                                               ├──▶ sink queue ──▶ sink thread
//!                                                               └──▶ ...
//! ```
//!
//! A full queue loses the record and counts it: a full intake queue counts against every sink, a
//! full sink queue against that sink only. The producer's push is a copy into a lock-free queue
//! and a few atomic additions: no allocation, no lock, no system call.

use std::fmt;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::thread::{self, JoinHandle, Thread};
use std::time::Duration;

use crossbeam_queue::ArrayQueue;
use thiserror::Error;

use crate::record::TickRecord;
use crate::sink::{Sink, SinkError, SinkStats};

/// Default capacity of the intake queue and of each sink's queue: two seconds at 1 kHz.
pub const DEFAULT_QUEUE_CAPACITY: usize = 2048;

/// How long the fan-out thread sleeps when the intake queue is empty.
const INTAKE_POLL: Duration = Duration::from_millis(1);

/// How long a sink thread sleeps when its queue is empty (the fan-out thread wakes it sooner).
const SINK_POLL: Duration = Duration::from_millis(5);

/// How long a waiting producer or fan-out thread sleeps before trying again (lossless delivery).
const RETRY: Duration = Duration::from_micros(50);

/// What the pipeline does when a queue is full.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Delivery {
    /// Lose the record and count it; the producer never waits. For real-time runs (default).
    #[default]
    Lossy,
    /// Wait for room: the producer's [`Producer::push`] sleeps until the intake has room and the
    /// fan-out thread until each sink's queue has, so every sink gets every record. For runs on
    /// virtual time and for tests; never on a real-time thread, since the producer then runs at
    /// the slowest sink's pace.
    Lossless,
}

/// What became of one pushed record.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PushOutcome {
    /// Queued for the sinks.
    Queued,
    /// The intake queue was full: the record is lost for every sink, and counted.
    Dropped,
    /// The pipeline has no sink: nothing was queued or counted.
    NoSinks,
    /// The pipeline has shut down: nothing was queued or counted.
    Closed,
}

/// Starting the pipeline failed.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum PipelineError {
    /// A queue capacity of zero.
    #[error("a telemetry queue capacity must be at least 1")]
    ZeroCapacity,
    /// The OS refused a thread.
    #[error("starting the telemetry thread {name:?}: {source}")]
    Spawn {
        /// The thread's name.
        name: String,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
}

/// State the producer shares with the fan-out thread.
struct Intake {
    queue: ArrayQueue<TickRecord>,
    delivery: Delivery,
    open: AtomicBool,
    offered: AtomicU64,
    dropped: AtomicU64,
}

/// One sink's queue and counters.
struct Lane {
    name: String,
    queue: ArrayQueue<TickRecord>,
    closing: AtomicBool,
    alive: AtomicBool,
    written: AtomicU64,
    failed: AtomicU64,
    dropped: AtomicU64,
    errors: AtomicU64,
}

/// The producer's end: pushes one record per tick, never waits.
///
/// Cheap to clone; [`Producer::disabled`] is the producer of a run without telemetry.
#[derive(Clone)]
pub struct Producer {
    intake: Option<Arc<Intake>>,
}

impl fmt::Debug for Producer {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Producer")
            .field("enabled", &self.is_enabled())
            .finish()
    }
}

impl Producer {
    /// A producer with no sink behind it: [`Producer::push`] does nothing and counts nothing.
    pub const fn disabled() -> Self {
        Self { intake: None }
    }

    /// Whether any sink receives the records.
    pub fn is_enabled(&self) -> bool {
        self.intake.is_some()
    }

    /// Queues a copy of `record` for every sink. With [`Delivery::Lossy`] (the default) it never
    /// blocks, never allocates and takes no lock: safe on the real-time thread. With
    /// [`Delivery::Lossless`] it sleeps while the intake queue is full.
    pub fn push(&self, record: &TickRecord) -> PushOutcome {
        let Some(intake) = &self.intake else {
            return PushOutcome::NoSinks;
        };
        if !intake.open.load(Ordering::Acquire) {
            return PushOutcome::Closed;
        }
        intake.offered.fetch_add(1, Ordering::Relaxed);
        // One copy, straight into the queue's slot when there is room.
        let Err(mut pending) = intake.queue.push(*record) else {
            return PushOutcome::Queued;
        };
        while intake.delivery == Delivery::Lossless && intake.open.load(Ordering::Acquire) {
            thread::sleep(RETRY);
            match intake.queue.push(pending) {
                Ok(()) => return PushOutcome::Queued,
                Err(back) => pending = back,
            }
        }
        intake.dropped.fetch_add(1, Ordering::Relaxed);
        PushOutcome::Dropped
    }
}

/// Builds a telemetry pipeline: add sinks, then [`TelemetryBuilder::start`].
///
/// ```
/// use rmd_telemetry::{PushOutcome, Telemetry, TickRecord};
///
/// // No sink: the producer does nothing and nothing is counted.
/// let (producer, pipeline) = Telemetry::builder().start()?;
/// assert_eq!(producer.push(&TickRecord::new(0, 0, 0)), PushOutcome::NoSinks);
/// let stats = pipeline.shutdown();
/// assert_eq!((stats.offered, stats.sinks.len()), (0, 0));
/// # Ok::<(), rmd_telemetry::PipelineError>(())
/// ```
#[must_use]
pub struct TelemetryBuilder {
    sinks: Vec<Box<dyn Sink>>,
    intake_capacity: usize,
    sink_capacity: usize,
    delivery: Delivery,
}

impl fmt::Debug for TelemetryBuilder {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("TelemetryBuilder")
            .field(
                "sinks",
                &self.sinks.iter().map(|s| s.name()).collect::<Vec<_>>(),
            )
            .field("intake_capacity", &self.intake_capacity)
            .field("sink_capacity", &self.sink_capacity)
            .field("delivery", &self.delivery)
            .finish()
    }
}

/// The entry point: [`Telemetry::builder`].
#[derive(Debug)]
pub struct Telemetry;

impl Telemetry {
    /// A pipeline with no sink yet and [`DEFAULT_QUEUE_CAPACITY`] queues.
    pub fn builder() -> TelemetryBuilder {
        TelemetryBuilder {
            sinks: Vec::new(),
            intake_capacity: DEFAULT_QUEUE_CAPACITY,
            sink_capacity: DEFAULT_QUEUE_CAPACITY,
            delivery: Delivery::Lossy,
        }
    }
}

impl TelemetryBuilder {
    /// Adds a sink.
    pub fn sink(mut self, sink: impl Sink) -> Self {
        self.sinks.push(Box::new(sink));
        self
    }

    /// Adds a boxed sink.
    pub fn boxed_sink(mut self, sink: Box<dyn Sink>) -> Self {
        self.sinks.push(sink);
        self
    }

    /// Adds a sink if there is one (handy for optional `--mcap` style flags).
    pub fn sink_opt(self, sink: Option<impl Sink>) -> Self {
        match sink {
            Some(sink) => self.sink(sink),
            None => self,
        }
    }

    /// Records the intake queue holds (between the producer and the fan-out thread).
    pub fn intake_capacity(mut self, records: usize) -> Self {
        self.intake_capacity = records;
        self
    }

    /// Records each sink's queue holds.
    pub fn sink_capacity(mut self, records: usize) -> Self {
        self.sink_capacity = records;
        self
    }

    /// What to do when a queue is full (default [`Delivery::Lossy`]).
    pub fn delivery(mut self, delivery: Delivery) -> Self {
        self.delivery = delivery;
        self
    }

    /// The number of sinks added so far.
    pub fn sink_count(&self) -> usize {
        self.sinks.len()
    }

    /// Starts one thread per sink and the fan-out thread; returns the producer and the handle
    /// that stops them. With no sink, starts nothing and returns [`Producer::disabled`].
    ///
    /// # Errors
    /// [`PipelineError::ZeroCapacity`] for a zero capacity; [`PipelineError::Spawn`] if the OS
    /// refuses a thread (threads already started are stopped and their sinks closed).
    pub fn start(self) -> Result<(Producer, Pipeline), PipelineError> {
        if self.intake_capacity == 0 || self.sink_capacity == 0 {
            return Err(PipelineError::ZeroCapacity);
        }
        if self.sinks.is_empty() {
            return Ok((Producer::disabled(), Pipeline::empty()));
        }
        let intake = Arc::new(Intake {
            queue: ArrayQueue::new(self.intake_capacity),
            delivery: self.delivery,
            open: AtomicBool::new(true),
            offered: AtomicU64::new(0),
            dropped: AtomicU64::new(0),
        });
        let mut pipeline = Pipeline {
            intake: Some(Arc::clone(&intake)),
            lanes: Vec::new(),
            stop: Arc::new(AtomicBool::new(false)),
            fan_out: None,
            sink_threads: Vec::new(),
            finished: None,
        };
        for (index, sink) in self.sinks.into_iter().enumerate() {
            let lane = Arc::new(Lane {
                name: sink.name().to_owned(),
                queue: ArrayQueue::new(self.sink_capacity),
                closing: AtomicBool::new(false),
                alive: AtomicBool::new(true),
                written: AtomicU64::new(0),
                failed: AtomicU64::new(0),
                dropped: AtomicU64::new(0),
                errors: AtomicU64::new(0),
            });
            let name = format!("rmd-tlm-sink{index}");
            let worker_lane = Arc::clone(&lane);
            let spawned = thread::Builder::new()
                .name(name.clone())
                .spawn(move || run_sink(sink, &worker_lane));
            match spawned {
                Ok(handle) => {
                    pipeline.lanes.push(lane);
                    pipeline.sink_threads.push(handle);
                }
                // Dropping `pipeline` closes the sinks already started.
                Err(source) => return Err(PipelineError::Spawn { name, source }),
            }
        }
        let lanes: Vec<(Arc<Lane>, Thread)> = pipeline
            .lanes
            .iter()
            .zip(&pipeline.sink_threads)
            .map(|(lane, handle)| (Arc::clone(lane), handle.thread().clone()))
            .collect();
        let stop = Arc::clone(&pipeline.stop);
        let name = "rmd-tlm-fanout".to_owned();
        let fan_out = thread::Builder::new()
            .name(name.clone())
            .spawn(move || run_fan_out(&intake, &lanes, &stop))
            .map_err(|source| PipelineError::Spawn { name, source })?;
        pipeline.fan_out = Some(fan_out);
        Ok((
            Producer {
                intake: pipeline.intake.clone(),
            },
            pipeline,
        ))
    }
}

/// The fan-out thread: intake queue to every sink queue.
fn run_fan_out(intake: &Intake, lanes: &[(Arc<Lane>, Thread)], stop: &AtomicBool) {
    loop {
        // Read the flag before draining: everything pushed before it was set is drained below.
        let stopping = stop.load(Ordering::Acquire);
        let mut moved = 0_usize;
        while let Some(record) = intake.queue.pop() {
            for (lane, thread) in lanes {
                deliver(intake.delivery, lane, thread, record);
            }
            moved += 1;
            if moved.is_multiple_of(64) {
                wake(lanes);
            }
        }
        if moved > 0 {
            wake(lanes);
        }
        if stopping {
            break;
        }
        thread::park_timeout(INTAKE_POLL);
    }
    for (lane, thread) in lanes {
        lane.closing.store(true, Ordering::Release);
        thread.unpark();
    }
}

/// Puts `record` on `lane`'s queue, waiting for room if lossless and the sink is still running.
fn deliver(delivery: Delivery, lane: &Lane, thread: &Thread, record: TickRecord) {
    let mut pending = record;
    loop {
        match lane.queue.push(pending) {
            Ok(()) => return,
            Err(back) => {
                if delivery == Delivery::Lossy || !lane.alive.load(Ordering::Acquire) {
                    lane.dropped.fetch_add(1, Ordering::Relaxed);
                    return;
                }
                pending = back;
                thread.unpark();
                thread::sleep(RETRY);
            }
        }
    }
}

fn wake(lanes: &[(Arc<Lane>, Thread)]) {
    for (_, thread) in lanes {
        thread.unpark();
    }
}

/// What a sink thread reports at its end: the first error's message, the sink's note.
type SinkEnd = (Option<String>, Option<String>);

/// A sink thread: its queue to its sink, then close.
fn run_sink(mut sink: Box<dyn Sink>, lane: &Lane) -> SinkEnd {
    /// Marks the lane dead when the thread ends, even by a panic, so nobody waits for it.
    struct Alive<'a>(&'a AtomicBool);
    impl Drop for Alive<'_> {
        fn drop(&mut self) {
            self.0.store(false, Ordering::Release);
        }
    }
    let _alive = Alive(&lane.alive);
    let mut first_error = None;
    let mut note = |error: SinkError| {
        lane.errors.fetch_add(1, Ordering::Relaxed);
        first_error.get_or_insert_with(|| error.to_string());
    };
    // Records counted written that the sink reported lost since (moved to failed).
    let mut lost = 0;
    let mut account_lost = |sink: &dyn Sink| {
        let now = sink.lost();
        if now > lost {
            lane.written.fetch_sub(now - lost, Ordering::Relaxed);
            lane.failed.fetch_add(now - lost, Ordering::Relaxed);
            lost = now;
        }
    };
    loop {
        let closing = lane.closing.load(Ordering::Acquire);
        let mut handled = false;
        while let Some(record) = lane.queue.pop() {
            handled = true;
            if sink.is_broken() {
                lane.failed.fetch_add(1, Ordering::Relaxed);
                continue;
            }
            match sink.write(&record) {
                Ok(()) => lane.written.fetch_add(1, Ordering::Relaxed),
                Err(error) => {
                    note(error);
                    lane.failed.fetch_add(1, Ordering::Relaxed)
                }
            };
            account_lost(&*sink);
        }
        if closing {
            break;
        }
        if !handled {
            if !sink.is_broken()
                && let Err(error) = sink.idle()
            {
                note(error);
                account_lost(&*sink);
            }
            thread::park_timeout(SINK_POLL);
        }
    }
    if let Err(error) = sink.close() {
        note(error);
    }
    account_lost(&*sink);
    (first_error, sink.note())
}

/// The running pipeline: live statistics and the clean stop. Dropping it stops it too.
pub struct Pipeline {
    intake: Option<Arc<Intake>>,
    lanes: Vec<Arc<Lane>>,
    stop: Arc<AtomicBool>,
    fan_out: Option<JoinHandle<()>>,
    sink_threads: Vec<JoinHandle<SinkEnd>>,
    finished: Option<PipelineStats>,
}

impl fmt::Debug for Pipeline {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Pipeline")
            .field("stats", &self.stats())
            .finish()
    }
}

impl Pipeline {
    fn empty() -> Self {
        Self {
            intake: None,
            lanes: Vec::new(),
            stop: Arc::new(AtomicBool::new(true)),
            fan_out: None,
            sink_threads: Vec::new(),
            finished: None,
        }
    }

    /// The counters so far (records still queued count as neither written nor dropped yet).
    pub fn stats(&self) -> PipelineStats {
        if let Some(done) = &self.finished {
            return done.clone();
        }
        self.snapshot(&[])
    }

    fn snapshot(&self, ends: &[SinkEnd]) -> PipelineStats {
        let (offered, intake_dropped) = self.intake.as_ref().map_or((0, 0), |i| {
            (
                i.offered.load(Ordering::Relaxed),
                i.dropped.load(Ordering::Relaxed),
            )
        });
        let sinks = self
            .lanes
            .iter()
            .enumerate()
            .map(|(i, lane)| SinkStats {
                name: lane.name.clone(),
                written: lane.written.load(Ordering::Relaxed),
                failed: lane.failed.load(Ordering::Relaxed),
                dropped: lane.dropped.load(Ordering::Relaxed) + intake_dropped,
                errors: lane.errors.load(Ordering::Relaxed),
                first_error: ends.get(i).and_then(|end| end.0.clone()),
                note: ends.get(i).and_then(|end| end.1.clone()),
            })
            .collect();
        PipelineStats {
            offered,
            intake_dropped,
            sinks,
        }
    }

    /// Stops accepting records, delivers everything queued, closes every sink (MCAP summaries
    /// written, servers stopped, files flushed) and returns the final counts.
    ///
    /// Call it after the producer's last push: a push that races with the shutdown returns
    /// [`PushOutcome::Closed`] or is delivered.
    pub fn shutdown(mut self) -> PipelineStats {
        self.finish()
    }

    fn finish(&mut self) -> PipelineStats {
        if let Some(done) = &self.finished {
            return done.clone();
        }
        if let Some(intake) = &self.intake {
            intake.open.store(false, Ordering::Release);
        }
        self.stop.store(true, Ordering::Release);
        if let Some(fan_out) = self.fan_out.take() {
            fan_out.thread().unpark();
            // A panicking fan-out thread has already stopped delivering; the counts below say so.
            let _ = fan_out.join();
        } else {
            // Never started (a spawn failed): tell the sink threads ourselves.
            for (lane, thread) in self.lanes.iter().zip(&self.sink_threads) {
                lane.closing.store(true, Ordering::Release);
                thread.thread().unpark();
            }
        }
        let ends: Vec<SinkEnd> = self
            .sink_threads
            .drain(..)
            .map(|handle| {
                handle
                    .join()
                    .unwrap_or_else(|_| (Some("the sink's thread panicked".to_owned()), None))
            })
            .collect();
        // Records the fan-out thread never delivered (a push that raced the stop) are lost for
        // every sink: count them.
        if let Some(intake) = &self.intake {
            let mut stranded = 0;
            while intake.queue.pop().is_some() {
                stranded += 1;
            }
            intake.dropped.fetch_add(stranded, Ordering::Relaxed);
        }
        let stats = self.snapshot(&ends);
        self.finished = Some(stats.clone());
        stats
    }
}

impl Drop for Pipeline {
    fn drop(&mut self) {
        self.finish();
    }
}

/// The pipeline's counts: records offered by the producer, and per sink what became of them.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct PipelineStats {
    /// Records pushed while the pipeline was open and had sinks.
    pub offered: u64,
    /// Records lost at the intake queue (counted in every sink's
    /// [`dropped`](SinkStats::dropped) too).
    pub intake_dropped: u64,
    /// One entry per sink, in the order they were added.
    pub sinks: Vec<SinkStats>,
}

impl PipelineStats {
    /// Records lost by any sink.
    pub fn total_dropped(&self) -> u64 {
        self.sinks.iter().map(|s| s.dropped).sum()
    }
}

impl fmt::Display for PipelineStats {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.sinks.is_empty() {
            return write!(f, "telemetry: off");
        }
        write!(f, "telemetry: {} records", self.offered)?;
        for sink in &self.sinks {
            write!(f, "; {sink}")?;
        }
        Ok(())
    }
}
