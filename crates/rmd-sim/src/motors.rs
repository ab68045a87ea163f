//! The motors of one bus, as firmware: frames in, scheduled reply frames out. Independent of
//! the simulated wire, so the same motors (with the same fault injection) can answer on a real
//! CAN interface.

use rmd_bus::Timestamp;
use rmd_protocol::{
    CanFrame, DecodedRequest, Dialect, LkSeries, MULTI_TORQUE_CAN_ID, MotorId, MultiTorque, Request,
};

use crate::config::{SimConfig, SimMotorConfig, validate_motors};
use crate::error::ConfigError;
use crate::family::FirmwareFamily;
use crate::fault::{FaultEngine, FaultRule, MotorSet, ReplyFaults, RequestKind};
use crate::motor::{MotorSnapshot, SimMotor};
use crate::request::MotorRequest;

/// A reply frame a motor will transmit, and when it is ready to go.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct ScheduledFrame {
    /// When the motor's controller has it ready to send (request received + turnaround +
    /// jitter + any injected delay). On a real interface: send it at this time.
    pub at: Timestamp,
    /// The sender.
    pub motor: MotorId,
    /// The frame (possibly corrupted by fault injection).
    pub frame: CanFrame,
}

/// The most replies one frame can produce: a 0x280 command to 32 MyActuator V3 motors, each
/// duplicated.
const MAX_REPLIES: usize = 2 * MotorId::MAX as usize;

/// The replies to one frame, in the order they become ready (ties in id order). Allocation-free.
#[derive(Copy, Clone, Debug)]
pub struct Replies {
    items: [Option<ScheduledFrame>; MAX_REPLIES],
    len: usize,
    next: usize,
}

impl Replies {
    fn new() -> Self {
        Self {
            items: [None; MAX_REPLIES],
            len: 0,
            next: 0,
        }
    }

    fn push(&mut self, item: ScheduledFrame) {
        if self.len < MAX_REPLIES {
            // Insertion sort by ready time, stable.
            let mut i = self.len;
            while i > 0 && self.items[i - 1].is_some_and(|p| p.at > item.at) {
                self.items[i] = self.items[i - 1];
                i -= 1;
            }
            self.items[i] = Some(item);
            self.len += 1;
        }
    }
}

impl Iterator for Replies {
    type Item = ScheduledFrame;
    fn next(&mut self) -> Option<ScheduledFrame> {
        if self.next < self.len {
            self.next += 1;
            self.items[self.next - 1]
        } else {
            None
        }
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let n = self.len - self.next;
        (n, Some(n))
    }
}

impl ExactSizeIterator for Replies {}

/// The simulated motors of one bus and their fault injection: the firmware side of the
/// simulator, without any wire.
///
/// Feed it every frame the host sends, with the time it was received; it answers with the
/// reply frames and when each is ready. [`SimBus`](crate::SimBus) uses it behind its simulated
/// wire; a tool running simulated motors on a real (or virtual) SocketCAN interface uses it
/// directly: receive a frame, call [`handle`](Self::handle), send each reply at its time.
///
/// ```
/// use rmd_bus::Timestamp;
/// use rmd_protocol::{IqControl, MultiTorque};
/// use rmd_sim::{SimConfig, SimMotors};
///
/// let mut motors = SimMotors::new(&SimConfig::with_motors(4), Timestamp::ZERO)?;
/// let frame = MultiTorque::new([IqControl::saturating(100).into(); 4]).encode();
/// let t = Timestamp::from_nanos(1_000_000);
/// let replies: Vec<_> = motors.handle(&frame, t).collect();
/// assert_eq!(replies.len(), 4);
/// assert_eq!(replies[0].frame.id(), 0x141);
/// assert!(replies.iter().all(|r| r.at >= t + core::time::Duration::from_micros(200)));
/// # Ok::<(), rmd_sim::ConfigError>(())
/// ```
#[derive(Clone, Debug)]
pub struct SimMotors {
    /// Sorted by id.
    motors: Vec<SimMotor>,
    faults: FaultEngine,
    ignored_frames: u64,
}

impl SimMotors {
    /// The motors and fault rules of `config` (its bus settings are not used), starting at
    /// `start`.
    pub fn new(config: &SimConfig, start: Timestamp) -> Result<Self, ConfigError> {
        Self::from_parts(&config.motors, &config.faults, config.seed, start)
    }

    /// Motors `motors` with fault rules `faults` and seed `seed`, starting at `start`.
    pub fn from_parts(
        motors: &[SimMotorConfig],
        faults: &[FaultRule],
        seed: u64,
        start: Timestamp,
    ) -> Result<Self, ConfigError> {
        validate_motors(motors)?;
        let faults = FaultEngine::new(faults, seed)?;
        let mut sims = motors
            .iter()
            .map(|m| SimMotor::new(m.clone(), start, seed))
            .collect::<Result<Vec<_>, _>>()?;
        sims.sort_by_key(|m| m.id());
        Ok(Self {
            motors: sims,
            faults,
            ignored_frames: 0,
        })
    }

    /// Handles one frame the host sent, received at `at`, and returns the replies.
    ///
    /// Each motor reads the frame as its firmware family does
    /// ([`FirmwareParams::family`](crate::FirmwareParams::family)): a v1.61 or LK-TECH motor
    /// takes a 0x280 frame as four torque currents (its own scale; ids 1..=4 answer in ascending
    /// id order), a MyActuator V3 motor as a command byte in DATA\[0\] that every V3 motor on
    /// the bus executes and answers on `0x240 + id` (unless its CAN ID filter is on). A V3 motor
    /// also takes its motion-mode frames on `0x400 + id`.
    ///
    /// Frames that are not valid requests (wrong DLC, unknown command byte, values out of
    /// range, an ID no motor here uses) are ignored, as the firmware would: no reply (counted
    /// in [`ignored_frames`](Self::ignored_frames)). Frames must come in time order; a frame
    /// older than a motor's state is handled at that state.
    pub fn handle(&mut self, frame: &CanFrame, at: Timestamp) -> Replies {
        let mut out = Replies::new();
        if frame.id() == MULTI_TORQUE_CAN_ID {
            self.handle_broadcast(frame, at, &mut out);
            return out;
        }
        let index = MotorId::from_can_id(frame.id())
            .ok()
            .or_else(|| motion_motor(frame.id()))
            .and_then(|motor| self.index(motor));
        let request = index.and_then(|i| {
            let v3 = self.motors[i].family() == FirmwareFamily::MyActuatorV3;
            match MotorRequest::single(self.motors[i].dialect(), frame)? {
                // Only V3 firmware has a use for a frame it does not know (the stale-reply
                // trap, the watchdog hearing it); the others ignore it.
                MotorRequest::Unknown { .. } if !v3 => None,
                request => Some((i, request)),
            }
        });
        let Some((index, request)) = request else {
            self.ignored_frames += 1;
            return out;
        };
        let motor = self.motors[index].id();
        let faults = self.faults.on_motor_frame(motor, request.kind(), at);
        let sim = &mut self.motors[index];
        if faults.silent {
            sim.stats_mut().silenced += 1;
            return out;
        }
        match sim.answer(&request, frame, at, &self.faults) {
            Some(reply) => {
                let ready = at + sim.turnaround();
                emit(&mut out, sim, ready, reply, &faults);
            }
            None if matches!(request, MotorRequest::Unknown { .. }) => self.ignored_frames += 1,
            None => {}
        }
        out
    }

    /// A 0x280 frame: every motor reads it as its family does.
    fn handle_broadcast(&mut self, frame: &CanFrame, at: Timestamp, out: &mut Replies) {
        let readings = BroadcastReadings::of(frame);
        let readable = if self.motors.is_empty() {
            readings.v161.is_some()
        } else {
            self.motors.iter().any(|m| readings.can_be_read_by(m))
        };
        if !readable {
            self.ignored_frames += 1;
            return;
        }
        let mut previous = at;
        for index in 0..self.motors.len() {
            let motor = self.motors[index].id();
            let Some(request) = readings.request_for(&self.motors[index], motor) else {
                continue;
            };
            let kind = match request {
                MotorRequest::Single(_) => request.kind(),
                _ => RequestKind::Multi,
            };
            let faults = self.faults.on_motor_frame(motor, kind, at);
            let sim = &mut self.motors[index];
            if faults.silent {
                sim.stats_mut().silenced += 1;
                continue;
            }
            if let Some(reply) = sim.answer(&request, frame, at, &self.faults) {
                // v1.61: motors 1..4 answer in ascending id order; V3: in the order bus
                // arbitration gives, which for simultaneous replies is ascending id too.
                let ready = (at + sim.turnaround()).max(previous);
                previous = ready;
                emit(out, sim, ready, reply, &faults);
            }
        }
    }

    /// Frames ignored because they were no valid request for a motor here.
    pub fn ignored_frames(&self) -> u64 {
        self.ignored_frames
    }

    /// Runs every motor's firmware and physics up to `at`.
    pub fn advance_to(&mut self, at: Timestamp) {
        for m in &mut self.motors {
            m.advance_to(at, &self.faults);
        }
    }

    /// Simulates a power cycle of motor `id` at `at`: RAM reloaded from ROM (so a zero written
    /// with 0x19 takes effect), the motor off, the multi-turn count restarted. `false` if there
    /// is no such motor.
    pub fn power_cycle(&mut self, id: MotorId, at: Timestamp) -> bool {
        match self.index(id) {
            Some(i) => {
                self.motors[i].power_cycle(at, &self.faults);
                true
            }
            None => false,
        }
    }

    /// Motor `id`, if present.
    pub fn motor(&self, id: MotorId) -> Option<&SimMotor> {
        self.index(id).map(|i| &self.motors[i])
    }

    /// The state of motor `id` after advancing it to `at`.
    pub fn snapshot_at(&mut self, id: MotorId, at: Timestamp) -> Option<MotorSnapshot> {
        let i = self.index(id)?;
        self.motors[i].advance_to(at, &self.faults);
        Some(self.motors[i].snapshot())
    }

    /// Every motor, in id order.
    pub fn iter(&self) -> impl Iterator<Item = &SimMotor> {
        self.motors.iter()
    }

    /// The set of motor ids present.
    pub fn ids(&self) -> MotorSet {
        self.motors
            .iter()
            .fold(MotorSet::NONE, |set, m| set.with(m.id()))
    }

    pub(crate) fn faults_mut(&mut self) -> &mut FaultEngine {
        &mut self.faults
    }

    fn index(&self, id: MotorId) -> Option<usize> {
        self.motors.binary_search_by_key(&id, |m| m.id()).ok()
    }
}

/// A 0x280 frame as each family reads it.
struct BroadcastReadings {
    v161: Option<MultiTorque>,
    lk_mf: Option<MultiTorque>,
    lk_mg: Option<MultiTorque>,
    /// The V3 reading (a request decodes alike in both manual revisions: 0xB5's form is in the
    /// request itself).
    v3: Option<Request>,
}

impl BroadcastReadings {
    fn of(frame: &CanFrame) -> Self {
        let torque = |dialect: Dialect| match dialect.decode_request(frame) {
            Ok(DecodedRequest::Multi(m)) => Some(m),
            _ => None,
        };
        Self {
            v161: torque(Dialect::V161),
            lk_mf: torque(Dialect::LkV23x(LkSeries::Mf)),
            lk_mg: torque(Dialect::LkV23x(LkSeries::Mg)),
            v3: match Dialect::MyActuatorV3(Default::default()).decode_request(frame) {
                Ok(DecodedRequest::Broadcast(request)) => Some(request),
                _ => None,
            },
        }
    }

    fn torque(&self, family: FirmwareFamily) -> Option<MultiTorque> {
        match family {
            FirmwareFamily::V161 => self.v161,
            FirmwareFamily::LkV23x(LkSeries::Mf) => self.lk_mf,
            FirmwareFamily::LkV23x(LkSeries::Mg) => self.lk_mg,
            FirmwareFamily::MyActuatorV3 => None,
        }
    }

    fn can_be_read_by(&self, motor: &SimMotor) -> bool {
        match motor.family() {
            FirmwareFamily::MyActuatorV3 => self.v3.is_some() && motor.hears_broadcasts(),
            other => self.torque(other).is_some(),
        }
    }

    fn request_for(&self, sim: &SimMotor, motor: MotorId) -> Option<MotorRequest> {
        match sim.family() {
            FirmwareFamily::MyActuatorV3 if sim.hears_broadcasts() => {
                self.v3.map(MotorRequest::Single)
            }
            FirmwareFamily::MyActuatorV3 => None,
            other => self
                .torque(other)?
                .iq_control_for(motor)
                .map(MotorRequest::SlotTorque),
        }
    }
}

/// The motor of a MyActuator V3 motion-mode identifier (`0x400 + id`).
fn motion_motor(can_id: u16) -> Option<MotorId> {
    match can_id.checked_sub(0x400) {
        Some(n @ 1..=32) => MotorId::new(n as u8).ok(),
        _ => None,
    }
}

/// Applies the reply faults and queues the reply (and its duplicate).
fn emit(
    out: &mut Replies,
    sim: &mut SimMotor,
    ready: Timestamp,
    frame: CanFrame,
    faults: &ReplyFaults,
) {
    if faults.drop {
        sim.stats_mut().dropped_replies += 1;
        return;
    }
    let mut data = [0u8; 8];
    data.copy_from_slice(frame.data8().map_or(&[0; 8], |d| d));
    for (byte, mask) in data.iter_mut().zip(faults.corrupt) {
        *byte ^= mask;
    }
    let dlc = usize::from(faults.wrong_dlc.unwrap_or(8).min(8));
    let Ok(frame) = CanFrame::new(frame.id(), &data[..dlc]) else {
        return;
    };
    let item = ScheduledFrame {
        at: sim.schedule_reply(ready + faults.late),
        motor: sim.id(),
        frame,
    };
    out.push(item);
    if faults.duplicate {
        out.push(item);
    }
}

/// The kind of a host frame and the motors it addresses, for bus-fault rules.
///
/// Bus-fault rules classify host frames as v1.61 reads them, whatever the motors' families.
pub(crate) fn classify(frame: &CanFrame) -> (RequestKind, Option<MotorSet>) {
    match Dialect::V161.decode_request(frame) {
        Ok(DecodedRequest::Single { motor, request }) => (
            RequestKind::Single(request.command()),
            Some(MotorSet::only(motor)),
        ),
        Ok(DecodedRequest::Multi(_)) => (RequestKind::Multi, Some(MotorSet::MULTI_TORQUE)),
        Ok(DecodedRequest::Broadcast(_) | DecodedRequest::Mit { .. }) | Err(_) => (
            RequestKind::Other,
            MotorId::from_can_id(frame.id()).ok().map(MotorSet::only),
        ),
    }
}
