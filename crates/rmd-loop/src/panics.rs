//! Panics on the loop thread: caught by the loop, and reported only after the motors are safe.
//!
//! The standard panic hook prints the message and, with `RUST_BACKTRACE` set, symbolises a
//! backtrace at once, on the panicking thread: tens of milliseconds during which the motors would
//! keep their last torque. While a thread runs a loop, the hook installed here only records the
//! panic (message, location, and the backtrace's frames when `RUST_BACKTRACE` asks for one,
//! unresolved); the loop makes the motors safe, then puts the record in its report, where the
//! backtrace is resolved. Panics on other threads go to the hook that was installed before.
//!
//! A program that installs its own panic hook after starting a loop replaces this one: the
//! loop still catches panics, but the backtrace is then symbolised before the motors are safe.

use std::backtrace::{Backtrace, BacktraceStatus};
use std::cell::{Cell, RefCell};
use std::sync::Once;

/// What a panic on the loop thread left behind.
#[derive(Debug)]
pub(crate) struct PanicRecord {
    /// Where it happened (`file:line:column`).
    pub(crate) location: Option<String>,
    /// The backtrace, if `RUST_BACKTRACE` asked for one (resolved only when printed).
    pub(crate) backtrace: Option<Backtrace>,
}

thread_local! {
    /// Whether this thread is running a loop (its panics are recorded, not printed).
    static IN_LOOP: Cell<bool> = const { Cell::new(false) };
    /// The last panic recorded on this thread.
    static RECORD: RefCell<Option<PanicRecord>> = const { RefCell::new(None) };
}

static INSTALL: Once = Once::new();

/// Installs the hook (once per process) and marks the calling thread as a loop thread until
/// [`leave`] is called.
pub(crate) fn enter() {
    INSTALL.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if IN_LOOP.with(Cell::get) {
                let backtrace = Backtrace::capture();
                let record = PanicRecord {
                    location: info.location().map(ToString::to_string),
                    backtrace: (backtrace.status() == BacktraceStatus::Captured)
                        .then_some(backtrace),
                };
                RECORD.with(|r| *r.borrow_mut() = Some(record));
            } else {
                previous(info);
            }
        }));
    });
    IN_LOOP.with(|f| f.set(true));
    RECORD.with(|r| *r.borrow_mut() = None);
}

/// Ends the loop's watch of this thread's panics.
pub(crate) fn leave() {
    IN_LOOP.with(|f| f.set(false));
}

/// The last panic recorded on this thread, taken.
pub(crate) fn take_record() -> Option<PanicRecord> {
    RECORD.with(|r| r.borrow_mut().take())
}
