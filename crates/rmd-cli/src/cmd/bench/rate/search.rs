//! The search for one bus count: the highest rate with at most the miss budget of its ticks
//! missed (the headline), then the highest with none missed, both on the same trials.
//!
//! For each of the two: from the highest rate that passed so far (if none, stepping down by 10%
//! from the worst-case budget's rate, or from the lowest rate tried), bisect up to the lowest
//! rate above it that failed (if none, 3% above the wire limit of the frames sent: beyond it
//! more exchanges overrun than any budget allows) until the interval is narrower than the
//! resolution; then run the rate found again (`--confirm` times), stepping down on a failure.
//! A rate counts only if it passed every time it ran.

use rmd_bus::wire::exchange_budget;

use super::trial::{Trial, trial};
use super::{BITRATE, MAX_CONFIRM_RUNS, MAX_STEPS_DOWN, MAX_TURNAROUND, RateArgs};
use crate::output::progress::Progress;

/// The trials of one bus count.
pub(super) struct Search<'a> {
    pub(super) buses: usize,
    pub(super) trials: Vec<Trial>,
    args: &'a RateArgs,
    progress: &'a Progress,
    /// Trials run before this search (for their numbers).
    offset: usize,
}

impl<'a> Search<'a> {
    pub(super) fn new(
        args: &'a RateArgs,
        buses: usize,
        progress: &'a Progress,
        offset: usize,
    ) -> Self {
        Self {
            buses,
            trials: Vec::new(),
            args,
            progress,
            offset,
        }
    }

    /// Runs a trial at `rate_hz` and keeps it.
    pub(super) fn run(&mut self, rate_hz: f64) -> Result<&Trial, String> {
        let n = self.offset + self.trials.len() + 1;
        self.progress.restart_timer(self.args.duration);
        self.progress.set_prefix(format!(
            "trial {n} at {rate_hz:.1} Hz, {} bus(es) ",
            self.buses
        ));
        let progress = self.progress;
        let show = progress
            .is_shown()
            .then_some(|elapsed| progress.set_elapsed(elapsed));
        let t = trial(self.args, self.buses, rate_hz, show)?;
        if !self.args.json {
            self.progress.println(t.line(n, self.args.budget()));
            for w in &t.warnings {
                self.progress.println(format!("  warning: {w}"));
            }
        }
        self.trials.push(t);
        Ok(&self.trials[self.trials.len() - 1])
    }

    /// Passes and failures at exactly `rate_hz` against `budget`.
    fn tally(&self, rate_hz: f64, budget: f64) -> (u32, u32) {
        self.trials
            .iter()
            .filter(|t| t.rate_hz == rate_hz)
            .fold((0, 0), |(p, f), t| {
                if t.within(budget) {
                    (p + 1, f)
                } else {
                    (p, f + 1)
                }
            })
    }

    /// The highest rate that passed `budget` every time it ran: its last trial, and how many
    /// times it passed.
    pub(super) fn best(&self, budget: f64) -> Option<(&Trial, u32)> {
        let mut best: Option<(&Trial, u32)> = None;
        for t in &self.trials {
            let (passes, fails) = self.tally(t.rate_hz, budget);
            if passes > 0 && fails == 0 && best.is_none_or(|(b, _)| t.rate_hz >= b.rate_hz) {
                best = Some((t, passes));
            }
        }
        best
    }

    /// Rates that passed `budget` at least once and failed it at least once.
    pub(super) fn flaky_rates(&self, budget: f64) -> Vec<f64> {
        let mut rates: Vec<f64> = self
            .trials
            .iter()
            .map(|t| t.rate_hz)
            .filter(|&r| matches!(self.tally(r, budget), (p, f) if p > 0 && f > 0))
            .collect();
        rates.sort_by(f64::total_cmp);
        rates.dedup();
        rates
    }

    /// The lowest rate above `lo` that failed `budget`, else the cap.
    fn lowest_failure_above(&self, lo: f64, budget: f64) -> f64 {
        let cap = self
            .trials
            .iter()
            .filter_map(Trial::wire_limit_hz)
            .fold(f64::NAN, f64::max)
            * 1.03;
        let cap = if cap.is_nan() { lo * 1.2 } else { cap.max(lo) };
        self.trials
            .iter()
            .filter(|t| t.rate_hz > lo && !t.within(budget))
            .map(|t| t.rate_hz)
            .fold(cap, f64::min)
    }

    /// Finds the highest rate within `budget`, reusing every trial so far.
    pub(super) fn find(&mut self, budget: f64) -> Result<(), String> {
        let mut lo = match self.best(budget) {
            Some((t, _)) => t.rate_hz,
            None => {
                let start = self
                    .trials
                    .iter()
                    .map(|t| t.rate_hz * 0.9)
                    .fold(f64::NAN, f64::min);
                let mut rate = if start.is_nan() {
                    let worst =
                        exchange_budget(u32::from(self.args.motors), BITRATE, MAX_TURNAROUND);
                    1.0 / worst.as_secs_f64()
                } else {
                    start
                };
                let mut steps = 0;
                loop {
                    if self.run(rate)?.within(budget) {
                        break rate;
                    }
                    steps += 1;
                    if steps > MAX_STEPS_DOWN {
                        return Ok(());
                    }
                    rate *= 0.9;
                }
            }
        };
        let res = self.args.resolution_pct / 100.0;
        let mut hi = self.lowest_failure_above(lo, budget);
        while (hi - lo) / hi > res {
            let mid = 0.5 * (lo + hi);
            if self.run(mid)?.within(budget) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        // Confirm: the rate must pass `confirm` more times and never fail; on a failure, step
        // down to the best rate that still holds, or below.
        let mut runs = 0;
        while runs < MAX_CONFIRM_RUNS {
            let (passes, fails) = self.tally(lo, budget);
            if fails > 0 {
                lo = match self.best(budget) {
                    Some((t, _)) if t.rate_hz < lo => t.rate_hz,
                    _ => lo * (1.0 - res),
                };
                continue;
            }
            if passes > self.args.confirm {
                break;
            }
            runs += 1;
            self.run(lo)?;
        }
        Ok(())
    }
}
