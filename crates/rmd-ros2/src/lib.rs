//! # rmd-ros2
//!
//! A ROS 2 node over DDS for an rmd-rt robot, built on `ros2-client` (RustDDS): no ROS
//! installation at build or run time. The node
//!
//! - publishes `joint_states` (`sensor_msgs/msg/JointState`, sensor-data QoS) at a configurable
//!   rate (default 500 Hz) and `diagnostics` (`diagnostic_msgs/msg/DiagnosticArray`) at 1 Hz;
//! - subscribes `joint_commands` (`sensor_msgs/msg/JointState`, the convention of
//!   `topic_based_ros2_control` and `joint_state_topic_hardware_interface`),
//!   `joint_trajectory` (`trajectory_msgs/msg/JointTrajectory`) and `enable`
//!   (`std_msgs/msg/Bool`: `true` enables, `false` is an emergency stop);
//! - rejects bad input (unknown joints, NaN, out-of-limit values, mismatched lengths, empty
//!   messages, non-increasing trajectory times) with a typed, counted [`MessageRejection`]; nothing of
//!   a rejected message reaches the robot.
//!
//! The robot is a [`RobotPort`]: the node reads samples and diagnostics from it and gives it
//! validated [`Setpoints`], [`Trajectory`]s and [`Enable`] requests. All DDS work runs on one
//! ordinary thread the node owns; the port is only ever called from there. The port of a real
//! robot is [`servo::ServoPort`], over `rmd-servo`'s joint servo in the real-time loop (the
//! `rmd ros2` command runs them together).
//!
//! ```no_run
//! use rmd_ros2::{NodeConfig, Ros2Node, fake::FakeRobot};
//! let robot = FakeRobot::start(FakeRobot::demo_joints(), true);
//! let node = Ros2Node::start(
//!     NodeConfig { namespace: "/leg".into(), ..NodeConfig::default() },
//!     robot,
//! )?;
//! assert_eq!(node.dds_names().joint_states, "rt/leg/joint_states");
//! std::thread::sleep(std::time::Duration::from_secs(1));
//! println!("{:?}", node.stats());
//! let _robot = node.stop()?;
//! # Ok::<(), rmd_ros2::NodeError>(())
//! ```
//!
//! See `docs/ros2.md` for running beside ROS 2 Humble or Jazzy and `ros2_control` on top.

mod config;
pub mod diagnostics;
#[cfg(feature = "fake-robot")]
pub mod fake;
mod inbound;
mod kind;
pub mod msg;
mod node;
mod port;
pub mod qos;
pub mod servo;
mod stats;
mod validate;

pub use config::{InputLimits, NodeConfig, NodeConfigError, TopicNames};
pub use inbound::Oversize;
pub use kind::RejectionKind;
pub use node::{DdsNames, NodeError, Ros2Node};
pub use port::{
    Enable, JointIndex, JointInfo, JointLimits, LoopEnd, LoopTiming, MotorDiagnostics, PortError,
    RobotDiagnostics, RobotPort, RobotState, Setpoint, Setpoints, Trajectory, TrajectoryPoint,
};
pub use stats::{InputTopic, NodeStats};
pub use validate::{CommandMode, MessageField, MessageRejection, Validator};
