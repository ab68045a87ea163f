//! Ctrl-C (SIGINT) and SIGTERM for the commands that move motors or run until stopped.
//!
//! [`install`] replaces the default "terminate at once" behaviour with a flag: the command
//! keeps control, sees [`requested`] in its loop, stops its motors and exits with
//! [`INTERRUPTED`](crate::output::report::INTERRUPTED). Install it only once nothing blocks for long any more (after a confirmation
//! prompt), since a blocked read no longer ends on Ctrl-C.

use std::sync::OnceLock;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use rmd_bus::{Clock, Timestamp};

static REQUESTED: AtomicBool = AtomicBool::new(false);
static INSTALLED: OnceLock<Result<(), String>> = OnceLock::new();

/// Installs the handler (once per process; later calls return the first result).
pub(crate) fn install() -> Result<(), String> {
    INSTALLED
        .get_or_init(|| {
            ctrlc::set_handler(|| REQUESTED.store(true, Ordering::SeqCst))
                .map_err(|e| format!("cannot install the Ctrl-C handler: {e}"))
        })
        .clone()
}

/// Whether Ctrl-C (or SIGTERM) was received since [`install`].
pub(crate) fn requested() -> bool {
    REQUESTED.load(Ordering::SeqCst)
}

/// Longest stretch slept without looking at the flag.
const SLICE: Duration = Duration::from_millis(20);

/// Sleeps until `deadline` on `clock`, waking regularly to check for Ctrl-C. Returns `false`
/// if interrupted (at once, not at the deadline).
pub(crate) fn sleep_until(clock: &dyn Clock, deadline: Timestamp) -> bool {
    loop {
        if requested() {
            return false;
        }
        let now = clock.now();
        if now >= deadline {
            return true;
        }
        clock.sleep_until(deadline.min(now + SLICE));
    }
}
