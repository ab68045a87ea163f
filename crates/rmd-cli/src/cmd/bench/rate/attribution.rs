//! Which missed ticks were the simulator's: the simulated motors run on threads of their own, on
//! the machine's other CPU, and when that CPU stalls (a host preemption of this VM) they hand a
//! reply over after it was due. Real motors answer on time; the loop, waiting for that reply,
//! misses the tick through no fault of its own.
//!
//! A missed tick is the simulator's when both hold:
//! - a reply due within the tick's period (its arrival on the simulated wire in
//!   `[scheduled, scheduled + period)`) was handed over late by its simulator thread, by
//!   [`SIM_LATE`] or more (a few microseconds late is the simulator thread's own noise, not a
//!   stall);
//! - the loop woke on time for that tick (within [`ON_TIME`] of its scheduled start), so the
//!   loop's own thread was not stalled too.
//!
//! The slots skipped after such a tick are the simulator's as well. Every other missed slot is
//! the loop's.

use core::time::Duration;

use rmd_bus::Timestamp;

use crate::cmd::bench::pd::MissedTick;

/// A loop that woke later than this after a tick's start was late itself (its wake latency is
/// about 2 µs at p99 with the benchmark's spin).
pub(super) const ON_TIME: Duration = Duration::from_micros(50);

/// A reply handed over this late or later was delayed by a stall of the simulator's thread.
pub(super) const SIM_LATE: Duration = Duration::from_micros(20);

/// The slots the simulator made the loop miss: every tick in `missed` (one entry per tick, or
/// several that are merged) counts 1 plus the slots skipped after it when a reply due in its
/// period is among `late_arrivals` (arrival, how late it was handed over; [`SIM_LATE`] or more)
/// and the loop woke on time for it.
pub(super) fn simulator_slots(
    missed: &[MissedTick],
    late_arrivals: &[(Timestamp, Duration)],
    period: Duration,
) -> u64 {
    let mut late: Vec<Timestamp> = late_arrivals
        .iter()
        .filter(|(_, by)| *by >= SIM_LATE)
        .map(|(at, _)| *at)
        .collect();
    late.sort_unstable();
    let mut ticks = missed.to_vec();
    ticks.sort_by_key(|t| t.index);
    ticks.dedup_by(|later, first| {
        let same = later.index == first.index;
        if same {
            first.skipped_after = first.skipped_after.max(later.skipped_after);
        }
        same
    });
    ticks
        .iter()
        .filter(|t| t.wake_late <= ON_TIME)
        .filter(|t| {
            let from = late.partition_point(|&at| at < t.scheduled);
            late.get(from).is_some_and(|&at| at < t.scheduled + period)
        })
        .map(|t| 1 + t.skipped_after)
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn us(n: u64) -> Duration {
        Duration::from_micros(n)
    }

    fn at(n: u64) -> Timestamp {
        Timestamp::ZERO + us(n)
    }

    /// A reply due at `n` us, handed over 300 us late.
    fn late(n: u64) -> (Timestamp, Duration) {
        (at(n), us(300))
    }

    fn tick(index: u64, wake_late_us: u64, skipped_after: u64) -> MissedTick {
        MissedTick {
            index,
            scheduled: at(index * 1000),
            wake_late: us(wake_late_us),
            skipped_after,
        }
    }

    #[test]
    fn a_tick_whose_reply_the_simulator_was_late_with_is_the_simulators() {
        // Tick 5 (5000..6000 us) overran and skipped one slot; a reply due at 5400 us was late.
        let missed = [tick(5, 2, 1)];
        assert_eq!(simulator_slots(&missed, &[late(5400)], us(1000)), 2);
    }

    #[test]
    fn a_late_reply_of_another_tick_does_not_count() {
        let missed = [tick(5, 2, 1)];
        assert_eq!(
            simulator_slots(&missed, &[late(4999), late(6000)], us(1000)),
            0
        );
        assert_eq!(simulator_slots(&missed, &[], us(1000)), 0);
    }

    #[test]
    fn a_loop_that_woke_late_itself_keeps_the_miss() {
        let missed = [tick(5, 300, 1)];
        assert_eq!(simulator_slots(&missed, &[late(5400)], us(1000)), 0);
    }

    #[test]
    fn a_reply_handed_over_a_few_microseconds_late_does_not_count() {
        let missed = [tick(5, 2, 1)];
        let barely = [(at(5400), us(19))];
        assert_eq!(simulator_slots(&missed, &barely, us(1000)), 0);
        let stalled = [(at(5400), SIM_LATE)];
        assert_eq!(simulator_slots(&missed, &stalled, us(1000)), 2);
    }

    #[test]
    fn entries_of_one_tick_are_merged_and_each_tick_is_counted_once() {
        // Tick 7 missed a reply (logged at once) and overran by two slots (logged by the next
        // tick); tick 9 missed a reply only. Three late replies, two in tick 7.
        let missed = [tick(7, 1, 0), tick(9, 1, 0), tick(7, 1, 2)];
        let late = [late(9100), late(7300), late(7500)];
        assert_eq!(simulator_slots(&missed, &late, us(1000)), 3 + 1);
    }
}
