//! The robot description: its buses, its joints (one motor each) and the loop settings.
//!
//! A description is written as TOML (or built in code) in its [file form](RobotConfig), then
//! converted once, with [`Robot::try_from`] or [`Robot::from_file`], into a [`Robot`] whose
//! every value is checked and typed: motor ids are [`MotorId`]s (1..=32), encoder
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
//! assert!(Robot::from_toml("[[bus]]\ninterface = \"can0\"\n[[bus.motor]]\nid = 33").is_err());
//! # Ok::<(), rmd_loop::robot::RobotError>(())
//! ```

mod bus;
mod error;
mod exchange;
mod file;
mod joint;
mod limits;
mod settings;
#[cfg(test)]
mod test_fixtures;

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
    BusConfig, CpuLatencySetting, ExchangeKind, LoopConfig, MotorConfig, Mounting,
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

    use super::test_fixtures::{LEG, expect_invalid};
    use super::*;
    use crate::schedule::OverrunPolicy;

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
        assert_eq!(hip.direction, Mounting::Reversed);
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
    fn clashes_and_a_missing_bus_name_their_key() {
        expect_invalid(&LEG.replace("id = 2", "id = 1"), "bus[0].motor[1].id");
        expect_invalid(
            &LEG.replace(
                "[[bus.motor]]\n        id = 2",
                "[[bus.motor]]\n        id = 2\n        name = \"hip\"",
            ),
            "bus[0].motor[1].name",
        );
        expect_invalid("[loop]\nrate_hz = 100.0", "bus");
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
