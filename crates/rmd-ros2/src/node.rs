//! [`Ros2Node`]: the DDS thread that publishes a [`RobotPort`]'s samples and diagnostics and
//! hands it validated commands.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant, SystemTime};

use ros2_client::dds::rustdds::mio1::{Events, Interest, Poll, Token};
use ros2_client::dds::rustdds::{DomainParticipantBuilder, ParticipantTuning};
use ros2_client::dds::{Context, Node, Publisher, Subscription};
use ros2_client::{MessageTypeName, Name, NodeOptions, QosProfile};
use serde::Serialize;

use crate::config::InputLimits;
use crate::config::{NodeConfig, NodeConfigError};
use crate::diagnostics::diagnostic_array;
use crate::inbound::{Inbound, InboundSeed, excerpt};
use crate::kind::RejectionKind;
use crate::msg::{self, RosMessage};
use crate::port::{Enable, RobotPort};
use crate::qos;
use crate::stats::{Counters, InputTopic, NodeStats};
use crate::validate::Validator;

/// Why the node could not start or did not stop cleanly.
#[derive(Debug, thiserror::Error)]
pub enum NodeError {
    /// The configuration is invalid.
    #[error("invalid node configuration: {0}")]
    Config(#[from] NodeConfigError),
    /// DDS could not create the participant, a topic, a reader or a writer.
    #[error("DDS setup failed ({what}): {reason}; check the domain id and the network interfaces")]
    Dds {
        /// What was being created.
        what: String,
        /// DDS's message.
        reason: String,
    },
    /// The operating system refused a thread or a poll instance.
    #[error("cannot start the node's thread: {0}")]
    Os(#[from] std::io::Error),
    /// The robot reports two joints with one name.
    #[error("the robot has two joints named {0:?}; joint names must be unique")]
    DuplicateJointName(String),
    /// The node's thread panicked (a bug); the port is lost.
    #[error("the node's thread panicked: {0}")]
    Panicked(String),
}

fn dds_error(what: impl Into<String>) -> impl FnOnce(&dyn std::fmt::Display) -> NodeError {
    let what = what.into();
    move |e| NodeError::Dds {
        what,
        reason: e.to_string(),
    }
}

/// A running ROS 2 node for one robot.
///
/// It owns one ordinary thread that does all DDS work: it publishes `joint_states` at the
/// configured rate and `diagnostics` at their period, and takes `joint_commands`,
/// `joint_trajectory` and the enable topic as they arrive, passing what validates to the port.
/// Dropping the node stops the thread (the port is dropped with it); [`Ros2Node::stop`] gives
/// the port back.
pub struct Ros2Node<P: RobotPort> {
    stop: Arc<AtomicBool>,
    counters: Arc<Counters>,
    thread: Option<JoinHandle<P>>,
    dds_names: DdsNames,
}

/// The DDS topic names the node uses (`rt/` + the resolved ROS name).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DdsNames {
    /// `joint_states`.
    pub joint_states: String,
    /// `diagnostics`.
    pub diagnostics: String,
    /// `joint_commands`.
    pub joint_commands: String,
    /// `joint_trajectory`.
    pub joint_trajectory: String,
    /// The enable topic.
    pub enable: String,
}

impl<P: RobotPort> Ros2Node<P> {
    /// Joins the DDS domain and starts publishing and subscribing. Returns once every DDS
    /// entity exists (discovery of peers continues in the background).
    pub fn start(config: NodeConfig, port: P) -> Result<Self, NodeError> {
        config.check()?;
        let joints = port.joints();
        for (i, j) in joints.iter().enumerate() {
            if joints[..i].iter().any(|o| o.name == j.name) {
                return Err(NodeError::DuplicateJointName(j.name.clone()));
            }
        }
        let t = &config.topics;
        let dds = |topic: &str| config.resolve_topic(topic).map(|n| format!("rt{n}"));
        let dds_names = DdsNames {
            joint_states: dds(&t.joint_states)?,
            diagnostics: dds(&t.diagnostics)?,
            joint_commands: dds(&t.joint_commands)?,
            joint_trajectory: dds(&t.joint_trajectory)?,
            enable: dds(&t.enable)?,
        };
        let stop = Arc::new(AtomicBool::new(false));
        let counters = Arc::new(Counters::default());
        let (ready_tx, ready_rx) = mpsc::channel();
        let thread = {
            let stop = Arc::clone(&stop);
            let counters = Arc::clone(&counters);
            std::thread::Builder::new()
                .name("rmd-ros2".into())
                .spawn(move || {
                    match Dds::open(&config, &port) {
                        Err(e) => {
                            // The receiver waits for exactly this message.
                            let _ = ready_tx.send(Err(e));
                        }
                        Ok(dds) => {
                            let _ = ready_tx.send(Ok(()));
                            let mut worker = Worker::new(&config, port, dds, counters);
                            worker.run(&stop, &config);
                            return worker.port;
                        }
                    }
                    port
                })?
        };
        match ready_rx.recv() {
            Ok(Ok(())) => Ok(Ros2Node {
                stop,
                counters,
                thread: Some(thread),
                dds_names,
            }),
            Ok(Err(e)) => {
                let _ = thread.join();
                Err(e)
            }
            Err(_) => Err(NodeError::Panicked(panic_text(thread.join().err()))),
        }
    }

    /// The node's counters now.
    pub fn stats(&self) -> NodeStats {
        self.counters.snapshot()
    }

    /// The DDS topic names in use (what a plain DDS client must use, e.g.
    /// `rt/leg/joint_states`).
    pub fn dds_names(&self) -> &DdsNames {
        &self.dds_names
    }

    /// Publishes one last `diagnostics` message (the port's final diagnostics and counters),
    /// stops the thread, leaves the DDS domain, and returns the port.
    pub fn stop(mut self) -> Result<P, NodeError> {
        self.stop.store(true, Ordering::Relaxed);
        let thread = self
            .thread
            .take()
            .expect("the thread is joined only here or in drop");
        thread
            .join()
            .map_err(|e| NodeError::Panicked(panic_text(Some(e))))
    }
}

impl<P: RobotPort> Drop for Ros2Node<P> {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

fn panic_text(e: Option<Box<dyn std::any::Any + Send>>) -> String {
    match e {
        Some(e) => e
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| e.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown panic".into()),
        None => "the thread ended before reporting".into(),
    }
}

const COMMANDS: Token = Token(0);
const TRAJECTORY: Token = Token(1);
const ENABLE: Token = Token(2);

/// How long the thread stays after its last diagnostics message, so that it goes out.
const FINAL_LINGER: Duration = Duration::from_millis(100);

/// Upper bound on samples taken from one reader per wake-up, so a flood on one topic cannot
/// starve publishing.
const MAX_TAKES_PER_WAKE: usize = 256;

/// The longest rejection text kept for diagnostics, in bytes: a rejection never republishes
/// more of a bad message than this.
const MAX_REJECTION_TEXT: usize = 400;

/// The DDS entities of the node.
struct Dds {
    // Keeps the participant and the ROS graph entry alive.
    _node: Node,
    fqn: String,
    joint_states: Publisher<msg::JointState>,
    diagnostics: Publisher<msg::DiagnosticArray>,
    commands: Subscription<Inbound<msg::JointState>>,
    trajectory: Subscription<Inbound<msg::JointTrajectory>>,
    enable: Subscription<Inbound<msg::Bool>>,
    poll: Poll,
    // Samples the DDS layer dropped as larger than InputLimits::max_sample_bytes.
    oversized_samples: Arc<AtomicU64>,
}

fn topic<M: RosMessage>(
    node: &mut Node,
    config: &NodeConfig,
    name: &str,
    qos: &QosProfile,
) -> Result<ros2_client::dds::rustdds::Topic, NodeError> {
    let resolved = config.resolve_topic(name)?;
    let name = Name::parse(&resolved).map_err(|_| NodeConfigError::BadTopic(name.to_owned()))?;
    node.create_topic(&name, MessageTypeName::new(M::PACKAGE, M::NAME), qos)
        .map_err(|e| dds_error(format!("topic {resolved}"))(&e))
}

fn publisher<M: RosMessage + Serialize>(
    node: &mut Node,
    config: &NodeConfig,
    name: &str,
    qos: QosProfile,
) -> Result<Publisher<M>, NodeError> {
    let t = topic::<M>(node, config, name, &qos)?;
    node.create_publisher(&t, Some(qos))
        .map_err(|e| dds_error(format!("publisher {name}"))(&e))
}

/// A subscription whose samples are decoded within the input limits (`take_seed` with an
/// [`InboundSeed`]).
fn subscription<M: RosMessage + 'static>(
    node: &mut Node,
    config: &NodeConfig,
    name: &str,
    qos: QosProfile,
) -> Result<Subscription<Inbound<M>>, NodeError> {
    let t = topic::<M>(node, config, name, &qos)?;
    node.create_subscription(&t, Some(qos))
        .map_err(|e| dds_error(format!("subscription {name}"))(&e))
}

impl Dds {
    fn open<P: RobotPort>(config: &NodeConfig, _port: &P) -> Result<Self, NodeError> {
        let oversized_samples = Arc::new(AtomicU64::new(0));
        let participant = DomainParticipantBuilder::new(config.domain_id)
            .tuning(ParticipantTuning {
                acknowledge_data_within: Some(config.acknowledge_within),
                bind_address: config.network,
                max_sample_size: Some(config.input_limits.max_sample_bytes),
                oversized_samples: Arc::clone(&oversized_samples),
            })
            .build()
            .map_err(|e| dds_error("domain participant")(&e))?;
        let context = Context::from_domain_participant(participant)
            .map_err(|e| dds_error("ROS 2 context")(&e))?;
        let node_name = config.node_name()?;
        let fqn = node_name.fully_qualified_name();
        let mut node = context
            .new_node(
                node_name,
                NodeOptions::new()
                    .enable_rosout(false)
                    .start_parameter_services(false),
            )
            .map_err(|e| dds_error("node")(&e))?;
        let t = &config.topics;
        let joint_states = publisher(&mut node, config, &t.joint_states, qos::joint_states())?;
        let diagnostics = publisher(&mut node, config, &t.diagnostics, qos::diagnostics())?;
        let mut commands = subscription(&mut node, config, &t.joint_commands, qos::commands())?;
        let mut trajectory = subscription(&mut node, config, &t.joint_trajectory, qos::commands())?;
        let mut enable = subscription(&mut node, config, &t.enable, qos::commands())?;
        let poll = Poll::new()?;
        poll.registry()
            .register(&mut commands, COMMANDS, Interest::READABLE)?;
        poll.registry()
            .register(&mut trajectory, TRAJECTORY, Interest::READABLE)?;
        poll.registry()
            .register(&mut enable, ENABLE, Interest::READABLE)?;
        Ok(Dds {
            _node: node,
            fqn,
            joint_states,
            diagnostics,
            commands,
            trajectory,
            enable,
            poll,
            oversized_samples,
        })
    }
}

/// The node's thread: its port, its DDS entities, its schedule.
struct Worker<P> {
    port: P,
    dds: Dds,
    validator: Validator,
    counters: Arc<Counters>,
    names: Vec<String>,
    last_rejection: Option<String>,
    limits: InputLimits,
    // How many of the DDS layer's oversized samples are counted already.
    oversized_seen: u64,
}

impl<P: RobotPort> Worker<P> {
    fn new(config: &NodeConfig, port: P, dds: Dds, counters: Arc<Counters>) -> Self {
        let validator = Validator::new(port.joints(), config.command_mode);
        let names = port.joints().iter().map(|j| j.name.clone()).collect();
        Worker {
            port,
            dds,
            validator,
            counters,
            names,
            last_rejection: None,
            limits: config.input_limits,
            oversized_seen: 0,
        }
    }

    fn run(&mut self, stop: &AtomicBool, config: &NodeConfig) {
        // Both periods are valid: `start` checked the configuration.
        let js_period = config
            .joint_state_period()
            .unwrap_or(Duration::from_millis(2));
        let diag_period = config.diagnostics_period;
        let mut events = Events::with_capacity(16);
        let mut next_js = Instant::now();
        let mut next_diag = Instant::now() + diag_period;
        while !stop.load(Ordering::Relaxed) {
            let now = Instant::now();
            let wake = next_js.min(next_diag).min(now + Duration::from_millis(50));
            match self
                .dds
                .poll
                .poll(&mut events, Some(wake.saturating_duration_since(now)))
            {
                Ok(()) => {}
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                // A poll that fails for another reason would fail again at once: take what is
                // there and publish on schedule all the same, by sleeping instead.
                Err(_) => std::thread::sleep(wake.saturating_duration_since(Instant::now())),
            }
            // Readers are edge-triggered: take everything each time one is ready. A wake-up
            // without events (timeout or failed poll) takes from all of them, a cheap safety
            // net against a missed edge.
            let (mut c, mut t, mut e) = (events.is_empty(), events.is_empty(), events.is_empty());
            for ev in events.iter() {
                match ev.token() {
                    COMMANDS => c = true,
                    TRAJECTORY => t = true,
                    _ => e = true,
                }
            }
            if c {
                self.take_commands();
            }
            if t {
                self.take_trajectories();
            }
            if e {
                self.take_enables();
            }
            self.count_dropped_samples();
            let now = Instant::now();
            if now >= next_js {
                self.publish_joint_state();
                next_js = advance(next_js, js_period, now);
            }
            if now >= next_diag {
                self.publish_diagnostics();
                next_diag = advance(next_diag, diag_period, now);
            }
        }
        // A last word: the robot's final state (e.g. how its loop ended) and the final
        // counters, for whoever watches diagnostics. RustDDS sends from its own event-loop
        // thread: give it a moment before the participant goes.
        self.publish_diagnostics();
        std::thread::sleep(FINAL_LINGER);
    }

    fn reject(&mut self, kind: RejectionKind, text: String) {
        self.counters.rejected(kind);
        let mut text = text;
        if text.len() > MAX_REJECTION_TEXT {
            text = format!("{}...", excerpt(&text, MAX_REJECTION_TEXT));
        }
        self.last_rejection = Some(text);
    }

    /// Counts the samples the DDS layer dropped as too large since the last call.
    fn count_dropped_samples(&mut self) {
        let dropped = self.dds.oversized_samples.load(Ordering::Relaxed);
        if dropped > self.oversized_seen {
            let limit = self.limits.max_sample_bytes;
            for _ in self.oversized_seen..dropped {
                self.reject(
                    RejectionKind::Oversized,
                    format!(
                        "a sample larger than the node's limit of {limit} bytes was dropped unread by DDS"
                    ),
                );
            }
            self.oversized_seen = dropped;
        }
    }

    fn take_commands(&mut self) {
        for _ in 0..MAX_TAKES_PER_WAKE {
            let seed = InboundSeed::<msg::JointState>::new(&self.limits, "joint_commands");
            match self.dds.commands.take_seed(seed) {
                Ok(None) => return,
                Ok(Some((Inbound(Err(o)), _))) => {
                    self.reject(RejectionKind::Oversized, format!("joint_commands: {o}"))
                }
                Ok(Some((Inbound(Ok(m)), _))) => match self.validator.joint_command(&m) {
                    Ok(s) => match self.port.send_setpoints(&s) {
                        Ok(()) => self.counters.accepted(InputTopic::JointCommands),
                        Err(e) => self.reject(e.kind(), format!("joint_commands: {e}")),
                    },
                    Err(r) => self.reject(r.kind(), format!("joint_commands: {r}")),
                },
                Err(e) => self.reject(RejectionKind::Malformed, format!("joint_commands: {e}")),
            }
        }
    }

    fn take_trajectories(&mut self) {
        for _ in 0..MAX_TAKES_PER_WAKE {
            let seed = InboundSeed::<msg::JointTrajectory>::new(&self.limits, "joint_trajectory");
            match self.dds.trajectory.take_seed(seed) {
                Ok(None) => return,
                Ok(Some((Inbound(Err(o)), _))) => {
                    self.reject(RejectionKind::Oversized, format!("joint_trajectory: {o}"))
                }
                Ok(Some((Inbound(Ok(m)), _))) => match self.validator.trajectory(&m) {
                    Ok(t) => match self.port.send_trajectory(&t) {
                        Ok(()) => self.counters.accepted(InputTopic::JointTrajectory),
                        Err(e) => self.reject(e.kind(), format!("joint_trajectory: {e}")),
                    },
                    Err(r) => self.reject(r.kind(), format!("joint_trajectory: {r}")),
                },
                Err(e) => self.reject(RejectionKind::Malformed, format!("joint_trajectory: {e}")),
            }
        }
    }

    fn take_enables(&mut self) {
        for _ in 0..MAX_TAKES_PER_WAKE {
            let seed = InboundSeed::<msg::Bool>::new(&self.limits, "enable");
            match self.dds.enable.take_seed(seed) {
                Ok(None) => return,
                Ok(Some((Inbound(Err(o)), _))) => {
                    self.reject(RejectionKind::Oversized, format!("enable: {o}"))
                }
                Ok(Some((Inbound(Ok(m)), _))) => {
                    let enable = if m.data {
                        Enable::Enabled
                    } else {
                        Enable::Estop
                    };
                    match self.port.set_enable(enable) {
                        Ok(()) => self.counters.accepted(InputTopic::Enable),
                        Err(e) => self.reject(e.kind(), format!("enable: {e}")),
                    }
                }
                Err(e) => self.reject(RejectionKind::Malformed, format!("enable: {e}")),
            }
        }
    }

    fn publish_joint_state(&mut self) {
        let Some(state) = self.port.latest_state() else {
            return;
        };
        let m = msg::JointState {
            header: msg::Header {
                stamp: msg::Time::from_system_time(state.stamp),
                frame_id: String::new(),
            },
            name: self.names.clone(),
            position: state.position_rad,
            velocity: state.velocity_rad_s,
            effort: state.effort_nm,
        };
        match self.dds.joint_states.publish(m) {
            Ok(()) => self.counters.joint_state_published(),
            Err(_) => self.counters.publish_failed(),
        }
    }

    fn publish_diagnostics(&mut self) {
        let robot = self.port.diagnostics();
        let m = diagnostic_array(
            &self.dds.fqn,
            SystemTime::now(),
            &robot,
            &self.counters.snapshot(),
            self.last_rejection.as_deref(),
        );
        match self.dds.diagnostics.publish(m) {
            Ok(()) => self.counters.diagnostics_published(),
            Err(_) => self.counters.publish_failed(),
        }
    }
}

/// The next deadline after `deadline`: one period on, or, when the thread fell more than a
/// period behind, one period from now (no burst of catch-up messages).
fn advance(deadline: Instant, period: Duration, now: Instant) -> Instant {
    let next = deadline + period;
    if next <= now { now + period } else { next }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn schedule_keeps_its_phase_and_skips_rather_than_bursts() {
        let t0 = Instant::now();
        let p = Duration::from_millis(2);
        assert_eq!(advance(t0, p, t0 + Duration::from_micros(300)), t0 + p);
        let late = t0 + Duration::from_millis(7);
        assert_eq!(advance(t0, p, late), late + p);
    }
}
