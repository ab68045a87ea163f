//! The ROS 2 messages the node speaks, laid out field for field as their `.msg` definitions
//! (Humble and Jazzy define them identically), so that serde's order gives the CDR (XCDR1) wire
//! format every ROS 2 DDS implementation uses.
//!
//! Each type's DDS type name (what `rmw` registers, e.g. `sensor_msgs::msg::dds_::JointState_`)
//! comes from [`RosMessage::PACKAGE`] and [`RosMessage::NAME`]; `ros2-client` adds the `msg`
//! and `dds_` parts.

use serde::{Deserialize, Serialize};

/// A ROS 2 message type: its package and type name (`sensor_msgs` / `JointState`).
pub trait RosMessage {
    /// The ROS package, e.g. `sensor_msgs`.
    const PACKAGE: &'static str;
    /// The type name inside the package, e.g. `JointState`.
    const NAME: &'static str;

    /// The DDS type name `rmw` registers for it, e.g. `sensor_msgs::msg::dds_::JointState_`.
    fn dds_type_name() -> String {
        format!("{}::msg::dds_::{}_", Self::PACKAGE, Self::NAME)
    }
}

/// `builtin_interfaces/Time`: seconds and nanoseconds since the epoch (or zero: "unset").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Time {
    /// Whole seconds.
    pub sec: i32,
    /// Nanoseconds, `0..1_000_000_000` in a well-formed message.
    pub nanosec: u32,
}

/// `builtin_interfaces/Duration`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Duration {
    /// Whole seconds (negative durations are representable on the wire).
    pub sec: i32,
    /// Nanoseconds, `0..1_000_000_000` in a well-formed message.
    pub nanosec: u32,
}

/// `std_msgs/Header`.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Header {
    /// The time the data belongs to.
    pub stamp: Time,
    /// The coordinate frame (empty for joint data).
    pub frame_id: String,
}

/// `sensor_msgs/JointState`: names, and per name position (rad or m), velocity (rad/s or m/s)
/// and effort (N·m or N). Each of the three arrays is either empty or as long as `name`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct JointState {
    /// Stamp of the sample (or of the command).
    pub header: Header,
    /// Joint names.
    pub name: Vec<String>,
    /// Positions, rad.
    pub position: Vec<f64>,
    /// Velocities, rad/s.
    pub velocity: Vec<f64>,
    /// Efforts, N·m.
    pub effort: Vec<f64>,
}

impl RosMessage for JointState {
    const PACKAGE: &'static str = "sensor_msgs";
    const NAME: &'static str = "JointState";
}

/// `trajectory_msgs/JointTrajectoryPoint`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct JointTrajectoryPoint {
    /// Positions, rad, one per joint.
    pub positions: Vec<f64>,
    /// Velocities, rad/s: empty or one per joint.
    pub velocities: Vec<f64>,
    /// Accelerations, rad/s²: empty or one per joint.
    pub accelerations: Vec<f64>,
    /// Efforts, N·m: empty or one per joint.
    pub effort: Vec<f64>,
    /// When the point is to be reached, from the trajectory's start.
    pub time_from_start: Duration,
}

/// `trajectory_msgs/JointTrajectory`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct JointTrajectory {
    /// `stamp` is the start time; zero means "now".
    pub header: Header,
    /// The joints the points' arrays refer to, in order.
    pub joint_names: Vec<String>,
    /// The points, in increasing `time_from_start`.
    pub points: Vec<JointTrajectoryPoint>,
}

impl RosMessage for JointTrajectory {
    const PACKAGE: &'static str = "trajectory_msgs";
    const NAME: &'static str = "JointTrajectory";
}

/// `std_msgs/Bool`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Bool {
    /// The value.
    pub data: bool,
}

impl RosMessage for Bool {
    const PACKAGE: &'static str = "std_msgs";
    const NAME: &'static str = "Bool";
}

/// `diagnostic_msgs/KeyValue`.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct KeyValue {
    /// What is measured.
    pub key: String,
    /// Its value, as text.
    pub value: String,
}

/// The levels of `diagnostic_msgs/DiagnosticStatus` (a `byte` on the wire).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Level {
    /// `OK`.
    Ok = 0,
    /// `WARN`.
    Warn = 1,
    /// `ERROR`.
    Error = 2,
    /// `STALE`.
    Stale = 3,
}

/// `diagnostic_msgs/DiagnosticStatus`.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct DiagnosticStatus {
    /// A [`Level`] as its byte.
    pub level: u8,
    /// What the status is about, e.g. `rmd_rt: loop`.
    pub name: String,
    /// A one-line summary.
    pub message: String,
    /// The hardware it describes (e.g. a motor's CAN id).
    pub hardware_id: String,
    /// The measured values.
    pub values: Vec<KeyValue>,
}

/// `diagnostic_msgs/DiagnosticArray`.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct DiagnosticArray {
    /// When the statuses were collected.
    pub header: Header,
    /// One status per subsystem.
    pub status: Vec<DiagnosticStatus>,
}

impl RosMessage for DiagnosticArray {
    const PACKAGE: &'static str = "diagnostic_msgs";
    const NAME: &'static str = "DiagnosticArray";
}

impl Time {
    /// The ROS time of a [`std::time::SystemTime`] (times before 1970 or after 2038 saturate).
    pub fn from_system_time(t: std::time::SystemTime) -> Self {
        let since = t
            .duration_since(std::time::UNIX_EPOCH)
            .unwrap_or(std::time::Duration::ZERO);
        let sec = i32::try_from(since.as_secs()).unwrap_or(i32::MAX);
        Time {
            sec,
            nanosec: since.subsec_nanos(),
        }
    }

    /// The [`std::time::SystemTime`] of this stamp, or `None` for the zero stamp ("unset"), a
    /// negative one, or one whose nanoseconds are out of range.
    pub fn to_system_time(self) -> Option<std::time::SystemTime> {
        if (self.sec == 0 && self.nanosec == 0) || self.sec < 0 || self.nanosec >= 1_000_000_000 {
            return None;
        }
        let since = std::time::Duration::new(u64::from(self.sec.unsigned_abs()), self.nanosec);
        std::time::UNIX_EPOCH.checked_add(since)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dds_type_names_are_the_ones_rmw_registers() {
        assert_eq!(
            JointState::dds_type_name(),
            "sensor_msgs::msg::dds_::JointState_"
        );
        assert_eq!(
            JointTrajectory::dds_type_name(),
            "trajectory_msgs::msg::dds_::JointTrajectory_"
        );
        assert_eq!(
            DiagnosticArray::dds_type_name(),
            "diagnostic_msgs::msg::dds_::DiagnosticArray_"
        );
        assert_eq!(Bool::dds_type_name(), "std_msgs::msg::dds_::Bool_");
    }

    #[test]
    fn time_round_trips_and_zero_means_unset() {
        let t = std::time::UNIX_EPOCH + std::time::Duration::new(1_700_000_000, 123_456_789);
        let ros = Time::from_system_time(t);
        assert_eq!(
            ros,
            Time {
                sec: 1_700_000_000,
                nanosec: 123_456_789
            }
        );
        assert_eq!(ros.to_system_time(), Some(t));
        assert_eq!(Time::default().to_system_time(), None);
        assert_eq!(
            Time {
                sec: 1,
                nanosec: 1_000_000_000
            }
            .to_system_time(),
            None
        );
    }
}
