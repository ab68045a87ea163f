//! The robot description: its buses, its joints (one motor each) and the loop settings.
//!
//! A description is written as TOML (or built in code) in its [file form](mod@file), then
//! converted once, with [`Robot::try_from`] or [`Robot::from_file`], into a [`Robot`] whose
//! every value is checked and typed: motor ids are [`MotorId`]s that fit a 0x280 frame, encoder
//! widths are [`EncoderWidth`](rmd_protocol::EncoderWidth)s, the rate is a
//! [`Period`](crate::schedule::Period), the reply deadline a [`Duration`](core::time::Duration).
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
//! assert!(Robot::from_toml("[[bus]]\ninterface = \"can0\"\n[[bus.motor]]\nid = 5").is_err());
//! # Ok::<(), rmd_loop::robot::RobotError>(())
//! ```

mod bus;
mod error;
mod exchange;
pub mod file;
mod joint;
mod limits;
mod settings;

use std::path::Path;

use rmd_protocol::MotorId;

use bus::bus_spec;
pub use bus::{BusSpec, Interface, MAX_MOTORS_PER_BUS, MAX_TURNAROUND};
pub use error::RobotError;
use error::invalid;
use exchange::{
    check_budget, check_bus_layout, check_motion_temperature, exchange_of, health_fits,
};
pub use file::{
    BusConfig, CpuLatencySetting, Direction, ExchangeKind, LoopConfig, MotorConfig,
    RejectedCommandPolicy, ReplyMode, RobotConfig, SafeStopConfig,
};
pub use joint::{
    CurrentLimit, GEAR_RATIO_RANGE, JointSpec, MAX_COMMAND_AMPS, MAX_PER_MOTOR_ID,
    MAX_ZERO_OFFSET_DEG, MIN_WATCHDOG_MS, TORQUE_CONSTANT_RANGE,
};
use joint::{check_watchdog_period, joint_spec};
pub use limits::{
    DEFAULT_LIMIT_MARGIN_DEG, JointLimits, MAX_LIMIT_DEG, MAX_LIMIT_MARGIN_DEG,
    MAX_VELOCITY_LIMIT_DPS,
};
pub use settings::{
    FifoPriority, LoopSettings, MAX_CPUS, MAX_STALL_BOUND, MAX_STARTUP_PROBES,
    MAX_TELEMETRY_CAPACITY, RealtimeSettings, SafeStopSettings,
};
use settings::{loop_settings, safe_stop_settings};

use crate::joint::JointId;

/// Most buses one loop drives.
pub const MAX_BUSES: usize = 8;
/// Most joints one loop drives (whatever their buses).
pub const MAX_JOINTS: usize = 32;

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
            let exchange = exchange_of(bus, &joints[spec.joint_range()], &key)?;
            spec.set_exchange(exchange, &joints[spec.joint_range()]);
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

#[cfg(test)]
mod tests {
    use core::time::Duration;

    use super::*;
    use crate::schedule::OverrunPolicy;

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
