//! The project's signal policy on a real signal: the first SIGINT stops the watched loop, the
//! second is an emergency stop, and the same signal from the same process at once (GNU
//! `timeout`'s pair) is the first again. Alone in a process of its own: the handler is
//! process-wide.

use core::time::Duration;

use nix::sys::signal::{Signal, raise};
use rmd_loop::{
    Commands, Controller, Feedback, Flow, RtLoop, RunLimit, StopReason, TickContext, robot::Robot,
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
    RtLoop::unsupervised(robot, rig.clock, rig.buses, Idle).unwrap()
}

fn raise_and_wait(signals: &signals::Signals, count: u32) {
    raise(Signal::SIGINT).unwrap();
    wait_for(signals, count);
}

fn wait_for(signals: &signals::Signals, count: u32) {
    let give_up = std::time::Instant::now() + Duration::from_secs(10);
    while signals.count() < count {
        assert!(std::time::Instant::now() < give_up, "the handler never ran");
        std::thread::sleep(Duration::from_millis(1));
    }
}

#[test]
fn the_first_signal_stops_the_run_the_second_is_an_emergency_stop() {
    if rmd_test_support::ran_in_own_process() {
        return;
    }
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

    // A second loop, after a reset: two signals before it runs are an emergency stop (the
    // second sent after the window in which it would repeat the first).
    signals.reset();
    let rt = build();
    let watch = signals.watch(rt.stopper());
    raise_and_wait(&signals, 1);
    std::thread::sleep(signals::REPEAT_WINDOW);
    raise_and_wait(&signals, 2);
    let out = rt.run(RunLimit::Forever);
    assert_eq!(out.report.stop_reason, StopReason::EmergencyStop);
    assert!(out.report.safe_stop.all_off_confirmed());
    drop(watch);

    // A third: the same signal twice at once from this process, as GNU timeout sends it (to
    // the command, then to its process group), is one request: the loop stops, no emergency
    // stop. (Each raise runs the process's signal handler before it returns: two deliveries.
    // Read apart, the second repeats the first; read together, they are one.)
    std::thread::sleep(signals::REPEAT_WINDOW);
    signals.reset();
    let rt = build();
    let _watch = signals.watch(rt.stopper());
    raise(Signal::SIGINT).unwrap();
    raise(Signal::SIGINT).unwrap();
    wait_for(&signals, 1);
    // Both are read well within a second.
    std::thread::sleep(Duration::from_secs(1));
    assert_eq!(signals.count(), 1, "the repeat was counted");
    let out = rt.run(RunLimit::Forever);
    assert_eq!(out.report.stop_reason, StopReason::Requested);
    assert!(out.report.safe_stop.all_off_confirmed());
}
