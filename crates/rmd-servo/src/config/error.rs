//! Why a servo configuration cannot be used.

/// A servo configuration that could not be used: unreadable, not TOML, a key unknown, a value
/// out of range, or a joint the robot does not have. The message names the joint and the key.
#[derive(Debug, thiserror::Error)]
pub enum ServoConfigError {
    /// The file could not be read.
    #[error("cannot read servo configuration {path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The file holds nothing (or only white space): taken as the defaults it would hide a
    /// wrong path or a truncated copy.
    #[error(
        "servo configuration {path} is empty: it sets nothing (is it the right file?); give \
         [servo], [defaults] or [joint.NAME] tables, or leave the file out for the built-in \
         defaults"
    )]
    Empty {
        /// The file.
        path: String,
    },
    /// The file is larger than any servo configuration.
    #[error("servo configuration {path} is larger than {limit} bytes: not a servo configuration")]
    TooLarge {
        /// The file.
        path: String,
        /// [`MAX_FILE_BYTES`](crate::config::MAX_FILE_BYTES).
        limit: u64,
    },
    /// Not valid TOML, or a key is unknown or of the wrong type.
    #[error("servo configuration: {0}")]
    Parse(String),
    /// A joint's effective value is out of range.
    #[error("servo configuration: joint `{joint}`: `{key}` {problem}")]
    Invalid {
        /// The joint.
        joint: String,
        /// Where the value came from (`joint.knee.kp_nm_per_rad`, `defaults.kp_nm_per_rad`).
        key: String,
        /// What is wrong, and what is allowed.
        problem: String,
    },
    /// An option of `[servo]` is out of range.
    #[error("servo configuration: `{key}` {problem}")]
    InvalidOption {
        /// The key (`servo.queue_capacity`).
        key: String,
        /// What is wrong, and what is allowed.
        problem: String,
    },
    /// A `[joint.NAME]` table for a joint the robot does not have.
    #[error(
        "servo configuration: [joint.{name}] names no joint of the robot (its joints: {known})"
    )]
    UnknownJoint {
        /// The name in the table.
        name: String,
        /// The robot's joints, comma-separated.
        known: String,
    },
    /// The servo works in N·m, so every joint needs its torque constant.
    #[error(
        "servo configuration: joint `{joint}` has no torque_constant_nm_per_amp in the robot \
         description; the servo commands torque in N·m: describe the joint's constant"
    )]
    NoTorqueConstant {
        /// The joint.
        joint: String,
    },
}
