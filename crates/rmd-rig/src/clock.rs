//! The clock of a run: virtual for simulated motors in virtual time, monotonic otherwise.

use rmd_bus::{Clock, MonotonicClock, Timestamp, VirtualClock};

use crate::placement::SimTime;

/// The clock of a run.
#[derive(Clone, Debug)]
pub enum AnyClock {
    /// Virtual time.
    Virtual(VirtualClock),
    /// Real time.
    Monotonic(MonotonicClock),
}

impl AnyClock {
    /// The clock for `time`.
    pub fn new(time: SimTime) -> Self {
        match time {
            SimTime::Real => AnyClock::Monotonic(MonotonicClock),
            SimTime::Virtual => AnyClock::Virtual(VirtualClock::new()),
        }
    }

    /// Whether this is virtual time.
    pub fn is_virtual(&self) -> bool {
        matches!(self, AnyClock::Virtual(_))
    }
}

impl Clock for AnyClock {
    fn now(&self) -> Timestamp {
        match self {
            AnyClock::Virtual(c) => c.now(),
            AnyClock::Monotonic(c) => c.now(),
        }
    }

    fn sleep_until(&self, deadline: Timestamp) {
        match self {
            AnyClock::Virtual(c) => c.sleep_until(deadline),
            AnyClock::Monotonic(c) => c.sleep_until(deadline),
        }
    }

    fn spin_until(&self, deadline: Timestamp) {
        match self {
            AnyClock::Virtual(c) => c.spin_until(deadline),
            AnyClock::Monotonic(c) => c.spin_until(deadline),
        }
    }

    fn is_virtual(&self) -> bool {
        AnyClock::is_virtual(self)
    }
}
