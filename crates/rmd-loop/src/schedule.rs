//! The cyclic scheduler: absolute deadlines `t0 + k * period`, a precise wait (sleep, then an
//! optional short spin), and overrun handling. The real-time loop and `rmd bench jitter` both
//! run on this code.

use core::time::Duration;

use rmd_bus::{Clock, Timestamp};
use serde::{Deserialize, Serialize};

/// Shortest period the loop accepts (100 kHz).
pub const MIN_PERIOD: Duration = Duration::from_micros(10);
/// Longest period the loop accepts.
pub const MAX_PERIOD: Duration = Duration::from_secs(10);

/// Why a rate or period was refused.
#[derive(Copy, Clone, Debug, PartialEq, thiserror::Error)]
pub enum RateError {
    /// The rate is zero, negative or not a number.
    #[error("loop rate {hz} Hz is not a positive number")]
    NotPositive {
        /// The rate given.
        hz: f64,
    },
    /// The period is shorter than [`MIN_PERIOD`].
    #[error("loop period {period:?} is shorter than the minimum {MIN_PERIOD:?} (100 kHz)")]
    TooFast {
        /// The period asked for.
        period: Duration,
    },
    /// The period is longer than [`MAX_PERIOD`].
    #[error("loop period {period:?} is longer than the maximum {MAX_PERIOD:?}")]
    TooSlow {
        /// The period asked for.
        period: Duration,
    },
}

/// A validated loop period.
///
/// ```
/// use rmd_loop::schedule::Period;
/// let p = Period::from_hz(1000.0).unwrap();
/// assert_eq!(p.get(), core::time::Duration::from_millis(1));
/// assert!(Period::from_hz(0.0).is_err());
/// assert!(Period::from_hz(f64::NAN).is_err());
/// ```
#[derive(Copy, Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Period(Duration);

impl Period {
    /// The period of a loop running at `hz`, rounded to the nanosecond.
    pub fn from_hz(hz: f64) -> Result<Self, RateError> {
        if !(hz.is_finite() && hz > 0.0) {
            return Err(RateError::NotPositive { hz });
        }
        let nanos = (1e9 / hz).round();
        if nanos > MAX_PERIOD.as_nanos() as f64 {
            return Err(RateError::TooSlow {
                period: Duration::try_from_secs_f64(1.0 / hz).unwrap_or(Duration::MAX),
            });
        }
        Self::new(Duration::from_nanos(nanos as u64))
    }

    /// A period given directly.
    pub fn new(period: Duration) -> Result<Self, RateError> {
        if period < MIN_PERIOD {
            Err(RateError::TooFast { period })
        } else if period > MAX_PERIOD {
            Err(RateError::TooSlow { period })
        } else {
            Ok(Self(period))
        }
    }

    /// The period.
    pub const fn get(self) -> Duration {
        self.0
    }

    /// The rate in Hz.
    pub fn hz(self) -> f64 {
        1.0 / self.0.as_secs_f64()
    }
}

/// What the scheduler does when a tick's work runs past the start of the next tick.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case", tag = "policy")]
pub enum OverrunPolicy {
    /// Count the miss and run the missed tick(s) right away, back to back, until the loop has
    /// caught up with the schedule. Beware: on a bus this sends 0x280 frames in a burst, closer
    /// together than the motors can answer.
    Continue,
    /// Count the miss and skip the ticks whose start has passed, so that the loop stays aligned
    /// to `t0 + k * period` and never sends a burst of frames (the default).
    #[default]
    Skip,
    /// Like `Continue`, but `after` consecutive misses are a fault that stops the loop.
    Fault {
        /// Consecutive misses that make a fault (at least 1).
        after: u32,
    },
}

/// When and how the current tick started.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct TickTiming {
    /// Tick number: tick `k` is due at `t0 + k * period`.
    pub index: u64,
    /// When the tick was due.
    pub scheduled: Timestamp,
    /// When the thread actually woke for it.
    pub woke: Timestamp,
    /// Ticks skipped just before this one (only with [`OverrunPolicy::Skip`]).
    pub skipped: u64,
}

impl TickTiming {
    /// How late the thread woke: `woke - scheduled` (zero if it woke early, which only a spin
    /// on a coarse clock can do).
    pub fn wake_latency(&self) -> Duration {
        self.woke - self.scheduled
    }
}

/// The outcome of a finished tick.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct TickEnd {
    /// The tick's work ended after the next tick was due.
    pub missed_deadline: bool,
    /// Consecutive ticks that missed their deadline, this one included.
    pub consecutive_misses: u32,
    /// The overrun policy says the loop must stop.
    pub fault: bool,
}

/// Absolute-deadline cyclic scheduler.
///
/// ```
/// use core::time::Duration;
/// use rmd_bus::{Clock, VirtualClock};
/// use rmd_loop::schedule::{OverrunPolicy, Period, Scheduler};
///
/// let clock = VirtualClock::new();
/// let period = Period::from_hz(1000.0).unwrap();
/// let mut sched = Scheduler::new(period, Duration::ZERO, OverrunPolicy::Continue, clock.now());
/// for k in 0..3 {
///     let tick = sched.wait_next(&clock);
///     assert_eq!(tick.index, k);
///     assert_eq!(tick.scheduled.as_nanos(), k * 1_000_000);
///     let end = sched.end_tick(clock.now());
///     assert!(!end.missed_deadline);
/// }
/// ```
#[derive(Clone, Debug)]
pub struct Scheduler {
    period: Duration,
    /// The period in nanoseconds (deadlines are integer arithmetic on the clock's nanoseconds).
    period_ns: u64,
    spin_margin: Duration,
    policy: OverrunPolicy,
    t0: Timestamp,
    next: u64,
    current: u64,
    consecutive_misses: u32,
}

impl Scheduler {
    /// A scheduler whose tick 0 is due at `t0`. Each wait sleeps until `spin_margin` before the
    /// deadline, then busy-waits the rest (a zero margin sleeps all the way).
    pub fn new(
        period: Period,
        spin_margin: Duration,
        policy: OverrunPolicy,
        t0: Timestamp,
    ) -> Self {
        Self {
            period: period.get(),
            // A period is at most MAX_PERIOD (10 s): it fits.
            period_ns: u64::try_from(period.get().as_nanos()).unwrap_or(u64::MAX),
            spin_margin: spin_margin.min(period.get()),
            policy,
            t0,
            next: 0,
            current: 0,
            consecutive_misses: 0,
        }
    }

    /// The period.
    pub fn period(&self) -> Duration {
        self.period
    }

    /// The index of the tick [`wait_next`](Self::wait_next) returns next, unless it skips.
    pub fn next_index(&self) -> u64 {
        self.next
    }

    /// When tick `index` is due.
    pub fn scheduled(&self, index: u64) -> Timestamp {
        let nanos = index.saturating_mul(self.period_ns);
        Timestamp::from_nanos(self.t0.as_nanos().saturating_add(nanos))
    }

    /// Waits for the next tick and returns its timing.
    pub fn wait_next<C: Clock + ?Sized>(&mut self, clock: &C) -> TickTiming {
        let mut skipped = 0;
        if self.policy == OverrunPolicy::Skip {
            // Skip every tick whose start has already passed: the next one runs on its slot.
            let now = clock.now();
            while self.scheduled(self.next) < now {
                self.next += 1;
                skipped += 1;
            }
        }
        let index = self.next;
        let scheduled = self.scheduled(index);
        clock.wait_until(scheduled, self.spin_margin);
        let woke = clock.now();
        self.current = index;
        self.next = index + 1;
        TickTiming {
            index,
            scheduled,
            woke,
            skipped,
        }
    }

    /// Records that the current tick's work ended at `end` and applies the overrun policy.
    #[inline]
    pub fn end_tick(&mut self, end: Timestamp) -> TickEnd {
        let missed_deadline = end > self.scheduled(self.current + 1);
        if missed_deadline {
            self.consecutive_misses = self.consecutive_misses.saturating_add(1);
        } else {
            self.consecutive_misses = 0;
        }
        let fault = match self.policy {
            OverrunPolicy::Fault { after } => self.consecutive_misses >= after.max(1),
            _ => false,
        };
        TickEnd {
            missed_deadline,
            consecutive_misses: self.consecutive_misses,
            fault,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rmd_bus::VirtualClock;

    #[test]
    fn absurd_rates_are_errors_not_panics() {
        for hz in [
            1e-300,
            1e-30,
            f64::MIN_POSITIVE,
            0.0,
            -1.0,
            f64::NAN,
            f64::INFINITY,
            1e300,
        ] {
            assert!(Period::from_hz(hz).is_err(), "{hz}");
        }
        assert!(matches!(
            Period::from_hz(1e-300),
            Err(RateError::TooSlow { period }) if period == Duration::MAX
        ));
    }

    fn ms(n: u64) -> Duration {
        Duration::from_millis(n)
    }

    fn sched(policy: OverrunPolicy) -> (VirtualClock, Scheduler) {
        let clock = VirtualClock::new();
        let s = Scheduler::new(
            Period::new(ms(1)).unwrap(),
            Duration::ZERO,
            policy,
            clock.now(),
        );
        (clock, s)
    }

    #[test]
    fn rates_are_validated() {
        assert!(matches!(
            Period::from_hz(-1.0),
            Err(RateError::NotPositive { .. })
        ));
        assert!(matches!(
            Period::from_hz(f64::INFINITY),
            Err(RateError::NotPositive { .. })
        ));
        assert!(matches!(
            Period::from_hz(1e6),
            Err(RateError::TooFast { .. })
        ));
        assert!(matches!(
            Period::from_hz(0.01),
            Err(RateError::TooSlow { .. })
        ));
        assert_eq!(Period::from_hz(3000.0).unwrap().get().as_nanos(), 333_333);
    }

    #[test]
    fn deadlines_are_absolute_and_do_not_drift() {
        let (clock, mut s) = sched(OverrunPolicy::Continue);
        for k in 0..1000u64 {
            let t = s.wait_next(&clock);
            assert_eq!(t.scheduled.as_nanos(), k * 1_000_000);
            // Uneven work inside the tick must not shift later deadlines.
            clock.advance(Duration::from_micros(100 + (k % 7) * 50));
            assert!(!s.end_tick(clock.now()).missed_deadline);
        }
    }

    #[test]
    fn continue_runs_missed_ticks_back_to_back() {
        let (clock, mut s) = sched(OverrunPolicy::Continue);
        s.wait_next(&clock);
        clock.advance(Duration::from_micros(2_500)); // overruns ticks 1 and 2
        let end = s.end_tick(clock.now());
        assert!(end.missed_deadline);
        let t1 = s.wait_next(&clock);
        assert_eq!((t1.index, t1.skipped), (1, 0));
        assert_eq!(t1.wake_latency(), Duration::from_micros(1_500));
        assert!(s.end_tick(clock.now()).missed_deadline); // still behind: tick 2 was due at 2 ms
        let t2 = s.wait_next(&clock);
        assert_eq!(t2.index, 2);
        assert!(!s.end_tick(clock.now()).missed_deadline);
    }

    #[test]
    fn skip_stays_phase_aligned() {
        let (clock, mut s) = sched(OverrunPolicy::Skip);
        s.wait_next(&clock);
        clock.advance(Duration::from_micros(2_500));
        assert!(s.end_tick(clock.now()).missed_deadline);
        let t = s.wait_next(&clock);
        assert_eq!(t.index, 3);
        assert_eq!(t.skipped, 2);
        assert_eq!(t.scheduled.as_nanos(), 3_000_000);
        assert_eq!(t.wake_latency(), Duration::ZERO);
    }

    #[test]
    fn fault_after_n_consecutive_misses() {
        let (clock, mut s) = sched(OverrunPolicy::Fault { after: 3 });
        let mut faults = vec![];
        for _ in 0..4 {
            s.wait_next(&clock);
            clock.advance(Duration::from_micros(1_100));
            faults.push(s.end_tick(clock.now()));
        }
        assert_eq!(
            faults
                .iter()
                .map(|e| e.consecutive_misses)
                .collect::<Vec<_>>(),
            [1, 2, 3, 4]
        );
        assert_eq!(
            faults.iter().map(|e| e.fault).collect::<Vec<_>>(),
            [false, false, true, true]
        );
        // A tick on time resets the count.
        s.wait_next(&clock);
        let end = s.end_tick(clock.now());
        assert_eq!(end.consecutive_misses, 0);
    }

    #[test]
    fn spin_margin_reaches_the_deadline_exactly_in_virtual_time() {
        let clock = VirtualClock::new();
        let mut s = Scheduler::new(
            Period::new(ms(1)).unwrap(),
            Duration::from_micros(50),
            OverrunPolicy::Continue,
            clock.now(),
        );
        s.wait_next(&clock);
        let t = s.wait_next(&clock);
        assert_eq!(t.woke, t.scheduled);
    }
}
