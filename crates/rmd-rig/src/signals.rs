//! One signal policy for every program of rmd-rt (the `rmd` tool and the examples): Ctrl-C
//! (SIGINT), SIGTERM and SIGHUP.
//!
//! - the first asks the watched loop to stop (zero torque, then motor off, then the report);
//!   commands without a loop see it with [`Signals::interrupted`] and stop their motors;
//! - the second is an emergency stop of the watched loop: its supervisor makes every motor safe
//!   at once, whatever the loop thread is doing;
//! - the third exits the process with status [`EXIT_INTERRUPTED`], as soon as motor-off has gone
//!   out on every bus (at most [`EXIT_WAIT`] later).
//!
//! A program that was stopped by a signal exits with [`EXIT_INTERRUPTED`] (130, as shells
//! report SIGINT) after its motors are safe.
//!
//! A signal that repeats the one before (the same signal from the same process, within
//! [`REPEAT_WINDOW`]) is that signal again, not a second request: GNU `timeout` sends its
//! signal to the command and then to the command's process group, which holds the command too,
//! so the command gets it twice, microseconds apart. It is not counted, and the notice thread
//! says so. A terminal's Ctrl-C comes from the kernel (no sending process), so pressing it twice
//! is always two requests.
//!
//! The handler runs on a thread of its own (`rmd-signal`, an ordinary thread, never the loop's),
//! fed by `signal-hook`'s iterator with each signal's sender, and is installed once per process
//! by [`install`].
//!
//! Invariant: the signal path acts and never writes. The handler only updates atomics, takes
//! the watched loop's stopper (from a mutex nobody holds across I/O or a wait) and asks the
//! loop to stop; it cannot fail and cannot block on output, whatever state stdout and stderr
//! are in (a hung-up terminal, a dead pipe, a full disk, a terminal nobody reads).
//! What it did is said on stderr by a thread of its own (`rmd-signal-notice`), best effort: a
//! write there that fails is lost, one that blocks holds only that thread. A panic in the
//! handler (there is none to expect) is caught, so the handler thread lives on and every later
//! signal still acts.

use std::io::Write;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::atomic::{AtomicBool, AtomicI32, AtomicU8, AtomicU32, AtomicU64, Ordering};
use std::sync::{Mutex, OnceLock, PoisonError};
use std::thread::Thread;
use std::time::{Duration, Instant};

use rmd_bus::{Clock, Timestamp};
use rmd_loop::Stopper;
use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
use signal_hook::iterator::SignalsInfo;
use signal_hook::iterator::exfiltrator::WithOrigin;

use crate::error::RigError;

/// Exit status of a program stopped by a signal (128 + SIGINT).
pub const EXIT_INTERRUPTED: u8 = 130;

/// How long the third signal waits for motor-off to go out before the process exits anyway.
pub const EXIT_WAIT: core::time::Duration = core::time::Duration::from_secs(2);

/// A signal from the same process as the one before, the same signal, read this soon after it,
/// repeats it (GNU `timeout`'s pair is microseconds apart; the window allows for the handler
/// thread waiting for a CPU on a loaded machine, and is far shorter than two deliberate
/// requests: a script that wants an emergency stop sends its second signal later).
pub const REPEAT_WINDOW: Duration = Duration::from_millis(100);

/// Signals received since the handler was installed.
static COUNT: AtomicU32 = AtomicU32::new(0);
/// The loop the signals stop, if one is watched.
static WATCHED: Mutex<Option<Stopper>> = Mutex::new(None);
/// A command drives motors itself (no loop): the third signal waits for its motor-off.
static MOVING: AtomicBool = AtomicBool::new(false);
/// That command has sent motor-off.
static OFF_SENT: AtomicBool = AtomicBool::new(false);
/// Whether the handler is installed (or why it could not be).
static INSTALLED: OnceLock<Result<(), String>> = OnceLock::new();
/// Notices the handler left for the notice thread ([`NOTICE_STOP`] | [`NOTICE_ESTOP`]).
static NOTICES: AtomicU8 = AtomicU8::new(0);
/// The thread that writes the notices (none if it could not start: the notices are then lost).
static NOTICE_THREAD: OnceLock<Thread> = OnceLock::new();
/// A notice: the first signal asked the watched loop to stop.
const NOTICE_STOP: u8 = 1;
/// A notice: the second signal was an emergency stop of the watched loop.
const NOTICE_ESTOP: u8 = 2;
/// A notice: a signal repeated the one before and was not counted ([`REPEATED`]).
const NOTICE_REPEAT: u8 = 4;
/// The last repeated signal, for its notice: its number, its sender, how long after the one it
/// repeated it was read (microseconds).
static REPEATED: (AtomicI32, AtomicI32, AtomicU64) =
    (AtomicI32::new(0), AtomicI32::new(0), AtomicU64::new(0));

/// One signal as the handler thread read it.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct Arrival {
    /// The signal (`SIGINT`, ...).
    pub signal: i32,
    /// The process that sent it; `None` when the kernel did (a terminal's Ctrl-C or hang-up).
    pub sender: Option<i32>,
    /// When it was read.
    pub at: Instant,
}

impl Arrival {
    /// Whether this arrival repeats `before`: the same signal from the same process, within
    /// [`REPEAT_WINDOW`].
    pub fn repeats(&self, before: &Arrival) -> bool {
        self.signal == before.signal
            && self.sender.is_some()
            && self.sender == before.sender
            && self.at.saturating_duration_since(before.at) < REPEAT_WINDOW
    }
}

/// Marks the start of a command that drives motors itself, without a loop (`rmd torque`,
/// `rmd move`): until [`motors_off_sent`] the third signal waits for its motor-off (at most
/// [`EXIT_WAIT`]) before the process exits.
pub fn driving_motors() {
    OFF_SENT.store(false, Ordering::SeqCst);
    MOVING.store(true, Ordering::SeqCst);
}

/// Tells the signal policy that the command's motor-off went out.
pub fn motors_off_sent() {
    OFF_SENT.store(true, Ordering::SeqCst);
}

/// Whether a signal was received since the handler was installed (false before).
pub fn interrupted() -> bool {
    COUNT.load(Ordering::SeqCst) > 0
}

/// Proof that the process's signal handler is installed; cheap to copy.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct Signals {
    _installed: (),
}

/// Installs the handler (once per process; later calls return the same result).
pub fn install() -> Result<Signals, RigError> {
    INSTALLED
        .get_or_init(|| {
            start_notices();
            let mut incoming = SignalsInfo::<WithOrigin>::new([SIGINT, SIGTERM, SIGHUP])
                .map_err(|e| format!("cannot handle SIGINT, SIGTERM and SIGHUP: {e}"))?;
            std::thread::Builder::new()
                .name("rmd-signal".to_owned())
                .spawn(move || {
                    let mut counted: Option<Arrival> = None;
                    for origin in incoming.forever() {
                        let arrival = Arrival {
                            signal: origin.signal,
                            sender: origin.process.map(|p| p.pid),
                            at: Instant::now(),
                        };
                        // Nothing in `on_signal` panics; should anything ever, this thread must
                        // live on for the next signal.
                        let _ = catch_unwind(AssertUnwindSafe(|| on_signal(arrival, &mut counted)));
                    }
                })
                .map(|_| ())
                .map_err(|e| format!("cannot start the signal thread: {e}"))
        })
        .clone()
        .map(|()| Signals { _installed: () })
        .map_err(RigError::Signals)
}

/// Starts the notice thread (best effort: without it the notices are lost, the signals still
/// act).
fn start_notices() {
    let spawned = std::thread::Builder::new()
        .name("rmd-signal-notice".to_owned())
        .spawn(|| {
            loop {
                std::thread::park();
                write_notices(NOTICES.swap(0, Ordering::AcqRel));
            }
        });
    if let Ok(handle) = spawned {
        let _ = NOTICE_THREAD.set(handle.thread().clone());
    }
}

/// Writes the notices `pending` stands for on stderr; an error is lost (docs/cli.md: a closed
/// stderr only loses messages).
fn write_notices(pending: u8) {
    let mut err = std::io::stderr().lock();
    if pending & NOTICE_STOP != 0 {
        let _ = err.write_all(
            b"\ninterrupted: stopping (zero torque, then motor off); again for an emergency stop\n",
        );
    }
    if pending & NOTICE_ESTOP != 0 {
        let _ = err
            .write_all(b"\ninterrupted again: EMERGENCY STOP; once more exits (after motor-off)\n");
    }
    if pending & NOTICE_REPEAT != 0 {
        let _ = err.write_all(
            repeat_notice(
                REPEATED.0.load(Ordering::Acquire),
                REPEATED.1.load(Ordering::Acquire),
                Duration::from_micros(REPEATED.2.load(Ordering::Acquire)),
            )
            .as_bytes(),
        );
    }
}

/// What the notice thread says of a signal that repeated the one before.
fn repeat_notice(signal: i32, sender: i32, after: Duration) -> String {
    let name = match signal {
        SIGINT => "SIGINT",
        SIGTERM => "SIGTERM",
        SIGHUP => "SIGHUP",
        _ => "signal",
    };
    format!(
        "\ninterrupted: {name} from process {sender} again, {:.1} ms after the first: taken as \
         the same request, not an emergency stop (GNU timeout signals a command, then its \
         process group); another signal is an emergency stop\n",
        after.as_secs_f64() * 1e3
    )
}

/// Leaves `notice` for the notice thread (never writes, never blocks).
fn notify(notice: u8) {
    NOTICES.fetch_or(notice, Ordering::AcqRel);
    if let Some(thread) = NOTICE_THREAD.get() {
        thread.unpark();
    }
}

/// Runs on the handler thread for every signal: acts, and leaves the telling to the notice
/// thread. `counted` is the last signal counted (a repeat of it is not counted).
fn on_signal(arrival: Arrival, counted: &mut Option<Arrival>) {
    if let Some(before) = counted
        && arrival.repeats(before)
        // Only while signals are counted: after `Signals::reset` a signal is a new request.
        && COUNT.load(Ordering::SeqCst) > 0
    {
        REPEATED.0.store(arrival.signal, Ordering::Release);
        REPEATED
            .1
            .store(arrival.sender.unwrap_or(0), Ordering::Release);
        let after = arrival.at.saturating_duration_since(before.at);
        REPEATED.2.store(
            u64::try_from(after.as_micros()).unwrap_or(u64::MAX),
            Ordering::Release,
        );
        notify(NOTICE_REPEAT);
        return;
    }
    *counted = Some(arrival);
    let count = COUNT.fetch_add(1, Ordering::SeqCst) + 1;
    // Held by nobody across I/O or a wait: `watch` and `Watch::drop` only swap the value.
    let watched = WATCHED
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .clone();
    match (count, watched) {
        (1, Some(stopper)) => {
            stopper.stop();
            notify(NOTICE_STOP);
        }
        (2, Some(stopper)) => {
            stopper.emergency_stop();
            notify(NOTICE_ESTOP);
        }
        (1 | 2, None) => {}
        (_, Some(stopper)) => {
            // Exit only once motor-off went out (the supervisor sends it at once after the
            // second signal), or after a bounded wait.
            stopper.emergency_stop();
            let give_up = std::time::Instant::now() + EXIT_WAIT;
            while !stopper.motors_off_sent() && std::time::Instant::now() < give_up {
                std::thread::sleep(core::time::Duration::from_millis(1));
            }
            std::process::exit(i32::from(EXIT_INTERRUPTED))
        }
        (_, None) => {
            // A command driving motors itself: exit once its motor-off went out, or after a
            // bounded wait.
            let give_up = std::time::Instant::now() + EXIT_WAIT;
            while MOVING.load(Ordering::SeqCst)
                && !OFF_SENT.load(Ordering::SeqCst)
                && std::time::Instant::now() < give_up
            {
                std::thread::sleep(core::time::Duration::from_millis(1));
            }
            std::process::exit(i32::from(EXIT_INTERRUPTED))
        }
    }
}

impl Signals {
    /// How many signals were received.
    pub fn count(&self) -> u32 {
        COUNT.load(Ordering::SeqCst)
    }

    /// Whether a signal was received.
    pub fn interrupted(&self) -> bool {
        self.count() > 0
    }

    /// Forgets the signals received so far (before another run in the same process, once the
    /// program decided to go on after an interrupted one).
    pub fn reset(&self) {
        COUNT.store(0, Ordering::SeqCst);
    }

    /// Makes signals stop the loop `stopper` belongs to, until the returned guard is dropped.
    /// A signal that came before (e.g. during start-up) stops it at once.
    pub fn watch(&self, stopper: Stopper) -> Watch {
        if self.interrupted() {
            stopper.stop();
        }
        *WATCHED.lock().unwrap_or_else(PoisonError::into_inner) = Some(stopper);
        Watch { _private: () }
    }

    /// Sleeps until `deadline` on `clock`, waking regularly to check for a signal. Returns
    /// `false` if interrupted (at once, not at the deadline).
    pub fn sleep_until(&self, clock: &dyn Clock, deadline: Timestamp) -> bool {
        const SLICE: core::time::Duration = core::time::Duration::from_millis(20);
        loop {
            if self.interrupted() {
                return false;
            }
            let now = clock.now();
            if now >= deadline {
                return true;
            }
            clock.sleep_until(deadline.min(now + SLICE));
        }
    }
}

/// While it lives, signals stop the watched loop.
#[derive(Debug)]
pub struct Watch {
    _private: (),
}

impl Drop for Watch {
    fn drop(&mut self) {
        *WATCHED.lock().unwrap_or_else(PoisonError::into_inner) = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn arrival(signal: i32, sender: Option<i32>, at: Instant) -> Arrival {
        Arrival { signal, sender, at }
    }

    #[test]
    fn the_same_signal_from_the_same_process_at_once_repeats_it() {
        let t0 = Instant::now();
        let first = arrival(SIGTERM, Some(4242), t0);
        // GNU timeout: the command, then its process group, microseconds apart.
        let group = arrival(SIGTERM, Some(4242), t0 + Duration::from_micros(40));
        assert!(group.repeats(&first));
        // Later than the window: a second request.
        let later = arrival(SIGTERM, Some(4242), t0 + REPEAT_WINDOW);
        assert!(!later.repeats(&first));
        // Another sender, another signal: a second request.
        assert!(!arrival(SIGTERM, Some(4243), group.at).repeats(&first));
        assert!(!arrival(SIGINT, Some(4242), group.at).repeats(&first));
        // A terminal's Ctrl-C comes from the kernel: twice is two requests, however quick.
        let key = arrival(SIGINT, None, t0);
        assert!(!arrival(SIGINT, None, t0 + Duration::from_millis(1)).repeats(&key));
    }

    #[test]
    fn a_repeat_is_not_counted_and_a_later_signal_is() {
        // No loop watched: the first two signals only count (a third would exit).
        COUNT.store(0, Ordering::SeqCst);
        let mut counted = None;
        let t0 = Instant::now();
        on_signal(arrival(SIGTERM, Some(4242), t0), &mut counted);
        on_signal(
            arrival(SIGTERM, Some(4242), t0 + Duration::from_micros(40)),
            &mut counted,
        );
        assert_eq!(COUNT.load(Ordering::SeqCst), 1);
        assert_eq!(REPEATED.1.load(Ordering::SeqCst), 4242);
        assert_eq!(REPEATED.2.load(Ordering::SeqCst), 40);
        on_signal(
            arrival(SIGTERM, Some(4242), t0 + REPEAT_WINDOW),
            &mut counted,
        );
        assert_eq!(COUNT.load(Ordering::SeqCst), 2);
        COUNT.store(0, Ordering::SeqCst);
    }

    #[test]
    fn the_notice_of_a_repeat_names_the_signal_the_sender_and_the_gap() {
        let notice = repeat_notice(SIGTERM, 4242, Duration::from_micros(40));
        assert!(
            notice.contains("SIGTERM from process 4242 again, 0.0 ms after the first"),
            "{notice}"
        );
        assert!(notice.contains("not an emergency stop"), "{notice}");
        assert!(notice.ends_with('\n'));
    }
}
