//! The servo's configuration: built once from a [`Robot`] (its joints, current limits and
//! torque constants) and a [`ServoFile`] (defaults and per-joint overrides), checked, typed.
//! Errors name the joint and the key.
//!
//! ```
//! use rmd_loop::robot::Robot;
//! use rmd_servo::{ServoConfig, StalePolicy};
//!
//! let robot = Robot::from_toml(r#"
//!     [[bus]]
//!     interface = "sim"
//!     [[bus.motor]]
//!     id = 1
//!     name = "knee"
//!     gear_ratio = 9.0
//!     torque_constant_nm_per_amp = 2.09
//!     current_limit_amps = 5.0
//! "#)?;
//! let config = ServoConfig::from_toml(&robot, r#"
//!     [defaults]
//!     kp_nm_per_rad = 40.0
//!     [joint.knee]
//!     position_min_rad = -0.5
//!     position_max_rad = 2.0
//!     stale_policy = "zero-torque"
//! "#)?;
//! let knee = config.joint(robot.joint("knee")?);
//! assert_eq!(knee.gains.kp_nm_per_rad, 40.0);
//! assert_eq!(knee.limits.position_max_rad, 2.0);
//! assert!((knee.limits.max_effort_nm - 5.0 * 2.09).abs() < 1e-12);
//! assert_eq!(knee.stale.policy, StalePolicy::ZeroTorque);
//!
//! // A bad value names the joint and the key.
//! let err = ServoConfig::from_toml(&robot, "[joint.knee]\nkd_nm_s_per_rad = -1.0").unwrap_err();
//! assert_eq!(
//!     err.to_string(),
//!     "servo configuration: joint `knee`: `joint.knee.kd_nm_s_per_rad` is -1, must be a finite number >= 0"
//! );
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod error;
pub mod file;

use core::time::Duration;

use rmd_loop::robot::{ExchangeKind, JointSpec};
use rmd_loop::{CommandKind, JointId, robot::Robot};

pub use error::ServoConfigError;
pub use file::{JointSettings, MAX_FILE_BYTES, ServoFile, ServoOptions, StalePolicy};

/// Built-in position gain, N·m/rad.
pub const DEFAULT_KP_NM_PER_RAD: f64 = 20.0;
/// Built-in velocity gain, N·m·s/rad.
pub const DEFAULT_KD_NM_S_PER_RAD: f64 = 1.0;
/// Built-in velocity limit, rad/s.
pub const DEFAULT_MAX_VELOCITY_RAD_S: f64 = 2.0;
/// Built-in acceleration limit of trajectories, rad/s².
pub const DEFAULT_MAX_ACCELERATION_RAD_S2: f64 = 10.0;
/// Built-in jerk limit of trajectories, rad/s³.
pub const DEFAULT_MAX_JERK_RAD_S3: f64 = 100.0;
/// Built-in stale time, ms.
pub const DEFAULT_STALE_AFTER_MS: u64 = 200;
/// Most trajectory buffers a servo may have.
pub const MAX_TRAJECTORY_BUFFERS: usize = 64;
/// Most points a trajectory buffer may be sized for.
pub const MAX_TRAJECTORY_POINTS: usize = 100_000;

/// The PD gains of one joint (joint side).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Gains {
    /// N·m per rad of position error.
    pub kp_nm_per_rad: f64,
    /// N·m per rad/s of velocity error.
    pub kd_nm_s_per_rad: f64,
}

/// Where one of a joint's position or velocity limits comes from: the tighter of the robot
/// description's ([`JointSpec::limits`]) and the servo configuration's own.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub enum LimitSource {
    /// The robot description (`position_min_deg`, `position_max_deg`, `velocity_limit_dps`),
    /// or no limit in either.
    #[default]
    RobotDescription,
    /// The servo configuration (`position_min_rad`, `position_max_rad`, `max_velocity_rad_s`,
    /// or the built-in velocity limit).
    ServoConfiguration,
}

impl LimitSource {
    /// The key of a lower position limit from this source, as refusals name it.
    pub fn min_key(self) -> &'static str {
        match self {
            LimitSource::RobotDescription => "robot description: position_min_deg",
            LimitSource::ServoConfiguration => "servo configuration: position_min_rad",
        }
    }

    /// The key of an upper position limit from this source, as refusals name it.
    pub fn max_key(self) -> &'static str {
        match self {
            LimitSource::RobotDescription => "robot description: position_max_deg",
            LimitSource::ServoConfiguration => "servo configuration: position_max_rad",
        }
    }

    /// The key of a velocity limit from this source, as refusals name it.
    pub fn velocity_key(self) -> &'static str {
        match self {
            LimitSource::RobotDescription => "robot description: velocity_limit_dps",
            LimitSource::ServoConfiguration => "servo configuration: max_velocity_rad_s",
        }
    }
}

/// The key of the effort limit, as refusals name it.
pub const EFFORT_KEY: &str = "servo configuration: max_effort_nm";

/// The limits of one joint (joint side). Position limits may be infinite (none). Each is the
/// tighter of the robot description's and the servo configuration's.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct JointLimits {
    /// Lowest position a setpoint or trajectory may ask for, rad (`-inf`: none).
    pub position_min_rad: f64,
    /// Highest position a setpoint or trajectory may ask for, rad (`inf`: none).
    pub position_max_rad: f64,
    /// Fastest velocity, rad/s (> 0).
    pub max_velocity_rad_s: f64,
    /// Largest planned acceleration, rad/s² (> 0).
    pub max_acceleration_rad_s2: f64,
    /// Largest planned jerk, rad/s³ (> 0).
    pub max_jerk_rad_s3: f64,
    /// Largest commanded torque, N·m (> 0, at most what the current limit allows).
    pub max_effort_nm: f64,
    /// Where the lower position limit comes from.
    pub position_min_from: LimitSource,
    /// Where the upper position limit comes from.
    pub position_max_from: LimitSource,
    /// Where the velocity limit comes from.
    pub velocity_from: LimitSource,
}

impl JointLimits {
    /// Whether `position_rad` lies within the position limits.
    pub fn allows_position(&self, position_rad: f64) -> bool {
        position_rad >= self.position_min_rad && position_rad <= self.position_max_rad
    }

    /// The keys of the lower and upper position limits, as refusals name them.
    pub fn position_keys(&self) -> (&'static str, &'static str) {
        (
            self.position_min_from.min_key(),
            self.position_max_from.max_key(),
        )
    }
}

/// When a streamed setpoint goes stale and what it turns into.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct StaleRule {
    /// Not renewed within this long (loop time): stale.
    pub after: Duration,
    /// What it turns into.
    pub policy: StalePolicy,
}

/// One joint's checked servo settings.
#[derive(Clone, Debug, PartialEq)]
pub struct JointServo {
    /// The joint's name (from the robot description).
    pub name: String,
    /// PD gains.
    pub gains: Gains,
    /// Limits.
    pub limits: JointLimits,
    /// The stale-setpoint rule.
    pub stale: StaleRule,
}

/// Options of the servo as a whole, checked.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct Options {
    /// Joints hold their start positions at start (else: zero torque until enabled).
    pub enabled_at_start: bool,
    /// Capacity of the message queue to the loop thread (>= 1).
    pub queue_capacity: usize,
    /// Trajectory buffers (>= 1).
    pub trajectory_buffers: usize,
    /// Most points of one trajectory (>= 1).
    pub max_trajectory_points: usize,
}

/// How the servo commands one joint, from its bus's exchange.
#[derive(Copy, Clone, Debug, PartialEq)]
pub(crate) enum JointOutput {
    /// Torque every tick: the servo runs the PD law.
    Torque,
    /// Motion-mode setpoints (a MyActuator V3 bus with `exchange = "motion"`): the motor runs
    /// the PD law with the servo's gains and targets, kept within these limits.
    Motion(MotionLimits),
}

/// The bounds of a joint's motion-mode setpoints, joint degrees and deg/s: the servo's limits,
/// within the robot description's (which the loop refuses setpoints beyond; converting the
/// servo's radians back to degrees must not step past them by a rounding).
#[derive(Copy, Clone, Debug, PartialEq)]
pub(crate) struct MotionLimits {
    /// Lowest position setpoint, degrees.
    pub(crate) position_min_deg: f64,
    /// Highest position setpoint, degrees.
    pub(crate) position_max_deg: f64,
    /// Fastest velocity setpoint either way, deg/s.
    pub(crate) velocity_max_dps: f64,
}

impl MotionLimits {
    fn new(servo: &JointLimits, spec: &JointSpec) -> Self {
        let described = spec.limits;
        Self {
            position_min_deg: servo
                .position_min_rad
                .to_degrees()
                .max(described.position_min_deg),
            position_max_deg: servo
                .position_max_rad
                .to_degrees()
                .min(described.position_max_deg),
            velocity_max_dps: servo
                .max_velocity_rad_s
                .to_degrees()
                .min(described.velocity_max_dps),
        }
    }
}

/// A checked servo configuration for one robot: one [`JointServo`] per joint, in the robot's
/// joint order.
#[derive(Clone, Debug, PartialEq)]
pub struct ServoConfig {
    joints: Vec<JointServo>,
    /// The robot's joint ids, in the same order.
    ids: Vec<JointId>,
    /// How each joint is commanded, in the same order.
    outputs: Vec<JointOutput>,
    options: Options,
}

impl ServoConfig {
    /// Checks `file` against `robot`: every joint gets the built-in defaults, then
    /// `[defaults]`, then its `[joint.NAME]` table.
    pub fn new(robot: &Robot, file: &ServoFile) -> Result<Self, ServoConfigError> {
        if let Some(name) = file
            .joint
            .keys()
            .find(|name| robot.joints().iter().all(|j| &j.name != *name))
        {
            return Err(ServoConfigError::UnknownJoint {
                name: name.clone(),
                known: robot
                    .joints()
                    .iter()
                    .map(|j| j.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
            });
        }
        let joints = robot
            .joints()
            .iter()
            .map(|spec| joint_servo(spec, &file.defaults, file.joint.get(&spec.name)))
            .collect::<Result<Vec<_>, _>>()?;
        let outputs = robot
            .joints()
            .iter()
            .zip(&joints)
            .map(|(spec, servo)| match robot.buses()[spec.bus].exchange {
                ExchangeKind::Motion => JointOutput::Motion(MotionLimits::new(&servo.limits, spec)),
                ExchangeKind::MultiTorque | ExchangeKind::PerMotor => JointOutput::Torque,
            })
            .collect();
        let options = options(&file.servo)?;
        Ok(Self {
            joints,
            ids: robot.joint_ids().collect(),
            outputs,
            options,
        })
    }

    /// The built-in defaults for every joint of `robot`.
    pub fn defaults(robot: &Robot) -> Result<Self, ServoConfigError> {
        Self::new(robot, &ServoFile::default())
    }

    /// Parses a TOML servo configuration and checks it against `robot`.
    pub fn from_toml(robot: &Robot, text: &str) -> Result<Self, ServoConfigError> {
        Self::new(robot, &ServoFile::from_toml(text)?)
    }

    /// Reads a TOML servo configuration file and checks it against `robot`.
    pub fn from_file(
        robot: &Robot,
        path: impl AsRef<std::path::Path>,
    ) -> Result<Self, ServoConfigError> {
        Self::new(robot, &ServoFile::from_file(path)?)
    }

    /// The settings of joint `id`.
    ///
    /// # Panics
    /// If `id` belongs to a larger robot.
    pub fn joint(&self, id: JointId) -> &JointServo {
        &self.joints[id.index()]
    }

    /// Every joint's settings, in the robot's joint order.
    pub fn joints(&self) -> &[JointServo] {
        &self.joints
    }

    /// How the servo commands joint `id`: [`CommandKind::Motion`] when its bus is
    /// `exchange = "motion"` (the motor runs the PD law with the servo's gains and targets),
    /// else [`CommandKind::Current`] (the servo runs it and sends torque). A joint the robot
    /// does not have: `Current`.
    pub fn command_kind(&self, id: JointId) -> CommandKind {
        match self.outputs.get(id.index()) {
            Some(JointOutput::Motion(_)) => CommandKind::Motion,
            Some(JointOutput::Torque) | None => CommandKind::Current,
        }
    }

    /// The robot's joint ids, in its joint order.
    pub(crate) fn ids(&self) -> &[JointId] {
        &self.ids
    }

    /// How each joint is commanded, in the robot's joint order.
    pub(crate) fn outputs(&self) -> &[JointOutput] {
        &self.outputs
    }

    /// The options.
    pub fn options(&self) -> &Options {
        &self.options
    }
}

/// Where a joint's effective value came from, for error messages.
struct Source<'a> {
    joint: &'a str,
    over: Option<&'a JointSettings>,
}

impl Source<'_> {
    /// The effective value of a key: the joint's own, else the default's, else the built-in.
    fn pick<T: Copy>(
        &self,
        defaults: &JointSettings,
        get: impl Fn(&JointSettings) -> Option<T>,
        builtin: T,
        key: &'static str,
    ) -> (T, String) {
        match self.over.and_then(&get) {
            Some(v) => (v, format!("joint.{}.{key}", self.joint)),
            None => match get(defaults) {
                Some(v) => (v, format!("defaults.{key}")),
                None => (builtin, format!("built-in {key}")),
            },
        }
    }

    fn invalid(&self, key: String, problem: String) -> ServoConfigError {
        ServoConfigError::Invalid {
            joint: self.joint.to_string(),
            key,
            problem,
        }
    }
}

fn joint_servo(
    spec: &JointSpec,
    defaults: &JointSettings,
    over: Option<&JointSettings>,
) -> Result<JointServo, ServoConfigError> {
    let kt = spec
        .torque_constant_nm_per_amp
        .ok_or_else(|| ServoConfigError::NoTorqueConstant {
            joint: spec.name.clone(),
        })?;
    let allowed_effort = spec.current_limit.amps() * kt;
    let src = Source {
        joint: &spec.name,
        over,
    };
    let non_negative = |(v, key): (f64, String)| {
        if v.is_finite() && v >= 0.0 {
            Ok(v)
        } else {
            Err(src.invalid(key, format!("is {v}, must be a finite number >= 0")))
        }
    };
    let positive = |(v, key): (f64, String)| {
        if v.is_finite() && v > 0.0 {
            Ok(v)
        } else {
            Err(src.invalid(key, format!("is {v}, must be a finite number > 0")))
        }
    };
    let kp = non_negative(src.pick(
        defaults,
        |s| s.kp_nm_per_rad,
        DEFAULT_KP_NM_PER_RAD,
        "kp_nm_per_rad",
    ))?;
    let kd = non_negative(src.pick(
        defaults,
        |s| s.kd_nm_s_per_rad,
        DEFAULT_KD_NM_S_PER_RAD,
        "kd_nm_s_per_rad",
    ))?;
    let finite_or_none = |(v, key): (Option<f64>, String)| match v {
        Some(x) if !x.is_finite() => Err(src.invalid(
            key,
            format!("is {x}, must be a finite number (leave it out for no limit)"),
        )),
        other => Ok((other, key)),
    };
    let (min, min_key) = finite_or_none(src.pick(
        defaults,
        |s| s.position_min_rad.map(Some),
        None,
        "position_min_rad",
    ))?;
    let (max, max_key) = finite_or_none(src.pick(
        defaults,
        |s| s.position_max_rad.map(Some),
        None,
        "position_max_rad",
    ))?;
    // The description's limits bound the servo's: each limit is the tighter of the two.
    let described = spec.limits;
    let tighter = |servo: Option<f64>, described: f64, lower: bool| match servo {
        Some(v) if (lower && v >= described) || (!lower && v <= described) => {
            (v, LimitSource::ServoConfiguration)
        }
        _ => (described, LimitSource::RobotDescription),
    };
    let (position_min_rad, position_min_from) =
        tighter(min, described.position_min_deg.to_radians(), true);
    let (position_max_rad, position_max_from) =
        tighter(max, described.position_max_deg.to_radians(), false);
    if position_min_rad >= position_max_rad {
        let (key, whose) = match (min, max) {
            (_, Some(_)) => (max_key, format!("`{min_key}` and the robot description")),
            _ => (
                min_key,
                "the robot description's position_max_deg".to_string(),
            ),
        };
        return Err(src.invalid(
            key,
            format!(
                "leaves no room: the joint's limits would be [{position_min_rad}, \
                 {position_max_rad}] rad (with {whose}: position_min_deg {}, position_max_deg {})",
                described.position_min_deg, described.position_max_deg
            ),
        ));
    }
    let max_velocity_rad_s = positive(src.pick(
        defaults,
        |s| s.max_velocity_rad_s,
        DEFAULT_MAX_VELOCITY_RAD_S,
        "max_velocity_rad_s",
    ))?;
    let (max_velocity_rad_s, velocity_from) = tighter(
        Some(max_velocity_rad_s),
        described.velocity_max_dps.to_radians(),
        false,
    );
    let max_acceleration_rad_s2 = positive(src.pick(
        defaults,
        |s| s.max_acceleration_rad_s2,
        DEFAULT_MAX_ACCELERATION_RAD_S2,
        "max_acceleration_rad_s2",
    ))?;
    let max_jerk_rad_s3 = positive(src.pick(
        defaults,
        |s| s.max_jerk_rad_s3,
        DEFAULT_MAX_JERK_RAD_S3,
        "max_jerk_rad_s3",
    ))?;
    let (effort, effort_key) = src.pick(
        defaults,
        |s| s.max_effort_nm,
        allowed_effort,
        "max_effort_nm",
    );
    let max_effort_nm = positive((effort, effort_key.clone()))?;
    // A small tolerance: a limit written as current * kt by hand may round up.
    if max_effort_nm > allowed_effort * (1.0 + 1e-9) {
        return Err(src.invalid(
            effort_key,
            format!(
                "is {max_effort_nm} N·m, above what the joint's current_limit_amps allows \
                 ({} A * {kt} N·m/A = {allowed_effort} N·m): lower it, or raise the current \
                 limit in the robot description",
                spec.current_limit.amps()
            ),
        ));
    }
    let (after_ms, after_key) = src.pick(
        defaults,
        |s| s.stale_after_ms,
        DEFAULT_STALE_AFTER_MS,
        "stale_after_ms",
    );
    if after_ms == 0 {
        return Err(src.invalid(
            after_key,
            "is 0, must be at least 1 ms (stale_policy = \"never\" turns the rule off)".into(),
        ));
    }
    let (policy, _) = src.pick(
        defaults,
        |s| s.stale_policy,
        StalePolicy::Hold,
        "stale_policy",
    );
    Ok(JointServo {
        name: spec.name.clone(),
        gains: Gains {
            kp_nm_per_rad: kp,
            kd_nm_s_per_rad: kd,
        },
        limits: JointLimits {
            position_min_rad,
            position_max_rad,
            max_velocity_rad_s,
            max_acceleration_rad_s2,
            max_jerk_rad_s3,
            max_effort_nm,
            position_min_from,
            position_max_from,
            velocity_from,
        },
        stale: StaleRule {
            after: Duration::from_millis(after_ms),
            policy,
        },
    })
}

fn options(o: &ServoOptions) -> Result<Options, ServoConfigError> {
    let range = |v: usize, key: &'static str, max: usize| {
        if (1..=max).contains(&v) {
            Ok(v)
        } else {
            Err(ServoConfigError::InvalidOption {
                key: format!("servo.{key}"),
                problem: format!("is {v}, must be 1..={max}"),
            })
        }
    };
    Ok(Options {
        enabled_at_start: o.enabled_at_start,
        queue_capacity: range(o.queue_capacity, "queue_capacity", 1 << 16)?,
        trajectory_buffers: range(
            o.trajectory_buffers,
            "trajectory_buffers",
            MAX_TRAJECTORY_BUFFERS,
        )?,
        max_trajectory_points: range(
            o.max_trajectory_points,
            "max_trajectory_points",
            MAX_TRAJECTORY_POINTS,
        )?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rmd_loop::robot::{BusConfig, MotorConfig, RobotConfig};

    fn robot() -> Robot {
        Robot::try_from(
            RobotConfig::new(1000.0).with_bus(
                BusConfig::new("can0")
                    .with_motor(
                        MotorConfig::new(1)
                            .name("hip")
                            .torque_constant(2.0)
                            .current_limit(5.0),
                    )
                    .with_motor(
                        MotorConfig::new(2)
                            .name("knee")
                            .torque_constant(1.0)
                            .current_limit(8.0),
                    ),
            ),
        )
        .unwrap()
    }

    fn invalid(text: &str) -> (String, String) {
        match ServoConfig::from_toml(&robot(), text) {
            Err(ServoConfigError::Invalid { joint, key, .. }) => (joint, key),
            other => panic!("expected an invalid value, got {other:?}"),
        }
    }

    #[test]
    fn an_empty_or_endless_file_is_refused_naming_it() {
        let robot = robot();
        let err = ServoConfig::from_file(&robot, "/dev/null").unwrap_err();
        assert!(matches!(err, ServoConfigError::Empty { .. }), "{err:?}");
        assert!(err.to_string().contains("/dev/null is empty"), "{err}");
        // An endless file (NUL bytes are text) is read no further than the limit.
        let err = ServoConfig::from_file(&robot, "/dev/zero").unwrap_err();
        assert!(
            matches!(
                err,
                ServoConfigError::TooLarge {
                    limit: MAX_FILE_BYTES,
                    ..
                }
            ),
            "{err:?}"
        );
        assert!(err.to_string().contains("/dev/zero"), "{err}");
    }

    #[test]
    fn defaults_then_overrides_per_joint() {
        let robot = robot();
        let c = ServoConfig::from_toml(
            &robot,
            r#"
            [servo]
            trajectory_buffers = 2
            [defaults]
            kp_nm_per_rad = 30.0
            stale_after_ms = 50
            [joint.knee]
            kp_nm_per_rad = 10.0
            position_min_rad = -1.0
            max_effort_nm = 4.0
            stale_policy = "never"
        "#,
        )
        .unwrap();
        let [hip, knee] = robot.joints_named(["hip", "knee"]).unwrap();
        let (h, k) = (c.joint(hip), c.joint(knee));
        assert_eq!(h.gains.kp_nm_per_rad, 30.0);
        assert_eq!(k.gains.kp_nm_per_rad, 10.0);
        assert_eq!(h.gains.kd_nm_s_per_rad, DEFAULT_KD_NM_S_PER_RAD);
        assert_eq!(h.limits.position_min_rad, f64::NEG_INFINITY);
        assert_eq!(k.limits.position_min_rad, -1.0);
        assert_eq!(k.limits.position_max_rad, f64::INFINITY);
        assert_eq!(h.limits.max_effort_nm, 10.0);
        assert_eq!(k.limits.max_effort_nm, 4.0);
        assert_eq!(h.stale.after, Duration::from_millis(50));
        assert_eq!(h.stale.policy, StalePolicy::Hold);
        assert_eq!(k.stale.policy, StalePolicy::Never);
        assert_eq!(c.options().trajectory_buffers, 2);
        assert!(c.options().enabled_at_start);
    }

    #[test]
    fn bad_values_name_the_joint_and_the_key() {
        assert_eq!(
            invalid("[defaults]\nkp_nm_per_rad = -2.0"),
            ("hip".into(), "defaults.kp_nm_per_rad".into())
        );
        assert_eq!(
            invalid("[joint.knee]\nmax_velocity_rad_s = 0.0"),
            ("knee".into(), "joint.knee.max_velocity_rad_s".into())
        );
        assert_eq!(
            invalid("[joint.knee]\nposition_min_rad = 1.0\nposition_max_rad = 0.5"),
            ("knee".into(), "joint.knee.position_max_rad".into())
        );
        assert_eq!(
            invalid("[joint.hip]\nposition_max_rad = nan"),
            ("hip".into(), "joint.hip.position_max_rad".into())
        );
        // hip allows 5 A * 2 N·m/A = 10 N·m.
        assert_eq!(
            invalid("[joint.hip]\nmax_effort_nm = 10.5"),
            ("hip".into(), "joint.hip.max_effort_nm".into())
        );
        assert_eq!(
            invalid("[defaults]\nstale_after_ms = 0"),
            ("hip".into(), "defaults.stale_after_ms".into())
        );
        assert_eq!(
            invalid("[defaults]\nmax_jerk_rad_s3 = inf"),
            ("hip".into(), "defaults.max_jerk_rad_s3".into())
        );
    }

    #[test]
    fn unknown_joints_keys_and_options_are_refused() {
        let robot = robot();
        let err = ServoConfig::from_toml(&robot, "[joint.ankle]\nkp_nm_per_rad = 1.0").unwrap_err();
        assert_eq!(
            err.to_string(),
            "servo configuration: [joint.ankle] names no joint of the robot (its joints: hip, knee)"
        );
        let err = ServoConfig::from_toml(&robot, "[defaults]\nkp = 1.0").unwrap_err();
        assert!(
            matches!(&err, ServoConfigError::Parse(m) if m.contains("kp")),
            "{err}"
        );
        let err = ServoConfig::from_toml(&robot, "[servo]\ntrajectory_buffers = 0").unwrap_err();
        assert!(
            matches!(&err, ServoConfigError::InvalidOption { key, .. } if key == "servo.trajectory_buffers"),
            "{err}"
        );
        let err =
            ServoConfig::from_toml(&robot, "[defaults]\nstale_policy = \"limp\"").unwrap_err();
        assert!(matches!(err, ServoConfigError::Parse(_)), "{err}");
    }

    /// A knee of 5..165 degrees and 120 deg/s in the robot description.
    fn limited_robot() -> Robot {
        Robot::try_from(
            RobotConfig::new(1000.0).with_bus(
                BusConfig::new("can0").with_motor(
                    MotorConfig::new(1)
                        .name("knee")
                        .torque_constant(2.0)
                        .position_limits(5.0, 165.0)
                        .velocity_limit(60.0),
                ),
            ),
        )
        .unwrap()
    }

    #[test]
    fn the_robot_descriptions_limits_bound_the_servos() {
        let robot = limited_robot();
        let knee = robot.joint("knee").unwrap();
        // No servo limits: the description's, in radians.
        let c = ServoConfig::defaults(&robot).unwrap();
        let l = c.joint(knee).limits;
        assert_eq!(l.position_min_rad, 5f64.to_radians());
        assert_eq!(l.position_max_rad, 165f64.to_radians());
        assert_eq!(
            l.position_keys(),
            (
                "robot description: position_min_deg",
                "robot description: position_max_deg"
            )
        );
        // 60 deg/s is below the built-in 2 rad/s: the description's.
        assert_eq!(l.max_velocity_rad_s, 60f64.to_radians());
        assert_eq!(l.velocity_from, LimitSource::RobotDescription);
        // Each limit is the tighter of the two: a narrower servo limit is taken, a wider one
        // is narrowed to the description's.
        let c = ServoConfig::from_toml(
            &robot,
            "[joint.knee]\nposition_min_rad = -1.0\nposition_max_rad = 2.0\nmax_velocity_rad_s = 0.5",
        )
        .unwrap();
        let l = c.joint(knee).limits;
        assert_eq!(
            (l.position_min_rad, l.position_max_rad),
            (5f64.to_radians(), 2.0)
        );
        assert_eq!(
            (l.position_min_from, l.position_max_from),
            (
                LimitSource::RobotDescription,
                LimitSource::ServoConfiguration
            )
        );
        assert_eq!(
            (l.max_velocity_rad_s, l.velocity_from),
            (0.5, LimitSource::ServoConfiguration)
        );
        let l = ServoConfig::from_toml(&robot, "[defaults]\nmax_velocity_rad_s = 9.0")
            .unwrap()
            .joint(knee)
            .limits;
        assert_eq!(
            (l.max_velocity_rad_s, l.velocity_from),
            (60f64.to_radians(), LimitSource::RobotDescription)
        );
        // Limits that leave no room between them are refused, naming the key.
        assert_eq!(
            invalid_on(&robot, "[joint.knee]\nposition_max_rad = 0.05"),
            ("knee".into(), "joint.knee.position_max_rad".into())
        );
        assert_eq!(
            invalid_on(&robot, "[defaults]\nposition_min_rad = 3.0"),
            ("knee".into(), "defaults.position_min_rad".into())
        );
        // Without description limits nothing changes: none, and the built-in 2 rad/s.
        let l = ServoConfig::defaults(&robot_plain()).unwrap().joints()[0].limits;
        assert_eq!(l.position_min_rad, f64::NEG_INFINITY);
        assert_eq!(l.max_velocity_rad_s, DEFAULT_MAX_VELOCITY_RAD_S);
        assert_eq!(l.velocity_from, LimitSource::ServoConfiguration);
    }

    fn robot_plain() -> Robot {
        robot()
    }

    fn invalid_on(robot: &Robot, text: &str) -> (String, String) {
        match ServoConfig::from_toml(robot, text) {
            Err(ServoConfigError::Invalid { joint, key, .. }) => (joint, key),
            other => panic!("expected an invalid value, got {other:?}"),
        }
    }

    #[test]
    fn a_joint_without_torque_constant_is_refused() {
        let robot = Robot::try_from(
            RobotConfig::new(1000.0)
                .with_bus(BusConfig::new("can0").with_motor(MotorConfig::new(1).name("wrist"))),
        )
        .unwrap();
        let err = ServoConfig::defaults(&robot).unwrap_err();
        assert!(
            matches!(&err, ServoConfigError::NoTorqueConstant { joint } if joint == "wrist"),
            "{err}"
        );
        assert!(
            err.to_string().contains("torque_constant_nm_per_amp"),
            "{err}"
        );
    }
}
