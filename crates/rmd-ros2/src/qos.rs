//! The QoS of each topic, chosen to match what stock ROS 2 peers offer and request.
//!
//! DDS matches a reader to a writer only when the writer offers at least what the reader
//! requests (reliable ≥ best effort, transient local ≥ volatile). So the node's writers offer
//! what their ROS 2 readers ask for, and its readers ask for no more than ROS 2 tools and
//! `ros2_control`'s topic bridges offer.

use ros2_client::QosProfile;
use ros2_client::qos::{Durability, History, Reliability, WhenFull};

/// `joint_states`: ROS 2's sensor-data profile (`rclcpp::SensorDataQoS`): best effort,
/// volatile, keep last 5. A lost sample is replaced by the next one a period later. A
/// best-effort writer matches only best-effort readers: `topic_based_ros2_control`,
/// `robot_state_publisher` and `ros2 topic echo` (which adapts to the writer) are; a reader
/// that insists on reliable delivery does not match (see `docs/ros2.md`).
pub fn joint_states() -> QosProfile {
    QosProfile::subscription_default()
        .reliability(Reliability::BestEffort)
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 5 })
}

/// `diagnostics`: reliable, volatile, keep last 10 (ROS 2's default profile), so that the
/// reliable readers of `diagnostic_aggregator` and `ros2 topic echo` match. A full send window
/// fails the publish at once (counted) instead of stalling the node's thread.
pub fn diagnostics() -> QosProfile {
    QosProfile::publisher_default()
        .reliability(Reliability::Reliable {
            when_full: WhenFull::Fail,
        })
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 10 })
}

/// `joint_commands`, `joint_trajectory` and the enable topic: reliable, volatile, keep last 10.
/// Reliable because a lost command is not repeated by `topic_based_ros2_control` (it publishes
/// only when the command changes) and a lost estop must not be lost; volatile so that both
/// volatile and transient-local writers match and no stale command is replayed on startup.
/// Writers must be reliable (ROS 2's default; `rclcpp::QoS(1)` as the bridges use).
pub fn commands() -> QosProfile {
    QosProfile::subscription_default()
        .reliability(Reliability::Reliable {
            when_full: WhenFull::Fail,
        })
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 10 })
}

#[cfg(test)]
mod tests {
    use super::*;
    use ros2_client::ros2::QosPolicies;
    use ros2_client::ros2::policy;

    #[test]
    fn joint_states_is_sensor_data() {
        let q = joint_states();
        assert_eq!(q.reliability, Reliability::BestEffort);
        assert_eq!(q.durability, Durability::Volatile);
        assert_eq!(q.history, History::KeepLast { depth: 5 });
        // And so it reaches DDS.
        let dds: QosPolicies = q.into();
        assert_eq!(dds.reliability(), Some(policy::Reliability::BestEffort));
        assert_eq!(dds.history(), Some(policy::History::KeepLast { depth: 5 }));
        assert_eq!(dds.durability(), Some(policy::Durability::Volatile));
    }

    #[test]
    fn diagnostics_is_reliable_and_never_blocks() {
        let q = diagnostics();
        assert_eq!(
            q.reliability,
            Reliability::Reliable {
                when_full: WhenFull::Fail
            }
        );
        assert_eq!(q.durability, Durability::Volatile);
        assert_eq!(q.history, History::KeepLast { depth: 10 });
        let dds: QosPolicies = q.into();
        assert!(matches!(
            dds.reliability(),
            Some(policy::Reliability::Reliable { .. })
        ));
    }

    #[test]
    fn command_readers_are_reliable_and_volatile() {
        let q = commands();
        assert!(matches!(q.reliability, Reliability::Reliable { .. }));
        assert_eq!(q.durability, Durability::Volatile);
        assert_eq!(q.history, History::KeepLast { depth: 10 });
        let dds: QosPolicies = q.into();
        assert_eq!(dds.durability(), Some(policy::Durability::Volatile));
    }
}
