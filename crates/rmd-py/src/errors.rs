//! The exceptions of `rmd_rt`, and the one place where Rust failures become them.
//!
//! The classes are defined in Python (`python/rmd_rt/_errors.py`: several derive from two
//! bases, e.g. `SetpointError(ServoError, ArgumentError)`, which pyo3's `create_exception!`
//! cannot make) and imported here. Every message is the Rust error's `Display`, which says what
//! is wrong and what to do.
//!
//! [`guard`] runs the body of every exported function and method: a panic there (a bug) becomes
//! `InternalError`, an `RmdError`, never pyo3's `PanicException` (a `BaseException` that
//! `except Exception` does not catch).

use std::panic::{AssertUnwindSafe, catch_unwind};

use pyo3::prelude::*;

pyo3::import_exception!(rmd_rt._errors, RmdError);
pyo3::import_exception!(rmd_rt._errors, ArgumentError);
pyo3::import_exception!(rmd_rt._errors, ProtocolError);
pyo3::import_exception!(rmd_rt._errors, TrajectoryError);
pyo3::import_exception!(rmd_rt._errors, ConfigError);
pyo3::import_exception!(rmd_rt._errors, BusError);
pyo3::import_exception!(rmd_rt._errors, NoReplyError);
pyo3::import_exception!(rmd_rt._errors, RomWriteNotConfirmed);
pyo3::import_exception!(rmd_rt._errors, ServoError);
pyo3::import_exception!(rmd_rt._errors, SetpointError);
pyo3::import_exception!(rmd_rt._errors, LimitError);
pyo3::import_exception!(rmd_rt._errors, LoopError);
pyo3::import_exception!(rmd_rt._errors, LoopStoppedError);
pyo3::import_exception!(rmd_rt._errors, ForkedProcessError);
pyo3::import_exception!(rmd_rt._errors, TelemetryError);
pyo3::import_exception!(rmd_rt._errors, InternalError);

/// Runs `body`, turning a panic into `InternalError` (the panic's message, and that it is a bug).
pub(crate) fn guard<T>(body: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
    catch_unwind(AssertUnwindSafe(body)).unwrap_or_else(|payload| {
        let message = payload
            .downcast_ref::<&str>()
            .map(|s| (*s).to_owned())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "no message".to_owned());
        Err(InternalError::new_err(format!(
            "rmd_rt hit a bug (a Rust panic: {message}); the call did nothing more. Please \
             report it with the call that raised this"
        )))
    })
}

/// The exception of a refusal by the servo: the request itself wrong (`SetpointError`, and
/// `LimitError` for a value outside a joint's limits), the loop ended (`LoopStoppedError`), or
/// the servo unable to take it now (`ServoError`).
pub(crate) fn servo_error(error: rmd_servo::ServoError) -> PyErr {
    use rmd_servo::{ServoError as E, TrajectoryRefusal as T};
    let message = error.to_string();
    match error {
        E::OutOfLimit { .. }
        | E::Trajectory(T::OutOfLimit { .. } | T::LeavesPositionLimits { .. }) => {
            LimitError::new_err(message)
        }
        E::UnknownJoint { .. }
        | E::UnknownJointId { .. }
        | E::NotFinite { .. }
        | E::DuplicateJoint { .. }
        | E::Trajectory(
            T::NoJoints
            | T::NoPoints
            | T::TooManyPoints { .. }
            | T::LengthMismatch { .. }
            | T::TimeNotIncreasing { .. }
            | T::StartNotFinite(_)
            | T::NotFinite { .. }
            | T::EndsMoving { .. }
            | T::Plan { .. },
        ) => SetpointError::new_err(message),
        E::EStopped | E::Stopped => LoopStoppedError::new_err(format!(
            "{message} (the loop has ended and its motors were made safe: stop() returns its \
             report; start a new loop to go on)"
        )),
        E::Disabled | E::QueueFull { .. } | E::NoTrajectoryBuffer { .. } | E::NoState => {
            ServoError::new_err(message)
        }
    }
}
