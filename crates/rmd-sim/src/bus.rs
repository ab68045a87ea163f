//! [`SimBus`]: simulated motors behind a simulated CAN wire, as a [`CanBus`].
//!
//! Nothing runs in the background. The simulation advances lazily, on the caller's thread,
//! to the clock's `now` (in [`send`](CanBus::send)) or up to the receive deadline (in
//! [`recv_until`](CanBus::recv_until)): `recv_until` works out the next host-side delivery; if
//! it is at `td <= deadline` it waits for `td` on the clock (`sleep_until`) and returns the
//! item stamped `td`, otherwise it waits for the deadline and returns `None`. The same code path
//! runs in virtual time ([`VirtualClock`](rmd_bus::VirtualClock): waiting moves time, runs are
//! fast and deterministic) and in real time ([`MonotonicClock`](rmd_bus::MonotonicClock):
//! replies arrive when they would on a real bus).
//!
//! Several `SimBus` may share one clock (a robot with several buses driven by one loop): each
//! keeps its own wire and motors, and items are stamped with their true time even when they are
//! collected after the clock moved on.

use std::collections::VecDeque;

use rmd_bus::{BusError, BusEvent, BusMessage, CanBus, Clock, Received, Timestamp};
use rmd_protocol::{CanFrame, MotorId};

use crate::config::SimConfig;
use crate::error::ConfigError;
use crate::fault::BusFault;
use crate::medium::{Node, Transmission, Wire, WireStep};
use crate::motor::MotorSnapshot;
use crate::motors::{SimMotors, classify};

/// Counters of a simulated bus.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct BusStats {
    /// Frames the host transmitted on the wire.
    pub host_frames: u64,
    /// Frames the motors transmitted on the wire.
    pub motor_frames: u64,
    /// Frames delivered to the client.
    pub received_frames: u64,
    /// `send` calls refused with [`BusError::TxQueueFull`].
    pub tx_queue_full: u64,
    /// `send` calls refused with [`BusError::BusOff`].
    pub tx_bus_off: u64,
    /// Frames lost to bus-off (queued by the host, or arriving while bus-off).
    pub lost_to_bus_off: u64,
    /// Frames the host sent after it fell silent ([`BusFault::HostSilent`]): none reached the motors.
    pub lost_to_host_silent: u64,
    /// Frames lost because the client's receive queue was full.
    pub rx_overflow: u64,
    /// Replies the motors could not queue (all transmit mailboxes full).
    pub motor_mailbox_overflow: u64,
    /// Bus-off episodes.
    pub bus_off_episodes: u64,
}

/// Simulated RMD motors on a simulated CAN bus, driven through the [`CanBus`] trait.
///
/// ```
/// use core::time::Duration;
/// use rmd_bus::{BusMessage, CanBus, Clock, VirtualClock};
/// use rmd_protocol::{Dialect, IqControl, MultiTorque};
/// use rmd_sim::{SimBus, SimConfig};
///
/// let clock = VirtualClock::new();
/// let mut bus = SimBus::new(clock.clone(), SimConfig::with_motors(4))?;
/// bus.send(&MultiTorque::new([IqControl::from_amps(1.0).unwrap().into(); 4]).encode()).unwrap();
/// let deadline = clock.now() + Duration::from_millis(1);
/// let mut replies = 0;
/// while let Some(rx) = bus.recv_until(deadline).unwrap() {
///     if let BusMessage::Frame(frame) = rx.message {
///         let (motor, _reply) = Dialect::V161.decode_reply(&frame).unwrap();
///         replies += 1;
///         assert_eq!(motor.get(), replies);
///     }
/// }
/// assert_eq!(replies, 4);
/// // The exchange took about 0.2 ms turnaround + 5 frames of ~0.12 ms on the 1 Mbit/s wire.
/// assert_eq!(clock.now(), deadline);
/// # Ok::<(), rmd_sim::ConfigError>(())
/// ```
#[derive(Debug)]
pub struct SimBus<C: Clock> {
    clock: C,
    wire: Wire,
    motors: SimMotors,
    rx: VecDeque<Received>,
    rx_queue_len: usize,
    /// While bus-off: when the controller restarts.
    bus_off_until: Option<Timestamp>,
    bus_faults: bool,
    /// The host fell silent: from then on nothing it sends reaches the wire.
    host_silent: bool,
    trace: Vec<Transmission>,
    trace_capacity: usize,
    stats: BusStats,
    /// The time of the latest event simulated: a frame sent later from another thread cannot
    /// be queued before it.
    simulated_to: Timestamp,
}

impl<C: Clock> SimBus<C> {
    /// A simulated bus with the motors, faults and seed of `config`, starting at `clock.now()`.
    pub fn new(clock: C, config: SimConfig) -> Result<Self, ConfigError> {
        config.validate()?;
        let start = clock.now();
        let motors = SimMotors::new(&config, start)?;
        let wire = Wire::new(
            config.bus.timing,
            config.bus.tx_queue_len,
            config.motors.len().max(1),
            config.bus.motor_mailboxes,
            start,
        );
        let mut motors = motors;
        let bus_faults = motors.faults_mut().has_bus_faults();
        Ok(Self {
            clock,
            wire,
            motors,
            rx: VecDeque::with_capacity(config.bus.rx_queue_len + 1),
            rx_queue_len: config.bus.rx_queue_len,
            bus_off_until: None,
            bus_faults,
            host_silent: false,
            trace: Vec::new(),
            trace_capacity: 0,
            stats: BusStats::default(),
            simulated_to: start,
        })
    }

    /// The bus's clock.
    pub fn clock(&self) -> &C {
        &self.clock
    }

    /// The motors (their state as of the last time the bus advanced; see
    /// [`snapshot`](Self::snapshot) for the state now).
    pub fn motors(&self) -> &SimMotors {
        &self.motors
    }

    /// The counters.
    pub fn stats(&self) -> BusStats {
        self.stats
    }

    /// Records every transmission from now on, up to `capacity` of them (allocated here, once;
    /// later ones are not recorded). For tests and debugging.
    pub fn record_trace(&mut self, capacity: usize) {
        self.trace = Vec::with_capacity(capacity);
        self.trace_capacity = capacity;
    }

    /// The transmissions recorded since [`record_trace`](Self::record_trace), in start order.
    pub fn trace(&self) -> &[Transmission] {
        &self.trace
    }

    /// Advances the bus and motor `id` to the clock's now and returns the motor's state.
    pub fn snapshot(&mut self, id: MotorId) -> Option<MotorSnapshot> {
        let now = self.clock.now();
        self.run_until(now, false);
        self.motors.snapshot_at(id, now)
    }

    /// Simulates a power cycle of motor `id` now (see [`SimMotors::power_cycle`]).
    pub fn power_cycle(&mut self, id: MotorId) -> bool {
        let now = self.clock.now();
        self.run_until(now, false);
        self.motors.power_cycle(id, now)
    }

    /// Whether the host's controller is bus-off now.
    pub fn is_bus_off(&mut self) -> bool {
        let now = self.clock.now();
        self.run_until(now, false);
        self.bus_off_until.is_some()
    }

    /// Frames waiting in the host's transmit queue now.
    pub fn tx_queued(&mut self) -> usize {
        let now = self.clock.now();
        self.run_until(now, false);
        self.wire.host_queued()
    }

    /// Processes every event up to `t` (inclusive); with `stop_at_rx`, stops as soon as the
    /// client has something to receive.
    fn run_until(&mut self, t: Timestamp, stop_at_rx: bool) {
        loop {
            if stop_at_rx && !self.rx.is_empty() {
                return;
            }
            let wire_next = self.wire.next_event();
            let restart = self.bus_off_until;
            let next = match (wire_next, restart) {
                (Some(a), Some(b)) => a.min(b),
                (a, b) => match a.or(b) {
                    Some(x) => x,
                    None => return,
                },
            };
            if next > t {
                return;
            }
            self.simulated_to = self.simulated_to.max(next);
            if restart == Some(next) {
                self.bus_off_until = None;
                self.push_rx(next, BusMessage::Event(BusEvent::Restarted));
                continue;
            }
            match self.wire.step() {
                Some(WireStep::Started(tx)) => {
                    match tx.from {
                        Node::Host => self.stats.host_frames += 1,
                        Node::Motor(_) => self.stats.motor_frames += 1,
                    }
                    if self.trace.len() < self.trace_capacity {
                        self.trace.push(tx);
                    }
                }
                Some(WireStep::Delivered(tx)) => self.deliver(tx),
                Some(WireStep::Freed) | None => {}
            }
        }
    }

    fn deliver(&mut self, tx: Transmission) {
        match tx.from {
            Node::Host => {
                for reply in self.motors.handle(&tx.frame, tx.delivered) {
                    if self
                        .wire
                        .push_motor(reply.motor.get(), reply.at, reply.frame)
                        .is_err()
                    {
                        self.stats.motor_mailbox_overflow += 1;
                    }
                }
            }
            Node::Motor(_) => {
                if self.bus_off_until.is_some() {
                    self.stats.lost_to_bus_off += 1;
                } else {
                    self.stats.received_frames += 1;
                    self.push_rx(tx.delivered, BusMessage::Frame(tx.frame));
                }
            }
        }
    }

    fn push_rx(&mut self, at: Timestamp, message: BusMessage) {
        let overflow = BusMessage::Event(BusEvent::RxOverflow);
        if self.rx.len() < self.rx_queue_len {
            self.rx.push_back(Received { at, message });
        } else {
            if matches!(message, BusMessage::Frame(_)) {
                self.stats.rx_overflow += 1;
            }
            // One slot is reserved for the overflow event.
            if self.rx.back().map(|r| r.message) != Some(overflow) {
                self.rx.push_back(Received {
                    at,
                    message: overflow,
                });
            }
        }
    }

    fn start_bus_off(&mut self, at: Timestamp, duration: core::time::Duration) {
        self.stats.lost_to_bus_off += self.wire.flush_host(at) as u64;
        self.stats.bus_off_episodes += 1;
        self.bus_off_until = Some(at + duration);
        self.push_rx(at, BusMessage::Event(BusEvent::BusOff));
    }
}

impl<C: Clock> SimBus<C> {
    /// Queues `frame` as sent by the host at `at`, or at the latest event already simulated if
    /// that is later (a frame cannot go back in the simulation's time). [`CanBus::send`] is
    /// `send_at(frame, clock.now())`; a thread that drives the simulation for another one (see
    /// [`threaded`](crate::threaded)) passes the time the frame was sent there.
    pub fn send_at(&mut self, frame: &CanFrame, at: Timestamp) -> Result<(), BusError> {
        let now = at.max(self.simulated_to);
        self.run_until(now, false);
        if self.bus_off_until.is_some() {
            self.stats.tx_bus_off += 1;
            return Err(BusError::BusOff);
        }
        if self.wire.host_queued() >= self.wire_capacity() {
            self.stats.tx_queue_full += 1;
            return Err(BusError::TxQueueFull);
        }
        if self.host_silent {
            self.stats.lost_to_host_silent += 1;
            return Ok(());
        }
        if self.bus_faults {
            let (kind, motors) = classify(frame);
            match self.motors.faults_mut().on_host_frame(kind, motors, now) {
                Some(BusFault::BusOff { duration }) => {
                    // The controller took the frame, then went bus-off: the frame is lost.
                    self.stats.lost_to_bus_off += 1;
                    self.start_bus_off(now, duration);
                    return Ok(());
                }
                Some(BusFault::TxStall { duration }) => self.wire.block_host_until(now + duration),
                Some(BusFault::HostSilent) => {
                    self.host_silent = true;
                    self.stats.lost_to_host_silent += 1;
                    return Ok(());
                }
                None => {}
            }
        }
        self.wire.push_host(now, *frame).map_err(|_| {
            self.stats.tx_queue_full += 1;
            BusError::TxQueueFull
        })
    }

    /// Simulates ahead, up to `horizon` and without waiting on the clock, until something is
    /// for the client; returns it, stamped with its time on the wire (which may be after the
    /// clock's now). `None`: nothing for the client until `horizon`.
    pub fn next_received(&mut self, horizon: Timestamp) -> Option<Received> {
        self.run_until(horizon, true);
        self.rx.pop_front()
    }

    /// The time of the simulation's next event (a frame starting, or reaching its receivers,
    /// a controller restart), if any is pending.
    pub fn next_event(&self) -> Option<Timestamp> {
        match (self.wire.next_event(), self.bus_off_until) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }
}

impl<C: Clock> CanBus for SimBus<C> {
    fn send(&mut self, frame: &CanFrame) -> Result<(), BusError> {
        let now = self.clock.now();
        self.send_at(frame, now)
    }

    fn recv_until(&mut self, deadline: Timestamp) -> Result<Option<Received>, BusError> {
        let now = self.clock.now();
        self.run_until(now, false);
        if let Some(item) = self.rx.pop_front() {
            // Already received (item.at <= now): no wait.
            return Ok(Some(item));
        }
        if deadline <= now {
            return Ok(None);
        }
        self.run_until(deadline, true);
        match self.rx.pop_front() {
            Some(item) => {
                self.clock.sleep_until(item.at);
                Ok(Some(item))
            }
            None => {
                self.clock.sleep_until(deadline);
                Ok(None)
            }
        }
    }
}

impl<C: Clock> SimBus<C> {
    fn wire_capacity(&self) -> usize {
        self.wire.host_capacity()
    }
}
