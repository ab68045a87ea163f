//! With the ROS 2 node running, the real-time loop thread allocates nothing: the loop runs the
//! joint servo on simulated motors in real time (through the rig, supervised, as `rmd ros2`
//! runs it), the node publishes `joint_states` at 500 Hz and diagnostics at 10 Hz over DDS on
//! loopback, a second DDS participant in this process streams position commands, sends
//! trajectories that replace each other, estops and enables, and this thread takes the loop's
//! statistics snapshots for the diagnostics, while a counting global allocator counts the loop
//! thread's allocations and frees (and only that thread's: DDS, the node and the planning of
//! trajectories allocate on their own threads, which is allowed).
//!
//! DDS here: RustDDS restricted to 127.0.0.1 (`NodeConfig::network`), a domain id of this
//! process's own; its discovery reaches same-host peers by unicast to the well-known local
//! ports, so no network namespace is needed.
//!
//! Other tests may run beside it in the process: only the loop thread's allocations and frees
//! are counted.

use crate::common;

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use common::{Client, LOOPBACK, drain, private_domain, wait_for};
use rmd_loop::{
    Commands, Controller, Fault, Feedback, Flow, RunLimit, StopReason, TickContext, robot::Robot,
};
use rmd_rig::{Placement, Rig, SimTime, sim};
use rmd_ros2::msg;
use rmd_ros2::servo::{LoopFeed, ServoPort};
use rmd_ros2::{NodeConfig, Ros2Node};
use rmd_servo::{ServoConfig, ServoController};
use ros2_client::QosProfile;
use ros2_client::dds::{Publisher, Subscription};

/// Set by the test thread: the loop thread counts its allocations from its next tick on, until
/// it is cleared (the whole thread between two updates: bus I/O, the exchange, statistics,
/// snapshots, the servo).
static MEASURE: AtomicBool = AtomicBool::new(false);
/// Ticks the loop thread ran while counting.
static COUNTED_TICKS: AtomicU64 = AtomicU64::new(0);

/// The servo, with the loop thread's counting switched on and off at the start of a tick.
struct Counted(ServoController);

impl Controller for Counted {
    fn signals(&self) -> Vec<String> {
        self.0.signals()
    }

    fn start(&mut self, ctx: &TickContext, feedback: &Feedback<'_>) {
        self.0.start(ctx, feedback);
    }

    fn update(&mut self, ctx: &TickContext, fb: &Feedback<'_>, cmd: &mut Commands<'_>) -> Flow {
        let on = MEASURE.load(Ordering::Acquire);
        rmd_test_support::alloc::count_this_thread(on);
        if on {
            COUNTED_TICKS.fetch_add(1, Ordering::Relaxed);
        }
        self.0.update(ctx, fb, cmd)
    }

    fn fault(&mut self, fault: &Fault) {
        self.0.fault(fault);
    }

    fn stop(&mut self, reason: &StopReason) {
        rmd_test_support::alloc::count_this_thread(false);
        self.0.stop(reason);
    }
}

const ROBOT: &str = r#"
[loop]
rate_hz = 1000.0
# Real time on a possibly loaded machine: an OS stall past 50 ms is not what this test is about.
stall_bound_ms = 60000
[[bus]]
name = "leg"
interface = "can0"
[[bus.motor]]
id = 1
name = "hip"
gear_ratio = 9.0
torque_constant_nm_per_amp = 2.09
current_limit_amps = 8.0
zero_offset_deg = 20.0
[[bus.motor]]
id = 2
name = "knee"
gear_ratio = 9.0
torque_constant_nm_per_amp = 2.09
current_limit_amps = 8.0
zero_offset_deg = 20.0
[[bus.motor]]
id = 3
name = "ankle"
gear_ratio = 9.0
torque_constant_nm_per_amp = 2.09
current_limit_amps = 8.0
zero_offset_deg = 20.0
"#;

const SERVO: &str = r#"
[defaults]
kp_nm_per_rad = 60.0
kd_nm_s_per_rad = 1.5
position_min_rad = -0.6
position_max_rad = 0.6
stale_after_ms = 100
"#;

/// How long the allocations are counted.
const WINDOW: Duration = Duration::from_secs(3);

fn position(names: &[&str], positions: &[f64]) -> msg::JointState {
    msg::JointState {
        name: names.iter().map(|s| s.to_string()).collect(),
        position: positions.to_vec(),
        ..Default::default()
    }
}

fn wave(amplitude: f64) -> msg::JointTrajectory {
    let point = |ms: u32, p: [f64; 2]| msg::JointTrajectoryPoint {
        positions: p.to_vec(),
        time_from_start: msg::Duration {
            sec: 0,
            nanosec: ms * 1_000_000,
        },
        ..Default::default()
    };
    msg::JointTrajectory {
        joint_names: vec!["knee".into(), "ankle".into()],
        points: vec![
            point(150, [amplitude, -amplitude]),
            point(300, [-amplitude, amplitude / 2.0]),
            point(450, [0.0, 0.0]),
        ],
        ..Default::default()
    }
}

#[test]
fn the_loop_thread_allocates_nothing_while_the_node_publishes_and_takes_commands() {
    let domain = private_domain(150);
    let ns = format!("/no_alloc_{}", std::process::id());
    let robot = Robot::from_toml(ROBOT).unwrap();
    let (servo, handle) = ServoController::new(ServoConfig::from_toml(&robot, SERVO).unwrap());
    let mut sims = sim::sim_configs(&robot, 5);
    sim::power_up_centred(&robot, &mut sims);
    let rig = Rig::open(&robot, &Placement::simulated(&robot, SimTime::Real), sims).unwrap();
    let feed = LoopFeed::new();
    let port = ServoPort::new(handle.clone(), &robot, rig.clock.clone())
        .unwrap()
        .with_feed(feed.clone());
    let node = Ros2Node::start(
        NodeConfig {
            namespace: ns.clone(),
            domain_id: domain,
            joint_state_rate_hz: 500.0,
            diagnostics_period: Duration::from_millis(100),
            network: Some(LOOPBACK),
            ..NodeConfig::default()
        },
        port,
    )
    .unwrap();
    let running = rig
        .into_loop(robot.clone(), Counted(servo))
        .unwrap()
        .spawn(RunLimit::Forever)
        .unwrap();

    let mut c = Client::new(domain);
    let states: Subscription<msg::JointState> =
        c.subscription(&format!("{ns}/joint_states"), rmd_ros2::qos::joint_states());
    let diagnostics: Subscription<msg::DiagnosticArray> =
        c.subscription("/diagnostics", QosProfile::publisher_default());
    let commands: Publisher<msg::JointState> = c.publisher(&format!("{ns}/joint_commands"));
    let trajectories: Publisher<msg::JointTrajectory> =
        c.publisher(&format!("{ns}/joint_trajectory"));
    let enable: Publisher<msg::Bool> = c.publisher(&format!("{ns}/enable"));

    // Warm up: discovery matched both ways, every input taken once.
    wait_for("joint_states", || drain(&states).1 > 0);
    wait_for("a first command taken", || {
        commands.publish(position(&["hip"], &[0.0])).unwrap();
        node.stats().commands_accepted > 0
    });
    wait_for("a first trajectory taken", || {
        trajectories.publish(wave(0.1)).unwrap();
        node.stats().trajectories_accepted > 0
    });
    wait_for("a first enable taken", || {
        enable.publish(msg::Bool { data: true }).unwrap();
        node.stats().enables_accepted > 0
    });
    std::thread::sleep(Duration::from_millis(600));
    let before = node.stats();
    let servo_before = handle.state().unwrap();

    MEASURE.store(true, Ordering::Release);
    let t0 = Instant::now();
    let mut received = 0;
    let mut snapshots = 0;
    let mut last_snapshot = t0;
    let mut sent_trajectories = 0;
    let mut estopped = false;
    let mut enabled_again = false;
    while t0.elapsed() < WINDOW {
        let t = t0.elapsed().as_secs_f64();
        // A streaming commander: the hip every 10 ms.
        commands
            .publish(position(&["hip"], &[0.2 * (3.0 * t).sin()]))
            .unwrap();
        // A trajectory every 400 ms, each replacing the last while it moves.
        if t >= 0.4 * f64::from(sent_trajectories) {
            let amplitude = [0.3, -0.2, 0.15][sent_trajectories as usize % 3];
            trajectories.publish(wave(amplitude)).unwrap();
            sent_trajectories += 1;
        }
        // An estop and an enable in the middle.
        if t >= 1.5 && !estopped {
            enable.publish(msg::Bool { data: false }).unwrap();
            estopped = true;
        }
        if t >= 1.7 && !enabled_again {
            enable.publish(msg::Bool { data: true }).unwrap();
            enabled_again = true;
        }
        // The loop's statistics for the diagnostics, as `rmd ros2` takes them.
        if last_snapshot.elapsed() >= Duration::from_millis(100) {
            last_snapshot = Instant::now();
            if let Some(stats) = running.snapshot(Duration::from_millis(50)) {
                feed.set_stats(stats);
                snapshots += 1;
            }
        }
        received += drain(&states).1;
        let _ = drain(&diagnostics);
        std::thread::sleep(Duration::from_millis(10));
    }
    MEASURE.store(false, Ordering::Release);
    // The loop thread stops counting at its next tick.
    let ticks = COUNTED_TICKS.load(Ordering::Acquire);
    wait_for("the loop thread to stop counting", || {
        std::thread::sleep(Duration::from_millis(5));
        COUNTED_TICKS.load(Ordering::Acquire) == ticks
    });
    let allocations = rmd_test_support::alloc::counted().total();
    let ticks = COUNTED_TICKS.load(Ordering::Acquire);

    let after = node.stats();
    let servo_after = handle.state().unwrap();
    node.stop().unwrap();
    let outcome = running.stop().unwrap();

    // The loop ran throughout, and every path of the node's traffic ran while counting.
    assert_eq!(
        outcome.report.stop_reason,
        StopReason::Requested,
        "{}",
        outcome.report
    );
    assert!(ticks > 1000, "ticks counted: {ticks}");
    assert!(snapshots >= 10, "snapshots: {snapshots}");
    assert!(received > 200, "joint_states received: {received}");
    assert!(
        after.joint_states_published - before.joint_states_published > 500,
        "{after:?}"
    );
    assert!(
        after.diagnostics_published - before.diagnostics_published >= 10,
        "{after:?}"
    );
    assert!(
        after.commands_accepted - before.commands_accepted > 100,
        "{after:?}"
    );
    assert!(
        after.trajectories_accepted - before.trajectories_accepted >= 4,
        "{after:?}"
    );
    assert_eq!(after.enables_accepted - before.enables_accepted, 2);
    let (b, a) = (servo_before.joints(), servo_after.joints());
    assert!(
        a[0].counters.setpoints - b[0].counters.setpoints > 100,
        "{a:?}"
    );
    assert!(
        a[1].counters.trajectories - b[1].counters.trajectories >= 4,
        "{a:?}"
    );
    assert!(servo_after.dropped_messages >= servo_before.dropped_messages);
    assert!(servo_after.enabled);
    assert_eq!(
        allocations, 0,
        "allocations on the loop thread in {ticks} ticks with the node running"
    );
}
