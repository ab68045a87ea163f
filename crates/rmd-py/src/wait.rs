//! Blocking calls that Ctrl-C interrupts. A call waits with the GIL released (other Python
//! threads run), but Python runs its signal handlers only in the main thread, between bytecodes:
//! a call that waited in Rust for its whole duration would hold back `KeyboardInterrupt` until
//! it returned. So every wait is cut into slices of at most [`SIGNAL_CHECK`], and Python's
//! signal handlers run between two slices: Ctrl-C raises `KeyboardInterrupt` (or whatever the
//! program's SIGINT handler raises) from the call within one slice.

use std::time::{Duration, Instant};

use pyo3::prelude::*;

/// The longest a blocking call waits without running Python's signal handlers.
pub(crate) const SIGNAL_CHECK: Duration = Duration::from_millis(10);

/// Calls `step` with the GIL released until it returns `Some`, running Python's signal handlers
/// between two calls; `step` gets the instant by which it returns (at most [`SIGNAL_CHECK`]
/// ahead). The error of a handler (`KeyboardInterrupt`) ends the wait.
pub(crate) fn interruptible<T: Send>(
    py: Python<'_>,
    mut step: impl FnMut(Instant) -> Option<T> + Send,
) -> PyResult<T> {
    loop {
        let until = Instant::now() + SIGNAL_CHECK;
        if let Some(done) = py.detach(|| step(until)) {
            return Ok(done);
        }
        py.check_signals()?;
    }
}

/// Runs Python's signal handlers from code that waits with the GIL released (it takes the GIL
/// for that): the error of a handler, if one raised.
pub(crate) fn signals_raised() -> Option<PyErr> {
    Python::attach(|py| py.check_signals().err())
}
