//! The node on the fake robot, driven over loopback DDS by a second `ros2-client` participant
//! in the same process: samples come out, commands go in and move the robot, bad commands are
//! counted and move nothing. (The independent check, against Cyclone DDS, is
//! `tests/ros2/run.sh`.)

use crate::common;

use std::time::Duration;

use common::{Client, drain, wait_for};
use rmd_ros2::fake::{FakeRobot, FakeRobotHandle};
use rmd_ros2::msg;
use rmd_ros2::{NodeConfig, RejectionKind, Ros2Node};
use ros2_client::QosProfile;
use ros2_client::dds::{Publisher, Subscription};
use serde::de::DeserializeOwned;

fn latest<M: 'static + DeserializeOwned>(s: &Subscription<M>) -> Option<M> {
    drain(s).0
}

fn command(names: &[&str], position: &[f64]) -> msg::JointState {
    msg::JointState {
        name: names.iter().map(|s| s.to_string()).collect(),
        position: position.to_vec(),
        ..Default::default()
    }
}

fn near(robot: &FakeRobotHandle, joint: usize, target: f64) -> bool {
    (robot.positions()[joint] - target).abs() < 1e-3
}

#[test]
fn node_publishes_takes_commands_and_rejects_bad_ones() {
    // A domain and namespace of our own: other DDS users on this host stay apart.
    let domain = 100 + (std::process::id() % 100) as u16;
    let ns = format!("/loopback_{}", std::process::id());
    let robot = FakeRobot::start(FakeRobot::demo_joints(), true);
    let h = robot.handle();
    let node = Ros2Node::start(
        NodeConfig {
            namespace: ns.clone(),
            domain_id: domain,
            joint_state_rate_hz: 200.0,
            diagnostics_period: Duration::from_millis(200),
            network: Some(common::LOOPBACK),
            ..NodeConfig::default()
        },
        robot,
    )
    .unwrap();
    assert_eq!(
        node.dds_names().joint_states,
        format!("rt{ns}/joint_states")
    );
    assert_eq!(node.dds_names().diagnostics, "rt/diagnostics");

    let mut c = Client::new(domain);
    let states: Subscription<msg::JointState> =
        c.subscription(&format!("{ns}/joint_states"), rmd_ros2::qos::joint_states());
    let diagnostics: Subscription<msg::DiagnosticArray> =
        c.subscription("/diagnostics", QosProfile::publisher_default());
    let commands: Publisher<msg::JointState> = c.publisher(&format!("{ns}/joint_commands"));
    let trajectories: Publisher<msg::JointTrajectory> =
        c.publisher(&format!("{ns}/joint_trajectory"));
    let enable: Publisher<msg::Bool> = c.publisher(&format!("{ns}/enable"));

    // Samples: the robot's names, SI values.
    let mut sample = None;
    wait_for("a joint_states sample", || {
        sample = latest(&states);
        sample.is_some()
    });
    let sample = sample.unwrap();
    assert_eq!(sample.name, ["hip", "knee", "wrist"]);
    assert_eq!(sample.position.len(), 3);
    assert_eq!(sample.velocity.len(), 3);
    assert_eq!(sample.effort.len(), 3);
    assert!(sample.header.stamp.sec > 0);

    // A command, repeated until discovery has matched the writer to the node's reader.
    wait_for("the first command to be accepted", || {
        commands.publish(command(&["knee"], &[0.5])).unwrap();
        node.stats().commands_accepted > 0
    });
    wait_for("the knee at 0.5 rad in joint_states", || {
        latest(&states).is_some_and(|s| (s.position[1] - 0.5).abs() < 1e-3)
    });

    // Bad commands: each counted under its kind, none reaching the robot.
    let received = h.setpoints_received();
    let before = h.positions();
    let mut nan = command(&["knee"], &[f64::NAN]);
    nan.velocity = vec![];
    let bad: [(msg::JointState, RejectionKind); 6] = [
        (command(&["elbow"], &[0.1]), RejectionKind::UnknownJoint),
        (nan, RejectionKind::NotFinite),
        (command(&["knee"], &[9.0]), RejectionKind::OutOfLimit),
        (
            command(&["hip", "knee"], &[0.1]),
            RejectionKind::LengthMismatch,
        ),
        (command(&[], &[]), RejectionKind::Empty),
        // Over the node's 256-byte string limit: refused while decoding.
        (
            command(&[&"k".repeat(5000)], &[0.1]),
            RejectionKind::Oversized,
        ),
    ];
    for (m, kind) in bad {
        let n = node.stats().rejected(kind);
        commands.publish(m).unwrap();
        wait_for(&format!("a {kind:?} rejection"), || {
            node.stats().rejected(kind) > n
        });
    }
    // A sample that does not decode as a JointState (a Bool under JointState's type name).
    let garbage: Publisher<msg::Bool> = {
        let qos = QosProfile::publisher_default();
        let t = c.topic::<msg::JointState>(&format!("{ns}/joint_commands"), &qos);
        c.node.create_publisher(&t, Some(qos)).unwrap()
    };
    wait_for("a malformed sample to be counted", || {
        garbage.publish(msg::Bool { data: true }).unwrap();
        node.stats().rejected(RejectionKind::Malformed) > 0
    });
    let mut backwards = msg::JointTrajectory {
        joint_names: vec!["hip".into()],
        points: vec![Default::default(), Default::default()],
        ..Default::default()
    };
    backwards.points[0].positions = vec![0.1];
    backwards.points[0].time_from_start.sec = 2;
    backwards.points[1].positions = vec![0.2];
    backwards.points[1].time_from_start.sec = 1;
    wait_for("a bad trajectory to be rejected", || {
        trajectories.publish(backwards.clone()).unwrap();
        node.stats().rejected(RejectionKind::BadTime) > 0
    });
    assert_eq!(h.setpoints_received(), received);
    assert_eq!(h.trajectories_received(), 0);
    for (b, a) in before.iter().zip(h.positions()) {
        // (Still settling on 0.5 rad by well under 0.01 rad; a bad target would move it far.)
        assert!(
            (b - a).abs() < 0.01,
            "the robot moved on a rejected command"
        );
    }

    // A trajectory moves the hip.
    let mut go = msg::JointTrajectory {
        joint_names: vec!["hip".into()],
        points: vec![Default::default()],
        ..Default::default()
    };
    go.points[0].positions = vec![-0.5];
    go.points[0].time_from_start.nanosec = 300_000_000;
    trajectories.publish(go).unwrap();
    wait_for("the hip at -0.5 rad", || near(&h, 0, -0.5));
    assert_eq!(node.stats().trajectories_accepted, 1);

    // Estop: the port refuses commands (counted) until enabled again.
    wait_for("the estop to arrive", || {
        enable.publish(msg::Bool { data: false }).unwrap();
        !h.enabled()
    });
    let refused = node.stats().rejected(RejectionKind::PortRefused);
    commands.publish(command(&["knee"], &[-0.25])).unwrap();
    wait_for("the refusal", || {
        node.stats().rejected(RejectionKind::PortRefused) > refused
    });
    assert!(near(&h, 1, 0.5));
    enable.publish(msg::Bool { data: true }).unwrap();
    wait_for("enable", || h.enabled());
    commands.publish(command(&["knee"], &[-0.25])).unwrap();
    wait_for("the knee at -0.25 rad", || near(&h, 1, -0.25));

    // Diagnostics carry the counters.
    let mut with_counters = None;
    wait_for("diagnostics with the rejections", || {
        with_counters = latest(&diagnostics).filter(|d| {
            d.status.iter().any(|s| {
                s.name == format!("{ns}/rmd_rt: ros2 inputs")
                    && s.values
                        .iter()
                        .any(|kv| kv.key == "rejected_unknown_joint" && kv.value == "1")
            })
        });
        with_counters.is_some()
    });
    // The oversized name was echoed only in part.
    let text: usize = with_counters
        .unwrap()
        .status
        .iter()
        .map(|s| s.message.len() + s.values.iter().map(|kv| kv.value.len()).sum::<usize>())
        .sum();
    assert!(text < 4000, "{text} bytes of diagnostics text");
    let s = node.stats();
    assert!(s.joint_states_published > 0 && s.diagnostics_published > 0);
    assert_eq!(s.publish_errors, 0);
    node.stop().unwrap();
}
