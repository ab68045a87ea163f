//! The file form of a robot description, as written (serde, builders): [`RobotConfig`] and its
//! parts.

use core::time::Duration;
use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use crate::schedule::OverrunPolicy;

/// When the loop takes a reply as this tick's feedback.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ReplyMode {
    /// Replies to this tick's 0x280 frame must arrive before the reply deadline of the same tick.
    #[default]
    SameTick,
    /// For motors whose turnaround exceeds the reply window: the reply to the previous tick's
    /// frame is accepted as feedback (age 1 tick, reported to the controller) and is not missing.
    Pipelined,
}

/// Loop settings, as written (`[loop]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LoopConfig {
    /// Tick rate in Hz.
    pub rate_hz: f64,
    /// CPU to pin the loop thread to.
    pub cpu: Option<usize>,
    /// `SCHED_FIFO` priority (1..=99); none runs under the normal scheduler.
    pub fifo_priority: Option<u8>,
    /// Lock the process's memory (`mlockall`) when the loop starts.
    pub lock_memory: bool,
    /// Busy-wait this long before each deadline for a precise wake (0: sleep only).
    pub spin_margin_us: u64,
    /// The CPU wake-up latency the loop holds (`/dev/cpu_dma_latency`) while it runs: a number
    /// of microseconds, `"off"`, or `"auto"` (the default: 0 when `cpu` or `fifo_priority` is
    /// set, off otherwise).
    pub cpu_dma_latency_us: CpuLatencySetting,
    /// Replies are collected until this long after the tick's scheduled start; the rest of the
    /// period is left for the controller. Default: the period minus 10% (at least 50 us).
    pub reply_deadline_us: Option<u64>,
    /// Same-tick or pipelined replies.
    pub reply_mode: ReplyMode,
    /// What to do when a tick overruns the next tick's start.
    pub overrun: OverrunPolicy,
    /// Consecutive ticks without fresh feedback from one motor that make a fault.
    pub missing_reply_fault_after: u32,
    /// Start-up probe exchanges (zero torque, each waiting up to max(4 periods, 20 ms)) allowed
    /// for every motor to answer once before the loop gives up.
    pub startup_probes: u32,
    /// Capacity of the telemetry queue, in ticks.
    pub telemetry_capacity: usize,
    /// Accept a period shorter than the worst-case exchange on a bus (benchmarks only: the loop
    /// then relies on frames being shorter than the worst case).
    pub allow_over_budget: bool,
    /// A tick that does not complete within this long (the controller or the bus I/O hangs) is
    /// ended by the supervisor, which makes the motors safe itself. Default: ten periods, at
    /// least 50 ms.
    pub stall_bound_ms: Option<u64>,
    /// What the loop does with a command it cannot send as given (not a finite number, a torque
    /// without a torque constant, an unknown joint): `"fault"` (the default) or `"zero"`.
    pub rejected_command: RejectedCommandPolicy,
    /// Read every motor's health (supply voltage, temperature, error flags: status 1, 0x9A) in
    /// rotation, one status request per bus per tick after the torque requests, so each
    /// motor's is at most as many ticks old as its bus has motors. An error flag stops the loop
    /// ([`Fault::MotorError`](crate::Fault::MotorError)). On by default; a bus whose wire budget
    /// has no room for the extra request and reply at the loop's rate runs without it.
    pub health_rotation: bool,
}

impl Default for LoopConfig {
    fn default() -> Self {
        Self {
            rate_hz: 1000.0,
            cpu: None,
            fifo_priority: None,
            lock_memory: false,
            spin_margin_us: 0,
            cpu_dma_latency_us: CpuLatencySetting::Auto,
            reply_deadline_us: None,
            reply_mode: ReplyMode::SameTick,
            overrun: OverrunPolicy::Skip,
            missing_reply_fault_after: 20,
            startup_probes: 5,
            telemetry_capacity: 4096,
            allow_over_budget: false,
            stall_bound_ms: None,
            rejected_command: RejectedCommandPolicy::Fault,
            health_rotation: true,
        }
    }
}

/// `cpu_dma_latency_us` as written: a number of microseconds, `"off"`, or `"auto"`.
///
/// ```
/// use rmd_loop::robot::{CpuLatencySetting, RobotConfig};
/// let on = RobotConfig::from_toml("[loop]\ncpu_dma_latency_us = 10")?;
/// assert_eq!(on.loop_config.cpu_dma_latency_us, CpuLatencySetting::Us(10));
/// let off = RobotConfig::from_toml("[loop]\ncpu_dma_latency_us = \"off\"")?;
/// assert_eq!(off.loop_config.cpu_dma_latency_us, CpuLatencySetting::Off);
/// assert!(RobotConfig::from_toml("[loop]\ncpu_dma_latency_us = -1").is_err());
/// # Ok::<(), rmd_loop::robot::RobotError>(())
/// ```
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub enum CpuLatencySetting {
    /// 0 us when the loop is pinned (`cpu`) or real-time (`fifo_priority`), off otherwise.
    #[default]
    Auto,
    /// Leave the CPUs' idle states alone.
    Off,
    /// Hold this many microseconds.
    Us(u32),
}

impl Serialize for CpuLatencySetting {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            CpuLatencySetting::Auto => s.serialize_str("auto"),
            CpuLatencySetting::Off => s.serialize_str("off"),
            CpuLatencySetting::Us(us) => s.serialize_u32(*us),
        }
    }
}

impl<'de> Deserialize<'de> for CpuLatencySetting {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Visitor;
        impl serde::de::Visitor<'_> for Visitor {
            type Value = CpuLatencySetting;
            fn expecting(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
                f.write_str("a whole number of microseconds (0 or more), \"off\" or \"auto\"")
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<Self::Value, E> {
                u32::try_from(v)
                    .map(CpuLatencySetting::Us)
                    .map_err(|_| E::invalid_value(serde::de::Unexpected::Signed(v), &self))
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<Self::Value, E> {
                u32::try_from(v)
                    .map(CpuLatencySetting::Us)
                    .map_err(|_| E::invalid_value(serde::de::Unexpected::Unsigned(v), &self))
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<Self::Value, E> {
                match v {
                    "off" => Ok(CpuLatencySetting::Off),
                    "auto" => Ok(CpuLatencySetting::Auto),
                    other => Err(E::invalid_value(serde::de::Unexpected::Str(other), &self)),
                }
            }
        }
        d.deserialize_any(Visitor)
    }
}

/// What the loop does when a controller writes a command it cannot send as given.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RejectedCommandPolicy {
    /// Stop the run with a fault (motors made safe), naming the joint and the reason.
    #[default]
    Fault,
    /// Send zero torque to that joint for this tick, count it per joint, and go on.
    Zero,
}

/// How the loop exchanges torque with the motors of a bus every tick.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ExchangeKind {
    /// One 0x280 frame carrying the torque of motors 1..=4, answered by each with 0xA1, and one
    /// 0xA1 request for each motor of a higher id (v1.61 and LK-TECH only: on a MyActuator V3
    /// bus 0x280 is one command for every motor).
    MultiTorque,
    /// One 0xA1 torque request per motor (`0x140 + id`, any id 1..=32), each in its motor's
    /// own family and scale, answered on the motor's reply id; every family.
    PerMotor,
    /// One motion-mode command per motor (`0x400 + id`: position, velocity, kp, kd and
    /// feed-forward torque, the law executed in the motor), answered on `0x500 + id`; MyActuator
    /// V3 only. A joint without a motion command this tick gets its current as feed-forward
    /// torque with zero gains.
    Motion,
}

impl ExchangeKind {
    /// The stable name, `multi-torque`, `per-motor` or `motion`.
    pub fn name(self) -> &'static str {
        match self {
            ExchangeKind::MultiTorque => "multi-torque",
            ExchangeKind::PerMotor => "per-motor",
            ExchangeKind::Motion => "motion",
        }
    }

    /// Whether each motor gets a request of its own (every kind but `multi-torque`).
    pub fn is_per_motor(self) -> bool {
        match self {
            ExchangeKind::MultiTorque => false,
            ExchangeKind::PerMotor | ExchangeKind::Motion => true,
        }
    }
}

impl core::fmt::Display for ExchangeKind {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.name())
    }
}

/// How a joint is mounted on its motor: which way it turns relative to the motor (the robot
/// file's `direction = "normal"` or `"reversed"`).
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Mounting {
    /// Joint angle grows with the motor angle.
    #[default]
    Normal,
    /// Joint angle grows when the motor angle shrinks.
    Reversed,
}

impl Mounting {
    /// +1.0 or -1.0.
    pub fn sign(self) -> f64 {
        match self {
            Mounting::Normal => 1.0,
            Mounting::Reversed => -1.0,
        }
    }
}

/// One motor and the joint it drives, as written (`[[bus.motor]]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MotorConfig {
    /// Motor id, 1..=32 (on a `multi-torque` bus the 0x280 frame drives ids 1..=4, and each
    /// higher id gets an 0xA1 request of its own).
    pub id: u8,
    /// The joint's name (e.g. "knee"): how controllers, reports and telemetry address it.
    /// Default: `bus<b>_motor<id>`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// A known motor model (e.g. `"rmd-x8-v2"`, `"mg4005e-i10"`; `rmd_protocol::models`): its
    /// protocol, current scales, gear ratio, torque constant and encoder width, each taken unless
    /// given here.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model: Option<String>,
    /// The motor's protocol: `"v1.61"` (the default), `"lk-v2.3x"` (then `lk_series`) or
    /// `"myactuator-v3"` (on a `per-motor` bus); overrides the bus's and the model's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub protocol: Option<String>,
    /// The LK-TECH motor series (`"mf"`, `"mg"`), whose current scale differs, for
    /// `protocol = "lk-v2.3x"`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lk_series: Option<String>,
    /// Encoder resolution in bits (12..=18; default: the model's, else 14).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub encoder_bits: Option<u8>,
    /// Motor turns per joint turn (e.g. 6.0 for a 1:6 gearbox; default: the model's, else 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gear_ratio: Option<f64>,
    /// Joint direction relative to the motor.
    #[serde(default)]
    pub direction: Mounting,
    /// Joint angle (degrees) subtracted after scaling: joint = dir * motor / gear - offset.
    #[serde(default)]
    pub zero_offset_deg: f64,
    /// Torque current limit in amperes applied to every command (0 < limit <= 32). The 0x280
    /// frame bypasses the motor's own "Max Torque Current" setting (spec, 0xA1 memo 1), so this
    /// is the only limit on the torque the loop commands.
    #[serde(default = "default_current_limit")]
    pub current_limit_amps: f64,
    /// Joint-side torque per ampere of torque current (N*m/A), for commands and feedback in N*m
    /// (default: the model's, if it has one).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub torque_constant_nm_per_amp: Option<f64>,
    /// A reported temperature at or above this is a fault (degrees Celsius).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub temperature_limit_celsius: Option<f64>,
    /// The joint's lowest angle, degrees (joint side, as the controller reads it). Past it the
    /// loop refuses torque that pushes the joint further down (zero torque that way, counted);
    /// further than `limit_margin_deg` past it is a fault. Default: none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position_min_deg: Option<f64>,
    /// The joint's highest angle, degrees; as `position_min_deg`, upwards.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position_max_deg: Option<f64>,
    /// The joint's fastest velocity either way, deg/s. Faster, the loop refuses torque that
    /// speeds the joint up further (braking torque passes); faster than this plus
    /// `velocity_margin_dps` is a fault. Default: none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub velocity_limit_dps: Option<f64>,
    /// How far past a position limit the joint may be carried (by its momentum, a load, a
    /// push) before the loop stops with a fault, degrees. Default 5.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub limit_margin_deg: Option<f64>,
    /// How far above `velocity_limit_dps` the joint may go before the loop stops with a fault,
    /// deg/s. Default: half the velocity limit.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub velocity_margin_dps: Option<f64>,
    /// A holding brake is fitted (MyActuator V3 only): the safe stop locks it (0x78) after
    /// motor-off. Default false.
    #[serde(default, skip_serializing_if = "core::ops::Not::not")]
    pub brake: bool,
    /// The communication watchdog kept in the motor's ROM (MyActuator V3 only, 0xB3),
    /// milliseconds; 0: off. With no frame for this long the motor turns its output off and
    /// locks its brake, even when the host has died. The firmware cannot report it: `rmd
    /// watchdog --robot FILE` writes it (asking first), and the loop's report calls the motor
    /// protected as described. Default: not described (unprotected).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub watchdog_ms: Option<u32>,
}

fn default_current_limit() -> f64 {
    5.0
}

impl MotorConfig {
    /// A motor with default settings (14-bit encoder, no gearbox, 5 A limit, v1.61).
    pub fn new(id: u8) -> Self {
        Self {
            id,
            name: None,
            model: None,
            protocol: None,
            lk_series: None,
            encoder_bits: None,
            gear_ratio: None,
            direction: Mounting::Normal,
            zero_offset_deg: 0.0,
            current_limit_amps: default_current_limit(),
            torque_constant_nm_per_amp: None,
            temperature_limit_celsius: None,
            position_min_deg: None,
            position_max_deg: None,
            velocity_limit_dps: None,
            limit_margin_deg: None,
            velocity_margin_dps: None,
            brake: false,
            watchdog_ms: None,
        }
    }

    /// Sets the joint's name.
    pub fn name(mut self, name: &str) -> Self {
        self.name = Some(name.to_string());
        self
    }
    /// Sets the motor model (see `rmd_protocol::models`).
    pub fn model(mut self, model: &str) -> Self {
        self.model = Some(model.to_string());
        self
    }
    /// Sets the protocol (`"v1.61"`, `"lk-v2.3x"`) and, for LK-TECH, the series (`"mf"`, `"mg"`).
    pub fn protocol(mut self, protocol: &str, lk_series: Option<&str>) -> Self {
        self.protocol = Some(protocol.to_string());
        self.lk_series = lk_series.map(str::to_string);
        self
    }
    /// Says a holding brake is fitted (MyActuator V3).
    pub fn brake(mut self, fitted: bool) -> Self {
        self.brake = fitted;
        self
    }
    /// Describes the communication watchdog in the motor's ROM, milliseconds (MyActuator V3;
    /// 0: off).
    pub fn watchdog_ms(mut self, millis: u32) -> Self {
        self.watchdog_ms = Some(millis);
        self
    }
    /// Sets the encoder resolution.
    pub fn encoder_bits(mut self, bits: u8) -> Self {
        self.encoder_bits = Some(bits);
        self
    }
    /// Sets the gear ratio.
    pub fn gear_ratio(mut self, ratio: f64) -> Self {
        self.gear_ratio = Some(ratio);
        self
    }
    /// Sets the direction.
    pub fn direction(mut self, direction: Mounting) -> Self {
        self.direction = direction;
        self
    }
    /// Sets the zero offset (joint degrees).
    pub fn zero_offset_deg(mut self, deg: f64) -> Self {
        self.zero_offset_deg = deg;
        self
    }
    /// Sets the current limit (amperes).
    pub fn current_limit(mut self, amps: f64) -> Self {
        self.current_limit_amps = amps;
        self
    }
    /// Sets the joint-side torque constant (N*m/A).
    pub fn torque_constant(mut self, nm_per_amp: f64) -> Self {
        self.torque_constant_nm_per_amp = Some(nm_per_amp);
        self
    }
    /// Sets the temperature fault limit.
    pub fn temperature_limit(mut self, celsius: f64) -> Self {
        self.temperature_limit_celsius = Some(celsius);
        self
    }
    /// Sets the joint's position limits (joint degrees).
    pub fn position_limits(mut self, min_deg: f64, max_deg: f64) -> Self {
        self.position_min_deg = Some(min_deg);
        self.position_max_deg = Some(max_deg);
        self
    }
    /// Sets the joint's velocity limit (deg/s, either way).
    pub fn velocity_limit(mut self, dps: f64) -> Self {
        self.velocity_limit_dps = Some(dps);
        self
    }
    /// Sets how far past its position limits (degrees) the joint may go before it is a fault.
    pub fn limit_margin(mut self, deg: f64) -> Self {
        self.limit_margin_deg = Some(deg);
        self
    }
    /// Sets how far above its velocity limit (deg/s) the joint may go before it is a fault.
    pub fn velocity_margin(mut self, dps: f64) -> Self {
        self.velocity_margin_dps = Some(dps);
        self
    }
}

/// One CAN bus and the motors on it, as written (`[[bus]]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BusConfig {
    /// A name for reports and for `--iface NAME=IFACE` (default: `bus<b>`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// SocketCAN interface (e.g. "can0"), or "sim" for simulated motors.
    pub interface: String,
    /// Bit rate in bit/s.
    #[serde(default = "default_bitrate")]
    pub bitrate: u32,
    /// Expected motor turnaround (request received to reply queued), microseconds, for the
    /// exchange budget.
    #[serde(default = "default_turnaround")]
    pub turnaround_us: u64,
    /// How torque is exchanged every tick (`"multi-torque"`, `"per-motor"`). Default:
    /// `per-motor` when a motor of the bus speaks MyActuator V3 (which refuses
    /// `multi-torque`), else `multi-torque`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exchange: Option<ExchangeKind>,
    /// The protocol of the bus's motors unless a motor says otherwise (`"v1.61"`, `"lk-v2.3x"`,
    /// `"myactuator-v3"`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub protocol: Option<String>,
    /// The LK-TECH series of the bus's motors unless a motor says otherwise (`"mf"`, `"mg"`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lk_series: Option<String>,
    /// Ids among 1..=4 of motors on this bus that the description does not drive but that may
    /// answer: the loop's 0x280 frame commands them zero torque every tick, and they are made
    /// safe at the end. Without this, an undescribed motor that answers at start-up stops the
    /// start before any torque is sent.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub zero_torque_ids: Vec<u8>,
    /// The motors.
    #[serde(default, rename = "motor")]
    pub motors: Vec<MotorConfig>,
}

fn default_bitrate() -> u32 {
    1_000_000
}
fn default_turnaround() -> u64 {
    200
}

impl BusConfig {
    /// A bus on `interface` at 1 Mbit/s with no motors yet.
    pub fn new(interface: &str) -> Self {
        Self {
            name: None,
            interface: interface.to_string(),
            bitrate: default_bitrate(),
            turnaround_us: default_turnaround(),
            exchange: None,
            protocol: None,
            lk_series: None,
            zero_torque_ids: Vec::new(),
            motors: Vec::new(),
        }
    }
    /// Sets the bus's name.
    pub fn name(mut self, name: &str) -> Self {
        self.name = Some(name.to_string());
        self
    }
    /// Adds a motor.
    pub fn with_motor(mut self, motor: MotorConfig) -> Self {
        self.motors.push(motor);
        self
    }
    /// Sets the exchange kind.
    pub fn exchange(mut self, kind: ExchangeKind) -> Self {
        self.exchange = Some(kind);
        self
    }
    /// Sets the protocol of the bus's motors (`"v1.61"`, `"myactuator-v3"`, ...).
    pub fn protocol(mut self, protocol: &str) -> Self {
        self.protocol = Some(protocol.to_string());
        self
    }
    /// Sets the bit rate.
    pub fn bitrate(mut self, bitrate: u32) -> Self {
        self.bitrate = bitrate;
        self
    }
    /// Sets the expected turnaround.
    pub fn turnaround(mut self, turnaround: Duration) -> Self {
        self.turnaround_us = turnaround.as_micros() as u64;
        self
    }
}

/// How the safe stop at the end of a run behaves, as written (`[safe_stop]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SafeStopConfig {
    /// How long the safe stop keeps trying, per bus, to get zero torque and motor-off through
    /// (a full or stalled transmit queue, unconfirmed motors), milliseconds.
    pub deadline_ms: u64,
    /// How long a bus that is bus-off may take to restart before the safe stop gives up on it,
    /// milliseconds (the CAN controller restarts by itself only with `restart-ms` set).
    pub bus_off_wait_ms: u64,
    /// How often motor-off is sent again to a motor that has not confirmed it, milliseconds.
    pub retry_ms: u64,
}

impl Default for SafeStopConfig {
    fn default() -> Self {
        Self {
            deadline_ms: 2000,
            bus_off_wait_ms: 1000,
            retry_ms: 20,
        }
    }
}

/// A whole robot as written: the loop settings and its buses. The file form of a robot
/// description: what a TOML file (or a builder in code) says, before it is checked.
/// [`Robot::try_from`](crate::robot::Robot) turns it, once, into a validated
/// [`Robot`](crate::robot::Robot); nothing else reads the file form.
///
/// ```toml
/// [loop]
/// rate_hz = 1000.0
/// cpu = 1
/// fifo_priority = 80
/// spin_margin_us = 50
/// cpu_dma_latency_us = 0   # the default with cpu or fifo_priority; "off" to leave it alone
///
/// [[bus]]
/// name = "leg"
/// interface = "can0"     # a SocketCAN interface, or "sim" for simulated motors
/// bitrate = 1000000
///
/// [[bus.motor]]
/// id = 1
/// name = "hip"
/// gear_ratio = 6.0
/// current_limit_amps = 8.0
/// torque_constant_nm_per_amp = 0.52
/// position_min_deg = -30.0   # joint limits: torque past them is refused, 5 degrees further a fault
/// position_max_deg = 120.0
/// velocity_limit_dps = 360.0
/// ```
///
/// The same in code:
///
/// ```
/// use rmd_loop::robot::{BusConfig, MotorConfig, Robot, RobotConfig};
/// let file = RobotConfig::new(1000.0).with_bus(
///     BusConfig::new("can0").with_motor(MotorConfig::new(1).name("hip").gear_ratio(6.0).current_limit(8.0)),
/// );
/// let robot = Robot::try_from(file)?;
/// assert_eq!(robot.joint("hip")?.index(), 0);
/// # Ok::<(), rmd_loop::robot::RobotError>(())
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotConfig {
    /// Loop settings.
    #[serde(default, rename = "loop")]
    pub loop_config: LoopConfig,
    /// The safe stop's patience.
    #[serde(default)]
    pub safe_stop: SafeStopConfig,
    /// Buses, in order; joints are numbered bus by bus in this order.
    #[serde(default, rename = "bus")]
    pub buses: Vec<BusConfig>,
    /// The file the description was read from ([`read_config`](crate::robot::read_config)),
    /// named in its errors; not part of the description itself.
    #[serde(skip)]
    pub source: Option<PathBuf>,
}

impl RobotConfig {
    /// An empty robot running at `rate_hz`.
    pub fn new(rate_hz: f64) -> Self {
        Self {
            loop_config: LoopConfig {
                rate_hz,
                ..LoopConfig::default()
            },
            safe_stop: SafeStopConfig::default(),
            buses: Vec::new(),
            source: None,
        }
    }

    /// Adds a bus.
    pub fn with_bus(mut self, bus: BusConfig) -> Self {
        self.buses.push(bus);
        self
    }

    /// Parses TOML text (syntax and types only; [`Robot::try_from`](crate::robot::Robot)
    /// checks the values).
    pub fn from_toml(text: &str) -> Result<Self, super::RobotError> {
        toml::from_str(text).map_err(|e| super::error::parse_error(e.to_string()))
    }

    /// The description as TOML.
    pub fn to_toml(&self) -> String {
        // Serialising plain structs of numbers and strings cannot fail.
        toml::to_string_pretty(self).unwrap_or_default()
    }
}
