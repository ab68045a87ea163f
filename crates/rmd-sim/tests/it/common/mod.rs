//! Helpers shared by the integration tests: a client of a `SimBus` in virtual time.

#![allow(dead_code)]

use core::time::Duration;

use rmd_bus::{BusMessage, CanBus, Clock, Received, Timestamp, VirtualClock};
use rmd_protocol::{CanFrame, Dialect, MotorId, Reply, Request, Status1, V161Status1};
use rmd_sim::{SimBus, SimConfig};

pub(crate) fn id(n: u8) -> MotorId {
    MotorId::new(n).unwrap()
}

pub(crate) fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}

pub(crate) fn us(n: u64) -> Duration {
    Duration::from_micros(n)
}

/// A bus on a fresh virtual clock that starts at 1 ms.
pub(crate) fn sim_bus(config: SimConfig) -> (VirtualClock, SimBus<VirtualClock>) {
    let clock = VirtualClock::starting_at(Timestamp::from_nanos(1_000_000));
    let bus = SimBus::new(clock.clone(), config).unwrap();
    (clock, bus)
}

/// Everything received until `deadline`.
pub(crate) fn collect(bus: &mut impl CanBus, deadline: Timestamp) -> Vec<Received> {
    let mut out = Vec::new();
    while let Some(rx) = bus.recv_until(deadline).unwrap() {
        out.push(rx);
    }
    out
}

/// The frames among `items`.
pub(crate) fn frames(items: &[Received]) -> Vec<(Timestamp, CanFrame)> {
    items
        .iter()
        .filter_map(|r| match r.message {
            BusMessage::Frame(f) => Some((r.at, f)),
            BusMessage::Event(_) => None,
        })
        .collect()
}

/// Sends `request` to motor `motor` and returns its decoded reply (within 5 ms).
pub(crate) fn ask<C: Clock>(bus: &mut SimBus<C>, motor: u8, request: Request) -> Reply {
    bus.send(&Dialect::V161.encode(id(motor), &request).unwrap())
        .unwrap();
    let deadline = bus.clock().now() + ms(5);
    let items = collect(bus, deadline);
    let got = frames(&items);
    assert_eq!(got.len(), 1, "{request:?}: {items:?}");
    let (m, reply) = Dialect::V161.decode_reply(&got[0].1).unwrap();
    assert_eq!(m, id(motor));
    reply
}

/// The v1.61 status 1 a reply carries.
pub(crate) fn v161_status1(reply: Reply) -> V161Status1 {
    match reply.status1() {
        Some(Status1::V161(s)) => s,
        other => panic!("{other:?}"),
    }
}

/// The multi-turn angle of `motor` in degrees, read with 0x92.
pub(crate) fn angle_deg<C: Clock>(bus: &mut SimBus<C>, motor: u8) -> f64 {
    match ask(bus, motor, Request::ReadMultiTurnAngle) {
        Reply::ReadMultiTurnAngle { motor_angle } => motor_angle.degrees(),
        other => panic!("{other:?}"),
    }
}

/// Sleeps the bus's clock until `t`.
pub(crate) fn wait_until<C: Clock>(bus: &SimBus<C>, t: Timestamp) {
    bus.clock().sleep_until(t);
}
