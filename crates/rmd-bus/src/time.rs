//! A point in time on a [`Clock`](crate::Clock)'s time line.

use core::ops::{Add, AddAssign, Sub};
use core::time::Duration;

/// A point in time: nanoseconds since the epoch of the [`Clock`](crate::Clock) that produced it.
///
/// For [`MonotonicClock`](crate::MonotonicClock) the epoch is the one of Linux
/// `CLOCK_MONOTONIC` (boot); for [`VirtualClock`](crate::VirtualClock) it is the clock's creation.
/// Timestamps from different clocks must not be compared. Arithmetic saturates instead of
/// wrapping or panicking.
///
/// ```
/// use core::time::Duration;
/// use rmd_bus::Timestamp;
/// let t0 = Timestamp::from_nanos(1_000);
/// let t1 = t0 + Duration::from_micros(1);
/// assert_eq!(t1.as_nanos(), 2_000);
/// assert_eq!(t1 - t0, Duration::from_micros(1));
/// assert_eq!(t0 - t1, Duration::ZERO); // saturates
/// ```
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Timestamp(u64);

impl Timestamp {
    /// The epoch of the clock.
    pub const ZERO: Self = Self(0);

    /// A timestamp `nanos` nanoseconds after the clock's epoch.
    pub const fn from_nanos(nanos: u64) -> Self {
        Self(nanos)
    }

    /// Nanoseconds since the clock's epoch.
    pub const fn as_nanos(self) -> u64 {
        self.0
    }

    /// Time elapsed from `earlier` to `self`, or `None` if `earlier` is later than `self`.
    pub const fn checked_duration_since(self, earlier: Self) -> Option<Duration> {
        match self.0.checked_sub(earlier.0) {
            Some(ns) => Some(Duration::from_nanos(ns)),
            None => None,
        }
    }

    /// Signed nanoseconds from `other` to `self` (positive when `self` is later).
    pub const fn signed_nanos_since(self, other: Self) -> i64 {
        (self.0 as i128 - other.0 as i128) as i64
    }

    /// `self - d`, saturating at the epoch.
    pub fn saturating_sub(self, d: Duration) -> Self {
        Self(self.0.saturating_sub(duration_nanos(d)))
    }
}

const fn duration_nanos(d: Duration) -> u64 {
    let ns = d.as_nanos();
    if ns > u64::MAX as u128 {
        u64::MAX
    } else {
        ns as u64
    }
}

impl Add<Duration> for Timestamp {
    type Output = Timestamp;
    fn add(self, rhs: Duration) -> Timestamp {
        Timestamp(self.0.saturating_add(duration_nanos(rhs)))
    }
}

impl AddAssign<Duration> for Timestamp {
    fn add_assign(&mut self, rhs: Duration) {
        *self = *self + rhs;
    }
}

/// The span from `rhs` to `self`, zero if `rhs` is later.
impl Sub for Timestamp {
    type Output = Duration;
    fn sub(self, rhs: Timestamp) -> Duration {
        Duration::from_nanos(self.0.saturating_sub(rhs.0))
    }
}
