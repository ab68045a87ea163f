//! The recorder never makes its caller wait: with the writer stalled, every send and receive
//! still returns, the frames that do not fit the queue are counted as dropped, and the caller's
//! path allocates nothing. No assertion here depends on timing.

use core::time::Duration;
use std::io::{self, Write};
use std::sync::mpsc;
use std::sync::{Arc, Condvar, Mutex};

use rmd_bus::candump::{FrameDirection, parse_line};
use rmd_bus::record::{RecordOptions, RecordStats, record};
use rmd_bus::{BusError, BusMessage, CanBus, CanFrame, Clock, Received, Timestamp, VirtualClock};

/// Generous bound for a thread to finish work that takes microseconds; only hit if it hangs.
const HANG: Duration = Duration::from_secs(60);

/// A sink whose writes wait until the test opens the gate, telling the test when the writer
/// thread is stuck in it.
#[derive(Clone)]
struct GatedSink {
    open: Arc<(Mutex<bool>, Condvar)>,
    entered: mpsc::SyncSender<()>,
    bytes: Arc<Mutex<Vec<u8>>>,
}

impl GatedSink {
    fn release(&self) {
        let (lock, condvar) = &*self.open;
        *lock.lock().unwrap() = true;
        condvar.notify_all();
    }
}

impl Write for GatedSink {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let _ = self.entered.try_send(());
        let (lock, condvar) = &*self.open;
        let mut open = lock.lock().unwrap();
        while !*open {
            open = condvar.wait(open).unwrap();
        }
        self.bytes.lock().unwrap().extend_from_slice(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

/// A bus that accepts every frame and receives one frame per call.
struct Loopback {
    clock: VirtualClock,
}

impl CanBus for Loopback {
    fn send(&mut self, _: &CanFrame) -> Result<(), BusError> {
        Ok(())
    }
    fn recv_until(&mut self, _: Timestamp) -> Result<Option<Received>, BusError> {
        self.clock.advance(Duration::from_micros(100));
        Ok(Some(Received {
            at: self.clock.now(),
            message: BusMessage::Frame(numbered(0x142, u32::MAX)),
        }))
    }
}

/// A 0x141 frame carrying `n` in its last four bytes.
fn numbered(id: u16, n: u32) -> CanFrame {
    let b = n.to_le_bytes();
    CanFrame::with_data(id, [0x9C, 0, 0, 0, b[0], b[1], b[2], b[3]]).unwrap()
}

fn number_of(frame: &CanFrame) -> u32 {
    let d = frame.data();
    u32::from_le_bytes([d[4], d[5], d[6], d[7]])
}

#[test]
fn a_stalled_writer_never_blocks_the_caller_and_drops_are_counted() {
    const CAPACITY: usize = 16;
    const FRAMES: u32 = 10_000;
    let (entered_tx, entered_rx) = mpsc::sync_channel(1);
    let sink = GatedSink {
        open: Arc::new((Mutex::new(false), Condvar::new())),
        entered: entered_tx,
        bytes: Arc::default(),
    };
    let clock = VirtualClock::new();
    let options = RecordOptions::new("can0")
        .time_offset(Duration::ZERO)
        .capacity(CAPACITY)
        .poll_interval(Duration::from_millis(1));
    let (mut bus, writer) = record(
        Loopback {
            clock: clock.clone(),
        },
        clock,
        sink.clone(),
        options,
    )
    .unwrap();

    // One frame, which the writer takes and then blocks on while writing it out.
    bus.send(&numbered(0x141, 0)).unwrap();
    entered_rx
        .recv_timeout(HANG)
        .expect("the writer never wrote the first frame");

    // Everything else while the writer is stuck: the caller must get through all of it.
    let (done_tx, done_rx) = mpsc::channel();
    let caller = std::thread::spawn(move || {
        for n in 1..=FRAMES {
            bus.send(&numbered(0x141, n)).unwrap();
        }
        let received = bus.recv_until(Timestamp::ZERO).unwrap();
        done_tx.send(()).unwrap();
        (bus, received)
    });
    done_rx
        .recv_timeout(HANG)
        .expect("the caller was blocked by the stalled writer");
    let (bus, received) = caller.join().unwrap();
    assert!(received.is_some());

    // The queue holds CAPACITY frames; the rest (and the received frame) were dropped.
    let stats = bus.stats();
    assert_eq!(stats.recorded, 1 + CAPACITY as u64);
    assert_eq!(stats.dropped, u64::from(FRAMES) + 1 - CAPACITY as u64);
    assert_eq!(stats.written, 0);

    sink.release();
    drop(bus);
    let stats = writer.finish().unwrap();
    assert_eq!(
        stats,
        RecordStats {
            recorded: 1 + CAPACITY as u64,
            dropped: u64::from(FRAMES) + 1 - CAPACITY as u64,
            written: 1 + CAPACITY as u64,
        }
    );

    // The log holds exactly what was recorded, in order: frame 0, then frames 1..=CAPACITY.
    let text = String::from_utf8(sink.bytes.lock().unwrap().clone()).unwrap();
    let numbers: Vec<u32> = text
        .lines()
        .map(|line| {
            let parsed = parse_line(line).unwrap();
            assert_eq!(parsed.direction, Some(FrameDirection::Tx));
            number_of(&parsed.frame)
        })
        .collect();
    assert_eq!(numbers, (0..=CAPACITY as u32).collect::<Vec<_>>());
}

#[test]
fn recording_allocates_nothing_on_the_callers_path() {
    let clock = VirtualClock::new();
    let options = RecordOptions::new("can0").time_offset(Duration::ZERO);
    let (mut bus, writer) = record(
        Loopback {
            clock: clock.clone(),
        },
        clock.clone(),
        io::sink(),
        options,
    )
    .unwrap();
    let frame = numbered(0x141, 7);
    // Warm up (first use of thread-locals etc.).
    bus.send(&frame).unwrap();
    let before = rmd_test_support::alloc::this_thread().allocations;
    for _ in 0..1_000 {
        bus.send(&frame).unwrap();
        let _ = bus.recv_until(clock.now()).unwrap();
    }
    let allocated = rmd_test_support::alloc::this_thread().allocations - before;
    assert_eq!(
        allocated, 0,
        "send/recv_until through the recorder allocated"
    );
    drop(bus);
    let stats = writer.finish().unwrap();
    assert_eq!(stats.recorded + stats.dropped, 2_001);
    assert_eq!(stats.written, stats.recorded);
}
