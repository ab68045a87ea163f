//! The theoretical wire limit of a run, from the frames that were actually on the simulated wire.
//!
//! One 0x280 exchange occupies the bus from the start of the 0x280 frame to the end of the last
//! reply's intermission: the 0x280 frame up to its end of frame, the motors' turnaround, then the
//! replies back to back, each with its intermission. The 0x280's own 3-bit intermission passes
//! during the turnaround, so
//!
//! ```text
//! cycle = sum of the (1 + motors) frame times (rmd_bus::wire::frame_duration, stuffed, with
//!         intermission) + turnaround - 3 bit times
//! ```
//!
//! No loop, however fast, can start the next exchange on the bus before the cycle of this one has
//! ended, so the highest rate any loop can sustain without a single overrun is `1 / max cycle`.
//!
//! A per-motor exchange (one 0xA1 request per motor, `rmd bench rate --sim-firmware
//! myactuator-v3`) is the same with `motors` requests back to back before the replies: its cycle
//! runs from the first request's start to the end of the last reply's intermission. So is a
//! multi-torque bus beyond id 4 (`--exchange multi-torque --motors 8`): the 0x280 frame, then
//! an 0xA1 request per motor beyond id 4.

use core::time::Duration;

use rmd_bus::Timestamp;
use rmd_bus::wire::{INTERFRAME_BITS, bits_to_duration, frame_bits, frame_duration};
use rmd_protocol::{MULTI_TORQUE_CAN_ID, MULTI_TORQUE_MOTORS};
use rmd_sim::{Node, Transmission};
use serde_json::{Value, json};

/// The timing of one exchange as it went over the wire.
#[derive(Copy, Clone, Debug, PartialEq)]
pub(crate) struct ExchangeTiming {
    /// When the 0x280 frame started on the wire.
    pub(crate) start: Timestamp,
    /// 0x280 start to the end of the last reply's intermission (the bus is free again).
    pub(crate) cycle: Duration,
    /// Sum of the frame times of the 0x280 frame and its replies (stuffed, with intermission).
    pub(crate) frames: Duration,
    /// From the 0x280's end of frame to the first reply's start.
    pub(crate) turnaround: Duration,
    /// Bits of the longest frame of the exchange.
    pub(crate) max_frame_bits: u32,
    /// Bits of the shortest frame of the exchange.
    pub(crate) min_frame_bits: u32,
}

/// The complete exchanges of a bus's trace: each 0x280 frame the host sent, or `motors` 0xA1
/// requests it sent back to back, followed by exactly `motors` motor frames. This includes the
/// loop's start-up probes and the zero-torque frames of its safe stop: select the ticks'
/// exchanges by their [`start`](ExchangeTiming::start).
pub(crate) fn exchanges(
    trace: &[Transmission],
    motors: usize,
    bitrate: u32,
) -> Vec<ExchangeTiming> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < trace.len() {
        let requests: Vec<&Transmission> = trace[i..]
            .iter()
            .take_while(|t| t.from == Node::Host)
            .collect();
        if requests.is_empty() {
            i += 1;
            continue;
        }
        // A multi-torque bus beyond id 4: the 0x280 frame, then one 0xA1 request per motor
        // beyond it (its replies may interleave with them).
        if motors > MULTI_TORQUE_MOTORS && requests[0].frame.id() == MULTI_TORQUE_CAN_ID {
            let expected = 1 + motors - MULTI_TORQUE_MOTORS;
            match interleaved(&trace[i..], motors, expected, bitrate) {
                Some((exchange, taken)) => {
                    out.push(exchange);
                    i += taken;
                }
                None => i += requests.len(),
            }
            continue;
        }
        // More requests than fit in one turnaround (8 motors per motor at 1 Mbit/s): the first
        // replies win arbitration over the later requests, and the two interleave.
        if requests.len() < motors
            && let Some((exchange, taken)) = interleaved(&trace[i..], motors, motors, bitrate)
        {
            out.push(exchange);
            i += taken;
            continue;
        }
        i += requests.len();
        let replies: Vec<&Transmission> = trace[i..]
            .iter()
            .take_while(|t| matches!(t.from, Node::Motor(_)))
            .collect();
        i += replies.len();
        // The last host frame before the replies, when it is a 0x280 frame (a probe's read
        // requests may precede it); else every host frame, when they are `motors` torque requests.
        let multi_torque = requests
            .last()
            .is_some_and(|t| t.frame.id() == MULTI_TORQUE_CAN_ID);
        let requests: Vec<&Transmission> = if multi_torque {
            requests[requests.len() - 1..].to_vec()
        } else {
            requests
        };
        let per_motor = !multi_torque
            && requests.len() == motors
            && requests.iter().all(|t| is_per_motor_request(&t.frame));
        if replies.len() != motors || !(multi_torque || per_motor) {
            continue;
        }
        let (tx, last_request) = (requests[0], requests[requests.len() - 1]);
        let all: Vec<&Transmission> = requests
            .iter()
            .copied()
            .chain(replies.iter().copied())
            .collect();
        let bits: Vec<u32> = all.iter().map(|t| frame_bits(&t.frame)).collect();
        out.push(ExchangeTiming {
            start: tx.start,
            cycle: replies[motors - 1].end - tx.start,
            frames: all.iter().map(|t| frame_duration(&t.frame, bitrate)).sum(),
            turnaround: replies[0].start - last_request.delivered,
            max_frame_bits: bits.iter().copied().max().unwrap_or(0),
            min_frame_bits: bits.iter().copied().min().unwrap_or(0),
        });
    }
    out
}

/// Whether `frame` is one motor's request of a per-motor exchange: an 0xA1 torque request, or a
/// MyActuator V3 motion-mode command (`0x400 + id`).
fn is_per_motor_request(frame: &rmd_protocol::CanFrame) -> bool {
    let motion = rmd_protocol::V3_MOTION_BASE_ID + 1..=rmd_protocol::V3_MOTION_BASE_ID + 32;
    frame.data().first() == Some(&0xA1) || motion.contains(&frame.id())
}

/// An exchange whose requests and replies interleave on the wire, from `trace[0]` (a host
/// frame): `expected` requests (0xA1 or motion-mode requests, the first of them possibly a 0x280
/// frame) and `motors` motor frames, in any order, the first reply after the first request. Returns it and the transmissions it took; `None` when the
/// frames do not make one.
fn interleaved(
    trace: &[Transmission],
    motors: usize,
    expected: usize,
    bitrate: u32,
) -> Option<(ExchangeTiming, usize)> {
    let (mut requests, mut replies) = (Vec::new(), Vec::new());
    for t in trace {
        // A 0x280 frame may open the exchange (a multi-torque bus beyond id 4).
        let opens = requests.is_empty() && t.frame.id() == MULTI_TORQUE_CAN_ID;
        match t.from {
            Node::Host
                if requests.len() < expected && (opens || is_per_motor_request(&t.frame)) =>
            {
                requests.push(t);
            }
            Node::Host => return None,
            Node::Motor(_) if !requests.is_empty() => replies.push(t),
            Node::Motor(_) => return None,
        }
        if replies.len() == motors {
            break;
        }
    }
    if requests.len() != expected || replies.len() != motors {
        return None;
    }
    let all: Vec<&Transmission> = requests.iter().chain(&replies).copied().collect();
    let bits: Vec<u32> = all.iter().map(|t| frame_bits(&t.frame)).collect();
    let cycle = replies[motors - 1].end - requests[0].start;
    let frames: Duration = all.iter().map(|t| frame_duration(&t.frame, bitrate)).sum();
    let exchange = ExchangeTiming {
        start: requests[0].start,
        cycle,
        frames,
        // The wire's idle time inside the exchange (waiting for the motors' turnarounds), so
        // that cycle = frames + turnaround - intermission holds as for the other exchanges.
        turnaround: (cycle + bits_to_duration(INTERFRAME_BITS, bitrate)).saturating_sub(frames),
        max_frame_bits: bits.iter().copied().max().unwrap_or(0),
        min_frame_bits: bits.iter().copied().min().unwrap_or(0),
    };
    Some((exchange, requests.len() + replies.len()))
}

/// What the exchanges of a run say about the wire limit.
#[derive(Copy, Clone, Debug, PartialEq)]
pub(crate) struct WireLimit {
    /// Exchanges analysed.
    pub(crate) exchanges: usize,
    /// Longest cycle: the wire-limited period.
    pub(crate) max_cycle: Duration,
    /// Mean cycle.
    pub(crate) mean_cycle: Duration,
    /// Frame times of the exchange with the longest cycle.
    pub(crate) frames_at_max: Duration,
    /// Turnaround of the exchange with the longest cycle.
    pub(crate) turnaround_at_max: Duration,
    /// Longest turnaround seen.
    pub(crate) max_turnaround: Duration,
    /// Shortest and longest frame of the run, bits.
    pub(crate) frame_bits: (u32, u32),
}

impl WireLimit {
    /// The summary of `exchanges` (several buses: pass them all, the buses run in parallel and
    /// the slowest sets the limit). `None` without exchanges.
    pub(crate) fn of(exchanges: &[ExchangeTiming]) -> Option<Self> {
        let worst = exchanges.iter().max_by_key(|e| e.cycle)?;
        let total: Duration = exchanges.iter().map(|e| e.cycle).sum();
        Some(Self {
            exchanges: exchanges.len(),
            max_cycle: worst.cycle,
            mean_cycle: total / exchanges.len() as u32,
            frames_at_max: worst.frames,
            turnaround_at_max: worst.turnaround,
            max_turnaround: exchanges.iter().map(|e| e.turnaround).max()?,
            frame_bits: (
                exchanges.iter().map(|e| e.min_frame_bits).min()?,
                exchanges.iter().map(|e| e.max_frame_bits).max()?,
            ),
        })
    }

    /// The highest rate the wire allows for every exchange of the run, Hz.
    pub(crate) fn rate_hz(&self) -> f64 {
        1.0 / self.max_cycle.as_secs_f64()
    }

    /// As JSON (microseconds).
    pub(crate) fn to_json(self) -> Value {
        json!({
            "exchanges": self.exchanges,
            "limit_hz": self.rate_hz(),
            "max_cycle_us": us(self.max_cycle),
            "mean_cycle_us": us(self.mean_cycle),
            "frames_at_max_us": us(self.frames_at_max),
            "turnaround_at_max_us": us(self.turnaround_at_max),
            "max_turnaround_us": us(self.max_turnaround),
            "frame_bits_min": self.frame_bits.0,
            "frame_bits_max": self.frame_bits.1,
        })
    }
}

/// The 3-bit intermission at `bitrate` (the overlap of the 0x280's intermission and the
/// turnaround).
pub(crate) fn intermission(bitrate: u32) -> Duration {
    bits_to_duration(INTERFRAME_BITS, bitrate)
}

/// Microseconds as a float.
pub(crate) fn us(d: Duration) -> f64 {
    d.as_secs_f64() * 1e6
}

#[cfg(test)]
mod tests {
    use super::*;
    use rmd_bus::{CanBus, Clock, VirtualClock};
    use rmd_protocol::{IqControl, MultiTorque};
    use rmd_sim::{SimBus, SimConfig};

    #[test]
    fn the_cycle_is_the_frames_plus_the_turnaround_minus_one_intermission() {
        let clock = VirtualClock::new();
        let mut bus = SimBus::new(clock.clone(), SimConfig::with_motors(4).seed(3)).unwrap();
        bus.record_trace(1000);
        for k in 0..20 {
            let iq = IqControl::new(37 * k - 300).unwrap();
            bus.send(&MultiTorque::new([iq.into(); 4]).encode())
                .unwrap();
            let end = clock.now() + Duration::from_millis(2);
            while bus.recv_until(end).unwrap().is_some() {}
        }
        let ex = exchanges(bus.trace(), 4, 1_000_000);
        assert_eq!(ex.len(), 20);
        for e in &ex {
            assert_eq!(e.cycle, e.frames + e.turnaround - intermission(1_000_000));
            // The simulator's default turnaround: 200 us + 0..=20 us.
            assert!(e.turnaround >= Duration::from_micros(200));
            assert!(e.turnaround <= Duration::from_micros(220));
            assert!((111..=135).contains(&e.min_frame_bits));
            assert!(e.max_frame_bits <= 135);
        }
        let limit = WireLimit::of(&ex).unwrap();
        assert_eq!(limit.max_cycle, ex.iter().map(|e| e.cycle).max().unwrap());
        assert!(limit.mean_cycle <= limit.max_cycle);
        // Five frames of at most 135 bits plus at most 220 us: at least 1117 Hz.
        assert!(limit.rate_hz() > 1117.0, "{limit:?}");
        assert_eq!(WireLimit::of(&[]), None);
    }

    #[test]
    fn a_per_motor_exchange_runs_from_its_first_request_to_its_last_reply() {
        let clock = VirtualClock::new();
        let v3 = rmd_protocol::Dialect::MyActuatorV3(rmd_protocol::V3Firmware::default());
        let config = SimConfig::with_motors(3)
            .seed(3)
            .firmware_family(rmd_sim::FirmwareFamily::MyActuatorV3);
        let mut bus = SimBus::new(clock.clone(), config).unwrap();
        bus.record_trace(1000);
        for k in 0..20 {
            for m in 1..=3 {
                let iq = rmd_protocol::ScaledCurrent::saturating(10 * k, v3.iq_control_scale());
                let request = rmd_protocol::Request::Torque { iq_control: iq };
                let id = rmd_protocol::MotorId::new(m).unwrap();
                bus.send(&v3.encode(id, &request).unwrap()).unwrap();
            }
            let end = clock.now() + Duration::from_millis(2);
            while bus.recv_until(end).unwrap().is_some() {}
        }
        let ex = exchanges(bus.trace(), 3, 1_000_000);
        assert_eq!(ex.len(), 20);
        for e in &ex {
            // Six frames back to back but for the wait before the first reply.
            assert_eq!(e.cycle, e.frames + e.turnaround - intermission(1_000_000));
            assert!(e.max_frame_bits <= 135);
        }
        // Six frames of at most 135 bits, the first reply waiting for the last request at most
        // the turnaround (220 us) after the first: at least 1 / (810 + 220 - 270) us.
        let limit = WireLimit::of(&ex).unwrap();
        assert!(limit.rate_hz() > 1000.0, "{limit:?}");
        // Counted as multi-torque exchanges of 3 motors, none.
        assert_eq!(exchanges(bus.trace(), 2, 1_000_000).len(), 0);
    }

    #[test]
    fn eight_per_motor_requests_interleave_with_the_replies_and_still_make_one_exchange() {
        // Eight v1.61 motors per motor: the first replies (lower ids) win arbitration over the
        // later requests, so requests and replies interleave on the wire.
        let clock = VirtualClock::new();
        let mut bus = SimBus::new(clock.clone(), SimConfig::with_motors(8).seed(5)).unwrap();
        bus.record_trace(1000);
        let v161 = rmd_protocol::Dialect::V161;
        for k in 0..10 {
            for m in 1..=8 {
                let iq = rmd_protocol::ScaledCurrent::saturating(10 * k, v161.iq_control_scale());
                let request = rmd_protocol::Request::Torque { iq_control: iq };
                let id = rmd_protocol::MotorId::new(m).unwrap();
                bus.send(&v161.encode(id, &request).unwrap()).unwrap();
            }
            let end = clock.now() + Duration::from_millis(4);
            while bus.recv_until(end).unwrap().is_some() {}
        }
        let interleaved = bus
            .trace()
            .windows(2)
            .any(|w| matches!(w[0].from, Node::Motor(_)) && w[1].from == Node::Host);
        assert!(interleaved, "the test needs interleaving");
        let ex = exchanges(bus.trace(), 8, 1_000_000);
        assert_eq!(ex.len(), 10);
        for e in &ex {
            assert_eq!(e.cycle, e.frames + e.turnaround - intermission(1_000_000));
            // 16 frames of at least 111 bits, and no more than their worst case plus one
            // turnaround (220 us).
            assert!(e.frames >= Duration::from_micros(16 * 111), "{e:?}");
            assert!(e.cycle <= Duration::from_micros(16 * 135 + 220), "{e:?}");
        }
        // Counted as exchanges of 4 motors, none.
        assert_eq!(exchanges(bus.trace(), 4, 1_000_000).len(), 0);
    }

    #[test]
    fn a_0x280_frame_and_four_requests_beyond_it_make_one_exchange_of_eight_motors() {
        // A multi-torque bus beyond id 4: the 0x280 frame for ids 1..=4, then 0xA1 requests to
        // 5..=8; the first replies interleave with the later requests.
        let clock = VirtualClock::new();
        let mut bus = SimBus::new(clock.clone(), SimConfig::with_motors(8).seed(6)).unwrap();
        bus.record_trace(1000);
        let v161 = rmd_protocol::Dialect::V161;
        for k in 0..10 {
            let iq = rmd_protocol::ScaledCurrent::saturating(10 * k, v161.iq_control_scale());
            let frame = rmd_protocol::MultiTorque::new([iq; 4]);
            bus.send(&v161.encode_multi_torque(&frame).unwrap())
                .unwrap();
            for m in 5..=8 {
                let request = rmd_protocol::Request::Torque { iq_control: iq };
                let id = rmd_protocol::MotorId::new(m).unwrap();
                bus.send(&v161.encode(id, &request).unwrap()).unwrap();
            }
            let end = clock.now() + Duration::from_millis(4);
            while bus.recv_until(end).unwrap().is_some() {}
        }
        let ex = exchanges(bus.trace(), 8, 1_000_000);
        assert_eq!(ex.len(), 10);
        for e in &ex {
            assert_eq!(e.cycle, e.frames + e.turnaround - intermission(1_000_000));
            // 13 frames (5 requests, 8 replies), not the 16 of a per-motor bus.
            assert!(e.frames >= Duration::from_micros(13 * 111), "{e:?}");
            assert!(e.frames <= Duration::from_micros(13 * 135), "{e:?}");
        }
    }

    #[test]
    fn incomplete_exchanges_and_other_frames_are_skipped() {
        let clock = VirtualClock::new();
        let mut bus = SimBus::new(clock.clone(), SimConfig::with_motors(2).seed(1)).unwrap();
        bus.record_trace(100);
        bus.send(&MultiTorque::new([IqControl::default().into(); 4]).encode())
            .unwrap();
        while bus
            .recv_until(clock.now() + Duration::from_millis(2))
            .unwrap()
            .is_some()
        {}
        // Counted with the wrong number of motors: not an exchange of 4.
        assert_eq!(exchanges(bus.trace(), 4, 1_000_000).len(), 0);
        assert_eq!(exchanges(bus.trace(), 2, 1_000_000).len(), 1);
    }
}
