//! The error of a name that is not one of the stable names rmd-rt accepts.

/// A name that is not one of the stable names rmd-rt accepts (protocol families, dialects, LK
/// motor series, motor models). `Copy` and allocation-free: the text lists the accepted names.
///
/// ```
/// use rmd_protocol::{NameError, ProtocolFamily};
/// let err = "v2".parse::<ProtocolFamily>().unwrap_err();
/// assert_eq!(err, NameError::Family);
/// assert_eq!(
///     err.to_string(),
///     "unknown protocol family: expected one of v1.61, lk-v2.3x, myactuator-v3, unknown"
/// );
/// ```
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash, thiserror::Error)]
#[non_exhaustive]
pub enum NameError {
    /// Not a protocol family name.
    #[error("unknown protocol family: expected one of v1.61, lk-v2.3x, myactuator-v3, unknown")]
    Family,
    /// Not a dialect rmd-rt can speak.
    #[error("unknown protocol: expected v1.61, lk-v2.3x or myactuator-v3")]
    Dialect,
    /// Not an LK-TECH motor series with a known current scale.
    #[error("unknown LK-TECH motor series: expected mf or mg")]
    LkSeries,
    /// `lk-v2.3x` without the motor series its current scale depends on.
    #[error(
        "protocol lk-v2.3x needs the LK-TECH motor series (mf or mg): its current scale depends on it"
    )]
    MissingLkSeries,
    /// Not a motor model of the table.
    #[error("unknown motor model: see rmd_protocol::MODELS for the known names")]
    Model,
}
