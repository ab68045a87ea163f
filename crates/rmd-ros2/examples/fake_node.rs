//! The ROS 2 node on the test-double robot (`FakeRobot`: three joints `hip`, `knee`, `wrist`
//! that follow setpoints with a first-order response), for demos and for trying a ROS 2 setup
//! without the real-time loop (`rmd ros2 --robot FILE --sim` runs the real one on simulated
//! motors).
//!
//! ```text
//! cargo run -p rmd-ros2 --example fake_node -- --namespace /fake --seconds 30
//! ```
//!
//! Prints `READY` once its DDS entities exist, and its counters (`stat NAME VALUE` lines) when
//! it stops (after `--seconds`, or on Ctrl-C / SIGTERM).

use std::net::IpAddr;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use clap::{Parser, ValueEnum};
use rmd_ros2::fake::FakeRobot;
use rmd_ros2::{CommandMode, NodeConfig, Ros2Node};

#[derive(Clone, Copy, ValueEnum)]
enum Mode {
    Auto,
    Position,
    Velocity,
    Effort,
}

#[derive(Parser)]
#[command(about = "The rmd-rt ROS 2 node on a simulated test-double robot")]
struct Args {
    /// ROS 2 namespace of the node.
    #[arg(long, default_value = "/")]
    namespace: String,
    /// DDS domain (ROS_DOMAIN_ID).
    #[arg(long, default_value_t = 0)]
    domain_id: u16,
    /// joint_states rate, Hz.
    #[arg(long, default_value_t = 500.0)]
    rate_hz: f64,
    /// Stop after this many seconds (0: run until Ctrl-C).
    #[arg(long, default_value_t = 0.0)]
    seconds: f64,
    /// Use only the interface with this address, e.g. 127.0.0.1 (bound: nothing from other
    /// interfaces reaches the node).
    #[arg(long)]
    network: Option<IpAddr>,
    /// Start in emergency stop (publish true on `enable` to enable).
    #[arg(long)]
    estopped: bool,
    /// How joint_commands become setpoints.
    #[arg(long, value_enum, default_value_t = Mode::Auto)]
    command_mode: Mode,
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args = Args::parse();
    let config = NodeConfig {
        namespace: args.namespace,
        domain_id: args.domain_id,
        joint_state_rate_hz: args.rate_hz,
        network: args.network,
        command_mode: match args.command_mode {
            Mode::Auto => CommandMode::Auto,
            Mode::Position => CommandMode::Position,
            Mode::Velocity => CommandMode::Velocity,
            Mode::Effort => CommandMode::Effort,
        },
        ..NodeConfig::default()
    };
    let robot = FakeRobot::start(FakeRobot::demo_joints(), !args.estopped);
    let node = Ros2Node::start(config, robot)?;
    let stop = Arc::new(AtomicBool::new(false));
    {
        let stop = Arc::clone(&stop);
        ctrlc::set_handler(move || stop.store(true, Ordering::Relaxed))?;
    }
    println!("READY {}", node.dds_names().joint_states);
    let t0 = Instant::now();
    while !stop.load(Ordering::Relaxed)
        && (args.seconds <= 0.0 || t0.elapsed().as_secs_f64() < args.seconds)
    {
        std::thread::sleep(Duration::from_millis(20));
    }
    let s = node.stats();
    let _robot = node.stop()?;
    println!("stat joint_states_published {}", s.joint_states_published);
    println!("stat diagnostics_published {}", s.diagnostics_published);
    println!("stat publish_errors {}", s.publish_errors);
    println!("stat commands_accepted {}", s.commands_accepted);
    println!("stat trajectories_accepted {}", s.trajectories_accepted);
    println!("stat enables_accepted {}", s.enables_accepted);
    for (kind, n) in s.rejections {
        println!("stat rejected_{} {n}", kind.name());
    }
    Ok(())
}
