//! Configuration errors of the simulator.

/// A simulator configuration that cannot be used. `Copy` and allocation-free; the text says
/// which value is wrong and what was expected.
///
/// ```
/// use rmd_sim::{ConfigError, MotorParams};
/// let p = MotorParams { gear_ratio: 0.0, ..MotorParams::default() };
/// let err = p.validate().unwrap_err();
/// assert_eq!(err.to_string(), "parameter gear_ratio = 0: expected a finite number > 0");
/// ```
#[derive(Copy, Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ConfigError {
    /// A numeric parameter is out of its meaningful range (or not finite).
    #[error("parameter {name} = {value}: expected {expected}")]
    InvalidParameter {
        /// The parameter's name.
        name: &'static str,
        /// The value given.
        value: f64,
        /// What would be valid.
        expected: &'static str,
    },
    /// Two motors of one simulation have the same id.
    #[error("motor id {id} is configured twice: ids on one bus must be unique")]
    DuplicateMotor {
        /// The repeated id.
        id: u8,
    },
    /// A fault rule is not meaningful.
    #[error("fault rule #{index}: {reason}")]
    InvalidFaultRule {
        /// Position of the rule in the order it was added (0-based).
        index: usize,
        /// What is wrong with it.
        reason: &'static str,
    },
}
