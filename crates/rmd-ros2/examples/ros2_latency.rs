//! The ROS 2 node on the real loop: command latency into the 0x280 frame, and what the node
//! costs the real-time thread. Printed, not asserted; for `docs/ros2.md`.
//!
//! The robot is `examples/robots/leg4.toml` on simulated motors in real time (four motors, one
//! bus, 1 kHz), the loop runs the joint servo through the rig (supervised), as `rmd ros2` runs
//! it. A command stream of effort setpoints for `hip_aa` (motor 1) alternates in sign, so that
//! every command changes the 0x280 frame; a tap on the bus notes when the frame's value for
//! motor 1 changes. Two phases of `--seconds` each, `--rounds` times:
//!
//! - **off**: no DDS; an ordinary thread sends the same effort stream through the servo's
//!   handle. The loop's work per tick and wake-up lateness, as reported by the loop.
//! - **on**: the ROS 2 node runs (`joint_states` at 500 Hz to a subscribed peer, diagnostics
//!   at 1 Hz with statistics snapshots), and the stream comes from a second DDS participant
//!   in this process as `joint_commands` over loopback. The same loop figures, plus per
//!   command: published by the peer -> received by the node's thread (taken from its reader,
//!   validated, handed to the port) -> the first 0x280 frame carrying it on the bus.
//!
//! ```text
//! cargo run --release -p rmd-ros2 --example ros2_latency -- --seconds 10 --rounds 2
//! ```
//!
//! A command reaches the loop through the servo's queue: it is applied at the next tick's
//! controller update, and the loop sends what the controller wrote at the start of the tick
//! after (see docs/loop.md), so the floor is one to two periods.

use std::collections::HashMap;
use std::net::{IpAddr, Ipv4Addr};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant, SystemTime};

use clap::Parser;
use rmd_bus::{BusError, CanBus, Received, Timestamp};
use rmd_loop::mailbox::{Receiver, Sender, mailbox};
use rmd_loop::mapping::JointMap;
use rmd_loop::{LoopReport, RtLoop, RunLimit, robot::Robot, stats::Percentiles};
use rmd_protocol::{CanFrame, DecodedRequest, Dialect, ScaledCurrent};
use rmd_rig::{AnyBus, AnyClock, Placement, Rig, SimTime, sim};
use rmd_ros2::msg::{self, RosMessage};
use rmd_ros2::servo::{LoopFeed, ServoPort};
use rmd_ros2::{
    Enable, JointInfo, NodeConfig, PortError, RobotDiagnostics, RobotPort, RobotState, Ros2Node,
    Setpoint, Setpoints, Trajectory,
};
use rmd_servo::{ServoConfig, ServoController, ServoHandle};
use ros2_client::dds::rustdds::DomainParticipantBuilder;
use ros2_client::dds::{Context, Node, Publisher, Subscription};
use ros2_client::{MessageTypeName, Name, NodeName, NodeOptions, QosProfile};

const LOOPBACK: IpAddr = IpAddr::V4(Ipv4Addr::LOCALHOST);
const ROBOT: &str = include_str!("../../../examples/robots/leg4.toml");
/// The joint the commands drive (motor 1: the frame's first value).
const JOINT: &str = "hip_aa";

#[derive(Parser)]
#[command(about = "Command latency into the 0x280 frame, and the node's cost to the loop")]
struct Args {
    /// Length of each phase (s).
    #[arg(long, default_value_t = 10.0)]
    seconds: f64,
    /// Rounds of the two phases (off, on).
    #[arg(long, default_value_t = 1)]
    rounds: u32,
    /// Commands per second.
    #[arg(long, default_value_t = 50.0)]
    command_hz: f64,
    /// DDS domain (default: derived from the process id).
    #[arg(long)]
    domain_id: Option<u16>,
}

/// The n-th command's effort, N·m: the sign alternates, so that each one changes the frame.
fn effort(n: u64) -> f64 {
    let magnitude = [0.3, 0.4, 0.5][(n / 2 % 3) as usize];
    if n.is_multiple_of(2) {
        magnitude
    } else {
        -magnitude
    }
}

/// A bus that notes when motor 1's value in the 0x280 frame changes (time, raw value), through
/// a preallocated queue (nothing allocated on the loop thread).
struct Tap {
    inner: AnyBus,
    last: Option<i16>,
    changes: Sender<(Instant, i16)>,
}

impl CanBus for Tap {
    fn send(&mut self, frame: &CanFrame) -> Result<(), BusError> {
        let result = self.inner.send(frame);
        if let Ok(DecodedRequest::Multi(m)) = Dialect::V161.decode_request(frame) {
            let raw = m.iq_control[0].raw();
            if self.last != Some(raw) {
                self.last = Some(raw);
                let _ = self.changes.send((Instant::now(), raw));
            }
        }
        result
    }

    fn recv_until(&mut self, deadline: Timestamp) -> Result<Option<Received>, BusError> {
        self.inner.recv_until(deadline)
    }
}

/// The servo port, noting when each command reaches it (the node's thread hands it over right
/// after taking it from its DDS reader and validating it).
struct Timed {
    inner: ServoPort,
    /// Per command: its stamp (which identifies it), its effort, when it reached the port.
    received: Arc<Mutex<Vec<(SystemTime, f64, Instant)>>>,
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
        let now = Instant::now();
        if let (Some(stamp), Some((_, Setpoint::Effort { effort_nm }))) =
            (setpoints.stamp(), setpoints.joints().first())
        {
            self.received
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
                .push((stamp, *effort_nm, now));
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

struct Peer {
    node: Node,
}

impl Peer {
    fn new(domain: u16) -> Peer {
        let dp = DomainParticipantBuilder::new(domain)
            .with_only_networks([LOOPBACK])
            .build()
            .expect("a DDS participant");
        let ctx = Context::from_domain_participant(dp).expect("a ROS 2 context");
        let node = ctx
            .new_node(
                NodeName::new("/", "latency_peer").expect("a node name"),
                NodeOptions::new()
                    .enable_rosout(false)
                    .start_parameter_services(false),
            )
            .expect("a ROS 2 node");
        Peer { node }
    }

    fn topic<M: RosMessage>(
        &mut self,
        name: &str,
        qos: &QosProfile,
    ) -> ros2_client::dds::rustdds::Topic {
        self.node
            .create_topic(
                &Name::parse(name).expect("a topic name"),
                MessageTypeName::new(M::PACKAGE, M::NAME),
                qos,
            )
            .expect("a topic")
    }
}

/// One phase's loop report, and the commands' times if they came over DDS.
struct Phase {
    report: LoopReport,
    latency: Option<Latency>,
}

#[derive(Default)]
struct Latency {
    sent: usize,
    matched: usize,
    publish_to_node: Vec<Duration>,
    node_to_frame: Vec<Duration>,
    publish_to_frame: Vec<Duration>,
}

fn percentile(sorted: &[Duration], q: f64) -> Duration {
    if sorted.is_empty() {
        return Duration::ZERO;
    }
    let i = ((sorted.len() - 1) as f64 * q).round() as usize;
    sorted[i]
}

fn show(d: &mut [Duration]) -> String {
    d.sort();
    let us = |d: Duration| d.as_secs_f64() * 1e6;
    format!(
        "p50 {:>7.0} us  p99 {:>7.0} us  max {:>7.0} us",
        us(percentile(d, 0.5)),
        us(percentile(d, 0.99)),
        us(d.last().copied().unwrap_or_default())
    )
}

fn percentiles(p: &Percentiles) -> String {
    format!(
        "p50 {:>6.1}  p99 {:>7.1}  p99.9 {:>7.1}  max {:>8.1}",
        p.p50, p.p99, p.p999, p.max
    )
}

/// A loop of the leg with the servo, its buses tapped, ready to spawn.
struct Opened {
    rt: RtLoop<Tap, AnyClock, ServoController>,
    handle: ServoHandle,
    clock: AnyClock,
    /// The tap's notes: when motor 1's value in the 0x280 frame changed, and to what.
    changes: Receiver<(Instant, i16)>,
}

fn open(robot: &Robot) -> Opened {
    let mut sims = sim::sim_configs(robot, 1);
    sim::power_up_centred(robot, &mut sims);
    let rig = Rig::open(robot, &Placement::simulated(robot, SimTime::Real), sims)
        .expect("simulated buses");
    let (tx, rx) = mailbox(1 << 16);
    let ports = rig
        .buses
        .iter()
        .map(AnyBus::safety_port)
        .collect::<Result<Vec<_>, _>>()
        .expect("the supervisor's ports");
    let buses = rig
        .buses
        .into_iter()
        .map(|inner| Tap {
            inner,
            last: None,
            changes: tx.clone(),
        })
        .collect();
    let config = ServoConfig::defaults(robot).expect("a servo configuration");
    let (servo, handle) = ServoController::new(config);
    let rt = RtLoop::unsupervised(robot.clone(), rig.clock.clone(), buses, servo)
        .and_then(|rt| rt.supervise(ports))
        .expect("the loop");
    Opened {
        rt,
        handle,
        clock: rig.clock,
        changes: rx,
    }
}

fn phase_off(robot: &Robot, args: &Args) -> Phase {
    let Opened { rt, handle, .. } = open(robot);
    let running = rt.spawn(RunLimit::Forever).expect("the loop thread");
    let stop = Arc::new(AtomicBool::new(false));
    let sender = {
        let stop = Arc::clone(&stop);
        let period = Duration::from_secs_f64(1.0 / args.command_hz);
        std::thread::spawn(move || {
            let mut n = 0;
            while !stop.load(Ordering::Relaxed) {
                let _ = handle.set_effort(JOINT, effort(n));
                n += 1;
                std::thread::sleep(period);
            }
        })
    };
    std::thread::sleep(Duration::from_secs_f64(args.seconds));
    stop.store(true, Ordering::Relaxed);
    let _ = sender.join();
    let outcome = running.stop().expect("the loop's report");
    Phase {
        report: outcome.report,
        latency: None,
    }
}

fn phase_on(robot: &Robot, args: &Args, domain: u16, round: u32) -> Phase {
    let Opened {
        rt,
        handle,
        clock,
        changes,
    } = open(robot);
    let ns = format!("/latency_{}_{round}", std::process::id());
    let feed = LoopFeed::new();
    let received = Arc::new(Mutex::new(Vec::new()));
    let port = Timed {
        inner: ServoPort::new(handle, robot, clock)
            .expect("the servo port")
            .with_feed(feed.clone()),
        received: Arc::clone(&received),
    };
    let node = Ros2Node::start(
        NodeConfig {
            namespace: ns.clone(),
            domain_id: domain,
            network: Some(LOOPBACK),
            ..NodeConfig::default()
        },
        port,
    )
    .expect("the node");
    let mut peer = Peer::new(domain);
    let states_topic = peer.topic::<msg::JointState>(
        &format!("{ns}/joint_states"),
        &rmd_ros2::qos::joint_states(),
    );
    let states: Subscription<msg::JointState> = peer
        .node
        .create_subscription(&states_topic, Some(rmd_ros2::qos::joint_states()))
        .expect("a joint_states reader");
    let qos = QosProfile::publisher_default();
    let commands_topic = peer.topic::<msg::JointState>(&format!("{ns}/joint_commands"), &qos);
    let commands: Publisher<msg::JointState> = peer
        .node
        .create_publisher(&commands_topic, Some(qos))
        .expect("a joint_commands writer");
    // The stamp identifies the command.
    let command = |n: u64, stamp: SystemTime| msg::JointState {
        header: msg::Header {
            stamp: msg::Time::from_system_time(stamp),
            frame_id: String::new(),
        },
        name: vec![JOINT.into()],
        effort: vec![effort(n)],
        ..Default::default()
    };
    // Discovery both ways before the loop starts (the first command waits in the servo's
    // queue and applies at the first tick).
    let t0 = Instant::now();
    while node.stats().commands_accepted == 0 {
        assert!(t0.elapsed() < Duration::from_secs(30), "no DDS match");
        commands
            .publish(command(0, SystemTime::now()))
            .expect("publish");
        std::thread::sleep(Duration::from_millis(20));
    }
    received
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .clear();

    let running = rt.spawn(RunLimit::Forever).expect("the loop thread");
    let period = Duration::from_secs_f64(1.0 / args.command_hz);
    let mut published = HashMap::new();
    let start = Instant::now();
    let mut next = start;
    let mut last_snapshot = start;
    let mut n = 1;
    while start.elapsed().as_secs_f64() < args.seconds {
        let now = Instant::now();
        if now >= next {
            let stamp = SystemTime::now();
            let m = command(n, stamp);
            let stamp = m.header.stamp.to_system_time().expect("a stamp");
            published.insert(stamp, (n, Instant::now()));
            commands.publish(m).expect("publish");
            n += 1;
            next += period;
        }
        if last_snapshot.elapsed() >= Duration::from_secs(1) {
            last_snapshot = Instant::now();
            if let Some(stats) = running.snapshot(Duration::from_millis(50)) {
                feed.set_stats(stats);
            }
        }
        while let Ok(Some(_)) = states.take() {}
        std::thread::sleep(Duration::from_millis(1));
    }
    std::thread::sleep(Duration::from_millis(50));
    let outcome = running.stop().expect("the loop's report");
    let _port = node.stop().expect("the node's port");

    // Match: a command (identified by its stamp) reached the port at a noted time, and its
    // frame is the first change of motor 1's value to the command's, after that.
    let spec = robot.spec(robot.joint(JOINT).expect("the joint"));
    let map = JointMap::from_spec(spec);
    let raw_of = |nm: f64| {
        let amps = map.motor_amps_for_torque(nm).expect("a torque constant");
        ScaledCurrent::from_amps_saturating(amps, spec.command_scale()).raw()
    };
    let frames: Vec<(Instant, i16)> = changes.drain().collect();
    let received = received
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .clone();
    let mut l = Latency {
        sent: published.len(),
        ..Latency::default()
    };
    for &(stamp, nm, at_node) in &received {
        let Some(&(n, sent)) = published.get(&stamp) else {
            continue; // a warm-up command
        };
        assert_eq!(nm, effort(n), "the command's effort arrived unchanged");
        let raw = raw_of(nm);
        if let Some(&(out, _)) = frames.iter().find(|&&(t, r)| t >= at_node && r == raw) {
            l.matched += 1;
            l.publish_to_node.push(at_node - sent);
            l.node_to_frame.push(out - at_node);
            l.publish_to_frame.push(out - sent);
        }
    }
    Phase {
        report: outcome.report,
        latency: Some(l),
    }
}

fn print(name: &str, p: &Phase) {
    let s = &p.report.stats;
    println!(
        "{name}: {} ticks, {} deadline misses, stopped: {}",
        s.ticks, s.deadline_misses, p.report.stop_description
    );
    println!("  loop work/tick (us)   {}", percentiles(&s.work_us));
    println!(
        "  wake latency (us)     {}",
        percentiles(&s.wake_latency_us)
    );
    println!("  controller (us)       {}", percentiles(&s.controller_us));
}

fn main() {
    let args = Args::parse();
    let domain = args
        .domain_id
        .unwrap_or(120 + (std::process::id() % 100) as u16);
    let robot = Robot::from_toml(ROBOT).expect("examples/robots/leg4.toml");
    println!(
        "leg4 on simulated motors in real time, 1 kHz; {} effort commands/s for {JOINT}; \
         {} s per phase, {} round(s)",
        args.command_hz, args.seconds, args.rounds
    );
    for round in 0..args.rounds {
        let off = phase_off(&robot, &args);
        print(&format!("round {round}, node off"), &off);
        let on = phase_on(&robot, &args, domain, round);
        print(&format!("round {round}, node on "), &on);
        if let Some(mut l) = on.latency {
            println!(
                "  commands: {} published, {} matched to their 0x280 frame",
                l.sent, l.matched
            );
            println!(
                "  publish -> node          {}",
                show(&mut l.publish_to_node)
            );
            println!("  node -> 0x280 frame out  {}", show(&mut l.node_to_frame));
            println!(
                "  publish -> 0x280 out     {}",
                show(&mut l.publish_to_frame)
            );
        }
    }
}
