//! Converting the kernel's receive timestamps to the [`MonotonicClock`](crate::MonotonicClock)
//! time line.
//!
//! With `SO_TIMESTAMPNS` the kernel stamps every frame when the network stack receives it
//! (`skb->tstamp`, taken in the driver's receive path), but on the `CLOCK_REALTIME` (wall
//! clock) time line: Linux offers no monotonic receive timestamps for sockets. The backend
//! converts each one at read time:
//!
//! 1. read `CLOCK_MONOTONIC`, `CLOCK_REALTIME`, `CLOCK_MONOTONIC` again (three vDSO reads, no
//!    system call);
//! 2. the offset between the clocks is `realtime - (mono_before + mono_after) / 2`;
//! 3. the frame's monotonic time is `rx_realtime - offset`, clamped to at most `mono_after`
//!    (nothing can be received in the future) and to at least the previous frame's time (the
//!    time line the loop sees never goes backwards).
//!
//! Error of the conversion:
//! - sampling: at most half the gap between the two monotonic reads (typically well under
//!   100 ns). A thread preempted between the reads (a loaded host, an emulated VM) widens the
//!   gap to milliseconds, which would date frames that much too early or late: a sample wider
//!   than 20 us is taken again, up to four times, and the tightest is used;
//! - clock adjustment between reception and read: NTP or PTP *slewing* changes the wall clock's
//!   rate by at most 500 ppm, so a frame read `d` after reception is off by at most
//!   `0.0005 * d` (0.5 µs for a frame read 1 ms after it arrived);
//! - a *step* of the wall clock (`date -s`, NTP step at boot) between reception and read shifts
//!   the frames in flight by the step; the clamps above bound the damage to "read time" and
//!   "previous frame's time". Robots should not step the clock while the loop runs.

/// One sample of both clocks, in nanoseconds since each clock's epoch.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) struct ClockSample {
    /// `CLOCK_MONOTONIC` before reading the wall clock.
    pub(crate) mono_before: u64,
    /// `CLOCK_REALTIME`.
    pub(crate) real: u64,
    /// `CLOCK_MONOTONIC` after reading the wall clock.
    pub(crate) mono_after: u64,
}

/// A sample whose two monotonic reads are at most this far apart (ns) is taken as it is. The
/// three vDSO reads take well under a microsecond; a wider gap means the thread was preempted
/// between them (a loaded host, an emulated VM), and the offset would be off by up to half of it.
const TIGHT_SAMPLE_NS: u64 = 20_000;

/// Samples taken at most per conversion, looking for a tight one.
const MAX_SAMPLES: usize = 4;

impl ClockSample {
    /// Samples the clocks now: the tightest of up to [`MAX_SAMPLES`] samples, stopping at the
    /// first whose monotonic reads are at most [`TIGHT_SAMPLE_NS`] apart.
    pub(crate) fn now() -> Self {
        Self::tightest(Self::read)
    }

    /// The tightest of up to [`MAX_SAMPLES`] samples taken by `sample`, stopping at the first
    /// tight one.
    fn tightest(mut sample: impl FnMut() -> Self) -> Self {
        let mut best = sample();
        for _ in 1..MAX_SAMPLES {
            if best.gap() <= TIGHT_SAMPLE_NS {
                break;
            }
            let next = sample();
            if next.gap() < best.gap() {
                best = next;
            }
        }
        best
    }

    /// One sample of the clocks.
    fn read() -> Self {
        use nix::time::ClockId;
        let read = |clock: ClockId| {
            nix::time::clock_gettime(clock)
                .map(|ts| timespec_nanos(ts.tv_sec(), ts.tv_nsec()))
                .unwrap_or(0)
        };
        let mono_before = read(ClockId::CLOCK_MONOTONIC);
        let real = read(ClockId::CLOCK_REALTIME);
        let mono_after = read(ClockId::CLOCK_MONOTONIC);
        Self {
            mono_before,
            real,
            mono_after,
        }
    }

    /// Nanoseconds between the two monotonic reads: twice the sample's worst offset error.
    fn gap(&self) -> u64 {
        self.mono_after.saturating_sub(self.mono_before)
    }
}

/// Nanoseconds of a `timespec`, negative parts clamped to zero.
pub(crate) fn timespec_nanos(sec: i64, nsec: i64) -> u64 {
    (sec.max(0) as u64)
        .saturating_mul(1_000_000_000)
        .saturating_add(nsec.clamp(0, 999_999_999) as u64)
}

/// Converts a `CLOCK_REALTIME` receive time to `CLOCK_MONOTONIC` nanoseconds, as described in
/// the [module docs](self): `floor` is the previous frame's converted time.
pub(crate) fn realtime_to_monotonic(rx_real: u64, sample: ClockSample, floor: u64) -> u64 {
    let mono_mid = sample.mono_before / 2
        + sample.mono_after / 2
        + (sample.mono_before % 2 + sample.mono_after % 2) / 2;
    // mono = rx_real - (real - mono_mid), in i128 to stay exact for any inputs.
    let mono = i128::from(rx_real) - i128::from(sample.real) + i128::from(mono_mid);
    let mono = mono.clamp(0, i128::from(sample.mono_after)) as u64;
    mono.max(floor)
}

#[cfg(test)]
mod tests {
    use super::*;

    const SAMPLE: ClockSample = ClockSample {
        mono_before: 5_000_000_000,
        real: 1_700_000_000_000_000_100,
        mono_after: 5_000_000_200,
    };

    #[test]
    fn the_wall_clock_offset_is_removed() {
        // Received 1 ms before the sample's wall-clock reading.
        let rx_real = SAMPLE.real - 1_000_000;
        assert_eq!(
            realtime_to_monotonic(rx_real, SAMPLE, 0),
            5_000_000_100 - 1_000_000
        );
    }

    #[test]
    fn a_time_in_the_future_is_clamped_to_the_read_time() {
        let rx_real = SAMPLE.real + 3_000_000;
        assert_eq!(realtime_to_monotonic(rx_real, SAMPLE, 0), SAMPLE.mono_after);
    }

    #[test]
    fn converted_times_never_go_backwards() {
        let rx_real = SAMPLE.real - 1_000_000;
        let floor = 4_999_999_500;
        assert_eq!(realtime_to_monotonic(rx_real, SAMPLE, floor), floor);
    }

    #[test]
    fn a_time_before_the_monotonic_epoch_saturates_at_zero() {
        assert_eq!(realtime_to_monotonic(0, SAMPLE, 0), 0);
    }

    #[test]
    fn sampling_the_real_clocks_brackets_the_wall_clock() {
        let sample = ClockSample::now();
        assert!(sample.mono_before <= sample.mono_after);
        assert!(sample.real > 0);
        // A frame stamped exactly at the sample's wall-clock time lands between the two
        // monotonic reads.
        let mono = realtime_to_monotonic(sample.real, sample, 0);
        assert!((sample.mono_before..=sample.mono_after).contains(&mono));
    }

    #[test]
    fn a_sample_stretched_by_preemption_is_taken_again() {
        // The thread was preempted for 30 ms between the first sample's reads: its offset would
        // put every frame up to 15 ms early. The second sample is tight and is the one used.
        let stretched = ClockSample {
            mono_before: 1_000_000_000,
            real: 9_000_030_000_000,
            mono_after: 1_030_000_100,
        };
        let tight = ClockSample {
            mono_before: 1_030_001_000,
            real: 9_000_030_001_100,
            mono_after: 1_030_001_200,
        };
        let mut samples = [stretched, tight, stretched].into_iter();
        let mut taken = 0;
        let best = ClockSample::tightest(|| {
            taken += 1;
            samples.next().unwrap()
        });
        assert_eq!((best, taken), (tight, 2));
        // A frame received 1 ms before: converted with the tight sample, it is exact.
        let rx = tight.real - 1_000_000;
        assert_eq!(
            realtime_to_monotonic(rx, best, 0),
            1_030_001_100 - 1_000_000
        );
        // A tight first sample is taken alone; when none is tight, the tightest of four.
        let mut taken = 0;
        ClockSample::tightest(|| {
            taken += 1;
            tight
        });
        assert_eq!(taken, 1);
        let wide = |gap: u64| ClockSample {
            mono_before: 0,
            real: 0,
            mono_after: gap,
        };
        let mut gaps = [90_000, 40_000, 70_000, 50_000, 10].into_iter();
        let best = ClockSample::tightest(|| wide(gaps.next().unwrap()));
        assert_eq!(best.mono_after, 40_000);
        assert_eq!(gaps.next(), Some(10));
    }

    #[test]
    fn timespec_parts_are_clamped() {
        assert_eq!(timespec_nanos(-1, -1), 0);
        assert_eq!(timespec_nanos(2, 5), 2_000_000_005);
        assert_eq!(timespec_nanos(0, 2_000_000_000), 999_999_999);
    }
}
