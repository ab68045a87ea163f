//! The simulated bus on its own thread (`rmd_sim::threaded`), in real time: the same wire as the
//! simulator in the caller's thread (checked against a virtual-time run with the same seed),
//! replies never handed out before their time, every port sees every reply, bus-off as on
//! SocketCAN. No assertion on how late anything is (shared machine).
#![cfg(target_os = "linux")]

use core::time::Duration;

use rmd_bus::{
    BusError, BusEvent, BusMessage, CanBus, Clock, MonotonicClock, Readiness, Received, Timestamp,
    VirtualClock,
};
use rmd_protocol::{CanFrame, IqControl, MultiTorque};
use rmd_sim::threaded::{ThreadOptions, ThreadedSim};
use rmd_sim::{BusFault, FaultRule, Node, SimBus, SimConfig};

fn frame(k: i64) -> CanFrame {
    MultiTorque::new([IqControl::new((37 * k) % 400 - 200).unwrap().into(); 4]).encode()
}

fn spawn(
    config: SimConfig,
    options: ThreadOptions,
) -> (ThreadedSim, Vec<rmd_sim::threaded::SimPort>) {
    let bus = SimBus::new(MonotonicClock, config).unwrap();
    ThreadedSim::spawn(bus, &options, || {}).unwrap()
}

/// Receives until `n` frames came (or 1 s passed), checking that nothing is handed out before
/// its time.
fn receive(port: &mut impl CanBus, n: usize) -> Vec<Received> {
    let clock = MonotonicClock;
    let deadline = clock.now() + Duration::from_secs(1);
    let mut got = Vec::new();
    while got
        .iter()
        .filter(|r: &&Received| matches!(r.message, BusMessage::Frame(_)))
        .count()
        < n
    {
        match port.recv_until(deadline).unwrap() {
            Some(item) => {
                assert!(clock.now() >= item.at, "handed out before its arrival");
                got.push(item);
            }
            None => break,
        }
    }
    got
}

#[test]
fn the_wire_is_the_same_as_in_the_callers_thread() {
    // Real time on the simulator's own thread...
    let config = SimConfig::with_motors(3).seed(5);
    let mut bus = SimBus::new(MonotonicClock, config.clone()).unwrap();
    bus.record_trace(1000);
    let (sim, mut ports) = ThreadedSim::spawn(bus, &ThreadOptions::default(), || {}).unwrap();
    let mut handed = Vec::new();
    for k in 0..10 {
        ports[0].send(&frame(k)).unwrap();
        let got = receive(&mut ports[0], 3);
        assert_eq!(got.len(), 3, "exchange {k}: {got:?}");
        handed.extend(got.iter().map(|r| r.at));
        std::thread::sleep(Duration::from_micros(300));
    }
    let bus = sim.stop().unwrap();
    let trace = bus.trace().to_vec();
    assert_eq!(trace.len(), 40);
    // ...hands each reply out stamped with its arrival on the simulated wire.
    let arrivals: Vec<Timestamp> = trace
        .iter()
        .filter(|t| t.from != Node::Host)
        .map(|t| t.delivered)
        .collect();
    assert_eq!(handed, arrivals);
    // The same frames sent at the same times, in virtual time in the caller's thread, with the
    // same seed: the same wire, to the nanosecond (frames, contents, starts and ends).
    let sends: Vec<Timestamp> = trace
        .iter()
        .filter(|t| t.from == Node::Host)
        .map(|t| t.start)
        .collect();
    let clock = VirtualClock::starting_at(sends[0].saturating_sub(Duration::from_millis(1)));
    let mut reference = SimBus::new(clock.clone(), config).unwrap();
    reference.record_trace(1000);
    for (k, at) in sends.iter().enumerate() {
        clock.sleep_until(*at);
        reference.send(&frame(k as i64)).unwrap();
        let until = sends
            .get(k + 1)
            .copied()
            .unwrap_or(*at + Duration::from_millis(2));
        while reference.recv_until(until).unwrap().is_some() {}
    }
    assert_eq!(reference.trace(), &trace[..]);
}

#[test]
fn every_port_sees_every_reply_and_its_own_frames_are_simulated() {
    let (sim, mut ports) = spawn(
        SimConfig::with_motors(2).seed(1),
        ThreadOptions {
            ports: 2,
            ..ThreadOptions::default()
        },
    );
    ports[1].send(&frame(1)).unwrap();
    let a = receive(&mut ports[0], 2);
    let b = receive(&mut ports[1], 2);
    assert_eq!(a.len(), 2);
    assert_eq!(a, b);
    let bus = sim.stop().unwrap();
    assert_eq!(bus.stats().host_frames, 1);
}

#[test]
fn readiness_gives_the_doorbell_then_the_arrival_then_ready() {
    // A long turnaround: the simulator knows the reply's arrival well before it comes.
    let mut config = SimConfig::with_motors(1).seed(2);
    config.motors[0].turnaround = Duration::from_millis(30);
    let (sim, mut ports) = spawn(config, ThreadOptions::default());
    let port = &mut ports[0];
    // Nothing sent: the doorbell to watch, no arrival known.
    match port.readiness() {
        Readiness::Pending(wait) => {
            assert!(wait.fd().is_some());
            assert_eq!(wait.next_arrival(), None);
        }
        other => panic!("{other:?}"),
    }
    port.send(&frame(3)).unwrap();
    let clock = MonotonicClock;
    let give_up = clock.now() + Duration::from_secs(2);
    let mut known = None;
    loop {
        match port.readiness() {
            Readiness::Pending(wait) => {
                if let Some((at, _)) = wait.next_arrival() {
                    // Known ahead, no doorbell needed, never changes.
                    assert!(wait.fd().is_none());
                    assert_eq!(*known.get_or_insert(at), at);
                }
            }
            Readiness::Ready => break,
            Readiness::Alone => panic!("a threaded port waits with others"),
        }
        assert!(clock.now() < give_up, "no reply");
        std::thread::sleep(Duration::from_micros(200));
    }
    let got = port.recv_until(Timestamp::ZERO).unwrap().unwrap();
    assert!(clock.now() >= got.at);
    if let Some(at) = known {
        assert_eq!(got.at, at);
    }
    drop(sim);
}

#[test]
fn bus_off_is_received_then_sends_are_refused_until_the_restart() {
    let config = SimConfig::with_motors(1).seed(3).fault(
        FaultRule::new(BusFault::BusOff {
            duration: Duration::from_millis(5),
        })
        .multi_torque()
        .frames_window(0, 1),
    );
    let (sim, mut ports) = spawn(config, ThreadOptions::default());
    let port = &mut ports[0];
    port.send(&frame(0)).unwrap();
    let clock = MonotonicClock;
    let deadline = clock.now() + Duration::from_secs(1);
    let first = port.recv_until(deadline).unwrap().unwrap();
    assert_eq!(first.message, BusMessage::Event(BusEvent::BusOff));
    assert_eq!(port.send(&frame(1)), Err(BusError::BusOff));
    let restarted = port.recv_until(deadline).unwrap().unwrap();
    assert_eq!(restarted.message, BusMessage::Event(BusEvent::Restarted));
    assert!(restarted.at - first.at >= Duration::from_millis(5));
    port.send(&frame(2)).unwrap();
    assert_eq!(receive(port, 1).len(), 1);
    sim.stop().unwrap();
}

#[test]
fn a_full_queue_is_reported_as_an_overflow_before_the_next_item() {
    let (sim, mut ports) = spawn(
        SimConfig::with_motors(4).seed(4),
        ThreadOptions {
            queue_len: 4,
            ports: 2,
            ..ThreadOptions::default()
        },
    );
    // Port 1 sends three exchanges; port 0 reads nothing meanwhile: its queue of 4 overflows.
    for k in 0..3 {
        ports[1].send(&frame(k)).unwrap();
        assert_eq!(receive(&mut ports[1], 4).len(), 4);
    }
    let got = receive(&mut ports[0], 3);
    assert_eq!(got[0].message, BusMessage::Event(BusEvent::RxOverflow));
    assert!(
        got[1..]
            .iter()
            .all(|r| matches!(r.message, BusMessage::Frame(_)))
    );
    sim.stop().unwrap();
}

#[test]
fn a_simulator_thread_that_is_late_is_counted_and_its_replies_keep_their_times() {
    // The thread starts 50 ms late: the frame sent meanwhile is simulated at its sending time,
    // and its replies, computed after their arrival, are counted late.
    let bus = SimBus::new(MonotonicClock, SimConfig::with_motors(2).seed(9)).unwrap();
    let (sim, mut ports) = ThreadedSim::spawn(bus, &ThreadOptions::default(), || {
        std::thread::sleep(Duration::from_millis(50))
    })
    .unwrap();
    let sent = MonotonicClock.now();
    ports[0].send(&frame(1)).unwrap();
    let got = receive(&mut ports[0], 2);
    assert_eq!(got.len(), 2);
    // On the simulated wire the exchange began when the frame was sent.
    assert!(got[1].at - sent < Duration::from_millis(2), "{got:?}");
    let late = sim.lateness();
    assert_eq!(late.late_items, 2);
    assert!(late.max_late >= Duration::from_millis(45), "{late:?}");
    // Their arrivals are logged, as handed over (the two replies' own times), with how late.
    let arrivals = sim.late_arrivals();
    let times: Vec<_> = arrivals.iter().map(|(at, _)| *at).collect();
    assert_eq!(times, vec![got[0].at, got[1].at]);
    assert!(
        arrivals
            .iter()
            .all(|(_, by)| *by >= Duration::from_millis(45) && *by <= late.max_late)
    );
    sim.stop().unwrap();
}
