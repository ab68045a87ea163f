//! Wire timing as a bus client sees it: exact to the nanosecond in virtual time, computed with
//! `rmd_bus::wire` on the actual frames.

use crate::common;

use core::time::Duration;

use common::*;
use rmd_bus::wire::{INTERFRAME_BITS, bits_to_duration, exchange_budget, frame_duration};
use rmd_bus::{BusError, CanBus, Clock, MonotonicClock, Timestamp, VirtualClock};
use rmd_protocol::{CanFrame, Dialect, IqControl, MultiTorque, Request};
use rmd_sim::{Node, SimBus, SimConfig, WireTiming};

const BITRATE: u32 = 1_000_000;

fn exchange_frame() -> CanFrame {
    MultiTorque::new([
        IqControl::new(100).unwrap().into(),
        IqControl::new(-100).unwrap().into(),
        IqControl::new(200).unwrap().into(),
        IqControl::new(0).unwrap().into(),
    ])
    .encode()
}

/// Time from a frame's start to its end of frame (receivers have it then).
fn to_eof(frame: &CanFrame, bitrate: u32) -> Duration {
    frame_duration(frame, bitrate) - bits_to_duration(INTERFRAME_BITS, bitrate)
}

fn no_jitter(mut config: SimConfig) -> SimConfig {
    for m in &mut config.motors {
        m.turnaround_jitter = Duration::ZERO;
    }
    config
}

#[test]
fn a_0x280_exchange_takes_the_wire_time_plus_the_turnaround() {
    // The default bus (1 Mbit/s, 200 us turnaround) with the jitter switched off.
    let (clock, mut bus) = sim_bus(no_jitter(SimConfig::with_motors(4)));
    let t0 = clock.now();
    let request = exchange_frame();
    bus.send(&request).unwrap();
    let got = frames(&collect(&mut bus, t0 + ms(2)));
    assert_eq!(got.len(), 4);

    // The request is on the wire from t0; the motors have it at its end of frame and answer
    // 200 us later. The wire is free again by then (the request's intermission has passed), so
    // reply 1 starts at once; replies 2..4 are ready at the same time and follow back to back,
    // lowest ID first, each after the previous one's intermission.
    let turnaround = us(200);
    let mut start = t0 + to_eof(&request, BITRATE) + turnaround;
    for (k, (at, frame)) in got.iter().enumerate() {
        assert_eq!(frame.id(), 0x141 + k as u16);
        assert_eq!(*at, start + to_eof(frame, BITRATE), "reply {}", k + 1);
        start += frame_duration(frame, BITRATE);
    }
    // The whole exchange, request sent to last reply received: the wire time of the five
    // frames plus the turnaround, minus the two intermissions that are not waited for (the
    // request's passes during the turnaround, the last reply's after its reception).
    let wire: Duration = std::iter::once(&request)
        .chain(got.iter().map(|(_, f)| f))
        .map(|f| frame_duration(f, BITRATE))
        .sum();
    let exchange = got[3].0 - t0;
    assert_eq!(
        exchange,
        wire + turnaround - 2 * bits_to_duration(INTERFRAME_BITS, BITRATE)
    );
    // Within the worst-case budget of rmd_bus (every frame stuffed to the maximum).
    assert!(exchange <= exchange_budget(4, BITRATE, turnaround));
    // The client waited exactly until the deadline it gave.
    assert_eq!(clock.now(), t0 + ms(2));
}

#[test]
fn with_jitter_each_reply_follows_its_own_turnaround() {
    // The default bus with the default jitter (0..=20 us per reply, seeded).
    let (clock, mut bus) = sim_bus(SimConfig::with_motors(4).seed(3));
    bus.record_trace(16);
    let t0 = clock.now();
    let request = exchange_frame();
    bus.send(&request).unwrap();
    let got = frames(&collect(&mut bus, t0 + ms(2)));
    let trace = bus.trace().to_vec();
    assert_eq!(trace.len(), 5);
    assert_eq!(
        (trace[0].from, trace[0].start, trace[0].frame),
        (Node::Host, t0, request)
    );
    let delivered = t0 + to_eof(&request, BITRATE);
    assert_eq!(trace[0].delivered, delivered);
    // Reply 1 starts when motor 1 is ready: 200..=220 us after the request was delivered.
    let first = trace[1].start - delivered;
    assert!(first >= us(200) && first <= us(220), "turnaround {first:?}");
    for (k, tx) in trace[1..].iter().enumerate() {
        assert_eq!(tx.from, Node::Motor(k as u8 + 1));
        // Received exactly at the end of frame of what went on the wire.
        assert_eq!(got[k], (tx.start + to_eof(&tx.frame, BITRATE), tx.frame));
        assert_eq!(tx.delivered, got[k].0);
        if k > 0 {
            // Right after the previous reply, or at the motor's own (later) ready time.
            assert!(tx.start >= trace[k].end);
            assert!(tx.start == trace[k].end || tx.start - delivered <= us(220));
        }
    }
    assert!(got[3].0 - t0 <= exchange_budget(4, BITRATE, us(220)));
}

#[test]
fn the_bit_rate_scales_the_wire_time() {
    let mut config = no_jitter(SimConfig::with_motors(1));
    config.bus.timing = WireTiming::Bitrate(500_000);
    let (clock, mut bus) = sim_bus(config);
    let t0 = clock.now();
    let request = Dialect::V161.encode(id(1), &Request::ReadStatus1).unwrap();
    bus.send(&request).unwrap();
    let got = frames(&collect(&mut bus, t0 + ms(2)));
    let reply = got[0].1;
    assert_eq!(
        got[0].0,
        t0 + to_eof(&request, 500_000) + us(200) + to_eof(&reply, 500_000)
    );
    // Twice the bit time: twice the frame time.
    assert_eq!(
        frame_duration(&request, 500_000),
        2 * frame_duration(&request, BITRATE)
    );
}

#[test]
fn the_host_queue_has_the_socketcan_depth_and_drains_at_wire_speed() {
    let (_clock, mut bus) = sim_bus(SimConfig::with_motors(1));
    bus.record_trace(64);
    let frame = Dialect::V161.encode(id(1), &Request::ReadStatus2).unwrap();
    // All at the same instant: the first goes straight onto the wire, ten wait in the queue
    // (SocketCAN's default txqueuelen), the twelfth is refused.
    for _ in 0..11 {
        bus.send(&frame).unwrap();
    }
    assert_eq!(bus.send(&frame), Err(BusError::TxQueueFull));
    assert_eq!(bus.tx_queued(), 10);
    assert_eq!(bus.stats().tx_queue_full, 1);
    let end = bus.clock().now() + ms(20);
    collect(&mut bus, end);
    let host: Vec<_> = bus
        .trace()
        .iter()
        .filter(|t| t.from == Node::Host)
        .collect();
    assert_eq!(host.len(), 11);
    // Back to back: each starts when the previous one's intermission ends.
    for pair in host.windows(2) {
        assert_eq!(pair[1].start, pair[0].end);
    }
}

#[test]
fn several_buses_on_one_clock_stamp_replies_at_their_true_times() {
    // A robot with four buses driven by one loop: send on every bus, then collect each in turn.
    let clock = VirtualClock::starting_at(Timestamp::from_nanos(1_000_000));
    let mut buses: Vec<_> = (0..4)
        .map(|seed| SimBus::new(clock.clone(), SimConfig::with_motors(4).seed(seed)).unwrap())
        .collect();
    let t0 = clock.now();
    for bus in &mut buses {
        bus.send(&exchange_frame()).unwrap();
    }
    let deadline = t0 + ms(1);
    let collected: Vec<_> = buses
        .iter_mut()
        .map(|bus| frames(&collect(bus, deadline)))
        .collect();
    assert_eq!(clock.now(), deadline);
    // Each bus's replies are stamped as if it had been collected alone: compare with the same
    // bus simulated on its own clock.
    for (seed, got) in collected.iter().enumerate() {
        assert_eq!(got.len(), 4);
        let alone_clock = VirtualClock::starting_at(t0);
        let mut alone = SimBus::new(
            alone_clock.clone(),
            SimConfig::with_motors(4).seed(seed as u64),
        )
        .unwrap();
        alone.send(&exchange_frame()).unwrap();
        let expected = frames(&collect(&mut alone, deadline));
        assert_eq!(got, &expected, "bus {seed}");
        assert!(got.iter().all(|(at, _)| *at > t0 && *at < deadline));
    }
    // Different seeds, different jitter.
    assert_ne!(collected[0], collected[1]);
}

#[test]
fn the_simulation_catches_up_lazily_when_the_client_comes_back_late() {
    let (clock, mut bus) = sim_bus(no_jitter(SimConfig::with_motors(4)));
    let t0 = clock.now();
    bus.send(&exchange_frame()).unwrap();
    // The client does something else for 5 ms, then sends again before reading.
    clock.sleep_until(t0 + ms(5));
    bus.send(&exchange_frame()).unwrap();
    let got = frames(&collect(&mut bus, t0 + ms(7)));
    assert_eq!(got.len(), 8);
    // The first exchange's replies carry their true times, not the time they were read.
    assert!(got[..4].iter().all(|(at, _)| *at < t0 + ms(1)));
    assert!(got[4..].iter().all(|(at, _)| *at > t0 + ms(5)));
    // Both exchanges follow the wire model exactly from their own send times.
    for (sent, replies) in [(t0, &got[..4]), (t0 + ms(5), &got[4..])] {
        let mut start = sent + to_eof(&exchange_frame(), BITRATE) + us(200);
        for (at, frame) in replies {
            assert_eq!(*at, start + to_eof(frame, BITRATE));
            start += frame_duration(frame, BITRATE);
        }
    }
}

#[test]
fn a_past_deadline_polls_without_waiting() {
    let (clock, mut bus) = sim_bus(SimConfig::with_motors(1));
    let t0 = clock.now();
    assert_eq!(bus.recv_until(t0.saturating_sub(us(1))).unwrap(), None);
    assert_eq!(clock.now(), t0);
    bus.send(&Dialect::V161.encode(id(1), &Request::ReadStatus1).unwrap())
        .unwrap();
    // Nothing has arrived yet at t0.
    assert_eq!(bus.recv_until(t0).unwrap(), None);
    clock.sleep_until(t0 + ms(1));
    // Already arrived: returned at once with its time, the clock untouched.
    let rx = bus.recv_until(Timestamp::ZERO).unwrap().unwrap();
    assert!(rx.at < t0 + ms(1));
    assert_eq!(clock.now(), t0 + ms(1));
}

#[test]
fn the_instant_configuration_takes_no_time() {
    let (clock, mut bus) = sim_bus(SimConfig::with_motors(4).instant());
    let t0 = clock.now();
    for _ in 0..3 {
        bus.send(&exchange_frame()).unwrap();
        let got = frames(&collect(&mut bus, t0));
        let ids: Vec<u16> = got.iter().map(|(_, f)| f.id()).collect();
        assert_eq!(ids, [0x141, 0x142, 0x143, 0x144]);
        assert!(got.iter().all(|(at, _)| *at == t0));
    }
    assert_eq!(clock.now(), t0);
}

#[test]
fn the_same_code_runs_in_real_time() {
    let clock = MonotonicClock;
    let mut bus = SimBus::new(clock, no_jitter(SimConfig::with_motors(4))).unwrap();
    bus.record_trace(8);
    bus.send(&exchange_frame()).unwrap();
    let deadline = clock.now() + ms(20);
    let got = frames(&collect(&mut bus, deadline));
    assert_eq!(got.len(), 4);
    // Stamps are computed from the wire model, exactly as in virtual time, relative to when the
    // request went out; the call returned no earlier than each reply's time.
    let request = bus.trace()[0];
    let mut start = request.delivered + us(200);
    for (at, frame) in &got {
        assert_eq!(*at, start + to_eof(frame, BITRATE));
        start += frame_duration(frame, BITRATE);
    }
    assert!(clock.now() >= deadline);
}

#[test]
fn a_simulated_bus_can_move_to_the_loop_thread() {
    fn assert_send<T: Send>() {}
    assert_send::<SimBus<VirtualClock>>();
    assert_send::<SimBus<MonotonicClock>>();
    assert_send::<rmd_sim::SimMotors>();
    let (clock, bus) = sim_bus(SimConfig::with_motors(4));
    let handle = std::thread::spawn(move || {
        let mut bus = bus;
        bus.send(&exchange_frame()).unwrap();
        let deadline = bus.clock().now() + ms(1);
        frames(&collect(&mut bus, deadline)).len()
    });
    assert_eq!(handle.join().unwrap(), 4);
    assert!(clock.now() > Timestamp::from_nanos(1_000_000));
}
