//! The real-time path allocates nothing with simulated buses on threads of their own
//! (`rmd_sim::threaded`) and the loop waiting on every bus at once (one `ppoll` over their
//! doorbells, or a spin to a known arrival): a counting global allocator around steady-state
//! ticks, in real time. It counts every thread: the loop's, the supervisor's and the
//! simulators'.
//!
//! Alone in a process of its own, so that no other test's thread allocates while we count. No assertion on
//! timing (shared machine): only on allocations, and that the ticks ran with replies.
#![cfg(target_os = "linux")]

use crate::common;

use common::*;
use core::time::Duration;

use rmd_bus::MonotonicClock;
use rmd_loop::RtLoop;
use rmd_loop::supervisor::SafetyPort;
use rmd_sim::threaded::{ThreadOptions, ThreadedSim};
use rmd_sim::{SimBus, SimConfig};

#[test]
fn steady_state_ticks_on_threaded_simulators_allocate_nothing() {
    if rmd_test_support::ran_in_own_process() {
        return;
    }
    const BUSES: usize = 3;
    let mut sims = Vec::new();
    let mut loop_ports = Vec::new();
    let mut safety_ports: Vec<SafetyPort> = Vec::new();
    for b in 0..BUSES {
        let bus = SimBus::new(
            MonotonicClock,
            SimConfig::with_motors(4).seed(40 + b as u64),
        )
        .unwrap();
        let options = ThreadOptions {
            ports: 2,
            // Half the buses spin to their replies' arrivals, half sleep all the way.
            receive_spin: Duration::from_micros(if b % 2 == 0 { 0 } else { 30 }),
            ..ThreadOptions::default()
        };
        let (sim, ports) = ThreadedSim::spawn(bus, &options, || {}).unwrap();
        let mut ports = ports.into_iter();
        loop_ports.push(ports.next().unwrap());
        safety_ports.push(Box::new(ports.next().unwrap()));
        sims.push(sim);
    }
    // On a loaded machine this thread may be held up for a while: neither missing replies nor a
    // stall may end the run (this test is about allocations, not timing).
    let mut config = robot_config(500.0, BUSES, 4);
    config.loop_config.missing_reply_fault_after = u32::MAX;
    config.loop_config.stall_bound_ms = Some(60_000);
    let robot = rmd_loop::robot::Robot::try_from(config).unwrap();
    let mut rt = RtLoop::unsupervised(robot, MonotonicClock, loop_ports, PdTo::new(&[10.0; 12]))
        .unwrap()
        .supervise(safety_ports)
        .unwrap();
    let telemetry = rt.telemetry();
    let mut rt = rt.start().unwrap();
    for _ in 0..100 {
        assert!(rt.step().is_continue());
    }
    rmd_test_support::alloc::count_every_thread(true);
    for _ in 0..500 {
        assert!(rt.step().is_continue());
        let _ = telemetry.try_recv();
    }
    rmd_test_support::alloc::count_every_thread(false);
    let allocations = rmd_test_support::alloc::counted().allocations;
    let stats = rt.stats().summary();
    let out = rt.finish(rmd_loop::StopReason::TickLimit);
    for sim in sims {
        sim.stop().unwrap();
    }
    assert!(out.report.safe_stop.all_off_confirmed(), "{}", out.report);
    // Replies came (every tick with all of them records what the loop added).
    assert!(stats.loop_added_us.count > 0, "{stats}");
    assert_eq!(
        allocations, 0,
        "allocations in 500 steady-state ticks: {stats}"
    );
}
