//! The loop waits on every bus at once when the buses can be waited on together
//! ([`CanBus::readiness`]): each reply is taken when it arrives, whichever bus it is on, and not
//! after the buses before it have answered. In virtual time, with buses that know when their
//! replies arrive (as the threaded simulator does).

use crate::common;

use core::time::Duration;
use std::sync::{Arc, Mutex};

use common::*;
use rmd_bus::{
    BusError, BusMessage, CanBus, Clock, Readiness, Received, Timestamp, VirtualClock, WaitOn,
};
use rmd_loop::{RtLoop, RunLimit};
use rmd_protocol::{
    CanFrame, Dialect, EncoderValue, Iq, MULTI_TORQUE_CAN_ID, MotorId, Reply, Speed, Status2,
    Temperature,
};

/// When each reply was taken by the loop, and when it had arrived.
type Log = Arc<Mutex<Vec<(usize, Timestamp, Timestamp)>>>;

/// A bus that answers every 0x280 frame with the replies of motors 1..=4, the first `first`
/// after the frame and then one every `gap`; it knows their arrival times ahead and says so.
struct TimedBus {
    index: usize,
    clock: VirtualClock,
    first: Duration,
    gap: Duration,
    queue: Vec<Received>,
    log: Log,
}

impl TimedBus {
    fn new(index: usize, clock: &VirtualClock, first_us: u64, log: &Log) -> Self {
        Self {
            index,
            clock: clock.clone(),
            first: Duration::from_micros(first_us),
            gap: Duration::from_micros(120),
            queue: Vec::with_capacity(64),
            log: Arc::clone(log),
        }
    }

    fn reply(id: u8) -> CanFrame {
        let status = Status2 {
            temperature: Temperature::saturating(30),
            iq: Iq::saturating(0).into(),
            speed: Speed::saturating(0),
            position: rmd_protocol::StatusPosition::Encoder(EncoderValue::from_raw(
                1000 * u16::from(id),
            )),
        };
        Dialect::V161
            .encode_reply(MotorId::new(id).unwrap(), &Reply::Torque(status))
            .unwrap()
    }

    fn take(&mut self) -> Option<Received> {
        let item = self.queue.remove(0);
        self.log
            .lock()
            .unwrap()
            .push((self.index, self.clock.now(), item.at));
        Some(item)
    }
}

impl CanBus for TimedBus {
    fn send(&mut self, frame: &CanFrame) -> Result<(), BusError> {
        if frame.id() == MULTI_TORQUE_CAN_ID {
            let sent = self.clock.now();
            for id in 1..=4u8 {
                self.queue.push(Received {
                    at: sent + self.first + self.gap * u32::from(id - 1),
                    message: BusMessage::Frame(Self::reply(id)),
                });
            }
        }
        Ok(())
    }

    fn recv_until(&mut self, deadline: Timestamp) -> Result<Option<Received>, BusError> {
        match self.queue.first().map(|r| r.at) {
            Some(at) if at <= self.clock.now() => Ok(self.take()),
            Some(at) if at <= deadline => {
                self.clock.sleep_until(at);
                Ok(self.take())
            }
            _ => {
                self.clock.sleep_until(deadline);
                Ok(None)
            }
        }
    }

    fn readiness(&mut self) -> Readiness<'_> {
        match self.queue.first().map(|r| r.at) {
            Some(at) if at <= self.clock.now() => Readiness::Ready,
            Some(at) => Readiness::Pending(WaitOn::arrival(at, Duration::ZERO)),
            None => Readiness::Pending(WaitOn::default()),
        }
    }
}

#[test]
fn every_reply_is_taken_when_it_arrives_on_whichever_bus() {
    let clock = VirtualClock::new();
    let log: Log = Arc::default();
    // Bus 0 answers late, bus 1 early, bus 2 in between: bus after bus, bus 1's and bus 2's
    // replies would wait for bus 0's last one. Every first reply comes at least the shortest
    // physical round trip (two frames on a 1 Mbit/s wire, 216 us) after the request, or the
    // loop could not match it to that request.
    let buses = vec![
        TimedBus::new(0, &clock, 400, &log),
        TimedBus::new(1, &clock, 250, &log),
        TimedBus::new(2, &clock, 320, &log),
    ];
    let rt = RtLoop::unsupervised(robot(1000.0, 3, 4), clock, buses, PdTo::hold(12)).unwrap();
    let out = rt.run(RunLimit::Ticks(50));
    let s = &out.report.stats;
    assert_eq!(s.ticks, 50, "{}", out.report);
    assert_eq!(
        (s.missing_replies, s.deadline_misses, s.missed_ticks),
        (0, 0, 0)
    );
    let log = log.lock().unwrap();
    // First the start-up probe's one exchange per bus (collected bus after bus: it waits
    // generously), then the ticks', then the safe stop's.
    assert!(log.len() >= 12 + 50 * 12, "{}", log.len());
    let during_ticks = &log[12..12 + 50 * 12];
    for (bus, taken, arrived) in during_ticks {
        assert_eq!(
            taken, arrived,
            "bus {bus}: taken at {taken:?}, arrived at {arrived:?}"
        );
    }
    // In virtual time the loop costs nothing: it adds nothing after the last reply, and the
    // round trip is the latest bus's last reply (400 + 3 x 120 us).
    assert_eq!(s.loop_added_us.count, 50);
    assert_eq!(s.loop_added_us.max, 0.0);
    assert_eq!(s.round_trip_us.max, 760.0);
}

#[test]
fn a_bus_that_cannot_wait_with_others_is_collected_bus_after_bus() {
    // The simulator in the loop's thread advances its time while it waits: Readiness::Alone.
    let clock = VirtualClock::new();
    let mut a = sim(&clock, 4, 1, &[]);
    let mut b = sim(&clock, 4, 2, &[]);
    assert!(matches!(a.readiness(), Readiness::Alone));
    let rt = RtLoop::unsupervised(
        robot(1000.0, 2, 4),
        clock,
        vec![&mut a, &mut b],
        PdTo::hold(8),
    )
    .unwrap();
    let out = rt.run(RunLimit::Ticks(100));
    let s = &out.report.stats;
    assert_eq!((s.ticks, s.missing_replies, s.missed_ticks), (100, 0, 0));
    assert_eq!(s.loop_added_us.count, 100);
}
