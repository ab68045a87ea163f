//! One simulated motor: firmware + plant on a fixed time grid, advanced lazily.

use core::time::Duration;

use rand_pcg::Pcg64Mcg;
use rand_pcg::rand_core::Rng;
use rmd_bus::Timestamp;
use rmd_protocol::{CanFrame, Dialect, ErrorState, MotorId, PidParams};

use crate::config::SimMotorConfig;
use crate::error::ConfigError;
use crate::family::FirmwareFamily;
use crate::fault::{FaultEngine, stream};
use crate::firmware::{ControlMode, Firmware};
use crate::physics::{Plant, PlantState, SUBSTEP_NS};
use crate::request::MotorRequest;

/// A snapshot of one motor, in physical units (for tests, tools and visualisation; a bus client
/// only sees frames).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct MotorSnapshot {
    /// The motor.
    pub id: MotorId,
    /// Time of the state (the last physics substep).
    pub at: Timestamp,
    /// Rotor angle, motor side, degrees (unbounded).
    pub motor_angle_deg: f64,
    /// Output shaft angle, degrees.
    pub output_angle_deg: f64,
    /// Rotor speed, motor side, dps.
    pub motor_speed_dps: f64,
    /// Torque current, A.
    pub current_a: f64,
    /// Torque at the output shaft from the current (before friction), N·m.
    pub output_torque_nm: f64,
    /// Winding temperature, °C.
    pub temperature_c: f64,
    /// Supply voltage at the motor, V.
    pub voltage_v: f64,
    /// Latched protection flags.
    pub error_state: ErrorState,
    /// The firmware's control mode.
    pub mode: ControlMode,
    /// Whether a 0x81 stop holds the output off.
    pub stopped: bool,
    /// PID gains in RAM.
    pub pid_ram: PidParams,
    /// PID gains in ROM.
    pub pid_rom: PidParams,
    /// Whether the firmware applies, or is commanded to apply, torque (output enabled, in a mode
    /// other than zero torque).
    pub energising: bool,
    /// Since when it has not (see [`SimMotor::safe_since`]).
    pub safe_since: Option<Timestamp>,
    /// MyActuator V3: the brake is locked (0x78, a watchdog trip, power-up with a brake).
    pub brake_locked: bool,
    /// MyActuator V3: the communication-interruption protection has tripped and communication
    /// has not been re-established.
    pub watchdog_tripped: bool,
    /// MyActuator V3: rebooting after 0x76 (deaf until it has).
    pub rebooting: bool,
}

/// Counters of one motor.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct MotorStats {
    /// Requests the firmware handled.
    pub requests: u64,
    /// Requests ignored because they were not valid for this motor.
    pub invalid_requests: u64,
    /// Requests ignored because the motor was made silent by a fault rule.
    pub silenced: u64,
    /// Replies suppressed by a drop fault.
    pub dropped_replies: u64,
    /// MyActuator V3: times the communication-interruption protection tripped.
    pub watchdog_trips: u64,
    /// MyActuator V3: frames echoed but not executed, the first after a watchdog trip.
    pub echoed_after_trip: u64,
    /// MyActuator V3: frames unheard while rebooting after 0x76.
    pub unheard_while_rebooting: u64,
}

/// Counters of the firmware-state traps of one motor (see
/// [`FirmwareTraps`](crate::FirmwareTraps)).
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct TrapStats {
    /// Requests executed but not answered (`unanswered`).
    pub unanswered: u64,
    /// Motion commands answered but not obeyed after 0x88 (`motion_ignored_after_run`).
    pub ignored_motion: u64,
    /// Unknown commands answered with the previous reply (`stale_reply_to_unknown`).
    pub stale_replies: u64,
}

/// One simulated motor.
#[derive(Clone, Debug)]
pub struct SimMotor {
    config: SimMotorConfig,
    firmware: Firmware,
    plant: Plant,
    /// Time of the plant's state, a multiple of the substep.
    time: Timestamp,
    jitter: Pcg64Mcg,
    stats: MotorStats,
    trap_stats: TrapStats,
    /// When the last 0x88 was handled.
    run_at: Option<Timestamp>,
    /// Since when the firmware has applied no torque and been commanded none (`None` while it
    /// does): the ground truth of "safe".
    safe_since: Option<Timestamp>,
    /// When this motor's newest reply is scheduled (replies leave in order).
    last_reply_at: Timestamp,
    /// Its last reply (what V3 firmware repeats to a command it does not know).
    last_reply: Option<CanFrame>,
    /// MyActuator V3: when the last frame addressed to it arrived (the watchdog's reference).
    last_heard: Option<Timestamp>,
    /// MyActuator V3: when the watchdog tripped, until communication is re-established.
    tripped_at: Option<Timestamp>,
    /// MyActuator V3: the first frame after a trip (echoed, not executed).
    first_after_trip: Option<Timestamp>,
    /// MyActuator V3: deaf until this time (rebooting after 0x76).
    rebooting_until: Option<Timestamp>,
}

impl SimMotor {
    pub(crate) fn new(
        config: SimMotorConfig,
        start: Timestamp,
        seed: u64,
    ) -> Result<Self, ConfigError> {
        config.validate()?;
        let plant = Plant::new(
            config.motor.clone(),
            config.load.clone(),
            config.initial_output_angle_deg.to_radians(),
        )?;
        let firmware = Firmware::new(config.firmware, &plant);
        let jitter = stream(seed, 1_000 + u64::from(config.id.get()));
        Ok(Self {
            time: Timestamp::from_nanos(start.as_nanos() - start.as_nanos() % SUBSTEP_NS),
            config,
            firmware,
            plant,
            jitter,
            stats: MotorStats::default(),
            trap_stats: TrapStats::default(),
            run_at: None,
            safe_since: Some(start),
            last_reply_at: Timestamp::ZERO,
            last_reply: None,
            last_heard: None,
            tripped_at: None,
            first_after_trip: None,
            rebooting_until: None,
        })
    }

    /// Its firmware family.
    pub fn family(&self) -> FirmwareFamily {
        self.firmware.family()
    }

    /// The dialect its firmware speaks (for V3: with its firmware date and maximum torque).
    pub fn dialect(&self) -> Dialect {
        self.firmware.dialect()
    }

    /// Its trap counters.
    pub fn trap_stats(&self) -> TrapStats {
        self.trap_stats
    }

    /// The motor's id.
    pub fn id(&self) -> MotorId {
        self.config.id
    }

    /// Its configuration.
    pub fn config(&self) -> &SimMotorConfig {
        &self.config
    }

    /// Its counters.
    pub fn stats(&self) -> MotorStats {
        self.stats
    }

    pub(crate) fn stats_mut(&mut self) -> &mut MotorStats {
        &mut self.stats
    }

    /// The physical state at [`time`](Self::time).
    pub fn plant_state(&self) -> PlantState {
        *self.plant.state()
    }

    /// Time of the state (the motor is advanced lazily, when it handles a frame or is looked at).
    pub fn time(&self) -> Timestamp {
        self.time
    }

    /// Since when the firmware has applied no torque and been commanded none: off, stopped,
    /// tripped by a protection, or commanded zero torque. `None` while it applies or is commanded
    /// torque (any other mode). The instant a motor became safe, as the firmware knows it.
    pub fn safe_since(&self) -> Option<Timestamp> {
        self.safe_since
    }

    /// Notes whether the firmware is safe at `at` (after a command or a control step).
    fn note_safety(&mut self, at: Timestamp) {
        match (self.firmware.energising(), self.safe_since) {
            (true, Some(_)) => self.safe_since = None,
            (false, None) => self.safe_since = Some(at),
            _ => {}
        }
    }

    /// When a reply ready at `ready` leaves: with in-order replies, not before this motor's
    /// previous one (a reply held back holds the later ones back too).
    pub(crate) fn schedule_reply(&mut self, ready: Timestamp) -> Timestamp {
        let at = if self.config.firmware.in_order_replies {
            ready.max(self.last_reply_at)
        } else {
            ready
        };
        self.last_reply_at = at;
        at
    }

    /// The state in physical units.
    pub fn snapshot(&self) -> MotorSnapshot {
        let s = self.plant.state();
        let ratio = self.plant.params().gear_ratio;
        MotorSnapshot {
            id: self.config.id,
            at: self.time,
            motor_angle_deg: s.motor_angle_rad.to_degrees(),
            output_angle_deg: (s.motor_angle_rad / ratio).to_degrees(),
            motor_speed_dps: s.motor_speed_rad_s.to_degrees(),
            current_a: s.current_a,
            output_torque_nm: s.current_a * self.plant.params().torque_constant_nm_per_a * ratio,
            temperature_c: s.winding_temperature_c,
            voltage_v: s.bus_voltage_v,
            error_state: self.firmware.errors(),
            mode: self.firmware.mode(),
            stopped: self.firmware.stopped(),
            pid_ram: self.firmware.pid_ram(),
            pid_rom: self.firmware.pid_rom(),
            energising: self.firmware.energising(),
            safe_since: self.safe_since,
            brake_locked: self.firmware.v3.brake_locked,
            watchdog_tripped: self.tripped_at.is_some(),
            rebooting: self.rebooting_until.is_some(),
        }
    }

    /// MyActuator V3: whether it receives 0x280 frames (not with the CAN ID filter on, V4.4
    /// §2.36).
    pub(crate) fn hears_broadcasts(&self) -> bool {
        !self.firmware.v3.can_id_filter
    }

    /// The next time a V3 timer fires by itself: the end of a reboot, the watchdog's deadline.
    fn next_timer(&self) -> Option<Timestamp> {
        let watchdog = self.firmware.v3.watchdog;
        let deadline = match (self.last_heard, self.tripped_at) {
            (Some(heard), None) if !watchdog.is_off() => {
                Some(heard + Duration::from_millis(u64::from(watchdog.millis())))
            }
            _ => None,
        };
        match (self.rebooting_until, deadline) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    /// Fires the V3 timers due by the state's time: the reboot ends (the firmware runs as
    /// after a power-up), the watchdog trips ("the drive cuts off the output and locks the
    /// brake", V4.4 §2.32) when no frame came for longer than the protection time.
    fn fire_timers(&mut self) {
        if let Some(until) = self.rebooting_until
            && self.time >= until
        {
            self.rebooting_until = None;
            self.firmware.power_up(&self.plant);
            self.last_heard = None;
        }
        let watchdog = self.firmware.v3.watchdog;
        if let (Some(heard), None, false) = (self.last_heard, self.tripped_at, watchdog.is_off())
            && self.time > heard + Duration::from_millis(u64::from(watchdog.millis()))
        {
            self.firmware.watchdog_trip();
            self.tripped_at = Some(self.time);
            self.first_after_trip = None;
            self.stats.watchdog_trips += 1;
        }
    }

    /// Runs firmware and physics up to `t` (whole substeps; the state stays on the grid).
    pub(crate) fn advance_to(&mut self, t: Timestamp, faults: &FaultEngine) {
        let id = self.config.id;
        let max_current = self.plant.params().max_current_a;
        while t.as_nanos() >= self.time.as_nanos() + SUBSTEP_NS {
            self.fire_timers();
            let env = faults.environment(id, self.time);
            if !self.firmware.output_enabled() && self.plant.is_quiescent() {
                // Nothing moves: cool down in closed form up to `t`, the next change of the
                // environment or the next timer, whichever comes first.
                let whole = (t.as_nanos() - self.time.as_nanos()) / SUBSTEP_NS;
                let next = match (
                    faults.next_environment_change(id, self.time),
                    self.next_timer(),
                ) {
                    (Some(a), Some(b)) => Some(a.min(b)),
                    (a, b) => a.or(b),
                };
                let steps = match next {
                    Some(change) if change < t => {
                        (change.as_nanos() - self.time.as_nanos()).div_ceil(SUBSTEP_NS)
                    }
                    _ => whole,
                }
                .clamp(1, whole);
                self.plant.rest(steps, &env);
                self.time = Timestamp::from_nanos(self.time.as_nanos() + steps * SUBSTEP_NS);
                self.firmware.supervise(&self.plant);
                self.note_safety(self.time);
                continue;
            }
            let drive = self.firmware.control(&self.plant, max_current);
            self.plant.step(drive, &env);
            self.time = Timestamp::from_nanos(self.time.as_nanos() + SUBSTEP_NS);
            self.firmware.supervise(&self.plant);
            self.note_safety(self.time);
        }
    }

    /// Handles a request received at `at` (in `frame`) and returns the reply frame; `None` if
    /// the firmware ignores it or does not answer it.
    ///
    /// A MyActuator V3 motor whose watchdog has tripped echoes the first frame it then receives
    /// without executing it; a second frame within the protection time re-establishes the
    /// communication and is executed (2b-t/myactuator_rmd_ros PR 4, ioio2995, 2024-06-14: "The
    /// first command received will not be considered, and it will return an echo of the 8 data
    /// bytes. If the second command arrives within the time allowed, communication will
    /// resume."). A V3 motor rebooting after 0x76 hears nothing.
    pub(crate) fn answer(
        &mut self,
        request: &MotorRequest,
        frame: &CanFrame,
        at: Timestamp,
        faults: &FaultEngine,
    ) -> Option<CanFrame> {
        self.advance_to(at, faults);
        let id = self.config.id;
        let dialect = self.firmware.dialect();
        if self.firmware.family() == FirmwareFamily::MyActuatorV3 {
            if self.rebooting_until.is_some() {
                self.stats.unheard_while_rebooting += 1;
                return None;
            }
            self.last_heard = Some(at);
            if self.tripped_at.is_some() {
                let window = Duration::from_millis(u64::from(self.firmware.v3.watchdog.millis()));
                match self.first_after_trip {
                    Some(first) if at <= first + window => {
                        self.tripped_at = None;
                        self.first_after_trip = None;
                    }
                    _ => {
                        self.first_after_trip = Some(at);
                        self.stats.echoed_after_trip += 1;
                        let reply_id = match request {
                            MotorRequest::Mit(_) => 0x500 + u16::from(id.get()),
                            _ => dialect.reply_id(id),
                        };
                        let data = frame.data8().copied().unwrap_or([0; 8]);
                        return CanFrame::with_data(reply_id, data).ok();
                    }
                }
            }
        }
        let traps = self.firmware.traps();
        let window = traps.motion_ignored_after_run;
        let ignore = request.is_motion()
            && !window.is_zero()
            && self.run_at.is_some_and(|run| at < run + window);
        self.firmware.set_ignore_motion(ignore);
        let plant = &self.plant;
        let reply = match *request {
            MotorRequest::Single(r) => self
                .firmware
                .handle(&r, plant)
                .and_then(|reply| dialect.encode_reply(id, &reply).ok()),
            MotorRequest::SlotTorque(iq) => {
                let reply = self.firmware.torque(iq, plant);
                dialect.encode_reply(id, &reply).ok()
            }
            MotorRequest::Mit(command) => self
                .firmware
                .handle_mit(&command, plant)
                .and_then(|feedback| dialect.encode_mit_reply(id, &feedback).ok()),
            MotorRequest::Unknown { .. } if traps.stale_reply_to_unknown => {
                if self.last_reply.is_some() {
                    self.trap_stats.stale_replies += 1;
                }
                self.last_reply
            }
            MotorRequest::Unknown { .. } => None,
        };
        self.firmware.set_ignore_motion(false);
        if self.firmware.v3.reset_requested {
            // 0x76: no reply; the firmware restarts now and the motor is deaf until it has.
            self.firmware.power_up(&self.plant);
            self.rebooting_until = Some(at + self.config.firmware.v3.reboot_time);
            self.last_heard = None;
            self.tripped_at = None;
            self.first_after_trip = None;
            self.stats.requests += 1;
            self.note_safety(at);
            return None;
        }
        self.note_safety(at);
        let Some(reply) = reply else {
            self.stats.invalid_requests += 1;
            return None;
        };
        self.stats.requests += 1;
        if ignore {
            self.trap_stats.ignored_motion += 1;
        }
        if request.is_run() {
            self.run_at = Some(at);
        }
        self.last_reply = Some(reply);
        if request
            .command_byte()
            .is_some_and(|code| traps.unanswered.contains(code))
        {
            self.trap_stats.unanswered += 1;
            return None;
        }
        Some(reply)
    }

    /// A power cycle at `at` (RAM lost, ROM kept; the physical state is unchanged).
    pub(crate) fn power_cycle(&mut self, at: Timestamp, faults: &FaultEngine) {
        self.advance_to(at, faults);
        self.firmware.power_up(&self.plant);
        self.note_safety(at);
    }

    /// The time from receiving a request to its reply being ready: the turnaround plus a
    /// uniform jitter drawn from this motor's stream.
    pub(crate) fn turnaround(&mut self) -> Duration {
        let jitter = self
            .config
            .turnaround_jitter
            .as_nanos()
            .min(u128::from(u64::MAX)) as u64;
        let extra = match jitter.checked_add(1) {
            _ if jitter == 0 => 0,
            Some(range) => self.jitter.next_u64() % range,
            None => self.jitter.next_u64(),
        };
        self.config
            .turnaround
            .saturating_add(Duration::from_nanos(extra))
    }
}
