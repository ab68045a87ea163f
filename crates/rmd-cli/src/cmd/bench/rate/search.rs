//! The search for one bus count: the highest rate with at most the miss budget of its ticks
//! missed (the headline), then the highest with none missed, both on the same trials.
//!
//! A rate is judged on every trial run at it, pooled: the share of all their tick slots that
//! were missed. A machine's stalls come at random and cost the same few slots at any rate, so
//! one trial that exceeds the budget by a stall is run once more when two trials together could
//! still hold the budget (it missed at most twice the budget); above the loop's real limit
//! nearly every tick misses and no retry can pass. Every trial is kept and reported.
//!
//! For each of the two: from the highest rate that holds so far (if none, stepping down by 10%
//! from the worst-case budget's rate, or from the lowest rate tried), bisect up to the lowest
//! rate above it that does not hold (if none, 3% above the wire limit of the frames sent:
//! beyond it more exchanges overrun than any budget allows) until the interval is narrower than
//! the resolution; then run the rate found again (`--confirm` times), stepping down when the
//! pooled share no longer holds.

use std::time::Instant;

use rmd_bus::wire::exchange_budget;

use super::trial::{Trial, trial, within};
use super::{BITRATE, MAX_CONFIRM_RUNS, MAX_STEPS_DOWN, MAX_TURNAROUND, RateArgs};
use crate::output::progress::Progress;

/// The error of a search a signal ended (the trials run so far are kept).
pub(super) const INTERRUPTED: &str = "interrupted";

/// The trials of one bus count.
pub(super) struct Search<'a> {
    pub(super) buses: usize,
    pub(super) trials: Vec<Trial>,
    args: &'a RateArgs,
    progress: &'a Progress,
    /// Trials run before this search (for their numbers).
    offset: usize,
    /// When the first search of the run started (for the time so far).
    started: Instant,
}

impl<'a> Search<'a> {
    pub(super) fn new(
        args: &'a RateArgs,
        buses: usize,
        progress: &'a Progress,
        offset: usize,
        started: Instant,
    ) -> Self {
        Self {
            buses,
            trials: Vec::new(),
            args,
            progress,
            offset,
            started,
        }
    }

    /// Runs a trial at `rate_hz` and keeps it. After a signal, runs none: [`INTERRUPTED`].
    pub(super) fn run(&mut self, rate_hz: f64) -> Result<&Trial, String> {
        if rmd_rig::signals::interrupted() {
            return Err(INTERRUPTED.to_owned());
        }
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
        if !self.args.json {
            self.progress.println(self.so_far());
        }
        Ok(&self.trials[self.trials.len() - 1])
    }

    /// What the trials so far found: the highest rate within the budget and with zero misses,
    /// and the lowest beyond the budget above it.
    pub(super) fn so_far(&self) -> String {
        let budget = self.args.budget();
        let elapsed = self.started.elapsed().as_secs();
        let best = |budget: f64| self.best(budget).map(|(t, _)| t.rate_hz);
        let within = match best(budget) {
            Some(rate) => format!("up to {rate:.1} Hz"),
            None => "none yet".to_owned(),
        };
        let beyond = self
            .trials
            .iter()
            .filter(|t| best(budget).is_none_or(|b| t.rate_hz > b))
            .filter(|t| !self.holds(t.rate_hz, budget))
            .map(|t| t.rate_hz)
            .reduce(f64::min)
            .map_or(String::new(), |r| format!(", beyond it from {r:.1} Hz"));
        let zero = best(0.0).map_or("none yet".to_owned(), |r| format!("up to {r:.1} Hz"));
        format!(
            "  so far ({} bus(es), {} trial(s), {}m{:02}s in all): within {}% {within}{beyond}; \
             zero misses {zero}",
            self.buses,
            self.trials.len(),
            elapsed / 60,
            elapsed % 60,
            self.args.miss_budget_pct,
        )
    }

    /// Every trial at exactly `rate_hz`, pooled: the share of all their tick slots that were
    /// missed, and how many trials; `None` if the rate was never run.
    pub(super) fn pooled(&self, rate_hz: f64) -> Option<(f64, u32)> {
        let (missed, slots, trials) = self
            .trials
            .iter()
            .filter(|t| t.rate_hz == rate_hz)
            .fold((0u64, 0u64, 0u32), |(m, s, n), t| {
                (m + t.missed_slots(), s + t.slots(), n + 1)
            });
        (trials > 0).then(|| (missed as f64 / slots.max(1) as f64, trials))
    }

    /// Whether `rate_hz` was run and its pooled share of missed slots is within `budget`.
    fn holds(&self, rate_hz: f64, budget: f64) -> bool {
        self.pooled(rate_hz)
            .is_some_and(|(missed, _)| within(missed, budget))
    }

    /// Runs a trial at `rate_hz`, and once more if it missed more than `budget` but no more
    /// than twice it (two trials together may hold the budget); whether the rate holds.
    fn judge(&mut self, rate_hz: f64, budget: f64) -> Result<bool, String> {
        let missed = self.run(rate_hz)?.missed_fraction();
        if !within(missed, budget) && budget > 0.0 && missed <= 2.0 * budget {
            self.run(rate_hz)?;
        }
        Ok(self.holds(rate_hz, budget))
    }

    /// The highest rate that holds `budget` on its pooled trials: its last trial, and how many
    /// trials were pooled.
    pub(super) fn best(&self, budget: f64) -> Option<(&Trial, u32)> {
        let mut best: Option<(&Trial, u32)> = None;
        for t in &self.trials {
            if !self.holds(t.rate_hz, budget) || best.is_some_and(|(b, _)| t.rate_hz < b.rate_hz) {
                continue;
            }
            let trials = self.pooled(t.rate_hz).map_or(0, |(_, n)| n);
            best = Some((t, trials));
        }
        best
    }

    /// Rates with one trial within `budget` and another beyond it (noise).
    pub(super) fn flaky_rates(&self, budget: f64) -> Vec<f64> {
        let mut rates: Vec<f64> = self
            .trials
            .iter()
            .map(|t| t.rate_hz)
            .filter(|&r| {
                let at = || self.trials.iter().filter(move |t| t.rate_hz == r);
                at().any(|t| t.within(budget)) && at().any(|t| !t.within(budget))
            })
            .collect();
        rates.sort_by(f64::total_cmp);
        rates.dedup();
        rates
    }

    /// The lowest rate above `lo` that does not hold `budget`, else the cap.
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
            .filter(|t| t.rate_hz > lo && !self.holds(t.rate_hz, budget))
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
                    if self.judge(rate, budget)? {
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
            if self.judge(mid, budget)? {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        // Confirm: the rate must hold on `confirm` more trials, pooled; when it no longer does,
        // step down to the best rate that still holds, or below.
        let mut runs = 0;
        while runs < MAX_CONFIRM_RUNS {
            match self.pooled(lo) {
                None => {
                    runs += 1;
                    self.judge(lo, budget)?;
                }
                Some((missed, _)) if !within(missed, budget) => {
                    lo = match self.best(budget) {
                        Some((t, _)) if t.rate_hz < lo => t.rate_hz,
                        _ => lo * (1.0 - res),
                    };
                }
                Some((_, trials)) if trials > self.args.confirm => break,
                Some(_) => {
                    runs += 1;
                    self.run(lo)?;
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::super::trial::tests::{args, trial};
    use super::*;

    fn at(rate_hz: f64, missed: u64) -> Trial {
        Trial {
            rate_hz,
            ..trial(10_000, 0, missed, 10_000, true)
        }
    }

    #[test]
    fn a_rate_is_judged_on_all_its_trials_pooled() {
        let args = args("");
        let progress = Progress::timer(args.duration, false);
        let mut search = Search::new(&args, 1, &progress, 0, Instant::now());
        let budget = 0.001;
        // 1100 Hz: one trial over the budget by a stall (12 of 10 000), one clean: 0.06%.
        search.trials.push(at(1100.0, 12));
        assert!(
            !search.holds(1100.0, budget),
            "alone, the first trial fails"
        );
        search.trials.push(at(1100.0, 0));
        assert_eq!(search.pooled(1100.0), Some((12.0 / 20_000.0, 2)));
        assert!(search.holds(1100.0, budget));
        // 1200 Hz: beyond the loop's limit, every trial misses most ticks.
        search.trials.push(at(1200.0, 9_000));
        search.trials.push(at(1200.0, 8_000));
        assert!(!search.holds(1200.0, budget));
        // 1000 Hz: clean.
        search.trials.push(at(1000.0, 0));
        let (best, trials) = search.best(budget).unwrap();
        assert_eq!((best.rate_hz, trials), (1100.0, 2));
        // Zero misses: only the rate whose every trial missed nothing.
        assert_eq!(
            search.best(0.0).map(|(t, n)| (t.rate_hz, n)),
            Some((1000.0, 1))
        );
        assert_eq!(search.lowest_failure_above(1100.0, budget), 1200.0);
        assert_eq!(search.flaky_rates(budget), vec![1100.0]);
        assert!(
            search.so_far().starts_with(
                "  so far (1 bus(es), 5 trial(s), 0m00s in all): within 0.1% up to 1100.0 Hz, \
                 beyond it from 1200.0 Hz; zero misses up to 1000.0 Hz"
            ),
            "{}",
            search.so_far()
        );
        assert_eq!(search.pooled(900.0), None);
        assert!(
            !search.holds(900.0, budget),
            "a rate never run does not hold"
        );
    }
}
