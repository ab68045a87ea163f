//! The robot description: its buses, its joints (one motor each) and the loop settings.
//!
//! A description is written as TOML (or built in code) in its [file form](mod@file), then
//! converted once, with [`Robot::try_from`] or [`Robot::from_file`], into a [`Robot`] whose
//! every value is checked and typed: motor ids are [`MotorId`]s (1..=32), encoder
//! widths are [`EncoderWidth`]s, the rate is a [`Period`], the reply deadline a [`Duration`].
//! Errors name the key. Nothing downstream validates again.
//!
//! ```
//! use rmd_loop::robot::Robot;
//!
//! let robot = Robot::from_toml(r#"
//!     [loop]
//!     rate_hz = 500.0
//!
//!     [[bus]]
//!     interface = "can0"
//!
//!     [[bus.motor]]
//!     id = 1
//!     name = "hip"
//!     gear_ratio = 6.0
//! "#)?;
//! let hip = robot.joint("hip")?;
//! assert_eq!(robot.spec(hip).motor.get(), 1);
//! assert_eq!(robot.settings().period.get().as_millis(), 2);
//! assert!(Robot::from_toml("[[bus]]\ninterface = \"can0\"\n[[bus.motor]]\nid = 33").is_err());
//! # Ok::<(), rmd_loop::robot::RobotError>(())
//! ```

mod error;
pub mod file;
mod limits;

use core::num::{NonZeroU32, NonZeroUsize};
use core::ops::Range;
use core::time::Duration;
use std::path::Path;

use rmd_bus::wire;
use rmd_protocol::{
    CurrentScale, Dialect, EncoderWidth, MODELS, MULTI_TORQUE_MOTORS, MotorId, MotorModel,
    WatchdogTimeout, find_model,
};

pub use error::RobotError;
use error::{Shown, invalid};
pub use file::{
    BusConfig, CpuLatencySetting, Direction, ExchangeKind, LoopConfig, MotorConfig,
    RejectedCommandPolicy, ReplyMode, RobotConfig, SafeStopConfig,
};
pub use limits::{
    DEFAULT_LIMIT_MARGIN_DEG, JointLimits, MAX_LIMIT_DEG, MAX_LIMIT_MARGIN_DEG,
    MAX_VELOCITY_LIMIT_DPS,
};

use crate::joint::JointId;
use crate::schedule::{OverrunPolicy, Period};

/// Most buses one loop drives.
pub const MAX_BUSES: usize = 8;
/// The motor ids one 0x280 frame drives (1..=4): a `multi-torque` bus drives higher ids with
/// 0xA1 requests of their own.
pub const MAX_MOTORS_PER_BUS: usize = MULTI_TORQUE_MOTORS;
/// Most joints one loop drives (whatever their buses).
pub const MAX_JOINTS: usize = 32;
/// The highest motor id of a `per-motor` bus (the protocol's ids are 1..=32).
pub const MAX_PER_MOTOR_ID: u8 = 32;
/// Largest torque current a v1.61 0x280 command can carry (iqControl 2000 = 32 A; other
/// dialects: their own range).
pub const MAX_COMMAND_AMPS: f64 = 32.0;

/// The physically meaningful range of `gear_ratio` (motor turns per joint turn): from a 1:100
/// step-up to a 1000:1 reduction.
pub const GEAR_RATIO_RANGE: core::ops::RangeInclusive<f64> = 0.01..=1000.0;
/// The largest `zero_offset_deg`, either way: ten turns of the joint.
pub const MAX_ZERO_OFFSET_DEG: f64 = 3600.0;
/// The physically meaningful range of `torque_constant_nm_per_amp` (joint side, N*m/A).
pub const TORQUE_CONSTANT_RANGE: core::ops::RangeInclusive<f64> = 1e-4..=1000.0;
/// The longest `turnaround_us` of a bus (a motor that takes longer is not answering).
pub const MAX_TURNAROUND: Duration = Duration::from_millis(100);
/// The longest `loop.stall_bound_ms`.
pub const MAX_STALL_BOUND: Duration = Duration::from_secs(60);
/// The most `loop.startup_probes`.
pub const MAX_STARTUP_PROBES: u32 = 1000;
/// The largest `loop.telemetry_capacity`, in ticks (allocated up front).
pub const MAX_TELEMETRY_CAPACITY: usize = 65_536;
/// The CPUs `loop.cpu` may name (`0..MAX_CPUS`, the kernel's `CPU_SETSIZE`).
pub const MAX_CPUS: usize = 1024;

/// A `SCHED_FIFO` priority, 1..=99.
#[derive(Copy, Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct FifoPriority(u8);

impl FifoPriority {
    /// `priority` if it is in 1..=99.
    pub fn new(priority: u8) -> Option<Self> {
        (1..=99).contains(&priority).then_some(Self(priority))
    }

    /// The priority.
    pub fn get(self) -> u8 {
        self.0
    }
}

/// What the loop thread asks of the operating system.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct RealtimeSettings {
    /// Pin the loop thread to this CPU.
    pub cpu: Option<usize>,
    /// Run it under `SCHED_FIFO` at this priority.
    pub fifo_priority: Option<FifoPriority>,
    /// Lock the process's memory when the loop starts.
    pub lock_memory: bool,
    /// Hold this CPU wake-up latency (`/dev/cpu_dma_latency`) while the loop runs; `None`:
    /// leave the idle states alone. At most [`MAX_CPU_LATENCY`](crate::os::MAX_CPU_LATENCY).
    pub cpu_dma_latency: Option<Duration>,
}

/// The loop settings, checked.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct LoopSettings {
    /// The tick period.
    pub period: Period,
    /// Replies are collected until this long after a tick's scheduled start (within the period).
    pub reply_deadline: Duration,
    /// Same-tick or pipelined replies.
    pub reply_mode: ReplyMode,
    /// What to do when a tick overruns the next tick's start.
    pub overrun: OverrunPolicy,
    /// Busy-wait this long before each deadline (shorter than the period).
    pub spin_margin: Duration,
    /// CPU, priority, memory locking.
    pub realtime: RealtimeSettings,
    /// Consecutive ticks without fresh feedback from one motor that make a fault.
    pub missing_reply_fault_after: NonZeroU32,
    /// Start-up probe exchanges allowed for every motor to answer once.
    pub startup_probes: NonZeroU32,
    /// Capacity of the telemetry queue, in ticks.
    pub telemetry_capacity: NonZeroUsize,
    /// A period shorter than the worst-case exchange was accepted (benchmarks only).
    pub allow_over_budget: bool,
    /// What to do with a command that cannot be sent as given.
    pub rejected_command: RejectedCommandPolicy,
    /// A tick not complete after this long is ended by the supervisor (more than a period;
    /// default ten periods, at least 50 ms).
    pub stall_bound: Duration,
    /// Motor health in rotation was asked for (`loop.health_rotation`); each bus's
    /// [`BusSpec::health_rotation`] says whether it has room for it.
    pub health_rotation: bool,
}

/// The safe stop's patience, checked.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct SafeStopSettings {
    /// How long the safe stop keeps trying on each bus.
    pub deadline: Duration,
    /// How long a bus-off bus may take to restart (at most the deadline).
    pub bus_off_wait: Duration,
    /// How often motor-off is sent again to a motor that has not confirmed it.
    pub retry_every: Duration,
}

impl Default for SafeStopSettings {
    fn default() -> Self {
        let c = SafeStopConfig::default();
        Self {
            deadline: Duration::from_millis(c.deadline_ms),
            bus_off_wait: Duration::from_millis(c.bus_off_wait_ms),
            retry_every: Duration::from_millis(c.retry_ms),
        }
    }
}

/// Where a bus's motors are.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum Interface {
    /// A SocketCAN interface, by name (e.g. `can0`).
    SocketCan(String),
    /// Simulated motors matching the description (`interface = "sim"`).
    Simulator,
}

impl Interface {
    /// `"sim"` is the simulator; anything else names a SocketCAN interface.
    pub fn parse(name: &str) -> Option<Self> {
        let name = name.trim();
        match name {
            "" => None,
            "sim" => Some(Interface::Simulator),
            _ => Some(Interface::SocketCan(name.to_string())),
        }
    }
}

impl core::fmt::Display for Interface {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Interface::SocketCan(name) => f.write_str(name),
            Interface::Simulator => f.write_str("sim"),
        }
    }
}

/// One bus, checked.
#[derive(Clone, Debug, PartialEq)]
pub struct BusSpec {
    /// Its name (from the description, or `bus<b>`).
    pub name: String,
    /// Where its motors are.
    pub interface: Interface,
    /// Bit rate, bit/s (10 000..=1 000 000).
    pub bitrate: u32,
    /// Expected motor turnaround, for the exchange budget.
    pub turnaround: Duration,
    /// How torque is exchanged with its motors every tick.
    pub exchange: ExchangeKind,
    /// Motors the description does not drive but acknowledges (`zero_torque_ids`): commanded
    /// zero torque every tick, made safe at the end.
    pub zero_torque_ids: Vec<MotorId>,
    /// Whether each tick also sends one status request (0x9A) to one of its motors in turn
    /// (`loop.health_rotation`, when the wire budget has room for it at the loop's rate:
    /// [`health_budget`](Self::health_budget) within the reply window).
    pub health_rotation: bool,
    joints: Range<usize>,
    /// On a `multi-torque` bus, its motors beyond the 0x280 frame's ids 1..=4 (each driven by
    /// an 0xA1 request of its own).
    beyond_frame: u32,
}

impl BusSpec {
    /// The joints on this bus (consecutive in description order).
    pub fn joints(&self) -> impl Iterator<Item = JointId> + Clone + use<> {
        self.joints.clone().map(JointId::from_index)
    }

    /// The joints on this bus as indices.
    pub fn joint_range(&self) -> Range<usize> {
        self.joints.clone()
    }

    /// Number of motors on the bus.
    pub fn motor_count(&self) -> usize {
        self.joints.len()
    }

    /// The request frames of one exchange: one 0x280 frame (`multi-torque`) and one per motor
    /// beyond its ids 1..=4, or one per motor.
    pub fn requests_per_exchange(&self) -> u32 {
        match self.exchange {
            ExchangeKind::MultiTorque => 1 + self.beyond_frame,
            // A motion-mode command is an 8-byte standard frame, as an 0xA1 request is.
            ExchangeKind::PerMotor | ExchangeKind::Motion => self.joints.len() as u32,
        }
    }

    /// Worst-case duration of one exchange on this bus (every request, every reply:
    /// [`wire::exchange_budget_of`]).
    pub fn exchange_budget(&self) -> Duration {
        wire::exchange_budget_of(
            self.requests_per_exchange(),
            self.joints.len() as u32,
            self.bitrate,
            self.turnaround,
        )
    }

    /// Worst-case duration of one exchange with the status request of the health rotation:
    /// one request and one reply more than [`exchange_budget`](Self::exchange_budget).
    pub fn health_budget(&self) -> Duration {
        wire::exchange_budget_of(
            self.requests_per_exchange() + 1,
            self.joints.len() as u32 + 1,
            self.bitrate,
            self.turnaround,
        )
    }
}

/// A torque current limit: amperes, and the raw command it allows in the joint's dialect.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct CurrentLimit {
    amps: f64,
    raw: i16,
}

impl CurrentLimit {
    /// The limit in amperes (above 0, at most the dialect's command range).
    pub fn amps(self) -> f64 {
        self.amps
    }

    /// The largest raw command magnitude it allows (rounded towards zero).
    pub fn raw(self) -> i16 {
        self.raw
    }
}

/// One joint and its motor, checked.
#[derive(Clone, Debug, PartialEq)]
pub struct JointSpec {
    /// The joint's name (unique in the robot).
    pub name: String,
    /// The bus it is on (index in description order).
    pub bus: usize,
    /// Its motor's id (1..=4 on a `multi-torque` bus, 1..=32 on a `per-motor` one).
    pub motor: MotorId,
    /// The protocol dialect its firmware speaks (the current scales of its commands and replies).
    pub dialect: Dialect,
    /// Its model, when the description names one.
    pub model: Option<&'static str>,
    /// The motor's encoder width.
    pub encoder: EncoderWidth,
    /// Motor turns per joint turn (positive).
    pub gear_ratio: f64,
    /// Joint direction relative to the motor.
    pub direction: Direction,
    /// Joint angle subtracted after scaling, degrees.
    pub zero_offset_deg: f64,
    /// The limit applied to every torque command.
    pub current_limit: CurrentLimit,
    /// Joint-side torque per ampere (N*m/A), if known.
    pub torque_constant_nm_per_amp: Option<f64>,
    /// A reported temperature at or above this is a fault.
    pub temperature_limit_celsius: Option<f64>,
    /// Its position and velocity limits, enforced by the loop below every controller.
    pub limits: JointLimits,
    /// A holding brake is fitted (MyActuator V3): locked by the safe stop.
    pub brake: bool,
    /// The communication watchdog the description says is in the motor's ROM (MyActuator V3;
    /// `None`: not described).
    pub watchdog: Option<WatchdogTimeout>,
}

impl JointSpec {
    /// The motor's slot in its bus's 0x280 frame (id - 1).
    pub fn slot(&self) -> usize {
        usize::from(self.motor.get() - 1)
    }

    /// The scale of its torque commands (0x280 slots, 0xA1).
    pub fn command_scale(&self) -> CurrentScale {
        self.dialect.iq_control_scale()
    }

    /// The scale of the torque current in its replies.
    pub fn reply_scale(&self) -> CurrentScale {
        self.dialect.iq_scale()
    }
}

/// A robot description whose every value was checked: build it with [`Robot::try_from`] (from
/// a [`RobotConfig`]), [`Robot::from_toml`] or [`Robot::from_file`].
#[derive(Clone, Debug, PartialEq)]
pub struct Robot {
    settings: LoopSettings,
    safe_stop: SafeStopSettings,
    buses: Vec<BusSpec>,
    joints: Vec<JointSpec>,
    config: RobotConfig,
}

impl Robot {
    /// Parses and checks a TOML robot description.
    pub fn from_toml(text: &str) -> Result<Self, RobotError> {
        Self::try_from(RobotConfig::from_toml(text)?)
    }

    /// Reads, parses and checks a TOML robot description file.
    pub fn from_file(path: impl AsRef<Path>) -> Result<Self, RobotError> {
        Self::try_from(read_config(path)?)
    }

    /// Why bus `b` runs without the health rotation (`loop.health_rotation` off, or no room on
    /// its wire at the loop's rate), in words; `None` when it runs with it (or has no such bus).
    pub fn health_note(&self, b: usize) -> Option<String> {
        let bus = self.buses.get(b)?;
        if bus.health_rotation {
            return None;
        }
        if !self.settings.health_rotation {
            return Some(format!(
                "not read on bus {b} ({}): loop.health_rotation = false",
                bus.name
            ));
        }
        let window = match self.settings.reply_mode {
            ReplyMode::SameTick => self.settings.reply_deadline,
            ReplyMode::Pipelined => self.settings.period.get(),
        };
        Some(format!(
            "not read on bus {b} ({}): no room on the wire at this rate (its exchange with one \
             status request and reply needs up to {} us, the reply window is {} us); error \
             flags, voltage and status temperature go unseen. Lower loop.rate_hz, put fewer \
             motors on the bus or raise its bit rate to read them",
            bus.name,
            bus.health_budget().as_micros(),
            window.as_micros()
        ))
    }

    /// The loop settings.
    pub fn settings(&self) -> &LoopSettings {
        &self.settings
    }

    /// The safe stop's patience.
    pub fn safe_stop(&self) -> &SafeStopSettings {
        &self.safe_stop
    }

    /// The buses, in description order.
    pub fn buses(&self) -> &[BusSpec] {
        &self.buses
    }

    /// The joints, in description order (bus by bus).
    pub fn joints(&self) -> &[JointSpec] {
        &self.joints
    }

    /// Number of joints (= motors).
    pub fn joint_count(&self) -> usize {
        self.joints.len()
    }

    /// Every joint's id, in description order.
    pub fn joint_ids(&self) -> impl Iterator<Item = JointId> + Clone + use<> {
        (0..self.joints.len()).map(JointId::from_index)
    }

    /// The joint named `name`.
    pub fn joint(&self, name: &str) -> Result<JointId, RobotError> {
        self.joints
            .iter()
            .position(|j| j.name == name)
            .map(JointId::from_index)
            .ok_or_else(|| RobotError::UnknownJoint {
                name: name.to_string(),
                known: self
                    .joints
                    .iter()
                    .map(|j| j.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
            })
    }

    /// The joints named `names`, in that order (e.g. to fill a fixed-size array of handles).
    pub fn joints_named<const N: usize>(
        &self,
        names: [&str; N],
    ) -> Result<[JointId; N], RobotError> {
        let mut ids = [JointId::from_index(0); N];
        for (id, name) in ids.iter_mut().zip(names) {
            *id = self.joint(name)?;
        }
        Ok(ids)
    }

    /// The description of joint `id`.
    ///
    /// # Panics
    /// If `id` belongs to a larger robot.
    pub fn spec(&self, id: JointId) -> &JointSpec {
        &self.joints[id.index()]
    }

    /// The joint driven by motor `motor` on bus `bus`.
    pub fn joint_at(&self, bus: usize, motor: MotorId) -> Option<JointId> {
        let range = self.buses.get(bus)?.joint_range();
        range
            .into_iter()
            .find(|&j| self.joints[j].motor == motor)
            .map(JointId::from_index)
    }

    /// The file form this robot was built from (to change a setting and build again, or to
    /// write it out with [`RobotConfig::to_toml`]).
    pub fn config(&self) -> &RobotConfig {
        &self.config
    }
}

/// Reads and parses (but does not check) a TOML robot description file. The file is
/// remembered ([`RobotConfig::source`]): every error about the description names it, the
/// checks of [`Robot::try_from`] included.
pub fn read_config(path: impl AsRef<Path>) -> Result<RobotConfig, RobotError> {
    let path = path.as_ref();
    let shown = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|source| RobotError::Io {
        path: shown.clone(),
        source,
    })?;
    let mut config = RobotConfig::from_toml(&text).map_err(|e| e.in_file(Some(&shown)))?;
    config.source = Some(path.to_path_buf());
    Ok(config)
}

impl TryFrom<RobotConfig> for Robot {
    type Error = RobotError;

    fn try_from(config: RobotConfig) -> Result<Self, RobotError> {
        let file = config.source.as_ref().map(|p| p.display().to_string());
        Self::check(config).map_err(|e| e.in_file(file.as_deref()))
    }
}

impl Robot {
    fn check(config: RobotConfig) -> Result<Self, RobotError> {
        let settings = loop_settings(&config.loop_config)?;
        let safe_stop = safe_stop_settings(&config.safe_stop)?;
        if config.buses.is_empty() {
            return Err(invalid("bus", "the robot has no bus: add a [[bus]] table"));
        }
        if config.buses.len() > MAX_BUSES {
            return Err(invalid(
                "bus",
                format!(
                    "has {} buses, at most {MAX_BUSES} are supported",
                    config.buses.len()
                ),
            ));
        }
        let mut buses = Vec::with_capacity(config.buses.len());
        let mut joints: Vec<JointSpec> = Vec::new();
        for (b, bus) in config.buses.iter().enumerate() {
            let key = format!("bus[{b}]");
            let spec = bus_spec(b, bus, &key, joints.len())?;
            if let Some(other) = buses.iter().position(|o: &BusSpec| o.name == spec.name) {
                return Err(invalid(
                    format!("{key}.name"),
                    format!("`{}` is also the name of bus[{other}]", spec.name),
                ));
            }
            for (m, motor) in bus.motors.iter().enumerate() {
                let mkey = format!("{key}.motor[{m}]");
                let joint = joint_spec(b, bus, motor, &mkey)?;
                if bus.motors[..m].iter().any(|o| o.id == motor.id) {
                    return Err(invalid(
                        format!("{mkey}.id"),
                        format!("motor id {} appears twice on {key}", motor.id),
                    ));
                }
                if let Some(other) = joints.iter().position(|o| o.name == joint.name) {
                    return Err(invalid(
                        format!("{mkey}.name"),
                        format!(
                            "joint name `{}` is also used by joint {other}: joint names must be unique",
                            joint.name
                        ),
                    ));
                }
                check_watchdog_period(&joint, &settings, &mkey)?;
                joints.push(joint);
            }
            let mut spec = spec;
            spec.exchange = exchange_of(bus, &joints[spec.joint_range()], &key)?;
            spec.beyond_frame = match spec.exchange {
                ExchangeKind::MultiTorque => joints[spec.joint_range()]
                    .iter()
                    .filter(|j| j.slot() >= MAX_MOTORS_PER_BUS)
                    .count() as u32,
                ExchangeKind::PerMotor | ExchangeKind::Motion => 0,
            };
            check_bus_layout(&spec, &key)?;
            if joints.len() > MAX_JOINTS {
                return Err(invalid(
                    format!("{key}.motor"),
                    format!(
                        "brings the robot to {} motors, at most {MAX_JOINTS} are supported",
                        joints.len()
                    ),
                ));
            }
            let explicit_deadline = config.loop_config.reply_deadline_us.is_some();
            check_budget(&spec, &settings, explicit_deadline, &key)?;
            spec.health_rotation = settings.health_rotation && health_fits(&spec, &settings);
            check_motion_temperature(&spec, &joints[spec.joint_range()], &settings, &key)?;
            buses.push(spec);
        }
        Ok(Self {
            settings,
            safe_stop,
            buses,
            joints,
            config,
        })
    }
}

fn loop_settings(l: &LoopConfig) -> Result<LoopSettings, RobotError> {
    let period = Period::from_hz(l.rate_hz).map_err(|e| invalid("loop.rate_hz", e.to_string()))?;
    let p = period.get();
    let fifo_priority =
        match l.fifo_priority {
            None => None,
            Some(prio) => Some(FifoPriority::new(prio).ok_or_else(|| {
                invalid("loop.fifo_priority", format!("is {prio}, must be 1..=99"))
            })?),
        };
    let cpu_dma_latency = match l.cpu_dma_latency_us {
        CpuLatencySetting::Off => None,
        CpuLatencySetting::Auto => {
            (l.cpu.is_some() || fifo_priority.is_some()).then_some(Duration::ZERO)
        }
        CpuLatencySetting::Us(us) => {
            let latency = Duration::from_micros(u64::from(us));
            if latency > crate::os::MAX_CPU_LATENCY {
                return Err(invalid(
                    "loop.cpu_dma_latency_us",
                    format!(
                        "is {us} us, must be at most {} us (or \"off\")",
                        crate::os::MAX_CPU_LATENCY.as_micros()
                    ),
                ));
            }
            Some(latency)
        }
    };
    let spin_margin = Duration::from_micros(l.spin_margin_us);
    if spin_margin >= p {
        return Err(invalid(
            "loop.spin_margin_us",
            format!(
                "is {} us, must be shorter than the period ({} us)",
                l.spin_margin_us,
                p.as_micros()
            ),
        ));
    }
    let reply_deadline = match l.reply_deadline_us {
        Some(us) => Duration::from_micros(us),
        None => default_reply_deadline(p),
    };
    if reply_deadline.is_zero() || reply_deadline > p {
        return Err(invalid(
            "loop.reply_deadline_us",
            format!(
                "is {} us, must be within the period (1..={} us)",
                reply_deadline.as_micros(),
                p.as_micros()
            ),
        ));
    }
    let count = |key: &str, v: u32, max: u32| {
        NonZeroU32::new(v)
            .filter(|n| n.get() <= max)
            .ok_or_else(|| invalid(key, format!("is {v}, must be 1..={max}")))
    };
    if let Some(cpu) = l.cpu
        && cpu >= MAX_CPUS
    {
        return Err(invalid(
            "loop.cpu",
            format!("is {cpu}, must be below {MAX_CPUS} (a CPU number as in /proc/cpuinfo)"),
        ));
    }
    let stall_bound = match l.stall_bound_ms {
        Some(ms) => Duration::from_millis(ms),
        None => (p * 10).max(Duration::from_millis(50)),
    };
    if stall_bound <= p || stall_bound > MAX_STALL_BOUND {
        return Err(invalid(
            "loop.stall_bound_ms",
            format!(
                "is {} ms, must be longer than the period ({} us) and at most {} ms",
                stall_bound.as_millis(),
                p.as_micros(),
                MAX_STALL_BOUND.as_millis()
            ),
        ));
    }
    if let OverrunPolicy::Fault { after: 0 } = l.overrun {
        return Err(invalid("loop.overrun.after", "must be at least 1"));
    }
    Ok(LoopSettings {
        period,
        reply_deadline,
        reply_mode: l.reply_mode,
        overrun: l.overrun,
        spin_margin,
        realtime: RealtimeSettings {
            cpu: l.cpu,
            fifo_priority,
            lock_memory: l.lock_memory,
            cpu_dma_latency,
        },
        // Any number of ticks (u32::MAX: never, for benchmarks).
        missing_reply_fault_after: count(
            "loop.missing_reply_fault_after",
            l.missing_reply_fault_after,
            u32::MAX,
        )?,
        startup_probes: count("loop.startup_probes", l.startup_probes, MAX_STARTUP_PROBES)?,
        telemetry_capacity: NonZeroUsize::new(l.telemetry_capacity)
            .filter(|n| n.get() <= MAX_TELEMETRY_CAPACITY)
            .ok_or_else(|| {
                invalid(
                    "loop.telemetry_capacity",
                    format!(
                        "is {}, must be 1..={MAX_TELEMETRY_CAPACITY} ticks",
                        l.telemetry_capacity
                    ),
                )
            })?,
        allow_over_budget: l.allow_over_budget,
        rejected_command: l.rejected_command,
        stall_bound,
        health_rotation: l.health_rotation,
    })
}

fn safe_stop_settings(c: &SafeStopConfig) -> Result<SafeStopSettings, RobotError> {
    if c.deadline_ms == 0 || c.deadline_ms > 60_000 {
        return Err(invalid(
            "safe_stop.deadline_ms",
            format!("is {}, must be 1..=60000 ms", c.deadline_ms),
        ));
    }
    if c.bus_off_wait_ms > c.deadline_ms {
        return Err(invalid(
            "safe_stop.bus_off_wait_ms",
            format!(
                "is {} ms, must be at most safe_stop.deadline_ms ({} ms)",
                c.bus_off_wait_ms, c.deadline_ms
            ),
        ));
    }
    if c.retry_ms == 0 || c.retry_ms > c.deadline_ms {
        return Err(invalid(
            "safe_stop.retry_ms",
            format!(
                "is {}, must be 1..=safe_stop.deadline_ms ({} ms)",
                c.retry_ms, c.deadline_ms
            ),
        ));
    }
    Ok(SafeStopSettings {
        deadline: Duration::from_millis(c.deadline_ms),
        bus_off_wait: Duration::from_millis(c.bus_off_wait_ms),
        retry_every: Duration::from_millis(c.retry_ms),
    })
}

fn bus_spec(b: usize, bus: &BusConfig, key: &str, first: usize) -> Result<BusSpec, RobotError> {
    let interface = Interface::parse(&bus.interface).ok_or_else(|| {
        invalid(
            format!("{key}.interface"),
            "must not be empty: a SocketCAN interface (e.g. \"can0\") or \"sim\"",
        )
    })?;
    if !(10_000..=1_000_000).contains(&bus.bitrate) {
        return Err(invalid(
            format!("{key}.bitrate"),
            format!(
                "is {}, must be 10000..=1000000 bit/s (classic CAN)",
                bus.bitrate
            ),
        ));
    }
    let turnaround = Duration::from_micros(bus.turnaround_us);
    if turnaround > MAX_TURNAROUND {
        return Err(invalid(
            format!("{key}.turnaround_us"),
            format!(
                "is {} us, must be at most {} us (a motor's time from request to reply)",
                bus.turnaround_us,
                MAX_TURNAROUND.as_micros()
            ),
        ));
    }
    if bus.motors.is_empty() {
        return Err(invalid(
            format!("{key}.motor"),
            "a bus needs at least one motor",
        ));
    }
    let name = match &bus.name {
        Some(name) if name.trim().is_empty() => {
            return Err(invalid(format!("{key}.name"), "must not be empty"));
        }
        Some(name) => name.clone(),
        None => format!("bus{b}"),
    };
    let mut zero_torque_ids = Vec::new();
    for (i, &id) in bus.zero_torque_ids.iter().enumerate() {
        let ikey = format!("{key}.zero_torque_ids[{i}]");
        let motor = MotorId::new(id)
            .ok()
            .filter(|m| usize::from(m.get()) <= MAX_MOTORS_PER_BUS)
            .ok_or_else(|| invalid(&ikey, format!("is {id}, must be 1..=4")))?;
        if bus.motors.iter().any(|m| m.id == id) {
            return Err(invalid(
                ikey,
                format!("motor {id} is described on this bus: it cannot also be undriven"),
            ));
        }
        if !zero_torque_ids.contains(&motor) {
            zero_torque_ids.push(motor);
        }
    }
    Ok(BusSpec {
        name,
        interface,
        bitrate: bus.bitrate,
        turnaround,
        // Decided once its motors' dialects are known (`exchange_of`).
        exchange: ExchangeKind::MultiTorque,
        zero_torque_ids,
        // Decided once the exchange's budget is known (`health_fits`).
        health_rotation: false,
        joints: first..first + bus.motors.len(),
        beyond_frame: 0,
    })
}

/// The model named at `key`, if any.
fn model_of(m: &MotorConfig, key: &str) -> Result<Option<&'static MotorModel>, RobotError> {
    let Some(name) = &m.model else {
        return Ok(None);
    };
    find_model(name).map(Some).map_err(|_| {
        invalid(
            format!("{key}.model"),
            format!(
                "is `{name}`, which rmd-rt does not know (known models: {}); describe the motor \
                 with its own keys instead",
                MODELS.iter().map(|m| m.name).collect::<Vec<_>>().join(", ")
            ),
        )
    })
}

/// The motor's dialect: its own `protocol`, the bus's, the model's, or v1.61.
fn dialect_of(
    bus: &BusConfig,
    m: &MotorConfig,
    model: Option<&MotorModel>,
    key: &str,
) -> Result<Dialect, RobotError> {
    let (protocol, protocol_key) = match (&m.protocol, &bus.protocol) {
        (Some(p), _) => (Some(p.as_str()), format!("{key}.protocol")),
        (None, Some(p)) => (Some(p.as_str()), format!("{key}.protocol (from its bus)")),
        (None, None) => (None, format!("{key}.protocol")),
    };
    let series = m.lk_series.as_deref().or(bus.lk_series.as_deref()).or(model
        .and_then(|md| md.dialect.lk_series())
        .map(|s| s.name()));
    // A MyActuator V3 motor is driven per motor: its bus's exchange is checked with the bus.
    let model_dialect = model.map(|md| md.dialect);
    let dialect = match protocol {
        Some(p) => Dialect::from_names(p, series).map_err(|e| {
            invalid(
                protocol_key.clone(),
                format!(
                    "is `{p}`: {e} (\"v1.61\", \"myactuator-v3\", or \"lk-v2.3x\" with lk_series = \
                     \"mf\" or \"mg\")"
                ),
            )
        })?,
        None => model_dialect.unwrap_or_default(),
    };
    if let (Some(md), Some(model_dialect)) = (model, model_dialect)
        && model_dialect.family() != dialect.family()
    {
        return Err(invalid(
            protocol_key,
            format!(
                "is {}, but model `{}` speaks {}",
                dialect.name(),
                md.name,
                model_dialect.name()
            ),
        ));
    }
    Ok(dialect)
}

fn joint_spec(
    b: usize,
    bus: &BusConfig,
    m: &MotorConfig,
    key: &str,
) -> Result<JointSpec, RobotError> {
    let model = model_of(m, key)?;
    let dialect = dialect_of(bus, m, model, key)?;
    // 1..=4 on a multi-torque bus: checked with the bus (`check_bus_layout`).
    let motor = MotorId::new(m.id).ok().ok_or_else(|| {
        invalid(
            format!("{key}.id"),
            format!("is {}, must be 1..={MAX_PER_MOTOR_ID}", m.id),
        )
    })?;
    if m.brake && dialect.v3_firmware().is_none() {
        return Err(invalid(
            format!("{key}.brake"),
            format!(
                "is true, but the motor speaks {}: only MyActuator V3 motors have brake commands",
                dialect.name()
            ),
        ));
    }
    if let Some(millis) = m.watchdog_ms {
        check_watchdog(millis, dialect, &format!("{key}.watchdog_ms"))?;
    }
    let encoder = match (m.encoder_bits, model.and_then(|md| md.encoder_bits)) {
        (Some(bits), _) => EncoderWidth::new(bits).map_err(|_| {
            invalid(
                format!("{key}.encoder_bits"),
                format!(
                    "is {bits}, must be {}..={}",
                    EncoderWidth::MIN_BITS,
                    EncoderWidth::MAX_BITS
                ),
            )
        })?,
        (None, Some(from_model)) => from_model.value,
        (None, None) => EncoderWidth::DEFAULT,
    };
    let gear_ratio = m
        .gear_ratio
        .or(model.and_then(|md| md.gear_ratio).map(|g| g.value))
        .unwrap_or(1.0);
    if !GEAR_RATIO_RANGE.contains(&gear_ratio) {
        return Err(invalid(
            format!("{key}.gear_ratio"),
            format!(
                "is {}, must be {}..={} (motor turns per joint turn: 9 for a 1:9 \
                 gearbox)",
                Shown(gear_ratio),
                GEAR_RATIO_RANGE.start(),
                GEAR_RATIO_RANGE.end()
            ),
        ));
    }
    let torque_constant = m.torque_constant_nm_per_amp.or(model
        .and_then(|md| md.torque_constant_nm_per_a)
        .map(|kt| kt.value));
    if !(-MAX_ZERO_OFFSET_DEG..=MAX_ZERO_OFFSET_DEG).contains(&m.zero_offset_deg) {
        return Err(invalid(
            format!("{key}.zero_offset_deg"),
            format!(
                "is {}, must be within +-{MAX_ZERO_OFFSET_DEG} degrees of joint (ten turns)",
                Shown(m.zero_offset_deg)
            ),
        ));
    }
    let amps = m.current_limit_amps;
    let scale = dialect.iq_control_scale();
    let max_amps = scale.max_amps();
    // At least one step of the command's scale: a smaller limit would allow no torque at all.
    let min_amps = scale.amps_per_lsb();
    if !(amps.is_finite() && amps >= min_amps && amps <= max_amps) {
        return Err(invalid(
            format!("{key}.current_limit_amps"),
            format!(
                "is {}, must be in [{min_amps}, {max_amps}] A (one step to the whole {} \
                 command range)",
                Shown(amps),
                dialect
            ),
        ));
    }
    if let Some(kt) = torque_constant
        && !TORQUE_CONSTANT_RANGE.contains(&kt)
    {
        return Err(invalid(
            format!("{key}.torque_constant_nm_per_amp"),
            format!(
                "is {}, must be {}..={} N*m/A (at the joint, after the gearbox)",
                Shown(kt),
                TORQUE_CONSTANT_RANGE.start(),
                TORQUE_CONSTANT_RANGE.end()
            ),
        ));
    }
    if let Some(t) = m.temperature_limit_celsius
        && !(t.is_finite() && (-40.0..=127.0).contains(&t))
    {
        return Err(invalid(
            format!("{key}.temperature_limit_celsius"),
            format!("is {}, must be in -40..=127 degC", Shown(t)),
        ));
    }
    let name = match &m.name {
        Some(name) if name.trim().is_empty() => {
            return Err(invalid(format!("{key}.name"), "must not be empty"));
        }
        Some(name) => name.clone(),
        None => format!("bus{b}_motor{}", m.id),
    };
    Ok(JointSpec {
        name,
        bus: b,
        motor,
        dialect,
        model: model.map(|md| md.name),
        encoder,
        gear_ratio,
        direction: m.direction,
        zero_offset_deg: m.zero_offset_deg,
        current_limit: CurrentLimit {
            amps,
            // Rounded towards zero: a clamped command never exceeds the described limit.
            raw: (amps / scale.amps_per_lsb())
                .floor()
                .min(f64::from(scale.max_raw())) as i16,
        },
        torque_constant_nm_per_amp: torque_constant,
        temperature_limit_celsius: m.temperature_limit_celsius,
        limits: limits::joint_limits(m, key)?,
        brake: m.brake,
        watchdog: m.watchdog_ms.map(WatchdogTimeout::from_millis),
    })
}

/// The shortest communication watchdog accepted: 5 ms proved too short on real motors (a
/// normal pause between two frames tripped it); 20 to 100 ms is usual.
pub const MIN_WATCHDOG_MS: u32 = 10;

/// A described communication watchdog: only MyActuator V3 motors have one, and a non-zero one
/// is at least [`MIN_WATCHDOG_MS`].
fn check_watchdog(millis: u32, dialect: Dialect, key: &str) -> Result<(), RobotError> {
    if dialect.v3_firmware().is_none() {
        return Err(invalid(
            key,
            format!(
                "is set, but the motor speaks {}: only MyActuator V3 motors have a communication \
                 watchdog (0xB3); leave the key out",
                dialect.name()
            ),
        ));
    }
    if millis != 0 && millis < MIN_WATCHDOG_MS {
        return Err(invalid(
            key,
            format!(
                "is {millis}, must be 0 (off) or at least {MIN_WATCHDOG_MS} ms: shorter ones trip \
                 on a normal pause between two frames (20 to 100 ms is usual)"
            ),
        ));
    }
    Ok(())
}

/// Periods of the loop a described watchdog must span at least: the loop sends each motor one
/// frame a period, and a late tick must not trip it.
const WATCHDOG_MIN_PERIODS: u32 = 3;

/// A described non-zero watchdog spans at least [`WATCHDOG_MIN_PERIODS`] of the loop's periods.
fn check_watchdog_period(
    joint: &JointSpec,
    settings: &LoopSettings,
    key: &str,
) -> Result<(), RobotError> {
    let Some(watchdog) = joint.watchdog.filter(|w| !w.is_off()) else {
        return Ok(());
    };
    let shortest = settings.period.get() * WATCHDOG_MIN_PERIODS;
    if Duration::from_millis(u64::from(watchdog.millis())) < shortest {
        return Err(invalid(
            format!("{key}.watchdog_ms"),
            format!(
                "is {}, shorter than {WATCHDOG_MIN_PERIODS} of the loop's periods ({} ms at {} Hz): \
                 the motor would turn itself off whenever a tick came late; raise it or the rate",
                watchdog.millis(),
                shortest.as_secs_f64() * 1000.0,
                settings.period.hz()
            ),
        ));
    }
    Ok(())
}

/// The bus's exchange: as written, or `per-motor` when a motor speaks MyActuator V3 (whose
/// 0x280 frame is one command for every motor: `multi-torque` is refused there), else
/// `multi-torque`.
fn exchange_of(
    bus: &BusConfig,
    joints: &[JointSpec],
    key: &str,
) -> Result<ExchangeKind, RobotError> {
    let v3 = joints
        .iter()
        .find(|j| !j.dialect.multi_torque_is_per_motor_torque());
    match (bus.exchange, v3) {
        (Some(ExchangeKind::MultiTorque), Some(j)) => Err(invalid(
            format!("{key}.exchange"),
            format!(
                "is \"multi-torque\", but joint `{}` (motor {}) speaks {}, to which a 0x280 frame \
                 is one command for every motor, not torque: use exchange = \"per-motor\" (the \
                 default on such a bus)",
                j.name,
                j.motor.get(),
                j.dialect.name()
            ),
        )),
        (Some(ExchangeKind::Motion), _) => {
            check_motion_joints(joints, key)?;
            Ok(ExchangeKind::Motion)
        }
        (Some(kind), _) => Ok(kind),
        (None, Some(_)) => Ok(ExchangeKind::PerMotor),
        // The 0x280 frame for ids 1..=4 (and 0xA1 requests for the ids beyond), unless no motor
        // has one of those ids.
        (None, None) if joints.iter().any(|j| j.slot() < MAX_MOTORS_PER_BUS) => {
            Ok(ExchangeKind::MultiTorque)
        }
        (None, None) => Ok(ExchangeKind::PerMotor),
    }
}

/// Every joint of a `motion` bus speaks MyActuator V3 (the only family with a motion mode)
/// and has a torque constant (its replies report torque in N*m, from which the loop reports
/// the current, and its current commands become feed-forward torque).
fn check_motion_joints(joints: &[JointSpec], key: &str) -> Result<(), RobotError> {
    for j in joints {
        if j.dialect.v3_firmware().is_none() {
            return Err(invalid(
                format!("{key}.exchange"),
                format!(
                    "is \"motion\", but joint `{}` (motor {}) speaks {}, which has no motion \
                     mode (MyActuator V3 only): use exchange = \"per-motor\" or \
                     \"multi-torque\", or put the V3 motors on a bus of their own",
                    j.name,
                    j.motor.get(),
                    j.dialect.name()
                ),
            ));
        }
        if j.torque_constant_nm_per_amp.is_none() {
            return Err(invalid(
                format!("{key}.exchange"),
                format!(
                    "is \"motion\", but joint `{}` (motor {}) has no torque constant: motion \
                     mode reports torque in N*m and takes currents as feed-forward torque; set \
                     torque_constant_nm_per_amp (or a model that gives it)",
                    j.name,
                    j.motor.get()
                ),
            ));
        }
    }
    Ok(())
}

/// A `motion` bus's replies carry no temperature: its joints' temperature limits are watched
/// through the health rotation's status replies, so a temperature limit there needs the
/// rotation on.
fn check_motion_temperature(
    bus: &BusSpec,
    joints: &[JointSpec],
    settings: &LoopSettings,
    key: &str,
) -> Result<(), RobotError> {
    if bus.exchange != ExchangeKind::Motion || bus.health_rotation {
        return Ok(());
    }
    let Some(j) = joints
        .iter()
        .find(|j| j.temperature_limit_celsius.is_some())
    else {
        return Ok(());
    };
    let why = if settings.health_rotation {
        format!(
            "this bus has no room for it at {} Hz (its exchange with a status request and \
             reply needs up to {} us): lower loop.rate_hz or put fewer motors on the bus",
            settings.period.hz(),
            bus.health_budget().as_micros()
        )
    } else {
        "loop.health_rotation is off: turn it on".to_string()
    };
    Err(invalid(
        format!("{key}.exchange"),
        format!(
            "is \"motion\" and joint `{}` has temperature_limit_celsius, but motion-mode replies \
             carry no temperature: the limit is watched through the health rotation's status \
             replies, and {why}; or remove the limit, or use exchange = \"per-motor\"",
            j.name
        ),
    ))
}

/// What the bus's exchange allows: a `multi-torque` bus drives ids 1..=4 with its 0x280 frame
/// (and acknowledges undescribed ones among them) and any higher id with 0xA1 requests of its
/// own; a `per-motor` or `motion` bus commands only its described motors.
fn check_bus_layout(spec: &BusSpec, key: &str) -> Result<(), RobotError> {
    match spec.exchange {
        ExchangeKind::MultiTorque => {}
        ExchangeKind::PerMotor | ExchangeKind::Motion => {
            if !spec.zero_torque_ids.is_empty() {
                return Err(invalid(
                    format!("{key}.zero_torque_ids"),
                    "a per-motor bus commands only its described motors: an undescribed motor \
                     there is never sent torque; remove zero_torque_ids",
                ));
            }
        }
    }
    Ok(())
}

/// The bus must carry one exchange per tick (same tick: before the reply deadline). A rate it
/// cannot carry is refused, naming the highest rate it can carry and what to change.
fn check_budget(
    bus: &BusSpec,
    s: &LoopSettings,
    explicit_deadline: bool,
    key: &str,
) -> Result<(), RobotError> {
    let budget = bus.exchange_budget();
    let (window, window_name) = match s.reply_mode {
        ReplyMode::SameTick => (s.reply_deadline, "reply deadline"),
        ReplyMode::Pipelined => (s.period.get(), "period"),
    };
    if budget <= window || s.allow_over_budget {
        return Ok(());
    }
    let shortest = shortest_period(budget, s.reply_mode, explicit_deadline);
    let highest = highest_rate_hz(shortest);
    let deadline_hint = if explicit_deadline && s.reply_mode == ReplyMode::SameTick {
        format!(
            ", or raise loop.reply_deadline_us to at least {} us",
            budget.as_micros().max(1)
        )
    } else {
        String::new()
    };
    Err(invalid(
        key,
        format!(
            "cannot carry one exchange per tick at {} Hz: {} motors ({} exchange, {} request \
             frame(s)) at {} bit/s with {} us turnaround need up to {} us (worst-case bit \
             stuffing), but the {window_name} is {} us. The highest rate this bus can carry is \
             {highest} Hz. Lower loop.rate_hz to at most {highest}, put fewer motors on this \
             bus (spread them over more buses), raise the bit rate{}{deadline_hint}",
            Shown(1e9 / s.period.get().as_nanos() as f64),
            bus.motor_count(),
            bus.exchange,
            bus.requests_per_exchange(),
            bus.bitrate,
            bus.turnaround.as_micros(),
            budget.as_micros(),
            window.as_micros(),
            match s.reply_mode {
                ReplyMode::SameTick => ", or use reply_mode = \"pipelined\"",
                ReplyMode::Pipelined => "",
            },
        ),
    ))
}

/// Whether the bus carries the health rotation's status request and reply every tick within
/// its reply window (same tick: the reply deadline; pipelined: the period). Never with
/// `allow_over_budget`'s leave: a bus beyond its budget runs without it.
fn health_fits(bus: &BusSpec, s: &LoopSettings) -> bool {
    let window = match s.reply_mode {
        ReplyMode::SameTick => s.reply_deadline,
        ReplyMode::Pipelined => s.period.get(),
    };
    bus.health_budget() <= window
}

/// The reply deadline of a period when the description gives none: the period minus 10% (at
/// least 50 us), but at least half the period.
fn default_reply_deadline(p: Duration) -> Duration {
    p.saturating_sub((p / 10).max(Duration::from_micros(50)))
        .max(p / 2)
}

/// The shortest period whose window (same tick: the default reply deadline, or the explicit
/// one, which must fit in the period; pipelined: the period) holds an exchange of `budget`.
fn shortest_period(budget: Duration, mode: ReplyMode, explicit_deadline: bool) -> Duration {
    if mode == ReplyMode::Pipelined || explicit_deadline {
        return budget;
    }
    // The default deadline grows with the period: the least period whose deadline holds the
    // budget, to the nanosecond (at most twice the budget).
    let (mut low, mut high) = (budget.as_nanos() as u64, 2 * budget.as_nanos() as u64 + 1);
    while low < high {
        let mid = low + (high - low) / 2;
        if default_reply_deadline(Duration::from_nanos(mid)) >= budget {
            high = mid;
        } else {
            low = mid + 1;
        }
    }
    Duration::from_nanos(low)
}

/// The highest whole rate (Hz) whose period is at least `period`.
fn highest_rate_hz(period: Duration) -> u64 {
    let ns = period.as_nanos().max(1);
    let mut hz = (1_000_000_000 / ns) as u64;
    // `Period::from_hz` rounds the period to the nanosecond: step down until it is long enough.
    while hz > 1 && (1e9 / hz as f64).round() < ns as f64 {
        hz -= 1;
    }
    hz
}

#[cfg(test)]
mod tests {
    use super::*;

    const LEG: &str = r#"
        [loop]
        rate_hz = 500.0
        cpu = 1
        spin_margin_us = 20
        overrun = { policy = "fault", after = 5 }

        [[bus]]
        interface = "can0"

        [[bus.motor]]
        id = 1
        name = "hip"
        gear_ratio = 6.0
        direction = "reversed"
        current_limit_amps = 8.0
        torque_constant_nm_per_amp = 0.52

        [[bus.motor]]
        id = 2
    "#;

    fn expect_invalid(text: &str, key: &str) {
        match Robot::from_toml(text) {
            Err(RobotError::Invalid {
                key: k, problem, ..
            }) => assert_eq!(k, key, "{problem}"),
            other => panic!("expected an error on {key}, got {other:?}"),
        }
    }

    #[test]
    fn a_leg_description_parses_into_typed_values() {
        let robot = Robot::from_toml(LEG).unwrap();
        let s = robot.settings();
        assert_eq!(s.period.get(), Duration::from_millis(2));
        assert_eq!(s.overrun, OverrunPolicy::Fault { after: 5 });
        assert_eq!(s.reply_deadline, Duration::from_micros(1800));
        assert_eq!(s.realtime.cpu, Some(1));
        // Pinned: the CPU latency request defaults to 0 us.
        assert_eq!(s.realtime.cpu_dma_latency, Some(Duration::ZERO));
        assert_eq!(robot.joint_count(), 2);
        let hip = robot.spec(robot.joint("hip").unwrap());
        assert_eq!(hip.direction, Direction::Reversed);
        assert_eq!(hip.encoder.bits(), 14);
        assert_eq!(hip.current_limit.raw(), 500);
        // Never above the described limit: 3.0 A is 187.5 steps of 16 mA, 187 are allowed.
        let three =
            Robot::from_toml(&LEG.replace("current_limit_amps = 8.0", "current_limit_amps = 3.0"))
                .unwrap();
        let raw = three.joints()[0].current_limit.raw();
        assert_eq!(raw, 187);
        assert!(rmd_protocol::IqControl::saturating(raw).amps() <= 3.0);
        // Unnamed joints get a name from their bus and id.
        assert_eq!(robot.joints()[1].name, "bus0_motor2");
        assert_eq!(robot.buses()[0].name, "bus0");
        assert_eq!(
            robot.buses()[0].interface,
            Interface::SocketCan("can0".into())
        );
        assert_eq!(robot.buses()[0].bitrate, 1_000_000);
        // Round trip through TOML.
        assert_eq!(Robot::from_toml(&robot.config().to_toml()).unwrap(), robot);
    }

    #[test]
    fn bad_values_name_their_key() {
        expect_invalid(&LEG.replace("id = 2", "id = 33"), "bus[0].motor[1].id");
        expect_invalid(&LEG.replace("id = 2", "id = 0"), "bus[0].motor[1].id");
        expect_invalid(&LEG.replace("id = 2", "id = 1"), "bus[0].motor[1].id");
        expect_invalid(
            &LEG.replace("gear_ratio = 6.0", "gear_ratio = -6.0"),
            "bus[0].motor[0].gear_ratio",
        );
        expect_invalid(
            &LEG.replace("current_limit_amps = 8.0", "current_limit_amps = 40.0"),
            "bus[0].motor[0].current_limit_amps",
        );
        expect_invalid(
            &LEG.replace("rate_hz = 500.0", "rate_hz = 0.0"),
            "loop.rate_hz",
        );
        expect_invalid(
            &LEG.replace("spin_margin_us = 20", "spin_margin_us = 5000"),
            "loop.spin_margin_us",
        );
        expect_invalid(&LEG.replace("after = 5", "after = 0"), "loop.overrun.after");
        expect_invalid(
            &LEG.replace("cpu = 1", "cpu = 1\nfifo_priority = 100"),
            "loop.fifo_priority",
        );
        expect_invalid(
            &LEG.replace(
                "[[bus.motor]]\n        id = 2",
                "[[bus.motor]]\n        id = 2\n        encoder_bits = 20",
            ),
            "bus[0].motor[1].encoder_bits",
        );
        expect_invalid(
            &LEG.replace(
                "[[bus.motor]]\n        id = 2",
                "[[bus.motor]]\n        id = 2\n        name = \"hip\"",
            ),
            "bus[0].motor[1].name",
        );
        expect_invalid(
            &LEG.replace("interface = \"can0\"", "interface = \" \""),
            "bus[0].interface",
        );
        expect_invalid("[loop]\nrate_hz = 100.0", "bus");
        expect_invalid(
            &LEG.replace("cpu = 1", "cpu = 1\ncpu_dma_latency_us = 1000001"),
            "loop.cpu_dma_latency_us",
        );
    }

    #[test]
    fn physically_absurd_values_are_refused_naming_their_key() {
        let motor = "[[bus.motor]]\n        id = 2";
        let on_motor = |line: &str| LEG.replace(motor, &format!("{motor}\n        {line}"));
        for (line, key) in [
            ("gear_ratio = 1e308", "bus[0].motor[1].gear_ratio"),
            ("gear_ratio = 1e-308", "bus[0].motor[1].gear_ratio"),
            ("gear_ratio = nan", "bus[0].motor[1].gear_ratio"),
            ("gear_ratio = 0.0", "bus[0].motor[1].gear_ratio"),
            ("zero_offset_deg = 1e308", "bus[0].motor[1].zero_offset_deg"),
            (
                "zero_offset_deg = -3601.0",
                "bus[0].motor[1].zero_offset_deg",
            ),
            ("zero_offset_deg = inf", "bus[0].motor[1].zero_offset_deg"),
            (
                "torque_constant_nm_per_amp = 1e308",
                "bus[0].motor[1].torque_constant_nm_per_amp",
            ),
            (
                "torque_constant_nm_per_amp = 1e-308",
                "bus[0].motor[1].torque_constant_nm_per_amp",
            ),
            (
                "current_limit_amps = 1e-308",
                "bus[0].motor[1].current_limit_amps",
            ),
            (
                "temperature_limit_celsius = 1e308",
                "bus[0].motor[1].temperature_limit_celsius",
            ),
        ] {
            expect_invalid(&on_motor(line), key);
        }
        let on_loop = |line: &str| LEG.replace("[loop]", &format!("[loop]\n{line}"));
        for (line, key) in [
            (
                "stall_bound_ms = 18446744073709551615",
                "loop.stall_bound_ms",
            ),
            (
                "missing_reply_fault_after = 0",
                "loop.missing_reply_fault_after",
            ),
            ("startup_probes = 4294967295", "loop.startup_probes"),
            (
                "telemetry_capacity = 1000000000000",
                "loop.telemetry_capacity",
            ),
            (
                "reply_deadline_us = 18446744073709551615",
                "loop.reply_deadline_us",
            ),
        ] {
            expect_invalid(&on_loop(line), key);
        }
        expect_invalid(&LEG.replace("cpu = 1", "cpu = 4096"), "loop.cpu");
        expect_invalid(
            &LEG.replace(
                "interface = \"can0\"",
                "interface = \"can0\"\nturnaround_us = 18446744073709551615",
            ),
            "bus[0].turnaround_us",
        );
        expect_invalid(
            &LEG.replace("rate_hz = 500.0", "rate_hz = 1e308"),
            "loop.rate_hz",
        );
        // The edges of the ranges are accepted: a 1:100 step-up, a 1000:1 reduction.
        for line in [
            "gear_ratio = 0.01",
            "gear_ratio = 1000.0",
            "zero_offset_deg = -3600.0",
        ] {
            Robot::from_toml(&on_motor(line)).unwrap();
        }
    }

    #[test]
    fn errors_about_a_file_name_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("my_leg.toml");
        let shown = path.display().to_string();
        std::fs::write(&path, LEG.replace("gear_ratio = 6.0", "gear_ratio = 1e308")).unwrap();
        let err = Robot::from_file(&path).unwrap_err();
        assert_eq!(
            err.to_string(),
            format!(
                "robot description {shown}: `bus[0].motor[0].gear_ratio` is 1e308, must be \
                 0.01..=1000 (motor turns per joint turn: 9 for a 1:9 gearbox)"
            )
        );
        // The programs read the file, change settings, then check: the file is still named.
        let mut config = read_config(&path).unwrap();
        config.loop_config.rate_hz = 100.0;
        let err = Robot::try_from(config).unwrap_err();
        assert!(
            err.to_string()
                .starts_with(&format!("robot description {shown}: `bus[0]")),
            "{err}"
        );
        // Parse errors too.
        std::fs::write(&path, "[loop]\nrate_hz = \"fast\"").unwrap();
        let err = Robot::from_file(&path).unwrap_err();
        assert!(
            matches!(&err, RobotError::Parse { file: Some(f), .. } if *f == shown),
            "{err}"
        );
        assert!(err.to_string().contains("rate_hz"), "{err}");
        // Text without a file: no file named.
        let err =
            Robot::from_toml(&LEG.replace("gear_ratio = 6.0", "gear_ratio = 0.0")).unwrap_err();
        assert!(
            err.to_string()
                .starts_with("robot description: `bus[0].motor[0].gear_ratio` is 0,"),
            "{err}"
        );
    }

    #[test]
    fn the_cpu_latency_request_parses_and_defaults_to_zero_with_real_time_settings() {
        let latency = |text: &str| {
            Robot::from_toml(text)
                .unwrap()
                .settings()
                .realtime
                .cpu_dma_latency
        };
        let us = Duration::from_micros;
        // Auto: 0 us when pinned or SCHED_FIFO, off otherwise.
        assert_eq!(latency(LEG), Some(us(0)));
        let plain = LEG.replace("cpu = 1\n", "");
        assert_eq!(latency(&plain), None);
        assert_eq!(
            latency(&plain.replace("rate_hz = 500.0", "rate_hz = 500.0\nfifo_priority = 80")),
            Some(us(0))
        );
        // Given: a number of microseconds, or off, whatever else is set.
        assert_eq!(
            latency(&LEG.replace("cpu = 1", "cpu = 1\ncpu_dma_latency_us = 25")),
            Some(us(25))
        );
        assert_eq!(
            latency(&plain.replace("rate_hz = 500.0", "rate_hz = 500.0\ncpu_dma_latency_us = 3")),
            Some(us(3))
        );
        assert_eq!(
            latency(&LEG.replace("cpu = 1", "cpu = 1\ncpu_dma_latency_us = \"off\"")),
            None
        );
        assert_eq!(
            latency(&LEG.replace("cpu = 1", "cpu = 1\ncpu_dma_latency_us = \"auto\"")),
            Some(us(0))
        );
        // Survives a round trip through TOML.
        let robot =
            Robot::from_toml(&LEG.replace("cpu = 1", "cpu = 1\ncpu_dma_latency_us = \"off\""))
                .unwrap();
        assert_eq!(Robot::from_toml(&robot.config().to_toml()).unwrap(), robot);
        // Anything else is a parse error that says what is expected.
        for bad in ["-1", "\"on\"", "1.5", "5000000000"] {
            let err = Robot::from_toml(
                &LEG.replace("cpu = 1", &format!("cpu = 1\ncpu_dma_latency_us = {bad}")),
            )
            .unwrap_err();
            assert!(
                matches!(&err, RobotError::Parse { message: m, .. } if m.contains("microseconds") && m.contains("off")),
                "{bad}: {err}"
            );
        }
    }

    #[test]
    fn every_width_from_12_to_18_bits_is_accepted() {
        for bits in 12..=18 {
            let text = LEG.replace(
                "[[bus.motor]]\n        id = 2",
                &format!("[[bus.motor]]\n        id = 2\n        encoder_bits = {bits}"),
            );
            let robot = Robot::from_toml(&text).unwrap();
            assert_eq!(robot.joints()[1].encoder.bits(), bits);
        }
    }

    #[test]
    fn unknown_keys_and_wrong_types_are_parse_errors_naming_the_key() {
        let err = Robot::from_toml(&LEG.replace("cpu = 1", "cpus = 1")).unwrap_err();
        assert!(
            matches!(&err, RobotError::Parse { message: m, .. } if m.contains("cpus")),
            "{err}"
        );
        let err = Robot::from_toml(&LEG.replace("cpu = 1", "cpu = \"one\"")).unwrap_err();
        assert!(
            matches!(&err, RobotError::Parse { message: m, .. } if m.contains("cpu")),
            "{err}"
        );
    }

    #[test]
    fn a_period_the_bus_cannot_carry_is_refused() {
        // 4 motors at 1 Mbit/s need up to 875 us: 2 kHz (500 us period) cannot work.
        let mut bus = BusConfig::new("can0");
        for id in 1..=4 {
            bus = bus.with_motor(MotorConfig::new(id));
        }
        let err = Robot::try_from(RobotConfig::new(2000.0).with_bus(bus.clone())).unwrap_err();
        assert!(err.to_string().contains("875 us"), "{err}");
        // 1 kHz fits with the default 900 us reply deadline.
        Robot::try_from(RobotConfig::new(1000.0).with_bus(bus.clone())).unwrap();
        // Pipelined mode only needs the exchange to fit in the period.
        let mut pipelined = RobotConfig::new(1100.0).with_bus(bus.clone());
        pipelined.loop_config.reply_mode = ReplyMode::Pipelined;
        Robot::try_from(pipelined).unwrap();
        // A lower bit rate needs a lower rate.
        assert!(Robot::try_from(RobotConfig::new(1000.0).with_bus(bus.bitrate(500_000))).is_err());
    }

    #[test]
    fn ids_beyond_four_get_requests_of_their_own() {
        let mut bus = BusConfig::new("can0");
        for id in [1, 2, 3, 4, 5] {
            bus = bus.with_motor(MotorConfig::new(id));
        }
        // The 0x280 frame for ids 1..=4, an 0xA1 request for id 5.
        let robot = Robot::try_from(RobotConfig::new(100.0).with_bus(bus.clone())).unwrap();
        assert_eq!(robot.buses()[0].exchange, ExchangeKind::MultiTorque);
        assert_eq!(robot.buses()[0].requests_per_exchange(), 2);
        // A per-motor bus: one request each (ids up to 32), when the rate leaves the wire time.
        let per_motor = bus
            .exchange(ExchangeKind::PerMotor)
            .with_motor(MotorConfig::new(32));
        let robot = Robot::try_from(RobotConfig::new(100.0).with_bus(per_motor)).unwrap();
        assert_eq!(robot.buses()[0].exchange, ExchangeKind::PerMotor);
        assert_eq!(robot.buses()[0].requests_per_exchange(), 6);
        assert_eq!(robot.joints()[5].motor.get(), 32);
        // Without an id of 1..=4 there is nothing for a 0x280 frame to do: per-motor.
        let high = BusConfig::new("can0").with_motor(MotorConfig::new(5));
        let robot = Robot::try_from(RobotConfig::new(100.0).with_bus(high)).unwrap();
        assert_eq!(robot.buses()[0].exchange, ExchangeKind::PerMotor);
        // Thirty-two motors on one bus take their wire time: refused at 1 kHz, naming the rate.
        let mut full = BusConfig::new("can0");
        for id in 1..=32 {
            full = full.with_motor(MotorConfig::new(id));
        }
        let err = Robot::try_from(RobotConfig::new(1000.0).with_bus(full)).unwrap_err();
        assert!(
            err.to_string().contains("highest rate this bus can carry"),
            "{err}"
        );
    }

    fn v3_bus(motors: u8) -> BusConfig {
        let mut bus = BusConfig::new("can0").protocol("myactuator-v3");
        for id in 1..=motors {
            bus = bus.with_motor(MotorConfig::new(id));
        }
        bus
    }

    #[test]
    fn a_v3_bus_exchanges_per_motor_and_refuses_multi_torque() {
        let robot = Robot::try_from(RobotConfig::new(1000.0).with_bus(v3_bus(3))).unwrap();
        let bus = &robot.buses()[0];
        assert_eq!(bus.exchange, ExchangeKind::PerMotor);
        // Three requests outlast the first motor's turnaround: 6 frames of 135 us.
        assert_eq!(bus.exchange_budget(), Duration::from_micros(810));
        let multi = v3_bus(3).exchange(ExchangeKind::MultiTorque);
        match Robot::try_from(RobotConfig::new(1000.0).with_bus(multi)) {
            Err(RobotError::Invalid { key, problem, .. }) => {
                assert_eq!(key, "bus[0].exchange");
                assert!(problem.contains("per-motor"), "{problem}");
            }
            other => panic!("{other:?}"),
        }
        // A bus mixing a v1.61 motor with a V3 one is per-motor too.
        let mixed = BusConfig::new("can0")
            .with_motor(MotorConfig::new(1))
            .with_motor(MotorConfig::new(2).protocol("myactuator-v3", None));
        let robot = Robot::try_from(RobotConfig::new(1000.0).with_bus(mixed)).unwrap();
        assert_eq!(robot.buses()[0].exchange, ExchangeKind::PerMotor);
        // A brake only on V3.
        let braked = BusConfig::new("can0").with_motor(MotorConfig::new(1).brake(true));
        expect_invalid(
            &RobotConfig::new(100.0).with_bus(braked).to_toml(),
            "bus[0].motor[0].brake",
        );
        let braked = v3_bus(1);
        let mut braked = braked;
        braked.motors[0].brake = true;
        let robot = Robot::try_from(RobotConfig::new(100.0).with_bus(braked)).unwrap();
        assert!(robot.joints()[0].brake);
    }

    #[test]
    fn a_watchdog_is_described_on_v3_motors_only_and_spans_several_periods() {
        let refused = |robot: RobotConfig, key: &str, words: &str| match Robot::try_from(robot) {
            Err(RobotError::Invalid {
                key: k, problem, ..
            }) => {
                assert_eq!(k, key, "{problem}");
                assert!(problem.contains(words), "{problem}");
            }
            other => panic!("expected an error on {key}, got {other:?}"),
        };
        // v1.61 has no watchdog.
        let v161 = BusConfig::new("can0").with_motor(MotorConfig::new(1).watchdog_ms(50));
        refused(
            RobotConfig::new(100.0).with_bus(v161),
            "bus[0].motor[0].watchdog_ms",
            "only MyActuator V3 motors have a communication watchdog",
        );
        // 5 ms proved too short on real motors.
        let mut short = v3_bus(1);
        short.motors[0].watchdog_ms = Some(5);
        refused(
            RobotConfig::new(1000.0).with_bus(short),
            "bus[0].motor[0].watchdog_ms",
            "at least 10 ms",
        );
        // At 50 Hz a tick is 20 ms: 50 ms is less than three of them.
        let mut slow = v3_bus(1);
        slow.motors[0].watchdog_ms = Some(50);
        refused(
            RobotConfig::new(50.0).with_bus(slow.clone()),
            "bus[0].motor[0].watchdog_ms",
            "shorter than 3 of the loop's periods (60 ms at 50 Hz)",
        );
        let robot = Robot::try_from(RobotConfig::new(100.0).with_bus(slow)).unwrap();
        assert_eq!(robot.joints()[0].watchdog.map(|w| w.millis()), Some(50));
        // 0 describes a watchdog that is off, at any rate; no key, none described.
        let mut off = v3_bus(2);
        off.motors[0].watchdog_ms = Some(0);
        let robot = Robot::try_from(RobotConfig::new(1.0).with_bus(off)).unwrap();
        assert!(robot.joints()[0].watchdog.is_some_and(|w| w.is_off()));
        assert_eq!(robot.joints()[1].watchdog, None);
        // The key round-trips through TOML.
        let text = RobotConfig::new(100.0)
            .with_bus(
                BusConfig::new("can0")
                    .protocol("myactuator-v3")
                    .with_motor(MotorConfig::new(1).watchdog_ms(80)),
            )
            .to_toml();
        assert!(text.contains("watchdog_ms = 80"), "{text}");
        let robot = Robot::from_toml(&text).unwrap();
        assert_eq!(robot.joints()[0].watchdog.map(|w| w.millis()), Some(80));
    }

    #[test]
    fn a_rate_beyond_the_wire_budget_is_refused_naming_the_highest_it_can_carry() {
        // Four V3 motors per-motor at 1 Mbit/s: 4 * 135 + 4 * 135 = 1080 us; the default reply
        // deadline (90% of the period) holds it from 1200 us: 833 Hz.
        let err = Robot::try_from(RobotConfig::new(1000.0).with_bus(v3_bus(4))).unwrap_err();
        let RobotError::Invalid { key, problem, .. } = err else {
            panic!("{err:?}")
        };
        assert_eq!(key, "bus[0]");
        assert!(
            problem.contains("highest rate this bus can carry is 833 Hz"),
            "{problem}"
        );
        assert!(problem.contains("fewer motors"), "{problem}");
        Robot::try_from(RobotConfig::new(833.0).with_bus(v3_bus(4))).unwrap();
        assert!(Robot::try_from(RobotConfig::new(834.0).with_bus(v3_bus(4))).is_err());
        // Pipelined: the period must hold it: 1 / 1080 us = 925.9 Hz.
        let mut pipelined = RobotConfig::new(1000.0).with_bus(v3_bus(4));
        pipelined.loop_config.reply_mode = ReplyMode::Pipelined;
        let err = Robot::try_from(pipelined.clone()).unwrap_err();
        assert!(err.to_string().contains("is 925 Hz"), "{err}");
        pipelined.loop_config.rate_hz = 925.0;
        Robot::try_from(pipelined).unwrap();
        // The highest rate named is always one the check accepts, for every layout.
        for motors in 1..=8u8 {
            for bitrate in [125_000, 500_000, 1_000_000] {
                let bus = v3_bus(motors).bitrate(bitrate);
                let Err(RobotError::Invalid { problem, .. }) =
                    Robot::try_from(RobotConfig::new(5000.0).with_bus(bus.clone()))
                else {
                    panic!("5 kHz accepted");
                };
                let hz: f64 = problem
                    .split("can carry is ")
                    .nth(1)
                    .and_then(|rest| rest.split(' ').next())
                    .and_then(|n| n.parse().ok())
                    .unwrap_or_else(|| panic!("{problem}"));
                Robot::try_from(RobotConfig::new(hz).with_bus(bus.clone())).unwrap();
                assert!(Robot::try_from(RobotConfig::new(hz + 1.0).with_bus(bus)).is_err());
            }
        }
    }

    #[test]
    fn joints_are_found_by_name_and_by_bus_and_id() {
        let two_buses = RobotConfig::new(1000.0)
            .with_bus(BusConfig::new("can0").with_motor(MotorConfig::new(1).name("a")))
            .with_bus(
                BusConfig::new("can1")
                    .name("right")
                    .with_motor(MotorConfig::new(3).name("b"))
                    .with_motor(MotorConfig::new(1).name("c")),
            );
        let robot = Robot::try_from(two_buses).unwrap();
        let [a, b, c] = robot.joints_named(["a", "b", "c"]).unwrap();
        assert_eq!((a.index(), b.index(), c.index()), (0, 1, 2));
        let one = MotorId::new(1).unwrap();
        assert_eq!(robot.joint_at(1, one), Some(c));
        assert_eq!(robot.joint_at(0, one), Some(a));
        assert_eq!(robot.joint_at(2, one), None);
        assert_eq!(robot.spec(b).slot(), 2);
        assert_eq!(robot.buses()[1].joints().collect::<Vec<_>>(), [b, c]);
        let err = robot.joint("knee").unwrap_err();
        assert_eq!(
            err.to_string(),
            "the robot has no joint named `knee` (its joints: a, b, c)"
        );
    }
}
