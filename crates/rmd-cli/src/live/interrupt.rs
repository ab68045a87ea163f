//! Ctrl-C (SIGINT) and SIGTERM for the commands that move motors or run until stopped: the
//! project's one signal policy (`rmd_rig::signals`), as the examples have it.
//!
//! [`install`] replaces the default "terminate at once" behaviour: the command keeps control,
//! sees [`requested`] in its loop, stops its motors and exits with status 130
//! (`rmd_rig::signals::EXIT_INTERRUPTED`); a third signal exits at once. Install it only once
//! nothing blocks for long any more (after a confirmation prompt), since a blocked read no
//! longer ends on Ctrl-C.

use rmd_bus::{Clock, Timestamp};
use rmd_rig::signals;

/// Installs the handler (once per process; later calls return the first result).
pub(crate) fn install() -> Result<(), String> {
    signals::install().map(|_| ()).map_err(|e| e.to_string())
}

/// Installs the handler for a command that drives motors itself: until its motor-off went out
/// (`safe_stop::turn_off` says so), a third Ctrl-C waits for it before exiting.
pub(crate) fn install_driving() -> Result<(), String> {
    install()?;
    signals::driving_motors();
    Ok(())
}

/// Whether Ctrl-C (or SIGTERM) was received since [`install`].
pub(crate) fn requested() -> bool {
    signals::interrupted()
}

/// Sleeps until `deadline` on `clock`, waking regularly to check for Ctrl-C. Returns `false`
/// if interrupted (at once, not at the deadline).
pub(crate) fn sleep_until(clock: &dyn Clock, deadline: Timestamp) -> bool {
    match signals::install() {
        Ok(signals) => signals.sleep_until(clock, deadline),
        Err(_) => {
            clock.sleep_until(deadline);
            true
        }
    }
}
