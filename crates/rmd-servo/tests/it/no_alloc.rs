//! The servo's ticks allocate nothing on the loop thread while another thread streams
//! setpoints, sends trajectories that replace each other, reads the state, disables and enables:
//! a counting global allocator that counts the loop thread only (the sender plans on its own
//! thread, where allocating is allowed).
//!
//! Other tests may run beside it in the process: only the loop thread's allocations and frees
//! are counted. The same on a MyActuator V3 bus in motion mode, where every tick gives each
//! joint a motion setpoint.

use crate::common;

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use common::{Bench, SERVO, v3_leg};
use rmd_loop::robot::ExchangeKind;
use rmd_servo::{JointTrajectory, JointTrajectoryPoint, Setpoint, TrajectoryStart};

/// The last tick the loop thread ran, and the last one the sender acted on: they go in step,
/// so that the sender's schedule (in ticks) is the same on every run.
#[derive(Default)]
struct Lockstep {
    tick: AtomicU64,
    seen: AtomicU64,
    done: AtomicBool,
}

const TICKS: u64 = 3000;

fn wave(t0_ms: u64, amplitude: f64) -> JointTrajectory {
    JointTrajectory::new(["knee", "ankle"])
        .point(JointTrajectoryPoint::at(
            Duration::from_millis(t0_ms),
            [amplitude, -amplitude],
        ))
        .point(JointTrajectoryPoint::at(
            Duration::from_millis(t0_ms + 300),
            [-amplitude, amplitude / 2.0],
        ))
        .point(JointTrajectoryPoint::at(
            Duration::from_millis(t0_ms + 600),
            [0.0, 0.0],
        ))
}

fn servo() -> String {
    format!(
        "{SERVO}\n[joint.hip_fe]\nstale_after_ms = 20\nstale_policy = \"hold\"\n[joint.hip_aa]\nstale_after_ms = 20\nstale_policy = \"zero-torque\"\n"
    )
}

#[test]
fn servo_ticks_allocate_nothing_while_another_thread_drives_it() {
    drive(Bench::new(&servo(), [0.0; 4]));
}

#[test]
fn servo_ticks_on_a_motion_bus_allocate_nothing_while_another_thread_drives_it() {
    drive(Bench::on(v3_leg(ExchangeKind::Motion), &servo(), [0.0; 4]));
}

/// Steps `bench` while another thread drives its servo through every path, counting the
/// allocations of the stepping thread.
fn drive(mut bench: Bench) {
    let sync = Arc::new(Lockstep::default());
    let (ticked, seen, done) = (&sync.tick, &sync.seen, &sync.done);
    let handle = bench.handle.clone();
    let theirs = Arc::clone(&sync);
    let sender = std::thread::spawn(move || {
        let (ticked, seen, done) = (&theirs.tick, &theirs.seen, &theirs.done);
        let waves = [wave(200, 0.3), wave(150, -0.2), wave(250, 0.15)];
        let mut sent = 0u64;
        let mut last = 0;
        while !done.load(Ordering::Acquire) {
            let tick = ticked.load(Ordering::Acquire);
            if tick == last {
                std::thread::yield_now();
                continue;
            }
            last = tick;
            let state = handle.state();
            assert!(state.is_some());
            let t = tick as f64 * 1e-3;
            let ok = |r: Result<_, _>| r.is_ok() as u64;
            // Streamed positions for the hip (renewed every 5 ticks), until tick 2500: then it
            // goes stale (zero torque).
            if tick.is_multiple_of(5) && tick < 2500 {
                sent +=
                    ok(handle.set_many([("hip_aa", Setpoint::position(0.1 * (3.0 * t).sin()))]));
            }
            // The other hip: velocity, then effort, then one position left to go stale (hold).
            match tick {
                300 => sent += ok(handle.set_velocity("hip_fe", 0.3, 0.0)),
                800 => sent += ok(handle.set_effort("hip_fe", 0.2)),
                900 => sent += ok(handle.set_position("hip_fe", 0.1, 0.0, 0.0)),
                _ => {}
            }
            // Trajectories for the knee and ankle, each replacing the last while it moves,
            // one starting later.
            if tick % 400 == 200 {
                let k = (tick / 400) as usize % waves.len();
                sent += ok(handle.send_trajectory(&waves[k]).map(|_| ()));
            }
            if tick == 2200 {
                let later = wave(200, 0.1)
                    .starting(TrajectoryStart::AtLoopTime(state.unwrap().time_s + 0.1));
                sent += ok(handle.send_trajectory(&later).map(|_| ()));
            }
            // A disable and an enable: the servo drops what was queued and holds.
            if tick == 1500 {
                handle.set_position("knee", 0.0, 0.0, 0.0).ok();
                handle.disable();
            }
            if tick == 1510 {
                handle.enable();
            }
            seen.store(tick, Ordering::Release);
        }
        sent
    });

    bench.step(100);
    rmd_test_support::alloc::count_this_thread(true);
    for tick in 1..=TICKS {
        bench.step(1);
        ticked.store(tick, Ordering::Release);
        // Wait for the sender to act on this tick (bounded: a stuck sender fails the checks
        // below rather than hanging the test).
        let give_up = Instant::now() + Duration::from_secs(2);
        while seen.load(Ordering::Acquire) < tick && Instant::now() < give_up {
            std::thread::yield_now();
        }
    }
    rmd_test_support::alloc::count_this_thread(false);
    let allocations = rmd_test_support::alloc::counted().total();
    done.store(true, Ordering::Release);
    let sent = sender.join().unwrap();
    let state = bench.state().unwrap();
    let [hip_aa, hip_fe, knee, ankle] = [0, 1, 2, 3].map(|i| state.joints()[i]);
    // Every path of a tick ran while counting.
    assert!(bench.running.is_some(), "the loop ran throughout");
    assert!(sent > 400, "sent {sent}");
    assert!(hip_aa.counters.setpoints > 400, "{hip_aa:?}");
    assert_eq!(hip_aa.counters.stale_events, 1, "{hip_aa:?}");
    assert!(
        hip_fe.counters.setpoints >= 3 && hip_fe.counters.stale_events >= 1,
        "{hip_fe:?}"
    );
    assert!(knee.counters.trajectories >= 6, "{knee:?}");
    assert!(knee.counters.replans >= 3, "{knee:?}");
    assert!(ankle.counters.trajectories >= 6, "{ankle:?}");
    assert_eq!(knee.counters.trajectory_failures, 0);
    assert!(state.dropped_messages >= 1, "{state:?}");
    assert!(state.enabled);
    assert_eq!(
        allocations, 0,
        "allocations on the loop thread in {TICKS} ticks"
    );
}
