//! `rmd ros2`: a robot as a ROS 2 node over DDS (no ROS installation).
//!
//! The real-time loop runs the joint servo (`rmd-servo`) on its own thread, supervised, as every
//! run of the rig does; the ROS 2 node (`rmd-ros2`) runs on an ordinary thread and talks to the
//! servo only through its lock-free queues (`rmd_ros2::servo::ServoPort`); this thread owns the
//! loop's handle, feeds the node the loop's statistics once per diagnostics period, and waits
//! for the end (the run's length, a signal, a fault, an estop). The loop thread never touches
//! DDS.

use std::io::{IsTerminal, Write};
use std::net::IpAddr;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::{Args, ValueEnum};
use rmd_loop::robot::RobotConfig;
use rmd_loop::{LoopOutcome, robot::Robot, stats::StatsSummary};
use rmd_rig::args::duration::{self, Bounds};
use rmd_rig::args::{LoopArgs, RobotArgs};
use rmd_rig::runner::{EXIT_FAULT, EXIT_OK};
use rmd_rig::signals::{self, EXIT_INTERRUPTED};
use rmd_rig::{PlacementDefault, Rig, sim};
use rmd_ros2::servo::{EstopAction, LoopFeed, ServoPort};
use rmd_ros2::{CommandMode, NodeConfig, NodeStats, Ros2Node};
use rmd_servo::{ServoConfig, ServoController};
use serde_json::{Value, json};

use crate::output::report::{self, CliError};
use crate::output::{errln, outln};

/// How `joint_commands` become setpoints.
#[derive(Clone, Copy, Debug, ValueEnum)]
enum Mode {
    /// Position if given (velocity and effort as feed-forward), else velocity, else effort.
    Auto,
    /// Positions required; velocity and effort, if given, are feed-forward.
    Position,
    /// Velocities required; effort, if given, is feed-forward.
    Velocity,
    /// Efforts required.
    Effort,
}

/// `rmd ros2 ...`.
#[derive(Args, Debug)]
// The rig's robot flags, worded for this command: the description is required, and the
// simulated motors run in real time only.
#[command(mut_arg("robot", |a| a.required(true).help("The robot's description (TOML; see examples/robots/)")))]
#[command(mut_arg("iface", |a| a.help("CAN interface of each bus: in bus order (`can0,can1`) or by bus name (`front=can0`); repeatable. Default: the description's interfaces")))]
#[command(mut_arg("virtual_time", |a| a.hide(true)))]
#[command(
    after_help = "Topics (relative to --namespace): joint_states (sensor_msgs/JointState, \
    best effort), /diagnostics (diagnostic_msgs/DiagnosticArray), joint_commands \
    (sensor_msgs/JointState), joint_trajectory (trajectory_msgs/JointTrajectory), enable \
    (std_msgs/Bool: true enables, false is an emergency stop). See docs/ros2.md.\n\n\
    The loop runs the joint servo (docs/servo.md) at the description's rate; the node's DDS work \
    runs on its own thread. Ctrl-C stops (zero torque, motor off, the report); a second Ctrl-C \
    is an emergency stop.\n\n\
    Exit status: 0 when the run ended normally (its --seconds), 130 after a signal, 1 on a \
    fault or an emergency stop that ended the run, 2 on a usage error.\n\n\
    Examples:\n  rmd ros2 --robot examples/robots/leg4.toml --sim\n  \
    rmd ros2 --robot examples/robots/leg4.toml --servo examples/servo/leg4.toml \
    --iface can0 --namespace /leg --domain-id 7 --yes"
)]
pub(crate) struct Ros2Args {
    #[command(flatten)]
    robot: RobotArgs,
    #[command(flatten)]
    run: LoopArgs,
    /// The servo's configuration (TOML: gains, limits, stale-setpoint policy; see
    /// docs/servo.md). Default: the built-in gains and limits for every joint.
    #[arg(long, value_name = "FILE")]
    servo: Option<PathBuf>,
    /// The node's ROS 2 namespace (`/`, or `/a/b`).
    #[arg(long, default_value = "/", value_name = "NS")]
    namespace: String,
    /// The DDS domain: ROS_DOMAIN_ID of the ROS 2 side, 0..=232.
    #[arg(long, default_value_t = 0, value_name = "N")]
    domain_id: u16,
    /// The node's name.
    #[arg(long, default_value = "rmd_rt", value_name = "NAME")]
    node_name: String,
    /// How often joint_states is published, Hz (at most the loop's rate is useful).
    #[arg(long, default_value_t = 500.0, value_name = "HZ")]
    joint_states_hz: f64,
    /// How often diagnostics are published (e.g. 1s, 500ms).
    #[arg(long, default_value = "1s", value_name = "DURATION", value_parser = diagnostics_period)]
    diagnostics_period: Duration,
    /// How joint_commands become setpoints.
    #[arg(long, value_enum, default_value_t = Mode::Auto)]
    command_mode: Mode,
    /// Use only the network interface with this IPv4 address for DDS, e.g. 127.0.0.1 for this
    /// host only: every DDS socket is bound to it, so nothing arriving by another interface
    /// reaches the node. It must be an address of this host. Default: every interface.
    #[arg(long = "network", value_name = "ADDR")]
    network: Option<IpAddr>,
    /// `false` on the enable topic ends the run (emergency stop, motors off) instead of
    /// disabling the servo (zero torque until `true`).
    #[arg(long)]
    estop_ends_run: bool,
    /// No status line: only the final report.
    #[arg(long, short)]
    quiet: bool,
    /// Print the final report (the loop's, plus the node's counters under `ros2`) as one JSON
    /// object.
    #[arg(long)]
    json: bool,
}

fn diagnostics_period(text: &str) -> Result<Duration, String> {
    duration::parse(text, Bounds::positive_up_to(Duration::from_secs(3600)))
}

/// How often the loop's statistics are read at most (each read makes the loop thread copy
/// them between two ticks).
const MIN_SNAPSHOT_INTERVAL: Duration = Duration::from_millis(100);
/// How often this thread looks at the loop.
const POLL: Duration = Duration::from_millis(20);

/// Runs `rmd ros2`.
pub(crate) fn run(args: Ros2Args) -> ExitCode {
    match run_node(&args) {
        Ok(code) => code,
        Err(e) => report::exit(Err(e)),
    }
}

fn usage(e: impl std::fmt::Display) -> CliError {
    CliError::Usage(e.to_string())
}

fn failed(e: impl std::fmt::Display) -> CliError {
    CliError::Failed(e.to_string())
}

fn run_node(args: &Ros2Args) -> Result<ExitCode, CliError> {
    if args.robot.virtual_time {
        return Err(CliError::Usage(
            "rmd ros2 runs in real time (the ROS 2 side shares the wall clock): drop \
             --virtual-time"
                .into(),
        ));
    }
    let Some(path) = &args.robot.robot else {
        return Err(CliError::Usage(
            "give the robot's description: --robot FILE (see examples/robots/)".into(),
        ));
    };
    let mut description: RobotConfig = args.robot.description("").map_err(usage)?;
    args.run.apply(&mut description);
    let robot = Robot::try_from(description).map_err(usage)?;
    let servo_config = match &args.servo {
        Some(file) => ServoConfig::from_file(&robot, file),
        None => ServoConfig::defaults(&robot),
    }
    .map_err(usage)?;
    let node_config = NodeConfig {
        node_name: args.node_name.clone(),
        namespace: args.namespace.clone(),
        domain_id: args.domain_id,
        joint_state_rate_hz: args.joint_states_hz,
        diagnostics_period: args.diagnostics_period,
        command_mode: match args.command_mode {
            Mode::Auto => CommandMode::Auto,
            Mode::Position => CommandMode::Position,
            Mode::Velocity => CommandMode::Velocity,
            Mode::Effort => CommandMode::Effort,
        },
        network: args.network,
        ..NodeConfig::default()
    };
    node_config.check().map_err(usage)?;
    let placement = args
        .robot
        .placement(&robot, PlacementDefault::Described)
        .map_err(usage)?;
    if !args.robot.confirm_motion(
        &placement,
        &format!(
            "the servo holds every joint of {} where it is and follows ROS 2 commands",
            path.display()
        ),
    ) {
        return Err(CliError::Failed("not confirmed: nothing was moved".into()));
    }
    let signals = signals::install().map_err(failed)?;

    let mut sims = sim::sim_configs(&robot, args.robot.seed);
    sim::power_up_centred(&robot, &mut sims);
    let rig = Rig::open(&robot, &placement, sims).map_err(failed)?;
    let (servo, handle) = ServoController::new(servo_config);
    let feed = LoopFeed::new();
    let labels = robot
        .buses()
        .iter()
        .zip(placement.buses())
        .map(|(bus, target)| format!("{} ({target})", bus.name));
    let port = ServoPort::new(handle, &robot, rig.clock.clone())
        .and_then(|p| p.with_bus_labels(labels))
        .map_err(failed)?
        .with_feed(feed.clone())
        .with_estop(if args.estop_ends_run {
            EstopAction::EndRun
        } else {
            EstopAction::Disable
        });
    let full_name = match args.namespace.as_str() {
        "/" => format!("/{}", args.node_name),
        ns => format!("{ns}/{}", args.node_name),
    };
    // DDS first: if the node cannot start, nothing has moved.
    let node = Ros2Node::start(node_config, port).map_err(failed)?;
    let rt = rig.into_loop(robot.clone(), servo).map_err(failed)?;
    let limit = args.run.limit(None);
    let running = rt.spawn(limit).map_err(failed)?;
    let watch = signals.watch(running.stopper());
    let show = !args.quiet && !args.json;
    if show {
        errln!(
            "rmd ros2: node {} on DDS domain {}: {} and {} ({} joints at {} Hz on {placement}); \
             Ctrl-C stops",
            full_name,
            args.domain_id,
            node.dds_names().joint_states,
            node.dds_names().joint_commands,
            robot.joints().len(),
            robot.settings().period.hz(),
        );
    }
    let mut status = Status::new(show);
    let snapshot_every = args.diagnostics_period.max(MIN_SNAPSHOT_INTERVAL);
    let mut last_snapshot = Instant::now();
    while running.is_running() {
        std::thread::sleep(POLL);
        if last_snapshot.elapsed() >= snapshot_every {
            last_snapshot = Instant::now();
            if let Some(stats) = running.snapshot(Duration::from_millis(50)) {
                status.show(&stats, &node.stats());
                feed.set_stats(stats);
            }
        }
    }
    let outcome = running.join().map_err(failed)?;
    drop(watch);
    status.finish();
    // The node's last diagnostics say how the loop ended.
    feed.set_ended(&outcome.report, &robot);
    let ros2 = node.stats();
    let port = node.stop().map_err(failed)?;
    let unattributed = port.handle().rejected_unattributed();
    print_report(&outcome, &ros2, unattributed, args.json)?;
    Ok(ExitCode::from(if signals.interrupted() {
        EXIT_INTERRUPTED
    } else if outcome.report.normal_stop {
        EXIT_OK
    } else {
        EXIT_FAULT
    }))
}

/// The node's counters as JSON.
fn ros2_json(stats: &NodeStats, servo_unattributed: u64) -> Value {
    let mut rejected = serde_json::Map::new();
    for (kind, n) in stats.rejections {
        rejected.insert(kind.name().into(), n.into());
    }
    json!({
        "joint_states_published": stats.joint_states_published,
        "diagnostics_published": stats.diagnostics_published,
        "publish_errors": stats.publish_errors,
        "commands_accepted": stats.commands_accepted,
        "trajectories_accepted": stats.trajectories_accepted,
        "enables_accepted": stats.enables_accepted,
        "rejected_total": stats.rejected_total(),
        "rejected": rejected,
        "servo_refusals_unattributed": servo_unattributed,
    })
}

fn print_report(
    outcome: &LoopOutcome<ServoController>,
    ros2: &NodeStats,
    servo_unattributed: u64,
    json: bool,
) -> Result<(), CliError> {
    let report = &outcome.report;
    let written = if json {
        let mut value: Value = serde_json::from_str(&report.to_json()).map_err(failed)?;
        if let Value::Object(map) = &mut value {
            map.insert("ros2".into(), ros2_json(ros2, servo_unattributed));
        }
        outln!("{value}")
    } else {
        let rejected: Vec<String> = ros2
            .rejections
            .iter()
            .filter(|(_, n)| *n > 0)
            .map(|(kind, n)| format!("{} {n}", kind.name()))
            .collect();
        outln!(
            "{report}ros2 node: {} joint_states, {} diagnostics published ({} publish errors); \
             accepted {} commands, {} trajectories, {} enables; rejected {}{}",
            ros2.joint_states_published,
            ros2.diagnostics_published,
            ros2.publish_errors,
            ros2.commands_accepted,
            ros2.trajectories_accepted,
            ros2.enables_accepted,
            ros2.rejected_total(),
            if rejected.is_empty() {
                String::new()
            } else {
                format!(" ({})", rejected.join(", "))
            }
        )
    };
    written.map_err(|_| CliError::OutputClosed)
}

/// The status line on stderr: in place on a terminal, a line at a time otherwise.
struct Status {
    show: bool,
    terminal: bool,
    shown: bool,
}

impl Status {
    fn new(show: bool) -> Self {
        Status {
            show,
            terminal: std::io::stderr().is_terminal(),
            shown: false,
        }
    }

    fn show(&mut self, loop_stats: &StatsSummary, node: &NodeStats) {
        if !self.show {
            return;
        }
        let line = format!(
            "loop {} ticks, {} misses, work p99 {:.0} us | ros2 {} joint_states, {} commands, \
             {} trajectories, {} rejected",
            loop_stats.ticks,
            loop_stats.deadline_misses,
            loop_stats.work_us.p99,
            node.joint_states_published,
            node.commands_accepted,
            node.trajectories_accepted,
            node.rejected_total()
        );
        if self.terminal {
            let mut err = std::io::stderr();
            // A closed stderr is not worth stopping the robot for.
            let _ = write!(err, "\r{line}\x1b[K");
            let _ = err.flush();
        } else {
            errln!("{line}");
        }
        self.shown = true;
    }

    fn finish(&mut self) {
        if self.show && self.terminal && self.shown {
            errln!();
        }
    }
}
