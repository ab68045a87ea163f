//! Why a robot description cannot be used.

use core::fmt;

/// A robot description that could not be used: unreadable, not TOML, or a value out of range.
/// The message names the file (when the description came from one) and the key
/// (`bus[0].motor[2].id`), and says what is allowed.
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
    #[error("robot description{}: {message}", InFile(.file))]
    Parse {
        /// The file, when the description was read from one.
        file: Option<String>,
        /// What the TOML parser says (it names the key and the line).
        message: String,
    },
    /// A value is out of range or inconsistent.
    #[error("robot description{}: `{key}` {problem}", InFile(.file))]
    Invalid {
        /// The file, when the description was read from one.
        file: Option<String>,
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

impl RobotError {
    /// The same error, naming `file` as the description it is about (when it does not name one
    /// yet).
    pub(crate) fn in_file(mut self, path: Option<&str>) -> Self {
        if let (RobotError::Parse { file, .. } | RobotError::Invalid { file, .. }, Some(path)) =
            (&mut self, path)
        {
            file.get_or_insert_with(|| path.to_string());
        }
        self
    }
}

/// ` FILE` when there is a file.
struct InFile<'a>(&'a Option<String>);

impl fmt::Display for InFile<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            Some(file) => write!(f, " {file}"),
            None => Ok(()),
        }
    }
}

pub(crate) fn invalid(key: impl Into<String>, problem: impl Into<String>) -> RobotError {
    RobotError::Invalid {
        file: None,
        key: key.into(),
        problem: problem.into(),
    }
}

pub(crate) fn parse_error(message: impl Into<String>) -> RobotError {
    RobotError::Parse {
        file: None,
        message: message.into(),
    }
}

/// A number as a person reads it: `1e308` rather than 309 digits, `0.25` as it is.
pub(crate) struct Shown(pub(crate) f64);

impl fmt::Display for Shown {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = self.0;
        if v.is_finite() && v != 0.0 && !(1e-4..1e9).contains(&v.abs()) {
            write!(f, "{v:e}")
        } else {
            write!(f, "{v}")
        }
    }
}
