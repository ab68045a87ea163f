//! The SocketCAN backend against a real Linux kernel CAN stack.
//!
//! Every test makes its own interfaces (private vcan interfaces, or an slcan interface on a
//! pseudo-terminal), so the tests run in parallel and never disturb a user's `vcan0`. They
//! need CAP_NET_ADMIN and the can, can-raw, vcan and slcan modules: run them with
//! `tests/vcan/run.sh`, which boots a small VM on a stock Debian kernel unless this machine has
//! a usable `vcan0` and root.
//!
//! Timing in the VM is poor (software emulation): tests check what happens and its order, and
//! bound times only from below ("not before the deadline") or generously from above.
#![cfg(target_os = "linux")]

mod support;

use core::time::Duration;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use rmd_bus::socketcan::{OpenError, SocketCanBus, SocketCanOptions};
use rmd_bus::{
    BusError, BusEvent, BusMessage, CanBus, CanFrame, Clock, MonotonicClock, Received, Timestamp,
};
use socketcan::{EmbeddedFrame, ExtendedId, StandardId};
use support::slcan::Slcan;
use support::{Peer, Vcan, eventually};

#[global_allocator]
static ALLOCATOR: rmd_test_support::alloc::CountingAllocator =
    rmd_test_support::alloc::CountingAllocator;

/// Long enough for anything that should happen to happen, even under emulation.
const LONG: Duration = Duration::from_secs(5);
/// How long to listen before concluding that nothing more arrives.
const QUIET: Duration = Duration::from_millis(300);

fn now() -> Timestamp {
    MonotonicClock.now()
}

fn open(iface: &str) -> SocketCanBus {
    SocketCanBus::open(iface, &SocketCanOptions::new().drain_window(Duration::ZERO))
        .unwrap_or_else(|e| panic!("open {iface}: {e}"))
}

fn frame(id: u16, data: &[u8]) -> CanFrame {
    CanFrame::new(id, data).unwrap()
}

/// The next thing received within [`LONG`].
fn next(bus: &mut SocketCanBus) -> Received {
    bus.recv_until(now() + LONG)
        .expect("recv_until")
        .expect("something within the time limit")
}

/// Everything received until the bus has been quiet for [`QUIET`].
fn until_quiet(bus: &mut SocketCanBus) -> Vec<Received> {
    let mut all = Vec::new();
    while let Some(received) = bus.recv_until(now() + QUIET).expect("recv_until") {
        all.push(received);
    }
    all
}

fn frames_of(received: &[Received]) -> Vec<CanFrame> {
    received
        .iter()
        .filter_map(|r| match r.message {
            BusMessage::Frame(frame) => Some(frame),
            BusMessage::Event(_) => None,
        })
        .collect()
}

fn events_of(received: &[Received]) -> Vec<BusEvent> {
    received
        .iter()
        .filter_map(|r| match r.message {
            BusMessage::Event(event) => Some(event),
            BusMessage::Frame(_) => None,
        })
        .collect()
}

#[test]
fn frames_flow_both_ways_between_the_bus_and_another_program() {
    let vcan = Vcan::up();
    let mut bus = open(&vcan.name);
    let peer = Peer::open(&vcan.name);

    bus.send(&frame(0x141, &[0x9A, 0, 0, 0, 0, 0, 0, 0]))
        .unwrap();
    assert_eq!(
        peer.recv(LONG),
        Some((0x141, vec![0x9A, 0, 0, 0, 0, 0, 0, 0]))
    );
    bus.send(&frame(0x143, &[])).unwrap();
    assert_eq!(peer.recv(LONG), Some((0x143, vec![])));

    peer.send(0x141, &[0x9A, 1, 2, 3, 4, 5, 6, 7]);
    peer.send(0x142, &[1, 2, 3]);
    assert_eq!(
        next(&mut bus).message,
        BusMessage::Frame(frame(0x141, &[0x9A, 1, 2, 3, 4, 5, 6, 7]))
    );
    assert_eq!(
        next(&mut bus).message,
        BusMessage::Frame(frame(0x142, &[1, 2, 3]))
    );
    assert_eq!(bus.stats().frames_received, 2);
    assert_eq!(bus.iface(), vcan.name);
}

#[test]
fn the_kernel_delivers_only_reply_ids_and_requested_extras() {
    let vcan = Vcan::up();
    let mut plain = open(&vcan.name);
    let mut extra = SocketCanBus::open(
        &vcan.name,
        &SocketCanOptions::new()
            .accept_id(0x280)
            .accept_ids(0x600..=0x601)
            .accept_masked(0x7F0, 0x7F0)
            .drain_window(Duration::ZERO),
    )
    .unwrap();
    let peer = Peer::open(&vcan.name);

    for id in [
        0x000, 0x140, 0x141, 0x150, 0x160, 0x161, 0x280, 0x281, 0x600, 0x601, 0x602, 0x7EF, 0x7F3,
    ] {
        peer.send(id, &[id as u8; 8]);
    }
    // Same identifier as a reply, but extended or remote: never delivered.
    peer.send_frame(&socketcan::CanFrame::new(ExtendedId::new(0x141).unwrap(), &[1]).unwrap());
    peer.send_frame(&socketcan::CanFrame::new_remote(StandardId::new(0x141).unwrap(), 8).unwrap());
    peer.send(0x141, &[0xEE; 8]);

    let ids = |bus: &mut SocketCanBus| -> Vec<u16> {
        frames_of(&until_quiet(bus))
            .iter()
            .map(|f| f.id())
            .collect()
    };
    assert_eq!(ids(&mut plain), [0x141, 0x150, 0x160, 0x141]);
    assert_eq!(
        ids(&mut extra),
        [0x141, 0x150, 0x160, 0x280, 0x600, 0x601, 0x7F3, 0x141]
    );
    // Filtered in the kernel: the backend never even saw the others.
    assert_eq!(plain.stats().frames_ignored, 0);
    assert_eq!(extra.stats().frames_ignored, 0);
}

#[test]
fn own_frames_are_not_echoed_but_other_programs_on_the_host_see_them() {
    let vcan = Vcan::up();
    let mut sender = open(&vcan.name);
    let mut listener = open(&vcan.name);

    sender.send(&frame(0x141, &[0xA1; 8])).unwrap();
    assert_eq!(
        next(&mut listener).message,
        BusMessage::Frame(frame(0x141, &[0xA1; 8]))
    );
    assert_eq!(until_quiet(&mut sender), []);
}

#[test]
fn receive_timestamps_come_from_the_kernel_on_the_monotonic_time_line() {
    let vcan = Vcan::up();
    let mut bus = open(&vcan.name);
    let peer = Peer::open(&vcan.name);

    let mut previous = Timestamp::ZERO;
    for i in 0..20u8 {
        let before = now();
        peer.send(0x141, &[i; 8]);
        let received = next(&mut bus);
        let after = now();
        // The conversion from the kernel's wall-clock stamp is good to well under a
        // millisecond; allow that much before the send started.
        assert!(
            received.at >= before.saturating_sub(Duration::from_millis(1)) && received.at <= after,
            "frame {i}: stamped {:?}, sent at {before:?}, read by {after:?}",
            received.at
        );
        assert!(received.at >= previous, "timestamps went backwards");
        previous = received.at;
    }

    // A frame left waiting in the socket keeps its arrival time, not the time it was read. (vcan
    // stamps a frame while its sender's write runs: by the time `send` returned. Timed from
    // then, a stall of the test thread before the write cannot eat into the 200 ms.)
    let before = now();
    peer.send(0x142, &[0; 8]);
    let sent = now();
    std::thread::sleep(Duration::from_millis(200));
    let received = next(&mut bus);
    let read = now();
    assert!(
        received.at >= before.saturating_sub(Duration::from_millis(1))
            && received.at <= sent + Duration::from_millis(1),
        "stamped {:?}, sent between {before:?} and {sent:?}",
        received.at
    );
    assert!(
        read - received.at >= Duration::from_millis(100),
        "stamped {:?}, read {read:?}: the timestamp is the read time, not the kernel's",
        received.at
    );
}

#[test]
fn recv_until_returns_nothing_at_the_deadline_and_never_before() {
    let vcan = Vcan::up();
    let mut bus = open(&vcan.name);

    for wait in [
        Duration::from_micros(300),
        Duration::from_millis(2),
        Duration::from_millis(50),
    ] {
        let deadline = now() + wait;
        assert_eq!(bus.recv_until(deadline), Ok(None));
        let returned = now();
        assert!(
            returned >= deadline,
            "returned {:?} early",
            deadline - returned
        );
        assert!(
            returned - deadline < LONG,
            "returned {:?} late",
            returned - deadline
        );
    }

    // A past deadline polls: nothing queued, nothing returned...
    assert_eq!(bus.recv_until(Timestamp::ZERO), Ok(None));
    // ...and what is queued is returned.
    let peer = Peer::open(&vcan.name);
    peer.send(0x144, &[4; 8]);
    let polled = eventually(LONG, || bus.recv_until(Timestamp::ZERO).unwrap());
    assert_eq!(
        polled.map(|r| r.message),
        Some(BusMessage::Frame(frame(0x144, &[4; 8])))
    );
}

#[test]
fn a_frame_arriving_during_the_wait_ends_it() {
    let vcan = Vcan::up();
    let mut bus = open(&vcan.name);
    let peer = Peer::open(&vcan.name);

    let deadline = now() + Duration::from_secs(30);
    let sender = std::thread::spawn(move || {
        std::thread::sleep(Duration::from_millis(50));
        peer.send(0x141, &[7; 8]);
    });
    let received = bus.recv_until(deadline).unwrap();
    assert!(now() < deadline);
    assert_eq!(
        received.map(|r| r.message),
        Some(BusMessage::Frame(frame(0x141, &[7; 8])))
    );
    sender.join().unwrap();
}

#[test]
fn one_ppoll_over_several_sockets_wakes_for_the_one_that_receives() {
    use rmd_bus::Readiness;
    use rmd_bus::ready::wait_any;
    let (va, vb) = (Vcan::up(), Vcan::up());
    let (mut a, mut b) = (open(&va.name), open(&vb.name));
    let peer = Peer::open(&vb.name);
    // Nothing queued: each gives its socket to watch, no arrival known.
    for bus in [&mut a, &mut b] {
        match bus.readiness() {
            Readiness::Pending(wait) => {
                assert!(wait.fd().is_some());
                assert_eq!(wait.next_arrival(), None);
            }
            other => panic!("{other:?}"),
        }
    }
    let deadline = now() + Duration::from_secs(30);
    let sender = std::thread::spawn(move || {
        std::thread::sleep(Duration::from_millis(50));
        peer.send(0x142, &[2; 8]);
    });
    let waits = [a.readiness(), b.readiness()].map(|r| match r {
        Readiness::Pending(wait) => wait,
        other => panic!("{other:?}"),
    });
    let woken = wait_any(&MonotonicClock, waits, deadline).unwrap();
    assert!(now() < deadline, "woken by the frame, not the deadline");
    assert_eq!(woken.iter().collect::<Vec<_>>(), vec![1], "only b received");
    // The frame is on b, taken without waiting; a has nothing.
    assert_eq!(
        b.recv_until(Timestamp::ZERO).unwrap().map(|r| r.message),
        Some(BusMessage::Frame(frame(0x142, &[2; 8])))
    );
    assert_eq!(a.recv_until(Timestamp::ZERO).unwrap(), None);
    sender.join().unwrap();
    // Nothing arrives: the wait ends at its deadline, never before.
    let waits = [a.readiness(), b.readiness()].map(|r| match r {
        Readiness::Pending(wait) => wait,
        other => panic!("{other:?}"),
    });
    let deadline = now() + Duration::from_millis(20);
    let woken = wait_any(&MonotonicClock, waits, deadline).unwrap();
    assert!(now() >= deadline);
    assert!(woken.is_empty());
}

#[test]
fn drain_discards_what_is_queued() {
    let vcan = Vcan::up();
    let mut bus = open(&vcan.name);
    let peer = Peer::open(&vcan.name);
    for i in 0..5u8 {
        peer.send(0x141, &[i; 8]);
    }
    assert_eq!(bus.drain(Duration::from_millis(200)), Ok(5));
    assert_eq!(bus.stats().drained, 5);
    assert_eq!(until_quiet(&mut bus), []);
    peer.send(0x141, &[0xF; 8]);
    assert_eq!(
        next(&mut bus).message,
        BusMessage::Frame(frame(0x141, &[0xF; 8]))
    );
}

#[test]
fn open_discards_frames_arriving_during_its_drain_window() {
    let vcan = Vcan::up();
    let peer = Peer::open(&vcan.name);
    let opened = Arc::new(AtomicBool::new(false));
    // A stale adapter: keeps delivering old frames until the bus is open.
    let stale = {
        let opened = Arc::clone(&opened);
        std::thread::spawn(move || {
            while !opened.load(Ordering::Acquire) {
                peer.send(0x141, &[0x5A; 8]);
                std::thread::sleep(Duration::from_millis(1));
            }
            peer
        })
    };
    let options = SocketCanOptions::new().drain_window(Duration::from_millis(300));
    let mut bus = SocketCanBus::open(&vcan.name, &options).unwrap();
    opened.store(true, Ordering::Release);
    let peer = stale.join().unwrap();

    assert!(
        bus.stats().drained > 0,
        "frames kept arriving during the window"
    );
    // Frames sent between the end of the window and the sender noticing are not stale.
    bus.drain(Duration::ZERO).unwrap();
    peer.send(0x141, &[0x0F; 8]);
    assert_eq!(
        frames_of(&until_quiet(&mut bus)),
        [frame(0x141, &[0x0F; 8])]
    );
}

#[test]
fn a_slow_reader_is_told_that_frames_were_dropped() {
    let vcan = Vcan::up();
    // The smallest receive buffer the kernel allows holds a few dozen frames.
    let options = SocketCanOptions::new()
        .receive_buffer_bytes(1)
        .drain_window(Duration::ZERO);
    let mut bus = SocketCanBus::open(&vcan.name, &options).unwrap();
    let peer = Peer::open(&vcan.name);
    // Few enough that the kernel's per-CPU backlog (1000) cannot overflow: only the socket
    // drops.
    let sent = 300;
    for i in 0..sent {
        peer.send(0x141, &(i as u64).to_le_bytes());
    }
    let frames = frames_of(&until_quiet(&mut bus));
    assert!(
        frames.len() < sent,
        "every frame fit: the buffer was not small"
    );
    // The frames that did arrive are in order.
    let counters: Vec<u64> = frames
        .iter()
        .map(|f| u64::from_le_bytes(*f.data8().unwrap()))
        .collect();
    assert!(counters.windows(2).all(|w| w[0] < w[1]));

    // The kernel attaches the drop count to the next frame it queues: the loss is reported
    // just before that frame.
    peer.send(0x142, &[0xD; 8]);
    let messages: Vec<BusMessage> = until_quiet(&mut bus).iter().map(|r| r.message).collect();
    assert_eq!(
        messages,
        [
            BusMessage::Event(BusEvent::RxOverflow),
            BusMessage::Frame(frame(0x142, &[0xD; 8]))
        ]
    );
    assert_eq!(
        bus.stats().kernel_drops as usize,
        sent - frames.len(),
        "the kernel's drop count accounts for every missing frame"
    );
}

#[test]
fn vcan_never_fills_its_transmit_path() {
    // What the kernel does on vcan, which the docs rely on: vcan has no queue (qdisc
    // "noqueue") and loops each frame back inside the send call, so no send ever fails for
    // lack of room, even with the smallest send buffer and a peer that never reads. The
    // full-queue path is exercised on slcan below.
    let vcan = Vcan::up();
    let _idle_peer = Peer::open(&vcan.name);
    let options = SocketCanOptions::new()
        .send_buffer_bytes(1)
        .drain_window(Duration::ZERO);
    let mut bus = SocketCanBus::open(&vcan.name, &options).unwrap();
    for i in 0..20_000u64 {
        assert_eq!(
            bus.send(&frame(0x141, &i.to_le_bytes())),
            Ok(()),
            "send {i}"
        );
    }
    assert_eq!(bus.stats().tx_queue_full, 0);
}

/// Sends `request` until the transmit path refuses; returns how many were accepted.
fn fill_transmit_path(bus: &mut SocketCanBus, request: &CanFrame) -> u32 {
    let mut sent = 0u32;
    let error = loop {
        match bus.send(request) {
            Ok(()) => sent += 1,
            Err(error) => break error,
        }
        assert!(sent < 1_000_000, "the transmit path never filled up");
    };
    assert_eq!(error, BusError::TxQueueFull);
    sent
}

#[test]
fn a_full_transmit_queue_is_a_typed_error_and_clears_when_the_adapter_catches_up() {
    let slcan = Slcan::up();
    let mut bus = open(&slcan.name);
    let request = frame(0x141, &[0xA1, 0, 0, 0, 0x10, 0, 0, 0]);

    // Nobody reads the adapter's serial line: the driver holds one frame it cannot finish
    // writing and stops its queue, then the interface's queue (txqueuelen) fills.
    let sent = fill_transmit_path(&mut bus, &request);
    assert!(sent > 0);
    println!("slcan took {sent} frames before its transmit path was full");
    assert_eq!(bus.send(&request), Err(BusError::TxQueueFull));
    assert_eq!(bus.stats().tx_queue_full, 2);

    // The refusal comes from the interface's queue: 30 more places, 30 more frames.
    let bigger = Slcan::up();
    support::ip(&["link", "set", &bigger.name, "qlen", "40"]);
    let mut bigger_bus = open(&bigger.name);
    let sent_bigger = fill_transmit_path(&mut bigger_bus, &request);
    assert_eq!(sent_bigger, sent + 30);

    // The adapter reads its line again: the queue drains and sending works again.
    let mut wire = Vec::new();
    let recovered = eventually(LONG, || {
        wire.extend(slcan.adapter_reads());
        bus.send(&request).ok()
    });
    assert!(recovered.is_some(), "sending never recovered");
    let wire = String::from_utf8_lossy(&wire);
    assert!(
        wire.starts_with("t1418A100000010000000\r"),
        "the adapter got {:?}",
        &wire[..wire.len().min(60)]
    );
}

#[test]
fn adapter_state_changes_and_errors_arrive_as_events() {
    let slcan = Slcan::up();
    let mut bus = open(&slcan.name);
    let mut events_after = |report: &str| -> Vec<BusEvent> {
        slcan.adapter_says(report);
        events_of(&until_quiet(&mut bus))
    };
    assert_eq!(events_after("sw000100"), [BusEvent::ErrorWarning]);
    assert_eq!(events_after("sp000130"), [BusEvent::ErrorPassive]);
    assert_eq!(events_after("sa000000"), [BusEvent::ErrorActive]);
    assert_eq!(
        events_after("e1a"),
        [BusEvent::ProtocolViolation, BusEvent::NoAck]
    );
    assert_eq!(
        events_after("e1o"),
        [BusEvent::RxOverflow, BusEvent::ProtocolViolation]
    );
    assert_eq!(
        events_after("e1O"),
        [BusEvent::TxOverflow, BusEvent::ProtocolViolation]
    );
    // Frames from the adapter arrive in between, in order.
    slcan.adapter_says("t1418A100000010000000");
    slcan.adapter_says("e1a");
    slcan.adapter_says("t1428A100000020000000");
    let received = until_quiet(&mut bus);
    let messages: Vec<BusMessage> = received.iter().map(|r| r.message).collect();
    assert_eq!(
        messages,
        [
            BusMessage::Frame(frame(0x141, &[0xA1, 0, 0, 0, 0x10, 0, 0, 0])),
            BusMessage::Event(BusEvent::ProtocolViolation),
            BusMessage::Event(BusEvent::NoAck),
            BusMessage::Frame(frame(0x142, &[0xA1, 0, 0, 0, 0x20, 0, 0, 0])),
        ]
    );
    assert!(received.windows(2).all(|w| w[0].at <= w[1].at));
}

#[test]
fn bus_off_is_reported_refuses_sends_and_stops_new_opens() {
    let slcan = Slcan::up();
    let mut bus = open(&slcan.name);
    slcan.adapter_says("sb256256");
    let events = events_of(&until_quiet(&mut bus));
    assert!(events.contains(&BusEvent::BusOff), "{events:?}");
    assert!(bus.is_bus_off());

    // The kernel would take the frame and drop it silently (no carrier): refused instead.
    let request = frame(0x141, &[0x9C; 8]);
    assert_eq!(bus.send(&request), Err(BusError::BusOff));
    assert_eq!(bus.send(&request), Err(BusError::BusOff));
    assert_eq!(bus.stats().tx_queue_full, 0);

    // A new open finds the interface up but not running (once the kernel has processed the
    // carrier change, which it does asynchronously, within about a second).
    let error = eventually(LONG, || {
        SocketCanBus::open(&slcan.name, &SocketCanOptions::new()).err()
    })
    .expect("open kept succeeding on a bus-off interface");
    assert!(matches!(error, OpenError::NotRunning { .. }), "{error}");
    assert!(error.to_string().contains("restart-ms"), "{error}");

    // Why `send` refuses: the kernel itself accepts a frame on a bus-off interface (another
    // program's send succeeds) and never transmits it.
    let _ = slcan.adapter_reads();
    let peer = Peer::open(&slcan.name);
    peer.send(0x141, &[0x9C; 8]);
    std::thread::sleep(Duration::from_millis(200));
    assert_eq!(slcan.adapter_reads(), b"");

    // The controller recovers (here: the adapter reports error-active again).
    slcan.adapter_says("sa000000");
    assert_eq!(events_of(&until_quiet(&mut bus)), [BusEvent::ErrorActive]);
    assert!(!bus.is_bus_off());
}

#[test]
fn an_interface_going_down_or_away_is_reported() {
    let vcan = Vcan::up();
    let mut bus = open(&vcan.name);
    let request = frame(0x141, &[0x9C; 8]);

    // Down: the socket error is reported once (by whichever call comes first), and every
    // send keeps failing while the interface stays down.
    vcan.set_up(false);
    assert_eq!(bus.recv_until(now() + QUIET), Err(BusError::InterfaceDown));
    assert_eq!(bus.send(&request), Err(BusError::InterfaceDown));
    assert_eq!(bus.send(&request), Err(BusError::InterfaceDown));
    assert_eq!(bus.recv_until(now() + QUIET), Ok(None));

    // Up again: business as usual.
    vcan.set_up(true);
    let peer = Peer::open(&vcan.name);
    bus.send(&request).unwrap();
    assert_eq!(peer.recv(LONG), Some((0x141, vec![0x9C; 8])));
    vcan.set_up(false);
    assert_eq!(bus.send(&request), Err(BusError::InterfaceDown));
    vcan.set_up(true);

    // Removed (an unplugged USB adapter): the socket error is reported once, sends keep
    // failing.
    drop(vcan);
    assert_eq!(bus.recv_until(now() + QUIET), Err(BusError::InterfaceDown));
    assert_eq!(bus.send(&request), Err(BusError::InterfaceDown));
    assert_eq!(bus.send(&request), Err(BusError::InterfaceDown));
    assert_eq!(bus.recv_until(now() + QUIET), Ok(None));
}

#[test]
fn opening_a_missing_down_or_non_can_interface_says_what_to_do() {
    let options = SocketCanOptions::new();

    let missing = SocketCanBus::open("vcan9nothere", &options).unwrap_err();
    assert!(
        matches!(missing, OpenError::InterfaceMissing { .. }),
        "{missing}"
    );
    assert!(
        missing
            .to_string()
            .contains("ip link add dev vcan9nothere type vcan"),
        "{missing}"
    );

    let vcan = Vcan::down();
    let down = SocketCanBus::open(&vcan.name, &options).unwrap_err();
    assert!(matches!(down, OpenError::InterfaceDown { .. }), "{down}");
    assert!(
        down.to_string()
            .contains(&format!("ip link set {} up", vcan.name)),
        "{down}"
    );

    let not_can = SocketCanBus::open("lo", &options).unwrap_err();
    assert!(
        matches!(not_can, OpenError::NotCan { link_type: 772, .. }),
        "{not_can}"
    );
}

#[test]
fn the_real_time_path_does_not_allocate() {
    let vcan = Vcan::up();
    let mut bus = open(&vcan.name);
    let peer = Peer::open(&vcan.name);
    let slcan = Slcan::up();
    let mut adapter_bus = open(&slcan.name);
    let request = frame(0x141, &[0xA1; 8]);
    // Everything to be received is queued before counting starts.
    for i in 0..10u8 {
        peer.send(0x141, &[i; 8]);
    }
    slcan.adapter_says("e1a");
    slcan.adapter_says("sp000130");
    std::thread::sleep(Duration::from_millis(100));

    let before = rmd_test_support::alloc::this_thread().allocations;
    let mut frames = 0;
    for _ in 0..10 {
        bus.send(&request).unwrap();
        if let Some(Received {
            message: BusMessage::Frame(_),
            ..
        }) = bus.recv_until(now() + LONG).unwrap()
        {
            frames += 1;
        }
    }
    let deadline = now() + Duration::from_millis(5);
    let timed_out = bus.recv_until(deadline).unwrap();
    let polled = bus.recv_until(Timestamp::ZERO).unwrap();
    let mut events = 0;
    while let Some(Received {
        message: BusMessage::Event(_),
        ..
    }) = adapter_bus.recv_until(now() + QUIET).unwrap()
    {
        events += 1;
    }
    let allocated = rmd_test_support::alloc::this_thread().allocations - before;

    assert_eq!(allocated, 0, "send/recv_until allocated");
    assert_eq!((frames, timed_out, polled, events), (10, None, None, 3));
}
