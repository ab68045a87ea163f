//! Figures for `docs/ros2.md`, printed, not asserted, both in one process over loopback DDS:
//!
//! 1. the cost of publishing one `joint_states` message on the publishing thread (building it
//!    from a sample, serializing it, handing it to RustDDS, whose event-loop thread sends it),
//!    with a matched best-effort reader in the process, for 3 and 12 joints;
//! 2. the latency from publishing a `joint_commands` sample (its header stamp) to the port
//!    receiving the validated setpoints, over a few thousand commands at 500 Hz.
//!
//! ```text
//! cargo run --release -p rmd-ros2 --example ros2_figures -- --commands 3000
//! ```
//!
//! On a shared or busy machine the figures say little; run it on a quiet one.

use std::net::{IpAddr, Ipv4Addr};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant, SystemTime};

use clap::Parser;
use hdrhistogram::Histogram;
use rmd_ros2::fake::FakeRobot;
use rmd_ros2::msg::{self, RosMessage};
use rmd_ros2::{
    Enable, JointInfo, NodeConfig, PortError, RobotDiagnostics, RobotPort, RobotState, Ros2Node,
    Setpoints, Trajectory,
};
use ros2_client::dds::rustdds::DomainParticipantBuilder;
use ros2_client::dds::{Context, Node, Publisher, Subscription};
use ros2_client::{MessageTypeName, Name, NodeName, NodeOptions, QosProfile};

const LOOPBACK: IpAddr = IpAddr::V4(Ipv4Addr::LOCALHOST);

#[derive(Parser)]
struct Args {
    /// Commands to time (command in -> port).
    #[arg(long, default_value_t = 3000)]
    commands: u32,
    /// joint_states messages to time per joint count.
    #[arg(long, default_value_t = 5000)]
    publishes: u32,
    /// DDS domain to use (default: derived from the process id).
    #[arg(long)]
    domain_id: Option<u16>,
}

/// The fake robot, timing each setpoint message from its stamp to its arrival at the port.
struct Timed {
    inner: FakeRobot,
    latency: Arc<Mutex<Histogram<u64>>>,
}

impl RobotPort for Timed {
    fn joints(&self) -> &[JointInfo] {
        self.inner.joints()
    }
    fn latest_state(&mut self) -> Option<RobotState> {
        self.inner.latest_state()
    }
    fn diagnostics(&mut self) -> RobotDiagnostics {
        self.inner.diagnostics()
    }
    fn send_setpoints(&mut self, setpoints: &Setpoints) -> Result<(), PortError> {
        if let Some(sent) = setpoints.stamp()
            && let Ok(d) = SystemTime::now().duration_since(sent)
        {
            let mut h = self.latency.lock().unwrap_or_else(|e| e.into_inner());
            h.saturating_record(d.as_nanos() as u64);
        }
        self.inner.send_setpoints(setpoints)
    }
    fn send_trajectory(&mut self, trajectory: &Trajectory) -> Result<(), PortError> {
        self.inner.send_trajectory(trajectory)
    }
    fn set_enable(&mut self, enable: Enable) -> Result<(), PortError> {
        self.inner.set_enable(enable)
    }
}

fn node(domain: u16, name: &str) -> Node {
    let dp = DomainParticipantBuilder::new(domain)
        .with_only_networks([LOOPBACK])
        .build()
        .expect("DDS participant");
    Context::from_domain_participant(dp)
        .expect("ROS 2 context")
        .new_node(
            NodeName::new("/", name).expect("node name"),
            NodeOptions::new()
                .enable_rosout(false)
                .start_parameter_services(false),
        )
        .expect("node")
}

fn topic<M: RosMessage>(
    n: &mut Node,
    name: &str,
    qos: &QosProfile,
) -> ros2_client::dds::rustdds::Topic {
    n.create_topic(
        &Name::parse(name).expect("topic name"),
        MessageTypeName::new(M::PACKAGE, M::NAME),
        qos,
    )
    .expect("topic")
}

fn us(h: &Histogram<u64>, q: f64) -> f64 {
    h.value_at_quantile(q) as f64 / 1000.0
}

fn publish_cost(domain: u16, joints: usize, count: u32) {
    let mut n = node(domain, "figures_publisher");
    let qos = rmd_ros2::qos::joint_states();
    let name = format!("/figures/joint_states_{joints}");
    let t = topic::<msg::JointState>(&mut n, &name, &qos);
    let publisher: Publisher<msg::JointState> = n
        .create_publisher(&t, Some(qos.clone()))
        .expect("publisher");
    let mut r = node(domain, "figures_reader");
    let rt = topic::<msg::JointState>(&mut r, &name, &qos);
    let reader: Subscription<msg::JointState> =
        r.create_subscription(&rt, Some(qos)).expect("subscription");
    // Wait until the reader receives, so that every timed publish really sends.
    let t0 = Instant::now();
    loop {
        publisher
            .publish(msg::JointState::default())
            .expect("publish");
        if matches!(reader.take(), Ok(Some(_))) || t0.elapsed() > Duration::from_secs(10) {
            break;
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    let names: Vec<String> = (0..joints).map(|i| format!("joint_{i}")).collect();
    let state = RobotState {
        stamp: SystemTime::now(),
        position_rad: vec![0.1; joints],
        velocity_rad_s: vec![0.2; joints],
        effort_nm: vec![0.3; joints],
    };
    let mut h = Histogram::<u64>::new_with_bounds(1, 60_000_000_000, 3).expect("histogram");
    let mut received = 0u32;
    for _ in 0..count {
        let s = state.clone();
        let start = Instant::now();
        let m = msg::JointState {
            header: msg::Header {
                stamp: msg::Time::from_system_time(s.stamp),
                frame_id: String::new(),
            },
            name: names.clone(),
            position: s.position_rad,
            velocity: s.velocity_rad_s,
            effort: s.effort_nm,
        };
        publisher.publish(m).expect("publish");
        h.saturating_record(start.elapsed().as_nanos() as u64);
        while let Ok(Some(_)) = reader.take() {
            received += 1;
        }
        // 500 Hz, as the node publishes.
        std::thread::sleep(Duration::from_millis(2));
    }
    println!(
        "joint_states publish, {joints:2} joints: p50 {:.1} us, p99 {:.1} us, max {:.1} us, mean {:.1} us ({count} messages, {received} seen by the reader)",
        us(&h, 0.5),
        us(&h, 0.99),
        h.max() as f64 / 1000.0,
        h.mean() / 1000.0
    );
}

fn command_latency(domain: u16, count: u32) {
    let latency = Arc::new(Mutex::new(
        Histogram::<u64>::new_with_bounds(1, 60_000_000_000, 3).expect("histogram"),
    ));
    let port = Timed {
        inner: FakeRobot::start(FakeRobot::demo_joints(), true),
        latency: Arc::clone(&latency),
    };
    let node_under_test = Ros2Node::start(
        NodeConfig {
            namespace: "/figures".into(),
            domain_id: domain,
            network: Some(LOOPBACK),
            ..NodeConfig::default()
        },
        port,
    )
    .expect("node");
    let mut c = node(domain, "figures_commander");
    let qos = QosProfile::publisher_default();
    let t = topic::<msg::JointState>(&mut c, "/figures/joint_commands", &qos);
    let commands: Publisher<msg::JointState> =
        c.create_publisher(&t, Some(qos)).expect("publisher");
    let command = |p: f64| msg::JointState {
        header: msg::Header {
            stamp: msg::Time::from_system_time(SystemTime::now()),
            frame_id: String::new(),
        },
        name: vec!["hip".into(), "knee".into(), "wrist".into()],
        position: vec![p, -p, 0.5 * p],
        ..Default::default()
    };
    let t0 = Instant::now();
    while node_under_test.stats().commands_accepted == 0 {
        assert!(
            t0.elapsed() < Duration::from_secs(20),
            "discovery did not match"
        );
        commands.publish(command(0.0)).expect("publish");
        std::thread::sleep(Duration::from_millis(20));
    }
    std::thread::sleep(Duration::from_millis(100));
    latency.lock().expect("histogram").reset();
    let accepted0 = node_under_test.stats().commands_accepted;
    for i in 0..count {
        commands
            .publish(command(0.5 * (f64::from(i) * 0.01).sin()))
            .expect("publish");
        std::thread::sleep(Duration::from_millis(2));
    }
    std::thread::sleep(Duration::from_millis(500));
    let accepted = node_under_test.stats().commands_accepted - accepted0;
    let h = latency.lock().expect("histogram").clone();
    println!(
        "joint_commands in -> port: p50 {:.1} us, p99 {:.1} us, max {:.1} us ({} of {count} commands arrived)",
        us(&h, 0.5),
        us(&h, 0.99),
        h.max() as f64 / 1000.0,
        accepted
    );
    node_under_test.stop().expect("node stops");
}

fn main() {
    let args = Args::parse();
    let domain = args
        .domain_id
        .unwrap_or(100 + (std::process::id() % 100) as u16);
    println!(
        "rmd-ros2 figures (loopback DDS, one process, domain {domain}, {} build)",
        if cfg!(debug_assertions) {
            "debug"
        } else {
            "release"
        }
    );
    for joints in [3, 12] {
        publish_cost(domain, joints, args.publishes);
    }
    command_latency(domain, args.commands);
}
