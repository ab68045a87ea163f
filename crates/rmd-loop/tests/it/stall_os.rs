//! A stall the operating system causes, told apart from a controller's: the whole process is
//! stopped (`SIGSTOP`, then `SIGCONT` 400 ms later, sent by a shell outside it), so neither the
//! loop thread nor its supervisor runs. Whichever sees the stall first when they run again, the
//! run ends saying the OS did not run the loop thread, and every motor ends off.
//!
//! Alone in a process of its own: the stop freezes every test of the process it runs in.

use crate::common;

use core::time::Duration;

use common::*;
use rmd_bus::MonotonicClock;
use rmd_loop::{Fault, RtLoop, RunLimit, StallCause, StopReason};
use rmd_sim::{ControlMode, SharedSimBus, SimBus, SimConfig};

#[test]
fn a_stopped_process_is_a_stall_the_os_caused() {
    if rmd_test_support::ran_in_own_process() {
        return;
    }
    let bus =
        SharedSimBus::new(SimBus::new(MonotonicClock, SimConfig::with_motors(4).seed(9)).unwrap());
    // A bound far below the 400 ms stop and far above what a loaded machine does to a thread
    // that is not stopped (tens of milliseconds).
    let mut config = robot_config(1000.0, 1, 4);
    config.loop_config.stall_bound_ms = Some(250);
    let robot = rmd_loop::robot::Robot::try_from(config).unwrap();
    let handle = RtLoop::unsupervised(robot, MonotonicClock, vec![bus.clone()], PdTo::hold(4))
        .unwrap()
        .supervise(vec![Box::new(bus.clone())])
        .unwrap()
        .spawn(RunLimit::Forever)
        .unwrap();
    std::thread::sleep(Duration::from_millis(300));
    let pid = std::process::id();
    let mut stopper = std::process::Command::new("sh")
        .arg("-c")
        .arg(format!("kill -STOP {pid}; sleep 0.4; kill -CONT {pid}"))
        .spawn()
        .unwrap();
    // Frozen somewhere here until the shell sends SIGCONT.
    assert!(stopper.wait().unwrap().success());
    let r = handle.join().unwrap().report;
    println!("{}", r.stop_description);
    let StopReason::Fault(Fault::TickStalled { stalled, cause, .. }) = r.stop_reason else {
        panic!("{}", r.stop_description);
    };
    assert!(
        matches!(cause, StallCause::NotRun { .. }),
        "{cause:?}: {}",
        r.stop_description
    );
    assert!(stalled >= Duration::from_millis(250), "{stalled:?}");
    assert!(
        r.stop_description
            .contains("the OS did not run the loop thread for")
            && r.stop_description
                .contains("--fifo/--cpu, see docs/realtime.md"),
        "{}",
        r.stop_description
    );
    // Ground truth: every motor off.
    for m in 1..=4 {
        assert_eq!(bus.lock().snapshot(id(m)).unwrap().mode, ControlMode::Off);
    }
}
