//! Clocks: the real monotonic clock, and a virtual clock for deterministic, faster-than-real-time
//! runs.

use core::time::Duration;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use crate::Timestamp;

/// A source of time that can also wait.
///
/// The loop, the simulator and the buses all read time through this trait, so the same code runs
/// in real time ([`MonotonicClock`]) or in virtual time ([`VirtualClock`]), where waiting simply
/// moves time forward.
pub trait Clock: Send {
    /// The current time.
    fn now(&self) -> Timestamp;

    /// Blocks until `deadline` (an absolute time); returns at once if it has passed.
    ///
    /// Real clocks sleep in the kernel (they may wake somewhat late); virtual clocks advance.
    fn sleep_until(&self, deadline: Timestamp);

    /// Busy-waits until `deadline` without yielding the CPU: the precise last step of a wait.
    ///
    /// Virtual clocks advance instead of spinning.
    fn spin_until(&self, deadline: Timestamp) {
        while self.now() < deadline {
            core::hint::spin_loop();
        }
    }

    /// Waits until `deadline`: sleeps until `spin_margin` before it, then busy-waits the rest
    /// (a zero margin only sleeps). The margin buys sub-microsecond precision for one busy CPU.
    ///
    /// ```
    /// use core::time::Duration;
    /// use rmd_bus::{Clock, VirtualClock};
    /// let clock = VirtualClock::new();
    /// let deadline = clock.now() + Duration::from_millis(1);
    /// clock.wait_until(deadline, Duration::from_micros(50));
    /// assert_eq!(clock.now(), deadline);
    /// ```
    fn wait_until(&self, deadline: Timestamp, spin_margin: Duration) {
        if spin_margin.is_zero() {
            self.sleep_until(deadline);
        } else {
            self.sleep_until(deadline.saturating_sub(spin_margin));
            self.spin_until(deadline);
        }
    }

    /// Whether time moves only when someone waits on the clock (a virtual clock): a run on it
    /// goes as fast as the CPU allows, and waiting in real time costs it no deadline (so its
    /// telemetry may wait for a slow consumer rather than drop). `false` for real clocks (the
    /// default).
    fn is_virtual(&self) -> bool {
        false
    }
}

/// The system's monotonic clock (`CLOCK_MONOTONIC` on Linux), sleeping with
/// `clock_nanosleep(TIMER_ABSTIME)` so that waits target absolute instants and never drift.
///
/// ```
/// use rmd_bus::{Clock, MonotonicClock};
/// let clock = MonotonicClock;
/// let t0 = clock.now();
/// clock.sleep_until(t0 + core::time::Duration::from_micros(100));
/// assert!(clock.now() >= t0 + core::time::Duration::from_micros(100));
/// ```
#[derive(Copy, Clone, Debug, Default)]
pub struct MonotonicClock;

#[cfg(target_os = "linux")]
impl Clock for MonotonicClock {
    #[inline]
    fn now(&self) -> Timestamp {
        // CLOCK_MONOTONIC cannot fail on Linux for a valid clock id; fall back to the epoch
        // rather than panic if it ever does.
        nix::time::clock_gettime(nix::time::ClockId::CLOCK_MONOTONIC)
            .map(timespec_to_timestamp)
            .unwrap_or(Timestamp::ZERO)
    }

    fn sleep_until(&self, deadline: Timestamp) {
        use nix::time::{ClockId, ClockNanosleepFlags, clock_nanosleep};
        // A deadline that has passed needs no system call (a clock read is ~30 ns, a system
        // call in a virtual machine up to a microsecond).
        if self.now() >= deadline {
            return;
        }
        let ns = deadline.as_nanos();
        let request = nix::sys::time::TimeSpec::new(
            (ns / 1_000_000_000) as nix::libc::time_t,
            (ns % 1_000_000_000) as nix::libc::c_long,
        );
        // With TIMER_ABSTIME an interrupted sleep can simply be restarted with the same request.
        while let Err(nix::errno::Errno::EINTR) = clock_nanosleep(
            ClockId::CLOCK_MONOTONIC,
            ClockNanosleepFlags::TIMER_ABSTIME,
            &request,
        ) {}
    }
}

#[cfg(target_os = "linux")]
#[inline]
fn timespec_to_timestamp(ts: nix::sys::time::TimeSpec) -> Timestamp {
    let secs = ts.tv_sec().max(0) as u64;
    let nanos = ts.tv_nsec().max(0) as u64;
    Timestamp::from_nanos(secs.saturating_mul(1_000_000_000).saturating_add(nanos))
}

#[cfg(not(target_os = "linux"))]
impl Clock for MonotonicClock {
    fn now(&self) -> Timestamp {
        use std::sync::OnceLock;
        use std::time::Instant;
        static EPOCH: OnceLock<Instant> = OnceLock::new();
        let epoch = EPOCH.get_or_init(Instant::now);
        Timestamp::from_nanos(epoch.elapsed().as_nanos() as u64)
    }

    fn sleep_until(&self, deadline: Timestamp) {
        let now = self.now();
        if deadline > now {
            std::thread::sleep(deadline - now);
        }
    }
}

/// A clock whose time only moves when someone waits on it: deterministic and as fast as the
/// computation allows.
///
/// Clones share one time line, so a loop and a simulated bus holding clones of the same
/// `VirtualClock` see the same time. Time never goes backwards: waiting for a past instant
/// leaves the clock where it is.
///
/// ```
/// use core::time::Duration;
/// use rmd_bus::{Clock, Timestamp, VirtualClock};
/// let clock = VirtualClock::new();
/// let bus_side = clock.clone();
/// clock.sleep_until(Timestamp::ZERO + Duration::from_millis(1));
/// assert_eq!(bus_side.now().as_nanos(), 1_000_000);
/// ```
#[derive(Clone, Debug, Default)]
pub struct VirtualClock {
    nanos: Arc<AtomicU64>,
}

impl VirtualClock {
    /// A virtual clock at its epoch (time zero).
    pub fn new() -> Self {
        Self::default()
    }

    /// A virtual clock starting at `start`.
    pub fn starting_at(start: Timestamp) -> Self {
        Self {
            nanos: Arc::new(AtomicU64::new(start.as_nanos())),
        }
    }

    /// Moves time forward by `d`.
    pub fn advance(&self, d: Duration) {
        let now = self.now();
        self.sleep_until(now + d);
    }
}

impl Clock for VirtualClock {
    #[inline]
    fn now(&self) -> Timestamp {
        Timestamp::from_nanos(self.nanos.load(Ordering::Acquire))
    }

    #[inline]
    fn sleep_until(&self, deadline: Timestamp) {
        self.nanos.fetch_max(deadline.as_nanos(), Ordering::AcqRel);
    }

    fn spin_until(&self, deadline: Timestamp) {
        self.sleep_until(deadline);
    }

    fn is_virtual(&self) -> bool {
        true
    }
}

impl<C: Clock + Sync + ?Sized> Clock for &C {
    fn now(&self) -> Timestamp {
        (**self).now()
    }
    fn sleep_until(&self, deadline: Timestamp) {
        (**self).sleep_until(deadline)
    }
    fn spin_until(&self, deadline: Timestamp) {
        (**self).spin_until(deadline)
    }
    fn is_virtual(&self) -> bool {
        (**self).is_virtual()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn virtual_clock_never_goes_backwards() {
        let clock = VirtualClock::starting_at(Timestamp::from_nanos(500));
        clock.sleep_until(Timestamp::from_nanos(100));
        assert_eq!(clock.now().as_nanos(), 500);
        clock.spin_until(Timestamp::from_nanos(900));
        assert_eq!(clock.now().as_nanos(), 900);
        clock.advance(Duration::from_nanos(100));
        assert_eq!(clock.now().as_nanos(), 1_000);
        assert!(clock.is_virtual() && Clock::is_virtual(&&clock));
        assert!(!MonotonicClock.is_virtual());
    }

    #[test]
    fn monotonic_clock_sleeps_to_an_absolute_deadline() {
        let clock = MonotonicClock;
        let start = clock.now();
        let deadline = start + Duration::from_millis(2);
        clock.sleep_until(deadline);
        assert!(clock.now() >= deadline);
        // A past deadline returns without sleeping (no assertion on time: shared VM).
        clock.sleep_until(start);
    }
}
