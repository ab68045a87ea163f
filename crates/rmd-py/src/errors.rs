//! The exceptions of `rmd_rt`: one base, `RmdError`, and one class per kind of failure. Every
//! message is the Rust error's `Display`, which says what is wrong and what to do.

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;

create_exception!(
    rmd_rt,
    RmdError,
    PyException,
    "Base class of every error rmd_rt raises."
);
create_exception!(
    rmd_rt,
    ProtocolError,
    RmdError,
    "A value that does not fit the protocol (encode), or a frame that cannot be read (decode); \
     the message is the one `rmd encode` / `rmd decode` prints."
);
create_exception!(
    rmd_rt,
    BusError,
    RmdError,
    "The bus failed: it could not be opened, a frame could not be sent, or a motor answered \
     with something unexpected."
);
create_exception!(
    rmd_rt,
    NoReplyError,
    BusError,
    "A motor did not answer within the timeout, after every retry."
);
create_exception!(
    rmd_rt,
    RomWriteNotConfirmed,
    RmdError,
    "A command that writes the motor's ROM (flash) was asked for without \
     confirm_rom_write=True; nothing was sent."
);
create_exception!(
    rmd_rt,
    ConfigError,
    RmdError,
    "A robot description, servo configuration or placement (sim / iface) is not valid."
);
create_exception!(
    rmd_rt,
    ServoError,
    RmdError,
    "The servo refused a setpoint or a trajectory (unknown joint, beyond a limit, disabled, \
     e-stopped, queue full, ...); nothing was sent."
);
create_exception!(
    rmd_rt,
    LoopError,
    RmdError,
    "The real-time loop could not start, or is no longer running."
);
create_exception!(
    rmd_rt,
    TrajectoryError,
    RmdError,
    "rmd-traj could not calculate a trajectory for the input (the message names the axis and \
     the reason)."
);
create_exception!(
    rmd_rt,
    TelemetryError,
    RmdError,
    "A telemetry sink (MCAP file, live Foxglove server) could not be started."
);

/// Adds the exception classes to the module.
pub(crate) fn register(py: Python<'_>, m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("RmdError", py.get_type::<RmdError>())?;
    m.add("ProtocolError", py.get_type::<ProtocolError>())?;
    m.add("BusError", py.get_type::<BusError>())?;
    m.add("NoReplyError", py.get_type::<NoReplyError>())?;
    m.add(
        "RomWriteNotConfirmed",
        py.get_type::<RomWriteNotConfirmed>(),
    )?;
    m.add("ConfigError", py.get_type::<ConfigError>())?;
    m.add("ServoError", py.get_type::<ServoError>())?;
    m.add("LoopError", py.get_type::<LoopError>())?;
    m.add("TrajectoryError", py.get_type::<TrajectoryError>())?;
    m.add("TelemetryError", py.get_type::<TelemetryError>())?;
    Ok(())
}
