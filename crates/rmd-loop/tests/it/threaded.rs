//! The loop on its own thread: real time on the simulator, snapshots, emergency stop, and the
//! safe stop when the handle is dropped. No assertion here depends on timing (shared VM): timing
//! goals live in the benchmarks.

use crate::common;

use core::time::Duration;
use std::sync::{Arc, Mutex};

use common::*;
use rmd_bus::{Clock, MonotonicClock, VirtualClock};
use rmd_loop::{Commands, Controller, Feedback, Flow, RtLoop, RunLimit, StopReason, TickContext};
use rmd_sim::{ControlMode, SharedSimBus, SimBus, SimConfig};

/// A simulated bus of `motors` motors the test can still inspect after the loop thread took it.
fn shared_bus<C: Clock>(clock: C, motors: u8) -> SharedSimBus<C> {
    SharedSimBus::new(SimBus::new(clock, SimConfig::with_motors(motors).seed(5)).unwrap())
}

/// Whether motors 1..=`motors` are all off.
fn all_off<C: Clock>(bus: &SharedSimBus<C>, motors: u8) -> bool {
    let mut bus = bus.lock();
    (1..=motors).all(|m| bus.snapshot(id(m)).unwrap().mode == ControlMode::Off)
}

/// Records how the loop ended, for loops the test cannot join.
struct Recorder {
    stop: Arc<Mutex<Option<StopReason>>>,
}

impl Controller for Recorder {
    fn update(&mut self, _: &TickContext, fb: &Feedback<'_>, cmd: &mut Commands<'_>) -> Flow {
        for (joint, _) in fb.iter() {
            cmd.set_current(joint, 0.5);
        }
        Flow::Continue
    }
    fn stop(&mut self, reason: &StopReason) {
        *self.stop.lock().unwrap() = Some(reason.clone());
    }
}

#[test]
fn a_few_seconds_at_one_kilohertz_in_real_time() {
    let clock = MonotonicClock;
    let bus = SimBus::new(clock, SimConfig::with_motors(4).seed(1)).unwrap();
    let rt = RtLoop::unsupervised(
        realtime_robot(1000.0, 1, 4),
        clock,
        vec![bus],
        PdTo::new(&[10.0, -10.0, 5.0, 0.0]),
    )
    .unwrap();
    let handle = rt
        .spawn(RunLimit::Duration(Duration::from_secs(2)))
        .unwrap();
    let out = handle.join().unwrap();
    let r = &out.report;
    println!("{r}");
    assert_eq!(r.stop_reason, StopReason::TickLimit);
    // Two seconds of 1 ms slots: every slot ran, or was skipped because the loop was late (a
    // loaded machine stalls at times, across the run's end too); the run lasted 2 s either way.
    // A skip that lands on the end's own slot (the clock read just before the end) runs it.
    let slots = r.stats.ticks + r.stats.skipped_ticks;
    assert!((2000..=2001).contains(&slots), "{slots}");
    assert!(r.duration_s >= 2.0, "{}", r.duration_s);
    assert_eq!(r.stats.wake_latency_us.count, r.stats.ticks);
    assert_eq!(r.stats.work_us.count, r.stats.ticks);
    assert!(r.stats.round_trip_us.count > 0);
    // Percentiles are ordered.
    let w = r.stats.wake_latency_us;
    assert!(
        w.min <= w.p50 && w.p50 <= w.p90 && w.p90 <= w.p99 && w.p99 <= w.p999 && w.p999 <= w.max
    );
    assert!(r.safe_stop.all_off_confirmed(), "{}", r.safe_stop);
    // The JSON report has what `rmd bench loop --json` promises.
    let json: serde_json::Value = serde_json::from_str(&r.to_json()).unwrap();
    for key in [
        "ticks",
        "deadline_misses",
        "missing_replies",
        "late_replies",
        "telemetry_drops",
    ] {
        assert!(json[key].is_u64(), "{key} in {json}");
    }
    for key in [
        "wake_latency_us",
        "round_trip_us",
        "controller_us",
        "work_us",
    ] {
        for p in ["p50", "p90", "p99", "p999", "max"] {
            assert!(json[key][p].is_f64(), "{key}.{p} in {json}");
        }
    }
}

#[test]
fn snapshots_are_readable_while_the_loop_runs() {
    let clock = VirtualClock::new();
    let bus = shared_bus(clock.clone(), 4);
    let rt =
        RtLoop::unsupervised(robot(1000.0, 1, 4), clock, vec![bus.clone()], PdTo::hold(4)).unwrap();
    let handle = rt.spawn(RunLimit::Forever).unwrap();
    let first = loop {
        if let Some(s) = handle.snapshot(Duration::from_secs(5))
            && s.ticks > 0
        {
            break s;
        }
    };
    let second = handle.snapshot(Duration::from_secs(5)).unwrap();
    assert!(second.ticks >= first.ticks);
    assert_eq!(second.motors.len(), 4);
    assert_eq!(second.wake_latency_us.count, second.ticks);
    // The snapshot is taken inside a tick: that tick's work is not recorded yet.
    assert_eq!(second.work_us.count + 1, second.ticks);
    let out = handle.stop().unwrap();
    assert_eq!(out.report.stop_reason, StopReason::Requested);
    assert!(out.report.stats.ticks >= second.ticks);
    assert!(all_off(&bus, 4));
}

#[test]
fn an_emergency_stop_from_another_thread_makes_every_motor_safe() {
    let clock = MonotonicClock;
    let bus = shared_bus(clock, 4);
    let rt = RtLoop::unsupervised(
        realtime_robot(1000.0, 1, 4),
        clock,
        vec![bus.clone()],
        PdTo::hold(4),
    )
    .unwrap();
    let handle = rt.spawn(RunLimit::Forever).unwrap();
    let stopper = handle.stopper();
    std::thread::spawn(move || {
        std::thread::sleep(Duration::from_millis(200));
        stopper.emergency_stop();
    })
    .join()
    .unwrap();
    let out = handle.join().unwrap();
    assert_eq!(out.report.stop_reason, StopReason::EmergencyStop);
    assert!(!out.report.normal_stop);
    assert!(out.report.safe_stop.all_off_confirmed());
    assert!(all_off(&bus, 4));
}

#[test]
fn dropping_the_handle_stops_the_loop_safely() {
    let clock = MonotonicClock;
    let bus = shared_bus(clock, 4);
    let stop = Arc::new(Mutex::new(None));
    let rt = RtLoop::unsupervised(
        realtime_robot(500.0, 1, 4),
        clock,
        vec![bus.clone()],
        Recorder {
            stop: Arc::clone(&stop),
        },
    )
    .unwrap();
    let handle = rt.spawn(RunLimit::Forever).unwrap();
    std::thread::sleep(Duration::from_millis(100));
    {
        let mut sim = bus.lock();
        let mode = sim.snapshot(id(1)).unwrap().mode;
        assert!(matches!(mode, ControlMode::Torque { .. }), "{mode:?}");
    }
    drop(handle);
    assert_eq!(*stop.lock().unwrap(), Some(StopReason::HandleDropped));
    assert!(all_off(&bus, 4));
}

#[test]
fn missing_privileges_are_reported_not_fatal() {
    // Asks for SCHED_FIFO, which an unprivileged test run may not get; either way the loop runs.
    let clock = VirtualClock::new();
    let bus = shared_bus(clock.clone(), 2);
    let mut config = robot_config(1000.0, 1, 2);
    config.loop_config.fifo_priority = Some(10);
    config.loop_config.cpu = Some(0);
    let robot = rmd_loop::robot::Robot::try_from(config).unwrap();
    let rt = RtLoop::unsupervised(robot, clock, vec![bus], PdTo::hold(2)).unwrap();
    let out = rt.spawn(RunLimit::Ticks(100)).unwrap().join().unwrap();
    assert_eq!(out.report.stats.ticks, 100);
    assert_eq!(
        out.report.realtime.fifo.failed(),
        !out.report.realtime_warnings.is_empty()
    );
}
