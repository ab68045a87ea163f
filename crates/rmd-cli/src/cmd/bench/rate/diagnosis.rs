//! Why a bus count found no rate within the budget, and what to try: from the trials' own
//! figures (how late the loop woke, the simulator's late replies, whether the misses fell as
//! the rate fell, the wire limit) and the machine's load average.
//!
//! A machine's stall costs the same share of a trial's ticks at any rate (a 20 ms stall is 20
//! ticks of 20 000 at 1 kHz, 10 of 10 000 at 500 Hz), so misses that do not fall with the rate
//! come from stalls, not from the rate; on a loaded machine the loop also waits for a CPU.
//! Each suggestion is a set of `rmd bench rate` flags that exists, to add to the command (a flag
//! it already has is replaced; tested below).

use core::time::Duration;

use super::trial::Trial;
use super::{RateArgs, SimPlace};

/// The machine while the search ran: its 1-minute load average at the start and the end
/// (`/proc/loadavg`; `None` where there is none) and its CPUs.
#[derive(Copy, Clone, Debug, PartialEq)]
pub(super) struct Machine {
    pub(super) load_start: Option<f64>,
    pub(super) load_end: Option<f64>,
    pub(super) cpus: usize,
}

impl Machine {
    /// The machine now, as a start (the end is filled in by [`Self::ended`]).
    pub(super) fn now() -> Self {
        Self {
            load_start: load_average(),
            load_end: None,
            cpus: std::thread::available_parallelism().map_or(1, usize::from),
        }
    }

    /// The same machine with its load average at the end.
    pub(super) fn ended(self) -> Self {
        Self {
            load_end: load_average(),
            ..self
        }
    }

    /// The higher of the two load averages.
    fn load(&self) -> Option<f64> {
        match (self.load_start, self.load_end) {
            (Some(a), Some(b)) => Some(a.max(b)),
            (a, b) => a.or(b),
        }
    }

    /// `load average 3.10 at the start, 3.40 at the end; 2 CPU(s)`.
    fn describe(&self) -> String {
        let at = |load: Option<f64>, when: &str| load.map(|l| format!("{l:.2} at {when}"));
        let loads: Vec<String> = [
            at(self.load_start, "the start"),
            at(self.load_end, "the end"),
        ]
        .into_iter()
        .flatten()
        .collect();
        format!(
            "load average {}; {} CPU(s)",
            if loads.is_empty() {
                "unknown".to_owned()
            } else {
                loads.join(", ")
            },
            self.cpus
        )
    }
}

/// The 1-minute load average, from `/proc/loadavg`.
fn load_average() -> Option<f64> {
    std::fs::read_to_string("/proc/loadavg")
        .ok()?
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

/// A suggestion: flags to add to `rmd bench rate`, and why.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Try {
    pub(super) flags: String,
    pub(super) why: String,
}

/// What is known about a bus count whose trials all missed more than the budget.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Diagnosis {
    /// Each a sentence: what the trials and the machine show.
    pub(super) reasons: Vec<String>,
    /// What to try.
    pub(super) tries: Vec<Try>,
}

/// The trial at the lowest rate (the last of them) and at the highest.
fn extremes(trials: &[Trial]) -> Option<(&Trial, &Trial)> {
    let lowest = trials
        .iter()
        .min_by(|a, b| a.rate_hz.total_cmp(&b.rate_hz))?;
    let highest = trials
        .iter()
        .max_by(|a, b| a.rate_hz.total_cmp(&b.rate_hz))?;
    Some((lowest, highest))
}

/// Why none of `trials` (one bus count's, all beyond the budget) passed, and what to try.
pub(super) fn diagnose(trials: &[Trial], args: &RateArgs, machine: &Machine) -> Diagnosis {
    let mut reasons = Vec::new();
    let mut tries = Vec::new();
    let pct = |x: f64| format!("{:.3}%", 100.0 * x);

    // The bus itself: a rate above the wire limit of its frames cannot pass.
    let below_limit: Vec<&Trial> = trials
        .iter()
        .filter(|t| t.wire_limit_hz().is_some_and(|w| t.rate_hz <= w))
        .collect();
    if below_limit.is_empty() {
        if let Some(w) = trials
            .iter()
            .filter_map(Trial::wire_limit_hz)
            .reduce(f64::min)
        {
            reasons.push(format!(
                "every rate tried is above the wire limit of its frames ({w:.1} Hz): the \
                 simulated 1 Mbit/s buses cannot carry a whole exchange each tick"
            ));
        }
        if args.rate.is_some() {
            tries.push(Try {
                flags: "--rate 1000".to_owned(),
                why: "a rate below the wire limit (or no --rate: the search finds the highest)"
                    .to_owned(),
            });
        }
    }

    // Stalls: misses that did not fall with the rate, and how late the loop woke.
    if let Some((lowest, highest)) = extremes(trials)
        && lowest.rate_hz < highest.rate_hz
        && lowest.missed_fraction() >= 0.5 * highest.missed_fraction()
    {
        reasons.push(format!(
            "the misses did not fall with the rate ({} of the ticks at {:.1} Hz, {} at {:.1} \
             Hz): they come from stalls of the machine, not from the rate, so a lower rate \
             does not help",
            pct(highest.missed_fraction()),
            highest.rate_hz,
            pct(lowest.missed_fraction()),
            lowest.rate_hz,
        ));
    }
    let wake_max_us = trials.iter().map(|t| t.wake.max).fold(0.0, f64::max);
    let wake_p99_us = trials.iter().map(|t| t.wake.p99).fold(0.0, f64::max);
    if let Some(period) = trials.iter().map(|t| t.period).min()
        && Duration::from_secs_f64(wake_max_us / 1e6) >= period / 4
    {
        reasons.push(format!(
            "the loop thread woke up to {} late for a tick (p99 {wake_p99_us:.1} us, the \
             period is {}): it was off the CPU when its tick was due",
            human_us(wake_max_us),
            human_us(period.as_secs_f64() * 1e6),
        ));
    }
    let (deadline, missing, skipped) = trials.iter().fold((0, 0, 0), |(d, m, s), t| {
        (
            d + t.deadline_misses,
            m + t.missing_replies,
            s + t.skipped_ticks,
        )
    });
    reasons.push(format!(
        "over {} trial(s): {deadline} deadline miss(es), {missing} missing repl(ies), \
         {skipped} skipped tick(s)",
        trials.len()
    ));

    // The simulated motors' threads, late on a busy CPU.
    let sim_late = trials
        .iter()
        .filter_map(|t| t.sim_late)
        .fold((0, Duration::ZERO), |(n, max), l| {
            (n + l.late_items, max.max(l.max_late))
        });
    let sim_slots: u64 = trials.iter().map(|t| t.sim_missed_slots).sum();
    if sim_late.0 > 0 {
        reasons.push(format!(
            "the simulated motors' threads handed {} repl(ies) over late, up to {} ({sim_slots} \
             missed slot(s) were theirs and not counted against the loop)",
            sim_late.0,
            human_us(sim_late.1.as_secs_f64() * 1e6),
        ));
    }

    // On a virtual clock the machine's timing does not matter: the wire decided.
    if args.sim == SimPlace::Virtual || args.virtual_time {
        return Diagnosis { reasons, tries };
    }

    // The machine.
    let busy = machine
        .load()
        .is_some_and(|l| l >= 0.5 * machine.cpus as f64);
    reasons.push(format!(
        "the machine: {}{}",
        machine.describe(),
        match machine.load() {
            Some(l) if l >= machine.cpus as f64 => {
                " (busy: more threads wanted a CPU than there are, the loop's among them)"
            }
            Some(_) if busy => " (not idle: other work competed with the loop)",
            Some(_) => " (idle)",
            None => "",
        }
    ));

    if busy {
        tries.push(Try {
            flags: String::new(),
            why: "run it again when the machine is quieter (stop other builds and benchmarks)"
                .to_owned(),
        });
    }
    if args.rt.cpu.is_none() || args.rt.fifo.is_none() {
        tries.push(Try {
            flags: format!("--cpu {} --fifo 80", machine.cpus.saturating_sub(1)),
            why: "pin the loop to a CPU of its own and give it real-time priority (SCHED_FIFO \
                  needs root or an RLIMIT_RTPRIO; see docs/realtime.md)"
                .to_owned(),
        });
    }
    if args.sim == SimPlace::Thread && sim_late.0 > 0 {
        tries.push(Try {
            flags: "--sim inline".to_owned(),
            why: "the simulated motors in the loop's thread: no thread of theirs to be \
                  descheduled (the loop then also pays for them)"
                .to_owned(),
        });
    }
    // A larger budget helps only where some trial missed little more than the present one.
    let least_missed = trials
        .iter()
        .map(Trial::missed_fraction)
        .fold(f64::INFINITY, f64::min);
    if args.miss_budget_pct < 1.0 && least_missed <= 0.01 {
        tries.push(Try {
            flags: "--miss-budget-pct 1".to_owned(),
            why: "allow 1% of the ticks to be missed (the machine's stalls cost a share of \
                  every trial)"
                .to_owned(),
        });
    }
    tries.push(Try {
        flags: "--sim virtual".to_owned(),
        why: "the same search on a virtual clock: the wire limit, whatever the machine does"
            .to_owned(),
    });
    Diagnosis { reasons, tries }
}

/// Why a bus count that found a rate within the budget found none with zero misses.
pub(super) fn why_no_zero(trials: &[Trial]) -> String {
    let wake_max_us = trials.iter().map(|t| t.wake.max).fold(0.0, f64::max);
    format!(
        "every rate tried missed at least one tick (the loop woke up to {} late): zero misses \
         needs a trial without one stall of the machine",
        human_us(wake_max_us)
    )
}

/// Microseconds for people: `850.0 us`, `12.3 ms`.
fn human_us(us: f64) -> String {
    if us >= 1000.0 {
        format!("{:.1} ms", us / 1000.0)
    } else {
        format!("{us:.1} us")
    }
}

impl Diagnosis {
    /// The diagnosis as lines of text, each starting with `buses` (`4 bus(es): why: ...`).
    pub(super) fn text(&self, buses: usize) -> String {
        let mut out = String::new();
        for reason in &self.reasons {
            out += &format!("{buses} bus(es): why: {reason}\n");
        }
        for t in &self.tries {
            if t.flags.is_empty() {
                out += &format!("{buses} bus(es): try: {}\n", t.why);
            } else {
                out += &format!("{buses} bus(es): try: {}: {}\n", t.flags, t.why);
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use rmd_sim::threaded::Lateness;

    use super::super::trial::tests::{args, trial};
    use super::*;
    use crate::cmd::bench::wire_limit::WireLimit;

    /// A trial at `rate_hz` of 10 000 slots, `missed` of them missed, the loop waking up to
    /// `wake_max_us` late, below its wire limit.
    fn at(rate_hz: f64, missed: u64, wake_max_us: f64) -> Trial {
        let mut t = trial(10_000, 0, missed, 10_000, true);
        t.rate_hz = rate_hz;
        t.period = Duration::from_secs_f64(1.0 / rate_hz);
        t.wake.max = wake_max_us;
        t.wake.p99 = 3.0;
        t.wire = Some(WireLimit {
            exchanges: 1000,
            max_cycle: Duration::from_micros(816),
            mean_cycle: Duration::from_micros(790),
            frames_at_max: Duration::from_micros(609),
            turnaround_at_max: Duration::from_micros(210),
            max_turnaround: Duration::from_micros(210),
            frame_bits: (112, 126),
        });
        t
    }

    /// The flags of each suggestion.
    fn flags(d: &Diagnosis) -> Vec<&str> {
        d.tries.iter().map(|t| t.flags.as_str()).collect()
    }

    const BUSY: Machine = Machine {
        load_start: Some(3.1),
        load_end: Some(3.4),
        cpus: 2,
    };

    #[test]
    fn stalls_on_a_busy_machine_are_named_with_what_to_try() {
        // Stepping down from 1100 Hz to 580 Hz, every trial missed about 0.5% of its ticks,
        // and the loop woke up to 25 ms late: stalls.
        let trials = [
            at(1100.0, 52, 25_000.0),
            at(990.0, 49, 18_000.0),
            at(580.0, 47, 21_000.0),
        ];
        let mut rate = args("--buses 1,4");
        let d = diagnose(&trials, &rate, &BUSY);
        let text = d.text(1);
        assert!(
            text.contains(
                "did not fall with the rate (0.520% of the ticks at 1100.0 Hz, 0.470% at 580.0 Hz)"
            ),
            "{text}"
        );
        assert!(text.contains("woke up to 25.0 ms late"), "{text}");
        assert!(
            text.contains("load average 3.10 at the start, 3.40 at the end; 2 CPU(s) (busy"),
            "{text}"
        );
        assert!(
            text.contains("148 deadline miss(es), 0 missing repl(ies), 0 skipped"),
            "{text}"
        );
        assert_eq!(
            flags(&d),
            [
                "",
                "--cpu 1 --fifo 80",
                "--miss-budget-pct 1",
                "--sim virtual"
            ]
        );
        // The simulator's threads late too: --sim inline.
        let mut late = trials.clone();
        late[0].sim_late = Some(Lateness {
            late_items: 3,
            max_late: Duration::from_millis(9),
        });
        late[0].sim_missed_slots = 4;
        rate = args("--buses 1,4 --cpu 1 --fifo 80");
        let d = diagnose(&late, &rate, &BUSY);
        let text = d.text(1);
        assert!(
            text.contains("handed 3 repl(ies) over late, up to 9.0 ms (4 missed slot(s)"),
            "{text}"
        );
        assert_eq!(
            flags(&d),
            ["", "--sim inline", "--miss-budget-pct 1", "--sim virtual"]
        );
    }

    #[test]
    fn a_rate_above_the_wire_limit_on_a_virtual_clock_is_the_wires() {
        let above = [at(1400.0, 10_000, 0.0)];
        let rate = args("--virtual-time --rate 1400");
        let d = diagnose(&above, &rate, &BUSY);
        let text = d.text(1);
        assert!(
            text.contains("above the wire limit of its frames (1225.5 Hz)"),
            "{text}"
        );
        // The machine's load does not matter on a virtual clock, nor a larger budget.
        assert!(!text.contains("load average"), "{text}");
        assert_eq!(flags(&d), ["--rate 1000"]);
    }

    #[test]
    fn a_larger_budget_is_suggested_only_where_it_would_pass() {
        // Every trial missed 9% or more: 1% would not pass either.
        let trials = [at(1100.0, 2000, 9000.0), at(580.0, 900, 9000.0)];
        let rate = args("--miss-budget-pct 0");
        let d = diagnose(&trials, &rate, &BUSY);
        assert!(
            !d.tries
                .iter()
                .any(|t| t.flags.contains("--miss-budget-pct")),
            "{d:?}"
        );
    }

    #[test]
    fn an_idle_machine_is_said_to_be_idle() {
        let idle = Machine {
            load_start: Some(0.1),
            load_end: None,
            cpus: 2,
        };
        let trials = [at(1000.0, 30, 40.0)];
        let rate = args("");
        let text = diagnose(&trials, &rate, &idle).text(2);
        assert!(
            text.contains(
                "2 bus(es): why: the machine: load average 0.10 at the start; 2 CPU(s) (idle)"
            ),
            "{text}"
        );
        assert!(!text.contains("woke up to"), "{text}");
    }

    #[test]
    fn every_suggestion_is_flags_rmd_bench_rate_takes() {
        let trials = [at(1100.0, 52, 25_000.0), at(580.0, 47, 21_000.0)];
        let mut trials = trials.to_vec();
        trials[0].sim_late = Some(Lateness {
            late_items: 1,
            max_late: Duration::from_millis(1),
        });
        // At 1400 Hz, above the wire limit (1225 Hz): --rate 1000 instead.
        let above = [at(1400.0, 1500, 10.0)];
        for (flags, trials) in [
            ("", &trials[..]),
            ("--rate 1400", &above),
            ("--sim inline", &trials),
        ] {
            let rate = args(flags);
            let tries = diagnose(trials, &rate, &BUSY).tries;
            assert!(!tries.is_empty());
            for t in tries {
                // A suggested flag replaces the one given (every flag here takes a value).
                let words: Vec<&str> = flags.split_whitespace().collect();
                let given: Vec<&str> = words
                    .chunks(2)
                    .filter(|flag| !t.flags.contains(flag[0]))
                    .flatten()
                    .copied()
                    .collect();
                let line = format!("rmd bench rate --buses 1,4 {} {}", given.join(" "), t.flags);
                if let Err(e) = crate::command().try_get_matches_from(line.split_whitespace()) {
                    panic!("`{line}`: {e}");
                }
            }
        }
    }
}
