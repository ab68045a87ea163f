//! The project's signal policy on a real signal: the first SIGINT stops the watched loop, the
//! second is an emergency stop. Its own test binary: the handler is process-wide.

use core::time::Duration;

use nix::sys::signal::{Signal, raise};
use rmd_loop::{
    Commands, Controller, Feedback, Flow, Robot, RtLoop, RunLimit, StopReason, TickContext,
};
use rmd_rig::runner::Runner;
use rmd_rig::{AnyBus, AnyClock, Placement, Rig, SimTime, signals, sim};

struct Idle;

impl Controller for Idle {
    fn update(&mut self, _: &TickContext, _: &Feedback<'_>, _: &mut Commands<'_>) -> Flow {
        Flow::Continue
    }
}

fn build() -> RtLoop<AnyBus, AnyClock, Idle> {
    let robot =
        Robot::from_toml("[[bus]]\ninterface = \"sim\"\n[[bus.motor]]\nid = 1\ngear_ratio = 9.0")
            .unwrap();
    let placement = Placement::simulated(&robot, SimTime::Virtual);
    let rig = Rig::open(&robot, &placement, sim::sim_configs(&robot, 1)).unwrap();
    RtLoop::new(robot, rig.clock, rig.buses, Idle).unwrap()
}

fn raise_and_wait(signals: &signals::Signals, count: u32) {
    raise(Signal::SIGINT).unwrap();
    let give_up = std::time::Instant::now() + Duration::from_secs(10);
    while signals.count() < count {
        assert!(std::time::Instant::now() < give_up, "the handler never ran");
        std::thread::sleep(Duration::from_millis(1));
    }
}

#[test]
fn the_first_signal_stops_the_run_the_second_is_an_emergency_stop() {
    // A running loop (virtual time, no limit) run by the runner is stopped by the first SIGINT,
    // and the run says it was interrupted (exit status 130).
    let signals = signals::install().unwrap();
    let rt = build();
    let stopper = rt.stopper();
    let raiser = std::thread::spawn(move || {
        let give_up = std::time::Instant::now() + Duration::from_secs(10);
        while !stopper.is_running() {
            assert!(
                std::time::Instant::now() < give_up,
                "the loop never started"
            );
            std::thread::sleep(Duration::from_millis(1));
        }
        std::thread::sleep(Duration::from_millis(20));
        raise_and_wait(&signals, 1);
    });
    let finished = Runner::new().run(rt, RunLimit::Forever).unwrap();
    raiser.join().unwrap();
    assert_eq!(finished.outcome.report.stop_reason, StopReason::Requested);
    assert!(finished.interrupted);
    assert_eq!(finished.exit_status(), signals::EXIT_INTERRUPTED);
    assert!(finished.outcome.report.safe_stop.all_off_confirmed());
    assert!(finished.outcome.report.stats.ticks > 0);

    // A second loop, after a reset: two signals before it runs are an emergency stop.
    signals.reset();
    let rt = build();
    let _watch = signals.watch(rt.stopper());
    raise_and_wait(&signals, 1);
    raise_and_wait(&signals, 2);
    let out = rt.run(RunLimit::Forever);
    assert_eq!(out.report.stop_reason, StopReason::EmergencyStop);
    assert!(out.report.safe_stop.all_off_confirmed());
}
