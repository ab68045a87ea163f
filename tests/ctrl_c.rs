//! Ctrl-C (SIGINT) stops a loop registered with `rmd_rt::connect::stop_on_ctrl_c`: the first
//! interrupt is a stop, the second an emergency stop. Its own test binary: the handler is
//! process-wide.

use core::time::Duration;

use nix::sys::signal::{Signal, raise};
use rmd_rt::connect::{self, SimTime, Target};
use rmd_rt::{
    BusConfig, Commands, Controller, Feedback, Flow, MotorConfig, RobotConfig, RtLoop, RunLimit,
    StopReason, TickContext,
};

struct Idle;

impl Controller for Idle {
    fn update(&mut self, _: &TickContext, _: &Feedback<'_>, _: &mut Commands<'_>) -> Flow {
        Flow::Continue
    }
}

fn build() -> RtLoop<connect::AnyBus, connect::AnyClock, Idle> {
    let robot = RobotConfig::new(1000.0)
        .with_bus(BusConfig::new("sim").with_motor(MotorConfig::new(1).gear_ratio(9.0)));
    let target = Target::Simulator(SimTime::Virtual);
    let c = connect::open(&target, &robot, connect::sim_configs(&robot, 1)).unwrap();
    RtLoop::new(robot, c.clock, c.buses, Idle).unwrap()
}

fn interrupt_and_wait(count: u32) {
    raise(Signal::SIGINT).unwrap();
    let give_up = std::time::Instant::now() + Duration::from_secs(10);
    while connect::interrupts() < count {
        assert!(std::time::Instant::now() < give_up, "the handler never ran");
        std::thread::sleep(Duration::from_millis(1));
    }
}

#[test]
fn ctrl_c_stops_the_registered_loop_then_emergency_stops_it() {
    // A running loop (virtual time, no tick limit) is stopped by the first Ctrl-C.
    let rt = build();
    connect::stop_on_ctrl_c(rt.stopper()).unwrap();
    let telemetry = rt.telemetry();
    let handle = rt.spawn(RunLimit::Forever).unwrap();
    // Running: its first tick has published telemetry.
    let give_up = std::time::Instant::now() + Duration::from_secs(10);
    while telemetry.try_recv().is_none() {
        assert!(std::time::Instant::now() < give_up, "the loop never ticked");
        std::thread::sleep(Duration::from_millis(1));
    }
    interrupt_and_wait(1);
    let out = handle.join().unwrap();
    assert_eq!(out.report.stop_reason, StopReason::Requested);
    assert!(out.report.safe_stop.all_off_confirmed());
    assert!(out.report.stats.ticks > 0);

    // Registering the next loop resets the count; two interrupts are an emergency stop.
    let rt = build();
    connect::stop_on_ctrl_c(rt.stopper()).unwrap();
    assert_eq!(connect::interrupts(), 0);
    interrupt_and_wait(1);
    interrupt_and_wait(2);
    let out = rt.run(RunLimit::Forever);
    assert_eq!(out.report.stop_reason, StopReason::EmergencyStop);
    assert!(out.report.safe_stop.all_off_confirmed());
}
