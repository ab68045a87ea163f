//! Running one drill.

use std::sync::{Arc, OnceLock};

use rmd_bus::{Clock, MonotonicClock, Timestamp};
use rmd_loop::RunLimit;
use rmd_rig::telemetry::{TelemetryOutputs, TelemetryReport, TelemetrySinks, spawn_feed};
use rmd_rig::{AnyClock, Placement, Rig, RigError, SharedSim, SimTime};

use crate::controller::{DrillController, TimeBase};
use crate::fault::DrillFault;
use crate::spec::DrillSpec;
use crate::verdict::{Drill, judge};
use crate::{DrillError, robot};

/// Runs the drill `spec` describes: the PD hold on simulated motors (supervised, as every
/// program runs the loop), its faults at their times, then the verdict from the simulated
/// firmware.
///
/// ```
/// use core::time::Duration;
/// use rmd_drill::{DrillFault, DrillSpec};
/// use rmd_rig::SimTime;
/// let drill = rmd_drill::run(
///     &DrillSpec::new(DrillFault::ControllerPanic)
///         .at(Duration::from_millis(100))
///         .seconds(Duration::from_millis(300))
///         .time(SimTime::Virtual),
/// )?;
/// assert!(drill.stop_reason.contains("panicked"));
/// assert_eq!(drill.motors_energised_after, 0);
/// # Ok::<(), rmd_drill::DrillError>(())
/// ```
pub fn run(spec: &DrillSpec) -> Result<Drill, DrillError> {
    run_with_telemetry(spec, &TelemetryOutputs::default()).map(|(drill, _)| drill)
}

/// [`run`], with the loop's telemetry written to the sinks `outputs` asks for (an MCAP file, a
/// CSV file, the live Foxglove server: see `rmd_rig::telemetry`), fed from a thread of their
/// own; the second value says what each sink got (`None` without sinks). On virtual time every
/// tick reaches every sink.
///
/// ```
/// use core::time::Duration;
/// use rmd_drill::{DrillFault, DrillSpec};
/// use rmd_rig::SimTime;
/// use rmd_rig::telemetry::TelemetryOutputs;
/// let dir = tempfile::tempdir()?;
/// let outputs = TelemetryOutputs {
///     mcap: Some(dir.path().join("drill.mcap")),
///     ..TelemetryOutputs::default()
/// };
/// let (drill, telemetry) = rmd_drill::run_with_telemetry(
///     &DrillSpec::new("bus-off:50".parse::<DrillFault>()?)
///         .at(Duration::from_millis(100))
///         .seconds(Duration::from_millis(300))
///         .time(SimTime::Virtual),
///     &outputs,
/// )?;
/// assert!(drill.passed());
/// let telemetry = telemetry.expect("an MCAP file was asked for");
/// // Every tick that ran to its end (the one the bus-off ended did not) is in the file.
/// assert!(telemetry.complete() && telemetry.samples > 90);
/// assert_eq!(telemetry.sinks()[0].written, telemetry.samples);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn run_with_telemetry(
    spec: &DrillSpec,
    outputs: &TelemetryOutputs,
) -> Result<(Drill, Option<TelemetryReport>), DrillError> {
    spec.check()?;
    let robot = robot::robot(spec)?;
    let placement = Placement::simulated(&robot, spec.time);
    // The instant the drill's times count from: the run's clock before anything is opened.
    let start = match spec.time {
        SimTime::Real => MonotonicClock.now(),
        SimTime::Virtual => Timestamp::ZERO,
    };
    let rig = Rig::open(&robot, &placement, robot::sims(&robot, spec, start))?;
    let sims: Vec<SharedSim> = rig.buses.iter().filter_map(|b| b.sim().cloned()).collect();
    let clock = rig.clock.clone();
    let time = match &rig.clock {
        AnyClock::Virtual(clock) => TimeBase::Virtual(clock.clone()),
        AnyClock::Monotonic(_) => TimeBase::Real,
    };
    let stopper = Arc::new(OnceLock::new());
    let faults = spec.faults.iter().map(|&(fault, at)| (fault, start + at));
    let controller = DrillController::new(&robot, faults, time, Arc::clone(&stopper));
    let mut rt = rig.into_loop(robot, controller)?;
    // Only the drill sets it, once, here: it cannot be set already.
    let _ = stopper.set(rt.stopper());
    let feed = TelemetrySinks::attach(&mut rt, outputs)
        .map_err(RigError::from)?
        .map(spawn_feed)
        .transpose()
        .map_err(RigError::from)?;
    let watch = spec.signals.map(|signals| signals.watch(rt.stopper()));
    let outcome = rt.run(RunLimit::Duration(spec.seconds));
    drop(watch);
    let telemetry = feed.map(|feed| feed.finish(outcome.report.stats.telemetry_drops));
    let fault_at = spec
        .faults
        .iter()
        .map(|&(fault, at)| match fault {
            DrillFault::UnknownMotor(_) => start,
            _ => start + at,
        })
        .min()
        .unwrap_or(start);
    // A silent host sends nothing more, so the run's end is not the motors' end: the verdict
    // waits until each motor's watchdog could have acted (its protection time after the
    // silence, and a 20 ms margin), on the run's own clock.
    let settled = spec
        .faults
        .iter()
        .filter_map(|&(fault, at)| match fault {
            DrillFault::HostSilent(watchdog) => {
                Some(start + at + watchdog + core::time::Duration::from_millis(20))
            }
            _ => None,
        })
        .max();
    if let Some(settled) = settled
        && let Some(wait) = settled.checked_duration_since(clock.now())
    {
        match &clock {
            AnyClock::Virtual(clock) => clock.advance(wait),
            AnyClock::Monotonic(_) => {
                if spec.tell_waits {
                    tell_wait(wait);
                }
                wait_unless_signalled(wait, spec.signals)
            }
        }
    }
    let written: Vec<String> = spec.faults.iter().map(|(f, _)| f.to_string()).collect();
    Ok((
        judge(written.join(" + "), fault_at, &sims, outcome.report),
        telemetry,
    ))
}

/// Says on stderr that the drill now waits `wait` for the motors' watchdogs (a failed write is
/// ignored: nothing here may stop the drill).
fn tell_wait(wait: core::time::Duration) {
    use std::io::Write;
    let _ = writeln!(
        std::io::stderr(),
        "rmd drill: the host is silent; waiting {:.1} s for the motors' watchdogs to act (Ctrl-C ends the wait)",
        wait.as_secs_f64()
    );
}

/// Sleeps `wait` in real time, in slices of at most 10 ms, and stops early once one of the
/// program's signals arrived: the wait for a motor's watchdog never holds a Ctrl-C back (the
/// verdict is then taken at once, from what the firmware did so far).
fn wait_unless_signalled(wait: core::time::Duration, signals: Option<rmd_rig::signals::Signals>) {
    const SLICE: core::time::Duration = core::time::Duration::from_millis(10);
    let until = std::time::Instant::now() + wait;
    while !signals.is_some_and(|s| s.interrupted()) {
        let left = until.saturating_duration_since(std::time::Instant::now());
        if left.is_zero() {
            return;
        }
        std::thread::sleep(left.min(SLICE));
    }
}
