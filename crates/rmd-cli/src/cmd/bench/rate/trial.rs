//! One trial: the loop at one rate for the trial's length, and what it measured.
//!
//! The loop runs the PD controller of `rmd bench loop` (targets that move, so every frame's
//! content changes), with the reply deadline at the end of the period (it waits for replies as
//! long as the period allows), the wire-budget check off (`allow_over_budget`: the search looks
//! beyond the worst-case budget), no fault for missing replies (the trial always runs its
//! full length, so that its share of missed ticks is known) and no health rotation (the search
//! measures the torque exchange alone: a status request and reply would sit on the wire at the
//! low rates where they fit, not at the high ones, and the wire limit is the torque exchange's).
//!
//! The simulated buses run where `--sim` says: each on its own thread (real time, the default:
//! the loop thread is measured alone), in the loop's thread (`inline`), or in virtual time.

use core::time::Duration;

use rmd_bus::{CanBus, Clock, MonotonicClock, Timestamp, VirtualClock};
use rmd_loop::stats::Percentiles;
use rmd_loop::{LoopOutcome, RtLoop, RunLimit};
use rmd_sim::threaded::Lateness;
use rmd_sim::{SimBus, Transmission};
use serde_json::{Value, json};

use super::{BITRATE, RateArgs, SimPlace, attribution};
use crate::cmd::bench::pd::MovingTargetPd;
use crate::cmd::bench::robot;
use crate::cmd::bench::wire_limit::{self, WireLimit, us};

/// Whether a missed share is within `budget` (a fraction; 0 means none missed).
pub(super) fn within(missed: f64, budget: f64) -> bool {
    if budget == 0.0 {
        missed == 0.0
    } else {
        missed <= budget
    }
}

/// The outcome of one trial.
#[derive(Clone, Debug)]
pub(super) struct Trial {
    pub(super) buses: usize,
    pub(super) rate_hz: f64,
    pub(super) period: Duration,
    pub(super) normal_stop: bool,
    pub(super) stop_reason: String,
    pub(super) ticks: u64,
    pub(super) expected_ticks: u64,
    pub(super) missed_ticks: u64,
    pub(super) skipped_ticks: u64,
    pub(super) deadline_misses: u64,
    pub(super) missing_replies: u64,
    pub(super) late_replies: u64,
    pub(super) wake: Percentiles,
    pub(super) round_trip: Percentiles,
    pub(super) work: Percentiles,
    pub(super) loop_added: Percentiles,
    pub(super) last_reply: Percentiles,
    pub(super) handoff: Percentiles,
    pub(super) wire: Option<WireLimit>,
    /// With the simulators on their own threads: replies they handed over after their arrival
    /// (their thread was late, not the loop), and the latest.
    pub(super) sim_late: Option<Lateness>,
    /// Missed slots that were the simulator's, not the loop's (see [`super::attribution`]).
    pub(super) sim_missed_slots: u64,
    pub(super) warnings: Vec<String>,
}

impl Trial {
    /// The trial's tick slots: those it covered (ticks run and skipped), at least as many as its
    /// length holds.
    pub(super) fn slots(&self) -> u64 {
        (self.ticks + self.skipped_ticks)
            .max(self.expected_ticks)
            .max(1)
    }

    /// Missed slots that were the loop's: all of them ([`Self::all_missed_slots`]) but those
    /// the simulator made it miss (it handed a reply over late while the loop was on time).
    pub(super) fn missed_slots(&self) -> u64 {
        self.all_missed_slots()
            .saturating_sub(self.sim_missed_slots)
    }

    /// All missed slots: ticks that missed their deadline or a reply, ticks skipped (after an
    /// overrun), and slots the run never accounted for (an overrun across its end). A trial that
    /// stopped early missed them all.
    pub(super) fn all_missed_slots(&self) -> u64 {
        let covered = self.ticks + self.skipped_ticks;
        if !self.normal_stop || covered == 0 {
            return self.slots();
        }
        let unaccounted = self.expected_ticks.saturating_sub(covered);
        (self.missed_ticks + self.skipped_ticks + unaccounted).min(self.slots())
    }

    /// The share of the trial's tick slots that the loop missed.
    pub(super) fn missed_fraction(&self) -> f64 {
        self.missed_slots() as f64 / self.slots() as f64
    }

    /// The share of the trial's tick slots missed, the simulator's doing included.
    pub(super) fn all_missed_fraction(&self) -> f64 {
        self.all_missed_slots() as f64 / self.slots() as f64
    }

    /// Whether at most `budget` (a fraction) of the tick slots were missed.
    pub(super) fn within(&self, budget: f64) -> bool {
        within(self.missed_fraction(), budget)
    }

    /// The wire limit of this trial's frames, Hz.
    pub(super) fn wire_limit_hz(&self) -> Option<f64> {
        self.wire.map(|w| w.rate_hz())
    }

    pub(super) fn to_json(&self, budget: f64) -> Value {
        json!({
            "buses": self.buses,
            "rate_hz": self.rate_hz,
            "period_us": us(self.period),
            "wire_limit_hz": self.wire_limit_hz(),
            "rate_of_wire_limit": self.wire_limit_hz().map(|w| self.rate_hz / w),
            "missed_fraction": self.missed_fraction(),
            "missed_fraction_with_simulator": self.all_missed_fraction(),
            "simulator_missed_slots": self.sim_missed_slots,
            "within_budget": self.within(budget),
            "zero_misses": self.within(0.0),
            "stop_reason": self.stop_reason,
            "ticks": self.ticks,
            "expected_ticks": self.expected_ticks,
            "missed_ticks": self.missed_ticks,
            "skipped_ticks": self.skipped_ticks,
            "deadline_misses": self.deadline_misses,
            "missing_replies": self.missing_replies,
            "late_replies": self.late_replies,
            "loop_added_us": self.loop_added,
            "wake_latency_us": self.wake,
            "round_trip_us": self.round_trip,
            "work_us": self.work,
            "last_reply_after_start_us": self.last_reply,
            "reply_to_controller_us": self.handoff,
            "wire_limit": self.wire.map(WireLimit::to_json),
            "sim_late_items": self.sim_late.map(|l| l.late_items),
            "sim_max_late_us": self.sim_late.map(|l| us(l.max_late)),
        })
    }

    pub(super) fn line(&self, n: usize, budget: f64) -> String {
        format!(
            "trial {n:>2}: {} bus(es) {:>8.1} Hz ({}) missed {:.3}%{} {}  misses {} skipped {} missing {} late {}  \
             loop added p50 {:.1} p99 {:.1}  wake p99 {:.1} max {:.1}  work max {:.1} us{}",
            self.buses,
            self.rate_hz,
            self.wire_limit_hz()
                .map_or("wire limit n/a".to_string(), |w| format!(
                    "{:.1}% of {w:.1} Hz",
                    100.0 * self.rate_hz / w
                )),
            100.0 * self.missed_fraction(),
            if self.sim_missed_slots > 0 {
                format!(
                    " (+{} slot(s) the simulator's: {:.3}% in all)",
                    self.sim_missed_slots,
                    100.0 * self.all_missed_fraction()
                )
            } else {
                String::new()
            },
            match (self.within(0.0), self.within(budget)) {
                (true, _) => "ZERO",
                (false, true) => "PASS",
                (false, false) => "FAIL",
            },
            self.deadline_misses,
            self.skipped_ticks,
            self.missing_replies,
            self.late_replies,
            self.loop_added.p50,
            self.loop_added.p99,
            self.wake.p99,
            self.wake.max,
            self.work.max,
            self.sim_late
                .filter(|l| l.late_items > 0)
                .map_or(String::new(), |l| format!(
                    "  (simulator late: {} item(s), up to {:.1} us)",
                    l.late_items,
                    us(l.max_late)
                )),
        )
    }
}

/// Stack of the trial thread (as the loop's own thread).
const TRIAL_STACK_BYTES: usize = 8 * 1024 * 1024;

/// A receive clock for simulated buses in the loop's thread, in real time: the monotonic clock,
/// whose waits sleep until `spin` before the deadline and busy-wait the rest.
#[derive(Copy, Clone, Debug)]
struct ReceiveClock {
    spin: Duration,
}

impl Clock for ReceiveClock {
    fn now(&self) -> Timestamp {
        MonotonicClock.now()
    }

    fn sleep_until(&self, deadline: Timestamp) {
        MonotonicClock.wait_until(deadline, self.spin);
    }
}

/// Runs one trial of `buses` buses at `rate_hz` on a thread of its own (the loop pins and
/// prioritises it). With `running`, it is called every 50 ms meanwhile with the time elapsed;
/// without, this thread just waits (nothing else wakes up during the measurement).
pub(super) fn trial(
    args: &RateArgs,
    buses: usize,
    rate_hz: f64,
    mut running: Option<impl FnMut(Duration)>,
) -> Result<Trial, String> {
    let args = args.clone();
    let thread = std::thread::Builder::new()
        .name("rmd-bench-rate".to_string())
        .stack_size(TRIAL_STACK_BYTES)
        .spawn(move || run_trial(&args, buses, rate_hz))
        .map_err(|e| format!("cannot start the trial thread: {e}"))?;
    let start = std::time::Instant::now();
    if let Some(running) = &mut running {
        while !thread.is_finished() {
            running(start.elapsed());
            std::thread::sleep(Duration::from_millis(50));
        }
    }
    thread
        .join()
        .map_err(|_| "the trial thread panicked".to_string())?
}

fn run_trial(args: &RateArgs, buses: usize, rate_hz: f64) -> Result<Trial, String> {
    let family = super::super::sim_family(args.sim_firmware);
    let mut config = robot::robot_for(rate_hz, buses, args.motors, family, args.exchange);
    args.rt.apply(&mut config);
    let period = rmd_loop::schedule::Period::from_hz(rate_hz)
        .map_err(|e| e.to_string())?
        .get();
    let l = &mut config.loop_config;
    l.allow_over_budget = true;
    l.reply_deadline_us = Some((period.as_nanos() / 1000) as u64);
    l.missing_reply_fault_after = u32::MAX;
    l.health_rotation = false;
    let robot = rmd_loop::robot::Robot::try_from(config).map_err(|e| e.to_string())?;
    let expected_ticks = (args.duration.as_nanos() / period.as_nanos()) as u64;
    let requests = robot.buses()[0].requests_per_exchange() as usize;
    let frames_per_exchange = usize::from(args.motors) + requests;
    // Start-up probes, every tick, and the safe stop (zero torque, motor-off and replies).
    let trace = (expected_ticks as usize + 64) * frames_per_exchange + 64;
    let limit = RunLimit::Duration(args.duration);
    let controller = MovingTargetPd::new(args.sim != SimPlace::Virtual)
        .in_motion_mode(args.exchange == Some(rmd_loop::robot::ExchangeKind::Motion));
    let mut sim_late = None;
    let mut late_arrivals = Vec::new();
    let (outcome, traces) = match args.sim {
        SimPlace::Virtual => {
            let clock = VirtualClock::new();
            let mut sims = sim_buses(&clock, buses, args.motors, family, trace)?;
            let buses: Vec<_> = sims.iter_mut().collect();
            let outcome = run(robot, clock.clone(), buses, controller, limit)?;
            (outcome, traces_of(&sims))
        }
        SimPlace::Inline => {
            let clock = ReceiveClock {
                spin: Duration::from_micros(args.rx_spin_us),
            };
            let mut sims = sim_buses(&clock, buses, args.motors, family, trace)?;
            let buses: Vec<_> = sims.iter_mut().collect();
            let outcome = run(robot, MonotonicClock, buses, controller, limit)?;
            (outcome, traces_of(&sims))
        }
        SimPlace::Thread => {
            let spin = Duration::from_micros(args.rx_spin_us);
            let mut threaded =
                robot::threaded_buses(buses, args.motors, family, &args.rt, spin, trace)?;
            let ports = core::mem::take(&mut threaded.ports);
            let outcome = run(robot, MonotonicClock, ports, controller, limit)?;
            sim_late = Some(threaded.lateness());
            late_arrivals = threaded.late_arrivals();
            (outcome, traces_of(&threaded.stop()?))
        }
    };
    // The ticks' exchanges only: not the start-up probes nor the safe stop (zero-torque frames,
    // the longest there are).
    let (first, last) = outcome
        .controller
        .ticks_due
        .unwrap_or((Timestamp::ZERO, Timestamp::ZERO));
    let exchanges: Vec<_> = traces
        .iter()
        .flat_map(|trace| wire_limit::exchanges(trace, usize::from(args.motors), BITRATE))
        .filter(|e| e.start >= first && e.start < last + period)
        .collect();
    let r = &outcome.report;
    let s = &r.stats;
    Ok(Trial {
        buses,
        rate_hz,
        period,
        normal_stop: r.normal_stop,
        stop_reason: r.stop_reason.to_string(),
        ticks: s.ticks,
        expected_ticks,
        missed_ticks: s.missed_ticks,
        skipped_ticks: s.skipped_ticks,
        deadline_misses: s.deadline_misses,
        missing_replies: s.missing_replies,
        late_replies: s.late_replies,
        wake: s.wake_latency_us,
        round_trip: s.round_trip_us,
        work: s.work_us,
        loop_added: s.loop_added_us,
        last_reply: outcome.controller.last_reply.percentiles(),
        handoff: outcome.controller.handoff.percentiles(),
        wire: WireLimit::of(&exchanges),
        sim_late,
        sim_missed_slots: attribution::simulator_slots(
            &outcome.controller.missed,
            &late_arrivals,
            period,
        ),
        warnings: r.realtime_warnings.clone(),
    })
}

fn run<B: CanBus, C: Clock + Clone + 'static>(
    robot: rmd_loop::robot::Robot,
    clock: C,
    buses: Vec<B>,
    controller: MovingTargetPd,
    limit: RunLimit,
) -> Result<LoopOutcome<MovingTargetPd>, String> {
    let rt = RtLoop::unsupervised(robot, clock, buses, controller).map_err(|e| e.to_string())?;
    // A signal stops the trial's loop (`rmd_rig::signals`); the search then ends.
    let signals = rmd_rig::signals::install().map_err(|e| e.to_string())?;
    let watch = signals.watch(rt.stopper());
    let outcome = rt.run(limit);
    drop(watch);
    Ok(outcome)
}

fn sim_buses<C: Clock + Clone>(
    clock: &C,
    buses: usize,
    motors: u8,
    family: rmd_sim::FirmwareFamily,
    trace: usize,
) -> Result<Vec<SimBus<C>>, String> {
    let mut sims =
        robot::sim_buses_of(clock, buses, motors, family).map_err(|e| format!("simulator: {e}"))?;
    for sim in &mut sims {
        sim.record_trace(trace);
    }
    Ok(sims)
}

fn traces_of<C: Clock>(sims: &[SimBus<C>]) -> Vec<Vec<Transmission>> {
    sims.iter().map(|s| s.trace().to_vec()).collect()
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    /// The arguments of `rmd bench rate FLAGS`.
    pub(in crate::cmd::bench::rate) fn args(flags: &str) -> RateArgs {
        #[derive(clap::Parser)]
        struct Cli {
            #[command(flatten)]
            rate: RateArgs,
        }
        <Cli as clap::Parser>::parse_from(std::iter::once("rate").chain(flags.split_whitespace()))
            .rate
    }

    /// A trial at 1 kHz with these counts (the other figures empty).
    pub(in crate::cmd::bench::rate) fn trial(
        ticks: u64,
        skipped: u64,
        missed: u64,
        expected: u64,
        normal_stop: bool,
    ) -> Trial {
        Trial {
            buses: 1,
            rate_hz: 1000.0,
            period: Duration::from_millis(1),
            normal_stop,
            stop_reason: String::new(),
            ticks,
            expected_ticks: expected,
            missed_ticks: missed,
            skipped_ticks: skipped,
            deadline_misses: missed,
            missing_replies: 0,
            late_replies: 0,
            wake: Percentiles::default(),
            round_trip: Percentiles::default(),
            work: Percentiles::default(),
            loop_added: Percentiles::default(),
            last_reply: Percentiles::default(),
            handoff: Percentiles::default(),
            wire: None,
            sim_late: None,
            sim_missed_slots: 0,
            warnings: Vec::new(),
        }
    }

    #[test]
    fn a_skipped_tick_is_one_missed_slot_not_a_failed_trial() {
        // One overrun: the tick that overran missed its deadline, the next slot was skipped.
        let t = trial(9999, 1, 1, 10_000, true);
        assert_eq!(t.missed_fraction(), 2.0 / 10_000.0);
        assert!(t.within(0.001));
        assert!(!t.within(0.0));
    }

    #[test]
    fn slots_the_simulator_made_the_loop_miss_are_not_the_loops() {
        // 12 missed slots, 8 of them in ticks whose replies the simulator handed over late.
        let mut t = trial(9994, 6, 6, 10_000, true);
        t.sim_missed_slots = 8;
        assert_eq!(t.all_missed_fraction(), 12.0 / 10_000.0);
        assert_eq!(t.missed_fraction(), 4.0 / 10_000.0);
        assert!(t.within(0.001));
        let line = t.line(1, 0.001);
        assert!(
            line.contains("missed 0.040% (+8 slot(s) the simulator's: 0.120% in all) PASS"),
            "{line}"
        );
        let json = t.to_json(0.001);
        assert_eq!(json["simulator_missed_slots"], 8);
        assert_eq!(json["missed_fraction_with_simulator"], 12.0 / 10_000.0);
    }

    #[test]
    fn slots_the_run_never_reached_count_as_missed() {
        let t = trial(9998, 1, 1, 10_000, true);
        assert_eq!(t.missed_fraction(), 3.0 / 10_000.0);
    }

    #[test]
    fn a_clean_trial_missed_nothing_and_a_stopped_one_missed_everything() {
        assert_eq!(trial(10_000, 0, 0, 10_000, true).missed_fraction(), 0.0);
        assert!(trial(10_000, 0, 0, 10_000, true).within(0.0));
        assert_eq!(trial(10_000, 0, 0, 10_000, false).missed_fraction(), 1.0);
        assert_eq!(trial(0, 0, 0, 10_000, true).missed_fraction(), 1.0);
    }
}
