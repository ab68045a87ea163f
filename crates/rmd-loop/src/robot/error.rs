//! Why a robot description cannot be used.

/// A robot description that could not be used: unreadable, not TOML, or a value out of range.
/// The message names the key (`bus[0].motor[2].id`) and what is allowed.
#[derive(Debug, thiserror::Error)]
pub enum RobotError {
    /// The file could not be read.
    #[error("cannot read robot description {path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The text is not valid TOML, or a key is unknown or of the wrong type.
    #[error("robot description: {0}")]
    Parse(String),
    /// A value is out of range or inconsistent.
    #[error("robot description: `{key}` {problem}")]
    Invalid {
        /// The key, as a path (e.g. `bus[0].motor[2].id`).
        key: String,
        /// What is wrong, and what is allowed.
        problem: String,
    },
    /// A joint name that the description does not have.
    #[error("the robot has no joint named `{name}` (its joints: {known})")]
    UnknownJoint {
        /// The name asked for.
        name: String,
        /// The names it has, comma-separated.
        known: String,
    },
}

pub(crate) fn invalid(key: impl Into<String>, problem: impl Into<String>) -> RobotError {
    RobotError::Invalid {
        key: key.into(),
        problem: problem.into(),
    }
}
