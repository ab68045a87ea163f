//! The file form of a servo configuration: what a TOML file (or code) says, before it is checked
//! against a robot. [`ServoConfig::new`](crate::ServoConfig::new) turns it, once, into checked,
//! typed per-joint settings; nothing else reads these types.
//!
//! ```toml
//! [servo]
//! enabled_at_start = true
//! queue_capacity = 64
//! trajectory_buffers = 4
//! max_trajectory_points = 256
//!
//! [defaults]                   # every joint
//! kp_nm_per_rad = 20.0
//! kd_nm_s_per_rad = 1.0
//! max_velocity_rad_s = 2.0
//! max_acceleration_rad_s2 = 10.0
//! max_jerk_rad_s3 = 100.0
//! stale_after_ms = 200
//! stale_policy = "hold"        # or "zero-torque", "never"
//!
//! [joint.knee]                 # one joint, by its name in the robot description
//! position_min_rad = -0.5
//! position_max_rad = 2.2
//! max_effort_nm = 12.0
//! ```

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

/// What a setpoint that stopped coming turns into.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum StalePolicy {
    /// Hold the position the joint's reference had (default).
    #[default]
    Hold,
    /// Zero torque: the joint goes limp until a new setpoint comes.
    ZeroTorque,
    /// Setpoints never go stale (the last one stays in force).
    Never,
}

/// A whole servo configuration as written: options, defaults for every joint, per-joint
/// overrides by joint name.
///
/// ```
/// use rmd_servo::config::{JointSettings, ServoFile};
/// let mut file = ServoFile::default();
/// file.defaults.kp_nm_per_rad = Some(40.0);
/// file.joint.insert("knee".into(), JointSettings { position_max_rad: Some(2.0), ..Default::default() });
/// let again = ServoFile::from_toml(&file.to_toml())?;
/// assert_eq!(again, file);
/// # Ok::<(), rmd_servo::ServoConfigError>(())
/// ```
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ServoFile {
    /// `[servo]`: options of the servo as a whole.
    pub servo: ServoOptions,
    /// `[defaults]`: settings of every joint (each unset key keeps its built-in default).
    pub defaults: JointSettings,
    /// `[joint.NAME]`: settings of one joint, over the defaults.
    pub joint: BTreeMap<String, JointSettings>,
}

/// The largest servo configuration file [`ServoFile::from_file`] reads, bytes.
pub const MAX_FILE_BYTES: u64 = 1024 * 1024;

impl ServoFile {
    /// Parses a TOML servo configuration (unknown keys and wrong types are errors naming the key).
    pub fn from_toml(text: &str) -> Result<Self, crate::ServoConfigError> {
        toml::from_str(text).map_err(|e| crate::ServoConfigError::Parse(e.to_string()))
    }

    /// Reads and parses a TOML servo configuration file: at most [`MAX_FILE_BYTES`] read, and
    /// a file with nothing in it (`/dev/null`, a truncated copy) is refused, never taken as the
    /// defaults.
    pub fn from_file(path: impl AsRef<std::path::Path>) -> Result<Self, crate::ServoConfigError> {
        use std::io::Read as _;
        let path = path.as_ref();
        let named = || path.display().to_string();
        let mut text = String::new();
        std::fs::File::open(path)
            .and_then(|file| file.take(MAX_FILE_BYTES + 1).read_to_string(&mut text))
            .map_err(|source| crate::ServoConfigError::Io {
                path: named(),
                source,
            })?;
        if text.len() as u64 > MAX_FILE_BYTES {
            return Err(crate::ServoConfigError::TooLarge {
                path: named(),
                limit: MAX_FILE_BYTES,
            });
        }
        if text.trim().is_empty() {
            return Err(crate::ServoConfigError::Empty { path: named() });
        }
        Self::from_toml(&text)
    }

    /// The configuration as TOML.
    pub fn to_toml(&self) -> String {
        // Serialising plain data into a string cannot fail.
        toml::to_string(self).unwrap_or_default()
    }
}

/// `[servo]`: options of the servo as a whole.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ServoOptions {
    /// Whether the joints hold their start positions when the loop starts (`true`, default) or
    /// stay at zero torque until [`ServoHandle::enable`](crate::ServoHandle::enable).
    pub enabled_at_start: bool,
    /// How many messages (setpoint batches, trajectories) may wait for the loop thread
    /// (default 64; the loop takes every waiting one each tick).
    pub queue_capacity: usize,
    /// How many trajectories may be in flight at once: planned, waiting, running (default 4;
    /// each buffer is allocated once, for `max_trajectory_points` points of every joint).
    pub trajectory_buffers: usize,
    /// Most points of one trajectory (default 256).
    pub max_trajectory_points: usize,
}

impl Default for ServoOptions {
    fn default() -> Self {
        Self {
            enabled_at_start: true,
            queue_capacity: 64,
            trajectory_buffers: 4,
            max_trajectory_points: 256,
        }
    }
}

/// The settings of one joint (in `[defaults]` or `[joint.NAME]`); every key is optional.
///
/// Units: radians, seconds, newton-metres, at the joint (after the gear ratio).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct JointSettings {
    /// Position gain, N·m per rad of position error (default 20).
    pub kp_nm_per_rad: Option<f64>,
    /// Velocity gain, N·m per rad/s of velocity error (default 1).
    pub kd_nm_s_per_rad: Option<f64>,
    /// Lowest position a setpoint or trajectory may ask for, rad (default: none).
    pub position_min_rad: Option<f64>,
    /// Highest position a setpoint or trajectory may ask for, rad (default: none).
    pub position_max_rad: Option<f64>,
    /// Fastest velocity a setpoint may ask for and a trajectory may plan, rad/s (default 2).
    pub max_velocity_rad_s: Option<f64>,
    /// Largest acceleration a trajectory may plan, rad/s² (default 10).
    pub max_acceleration_rad_s2: Option<f64>,
    /// Largest jerk a trajectory may plan, rad/s³ (default 100).
    pub max_jerk_rad_s3: Option<f64>,
    /// Largest torque the servo commands (and an effort setpoint may ask for), N·m (default:
    /// what the joint's `current_limit_amps` allows, `current_limit_amps *
    /// torque_constant_nm_per_amp`; never more).
    pub max_effort_nm: Option<f64>,
    /// A streamed setpoint not renewed within this long is stale, ms (default 200).
    pub stale_after_ms: Option<u64>,
    /// What a stale setpoint turns into (default `"hold"`).
    pub stale_policy: Option<StalePolicy>,
}
