//! The pipeline with test sinks: per-sink drop counting, no sinks, clean shutdown, errors.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, Sender, channel};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use rmd_telemetry::{Delivery, PushOutcome, Sink, SinkError, Telemetry, TickRecord};

/// What a probe sink saw, shared with the test.
#[derive(Default)]
struct Seen {
    ticks: Mutex<Vec<u64>>,
    closes: AtomicU64,
}

impl Seen {
    fn count(&self) -> usize {
        self.ticks.lock().unwrap().len()
    }

    fn ticks(&self) -> Vec<u64> {
        self.ticks.lock().unwrap().clone()
    }
}

/// A sink that records the ticks it gets; optionally slow, blocked, failing or panicking.
struct Probe {
    name: String,
    seen: Arc<Seen>,
    delay: Duration,
    gate: Option<Receiver<()>>,
    fail_every: Option<u64>,
    panic_at: Option<u64>,
}

impl Probe {
    fn new(name: &str) -> (Self, Arc<Seen>) {
        let seen = Arc::new(Seen::default());
        (
            Self {
                name: name.to_owned(),
                seen: Arc::clone(&seen),
                delay: Duration::ZERO,
                gate: None,
                fail_every: None,
                panic_at: None,
            },
            seen,
        )
    }
}

impl Sink for Probe {
    fn name(&self) -> &str {
        &self.name
    }

    fn write(&mut self, record: &TickRecord) -> Result<(), SinkError> {
        if let Some(gate) = self.gate.take() {
            // Block on the first record until the test opens the gate.
            let _ = gate.recv();
        }
        if self.panic_at == Some(record.tick) {
            panic!("probe {} panics at tick {}", self.name, record.tick);
        }
        if !self.delay.is_zero() {
            std::thread::sleep(self.delay);
        }
        if self.fail_every.is_some_and(|n| record.tick % n == n - 1) {
            return Err(SinkError::Other(format!(
                "probe fails at tick {}",
                record.tick
            )));
        }
        self.seen.ticks.lock().unwrap().push(record.tick);
        Ok(())
    }

    fn close(&mut self) -> Result<(), SinkError> {
        self.seen.closes.fetch_add(1, Ordering::Relaxed);
        Ok(())
    }
}

fn record(tick: u64) -> TickRecord {
    TickRecord::new(tick, tick * 1_000_000, 5_000_000_000 + tick * 1_000_000)
}

fn wait_until(what: &str, mut done: impl FnMut() -> bool) {
    let deadline = Instant::now() + Duration::from_secs(20);
    while !done() {
        assert!(Instant::now() < deadline, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_micros(200));
    }
}

fn gate() -> (Sender<()>, Receiver<()>) {
    channel()
}

#[test]
fn a_sink_that_cannot_keep_up_loses_records_counted_for_it_alone() {
    let (fast, fast_seen) = Probe::new("fast");
    let (mut slow, slow_seen) = Probe::new("slow");
    let (open, gate_rx) = gate();
    slow.gate = Some(gate_rx);
    let capacity = 16;
    let (producer, pipeline) = Telemetry::builder()
        .sink(fast)
        .sink(slow)
        .intake_capacity(1024)
        .sink_capacity(capacity)
        .start()
        .unwrap();
    let total = 1000_u64;
    // Push in batches smaller than a queue and let the fast sink catch up after each: it never
    // falls behind, while the slow sink is blocked on its first record the whole time.
    for batch in 0..total / 10 {
        for tick in batch * 10..batch * 10 + 10 {
            assert_eq!(producer.push(&record(tick)), PushOutcome::Queued);
        }
        let pushed = (batch * 10 + 10) as usize;
        wait_until("the fast sink", || fast_seen.count() == pushed);
    }
    open.send(()).unwrap();
    let stats = pipeline.shutdown();

    assert_eq!(stats.offered, total);
    assert_eq!(stats.intake_dropped, 0);
    let (fast_stats, slow_stats) = (&stats.sinks[0], &stats.sinks[1]);
    assert_eq!((fast_stats.written, fast_stats.dropped), (total, 0));
    assert_eq!(fast_seen.ticks(), (0..total).collect::<Vec<_>>());
    // The slow sink held one record and a full queue; everything else was lost, and counted.
    assert_eq!(
        slow_stats.written + slow_stats.dropped,
        total,
        "{slow_stats:?}"
    );
    assert!(slow_stats.written <= capacity as u64 + 2, "{slow_stats:?}");
    let slow_ticks = slow_seen.ticks();
    assert_eq!(slow_ticks.len() as u64, slow_stats.written);
    assert!(slow_ticks.windows(2).all(|w| w[0] < w[1]), "in order");
    assert_eq!(slow_stats.errors, 0);
    assert_eq!(stats.total_dropped(), slow_stats.dropped);
}

#[test]
fn without_sinks_nothing_is_queued_and_nothing_counted() {
    let (producer, pipeline) = Telemetry::builder().start().unwrap();
    assert!(!producer.is_enabled());
    for tick in 0..10_000 {
        assert_eq!(producer.push(&record(tick)), PushOutcome::NoSinks);
    }
    let stats = pipeline.shutdown();
    assert_eq!(stats.offered, 0);
    assert_eq!(stats.intake_dropped, 0);
    assert!(stats.sinks.is_empty());
    assert_eq!(stats.total_dropped(), 0);
    assert_eq!(stats.to_string(), "telemetry: off");
}

#[test]
fn shutdown_delivers_everything_queued_and_closes_every_sink_once() {
    let (a, a_seen) = Probe::new("a");
    let (mut b, b_seen) = Probe::new("b");
    b.delay = Duration::from_micros(50);
    let (producer, pipeline) = Telemetry::builder()
        .sink(a)
        .sink(b)
        .delivery(Delivery::Lossless)
        .intake_capacity(64)
        .sink_capacity(64)
        .start()
        .unwrap();
    let total = 3000;
    for tick in 0..total {
        assert_eq!(producer.push(&record(tick)), PushOutcome::Queued);
    }
    // Shut down at once: most records are still queued.
    let stats = pipeline.shutdown();
    assert_eq!(producer.push(&record(total)), PushOutcome::Closed);
    assert_eq!(stats.offered, total);
    for (sink, seen) in stats.sinks.iter().zip([&a_seen, &b_seen]) {
        assert_eq!(
            (sink.written, sink.dropped, sink.errors),
            (total, 0, 0),
            "{sink:?}"
        );
        assert_eq!(seen.ticks(), (0..total).collect::<Vec<_>>());
        assert_eq!(seen.closes.load(Ordering::Relaxed), 1);
    }
    assert_eq!(
        stats.to_string(),
        "telemetry: 3000 records; a: 3000 written, 0 failed, 0 dropped, 0 errors; \
         b: 3000 written, 0 failed, 0 dropped, 0 errors"
    );
}

#[test]
fn dropping_the_pipeline_closes_the_sinks_too() {
    let (a, a_seen) = Probe::new("a");
    let (producer, pipeline) = Telemetry::builder()
        .sink(a)
        .delivery(Delivery::Lossless)
        .start()
        .unwrap();
    for tick in 0..100 {
        producer.push(&record(tick));
    }
    drop(pipeline);
    assert_eq!(a_seen.count(), 100);
    assert_eq!(a_seen.closes.load(Ordering::Relaxed), 1);
}

#[test]
fn write_errors_are_counted_per_sink_with_the_first_message() {
    let (mut failing, _) = Probe::new("failing");
    failing.fail_every = Some(10);
    let (fine, _) = Probe::new("fine");
    let (producer, pipeline) = Telemetry::builder()
        .sink(failing)
        .sink(fine)
        .delivery(Delivery::Lossless)
        .start()
        .unwrap();
    for tick in 0..1000 {
        producer.push(&record(tick));
    }
    let stats = pipeline.shutdown();
    let failing = &stats.sinks[0];
    assert_eq!(
        (failing.written, failing.failed, failing.errors),
        (900, 100, 100)
    );
    assert_eq!(
        failing.first_error.as_deref(),
        Some("probe fails at tick 9")
    );
    let fine = &stats.sinks[1];
    assert_eq!((fine.written, fine.failed, fine.errors), (1000, 0, 0));
    assert!(stats.to_string().contains("(first: probe fails at tick 9)"));
}

#[test]
fn a_full_intake_counts_against_every_sink() {
    let (a, _) = Probe::new("a");
    let (b, _) = Probe::new("b");
    let (producer, pipeline) = Telemetry::builder()
        .sink(a)
        .sink(b)
        .intake_capacity(4)
        .sink_capacity(100_000)
        .start()
        .unwrap();
    let total = 20_000;
    let mut dropped = 0;
    for tick in 0..total {
        if producer.push(&record(tick)) == PushOutcome::Dropped {
            dropped += 1;
        }
    }
    let stats = pipeline.shutdown();
    assert!(
        dropped > 0,
        "a 4-record intake took 20000 records in a tight loop"
    );
    assert_eq!(stats.intake_dropped, dropped);
    for sink in &stats.sinks {
        assert_eq!(sink.dropped, dropped, "{sink:?}");
        assert_eq!(sink.written + sink.dropped, total, "{sink:?}");
    }
}

#[test]
fn a_panicking_sink_neither_blocks_lossless_delivery_nor_the_others() {
    let (mut bad, _) = Probe::new("bad");
    bad.panic_at = Some(5);
    let (good, good_seen) = Probe::new("good");
    let (producer, pipeline) = Telemetry::builder()
        .sink(bad)
        .sink(good)
        .delivery(Delivery::Lossless)
        .sink_capacity(8)
        .start()
        .unwrap();
    for tick in 0..200 {
        producer.push(&record(tick));
    }
    let stats = pipeline.shutdown();
    assert_eq!(good_seen.count(), 200);
    let bad = &stats.sinks[0];
    assert_eq!(bad.written, 5);
    assert_eq!(
        bad.first_error.as_deref(),
        Some("the sink's thread panicked")
    );
    // Everything after the panic was lost for that sink (the record it panicked on too).
    assert!(bad.dropped >= 200 - 5 - 1 - 8, "{bad:?}");
}

#[test]
fn live_stats_grow_while_running() {
    let (a, a_seen) = Probe::new("a");
    let (producer, pipeline) = Telemetry::builder().sink(a).start().unwrap();
    producer.push(&record(0));
    producer.push(&record(1));
    wait_until("two records", || a_seen.count() == 2);
    let live = pipeline.stats();
    assert_eq!(live.offered, 2);
    assert_eq!(live.sinks[0].written, 2);
    assert_eq!(pipeline.shutdown().sinks[0].written, 2);
}

#[test]
fn zero_capacity_is_refused() {
    let (a, _) = Probe::new("a");
    let err = Telemetry::builder()
        .sink(a)
        .intake_capacity(0)
        .start()
        .unwrap_err();
    assert_eq!(
        err.to_string(),
        "a telemetry queue capacity must be at least 1"
    );
}
