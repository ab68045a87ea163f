//! The node's configuration: names, domain, rates, the network, input limits, and how commands
//! are read.

use std::net::IpAddr;
use std::time::Duration;

use crate::validate::CommandMode;

/// The topics of the node. A name without a leading `/` is relative to the node's namespace
/// (ROS 2 name resolution); one with a leading `/` is absolute.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TopicNames {
    /// Published `sensor_msgs/JointState` samples (default `joint_states`).
    pub joint_states: String,
    /// Published `diagnostic_msgs/DiagnosticArray` (default `/diagnostics`, where ROS 2's
    /// `diagnostic_aggregator` and `rqt_robot_monitor` look).
    pub diagnostics: String,
    /// Subscribed `sensor_msgs/JointState` commands (default `joint_commands`).
    pub joint_commands: String,
    /// Subscribed `trajectory_msgs/JointTrajectory` (default `joint_trajectory`).
    pub joint_trajectory: String,
    /// Subscribed `std_msgs/Bool`: `true` enables, `false` is an emergency stop (default
    /// `enable`).
    pub enable: String,
}

impl Default for TopicNames {
    fn default() -> Self {
        TopicNames {
            joint_states: "joint_states".into(),
            diagnostics: "/diagnostics".into(),
            joint_commands: "joint_commands".into(),
            joint_trajectory: "joint_trajectory".into(),
            enable: "enable".into(),
        }
    }
}

/// Bounds on what one inbound message may carry. Each string and array is measured while the
/// message is decoded, before anything of it is copied; a message over a limit is rejected
/// whole (`oversized`) with a short excerpt. The DDS layer does not reassemble a sample larger
/// than `max_sample_bytes` at all (it is acknowledged, dropped and counted as `oversized`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct InputLimits {
    /// The longest string (joint name, frame id), in bytes (default 256).
    pub max_string_bytes: usize,
    /// The most names or values in one array (default 1024).
    pub max_array_len: usize,
    /// The most points in one trajectory (default 10 000).
    pub max_points: usize,
    /// The largest sample, in bytes (default 4 MiB: 10 000 points of 16 joints with
    /// positions, velocities and accelerations fit).
    pub max_sample_bytes: usize,
}

impl Default for InputLimits {
    fn default() -> Self {
        InputLimits {
            max_string_bytes: 256,
            max_array_len: 1024,
            max_points: 10_000,
            max_sample_bytes: 4 << 20,
        }
    }
}

/// Everything the node can be told.
///
/// ```
/// use rmd_ros2::NodeConfig;
/// let config = NodeConfig {
///     namespace: "/leg".into(),
///     domain_id: 7,
///     joint_state_rate_hz: 250.0,
///     ..NodeConfig::default()
/// };
/// assert_eq!(config.joint_state_period().unwrap().as_micros(), 4000);
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct NodeConfig {
    /// The ROS 2 node name (default `rmd_rt`).
    pub node_name: String,
    /// The node's namespace: `/` (the default) or `/a/b`.
    pub namespace: String,
    /// The DDS domain (`ROS_DOMAIN_ID`), 0..=232 (default 0).
    pub domain_id: u16,
    /// How often `joint_states` is published, Hz (default 500).
    pub joint_state_rate_hz: f64,
    /// How often `diagnostics` is published (default 1 s).
    pub diagnostics_period: Duration,
    /// How `joint_commands` messages become setpoints.
    pub command_mode: CommandMode,
    /// Topic names.
    pub topics: TopicNames,
    /// DDS only on the interface with this IPv4 address (default: every interface), e.g.
    /// `127.0.0.1` for this host only: every socket of the node is bound to it (multicast
    /// listeners to their group, joined on that interface only), so datagrams that reach the
    /// host by another interface reach none of them. It must be an address of one of the
    /// host's interfaces.
    pub network: Option<IpAddr>,
    /// How soon the node acknowledges a reliable writer's samples by itself (default 100 ms):
    /// at once when it has not acknowledged that writer within this period, else at the end
    /// of the period, so at most one ACKNACK per writer per period whatever the rate. Without
    /// it a writer that attaches no HEARTBEAT to its data (eProsima Fast DDS with a history
    /// not full) hears of its samples' delivery only at its next periodic HEARTBEAT (3 s).
    pub acknowledge_within: Duration,
    /// Bounds on inbound messages.
    pub input_limits: InputLimits,
}

impl Default for NodeConfig {
    fn default() -> Self {
        NodeConfig {
            node_name: "rmd_rt".into(),
            namespace: "/".into(),
            domain_id: 0,
            joint_state_rate_hz: 500.0,
            diagnostics_period: Duration::from_secs(1),
            command_mode: CommandMode::Auto,
            topics: TopicNames::default(),
            network: None,
            acknowledge_within: Duration::from_millis(100),
            input_limits: InputLimits::default(),
        }
    }
}

/// A [`NodeConfig`] the node cannot run with.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum NodeConfigError {
    /// Not a valid ROS 2 namespace.
    #[error("namespace {0:?} is not a ROS 2 namespace: use \"/\" or \"/a/b\" (letters, digits, _)")]
    BadNamespace(String),
    /// Not a valid ROS 2 node name.
    #[error("node name {0:?} is not a ROS 2 node name: use letters, digits and _")]
    BadNodeName(String),
    /// Not a valid ROS 2 topic name.
    #[error("topic name {0:?} is not a ROS 2 topic name: use \"name\", \"a/name\" or \"/a/name\"")]
    BadTopic(String),
    /// A domain id DDS cannot map to ports.
    #[error("domain id {0} is out of range: use 0..=232")]
    BadDomain(u16),
    /// A rate that is not a positive number up to 10 kHz.
    #[error("joint_states rate {0} Hz is invalid: use a rate in (0, 10000] Hz")]
    BadRate(f64),
    /// A zero diagnostics period.
    #[error("the diagnostics period must be positive")]
    BadDiagnosticsPeriod,
    /// An input limit of zero.
    #[error("input limit {0} must be positive")]
    ZeroInputLimit(&'static str),
    /// An IPv6 network address (the DDS layer binds IPv4 sockets only).
    #[error(
        "network address {0} is IPv6: DDS here runs over IPv4 only; give an IPv4 address (127.0.0.1 for this host only)"
    )]
    Ipv6Network(IpAddr),
    /// A network address on none of the host's interfaces.
    #[error(
        "network address {address} is not an address of this host ({reason}): give one that `ip -4 addr` lists (127.0.0.1 for this host only)"
    )]
    NotLocal {
        /// The address given.
        address: IpAddr,
        /// Why it cannot be bound.
        reason: String,
    },
    /// A zero acknowledgement period.
    #[error("the acknowledgement period must be positive")]
    BadAcknowledgePeriod,
}

impl NodeConfig {
    /// The `joint_states` period, or why the rate is invalid.
    pub fn joint_state_period(&self) -> Result<Duration, NodeConfigError> {
        let hz = self.joint_state_rate_hz;
        if hz.is_finite() && hz > 0.0 && hz <= 10_000.0 {
            Ok(Duration::from_secs_f64(1.0 / hz))
        } else {
            Err(NodeConfigError::BadRate(hz))
        }
    }

    /// Checks everything that can be checked without DDS.
    pub fn check(&self) -> Result<(), NodeConfigError> {
        self.joint_state_period()?;
        if self.domain_id > 232 {
            return Err(NodeConfigError::BadDomain(self.domain_id));
        }
        if self.diagnostics_period.is_zero() {
            return Err(NodeConfigError::BadDiagnosticsPeriod);
        }
        if self.acknowledge_within.is_zero() {
            return Err(NodeConfigError::BadAcknowledgePeriod);
        }
        let l = &self.input_limits;
        for (value, name) in [
            (l.max_string_bytes, "max_string_bytes"),
            (l.max_array_len, "max_array_len"),
            (l.max_points, "max_points"),
            (l.max_sample_bytes, "max_sample_bytes"),
        ] {
            if value == 0 {
                return Err(NodeConfigError::ZeroInputLimit(name));
            }
        }
        if let Some(address) = self.network {
            check_local(address)?;
        }
        self.node_name()?;
        let t = &self.topics;
        for topic in [
            &t.joint_states,
            &t.diagnostics,
            &t.joint_commands,
            &t.joint_trajectory,
            &t.enable,
        ] {
            self.resolve_topic(topic)?;
        }
        Ok(())
    }

    pub(crate) fn node_name(&self) -> Result<ros2_client::NodeName, NodeConfigError> {
        let ns_ok = self.namespace == "/"
            || (self.namespace.starts_with('/')
                && self.namespace[1..].split('/').all(is_name_token));
        if !ns_ok {
            return Err(NodeConfigError::BadNamespace(self.namespace.clone()));
        }
        if !is_name_token(&self.node_name) {
            return Err(NodeConfigError::BadNodeName(self.node_name.clone()));
        }
        ros2_client::NodeName::new(&self.namespace, &self.node_name)
            .map_err(|_| NodeConfigError::BadNodeName(self.node_name.clone()))
    }

    /// The absolute name of a topic (ROS 2 resolution against the namespace), e.g.
    /// `joint_states` in `/leg` is `/leg/joint_states`. The DDS topic is this with `rt`
    /// in front: `rt/leg/joint_states`.
    pub fn resolve_topic(&self, topic: &str) -> Result<String, NodeConfigError> {
        let absolute = if topic.starts_with('/') {
            topic.to_owned()
        } else if self.namespace == "/" {
            format!("/{topic}")
        } else {
            format!("{}/{topic}", self.namespace)
        };
        if absolute[1..].split('/').all(is_name_token) {
            Ok(absolute)
        } else {
            Err(NodeConfigError::BadTopic(topic.to_owned()))
        }
    }
}

/// The address is IPv4 and one of this host's: a UDP socket can be bound to it.
fn check_local(address: IpAddr) -> Result<(), NodeConfigError> {
    if address.is_ipv6() {
        return Err(NodeConfigError::Ipv6Network(address));
    }
    std::net::UdpSocket::bind((address, 0))
        .map(drop)
        .map_err(|e| NodeConfigError::NotLocal {
            address,
            reason: e.to_string(),
        })
}

/// One component of a ROS 2 name: a letter or `_` first, then letters, digits, single `_`s.
fn is_name_token(s: &str) -> bool {
    let mut chars = s.chars();
    matches!(chars.next(), Some(c) if c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
        && !s.contains("__")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn topics_resolve_against_the_namespace() {
        let root = NodeConfig::default();
        assert_eq!(root.resolve_topic("joint_states").unwrap(), "/joint_states");
        assert_eq!(root.resolve_topic("/diagnostics").unwrap(), "/diagnostics");
        let leg = NodeConfig {
            namespace: "/robot/leg".into(),
            ..NodeConfig::default()
        };
        assert_eq!(
            leg.resolve_topic("joint_states").unwrap(),
            "/robot/leg/joint_states"
        );
        assert_eq!(leg.resolve_topic("a/b").unwrap(), "/robot/leg/a/b");
        assert_eq!(
            leg.resolve_topic("/robot_joint_states").unwrap(),
            "/robot_joint_states"
        );
        for bad in ["", "/", "a//b", "1abc", "a b", "a__b", "x/"] {
            assert_eq!(
                leg.resolve_topic(bad),
                Err(NodeConfigError::BadTopic(bad.into())),
                "{bad:?}"
            );
        }
    }

    #[test]
    fn bad_configurations_are_refused_with_their_reason() {
        let ok = NodeConfig::default();
        assert_eq!(ok.check(), Ok(()));
        assert_eq!(ok.joint_state_period().unwrap(), Duration::from_millis(2));
        let with = |f: &dyn Fn(&mut NodeConfig)| {
            let mut c = NodeConfig::default();
            f(&mut c);
            c.check()
        };
        assert_eq!(
            with(&|c| c.namespace = "leg".into()),
            Err(NodeConfigError::BadNamespace("leg".into()))
        );
        assert_eq!(
            with(&|c| c.namespace = "/leg/".into()),
            Err(NodeConfigError::BadNamespace("/leg/".into()))
        );
        assert!(with(&|c| c.namespace = "/leg/front_1".into()).is_ok());
        assert_eq!(
            with(&|c| c.node_name = "my-node".into()),
            Err(NodeConfigError::BadNodeName("my-node".into()))
        );
        assert_eq!(
            with(&|c| c.domain_id = 233),
            Err(NodeConfigError::BadDomain(233))
        );
        assert_eq!(
            with(&|c| c.joint_state_rate_hz = 0.0),
            Err(NodeConfigError::BadRate(0.0))
        );
        assert!(with(&|c| c.joint_state_rate_hz = f64::NAN).is_err());
        assert_eq!(
            with(&|c| c.diagnostics_period = Duration::ZERO),
            Err(NodeConfigError::BadDiagnosticsPeriod)
        );
        assert_eq!(
            with(&|c| c.topics.enable = "e-stop".into()),
            Err(NodeConfigError::BadTopic("e-stop".into()))
        );
        assert_eq!(
            with(&|c| c.acknowledge_within = Duration::ZERO),
            Err(NodeConfigError::BadAcknowledgePeriod)
        );
    }

    #[test]
    fn the_network_must_be_an_ipv4_address_of_this_host() {
        let with = |a: &str| {
            NodeConfig {
                network: Some(a.parse().unwrap()),
                ..NodeConfig::default()
            }
            .check()
        };
        assert_eq!(with("127.0.0.1"), Ok(()));
        // TEST-NET-1 (RFC 5737): never an address of a host. Only bound to, never sent to.
        let err = with("192.0.2.1").unwrap_err();
        assert!(
            matches!(err, NodeConfigError::NotLocal { address, .. } if address.to_string() == "192.0.2.1"),
            "{err:?}"
        );
        assert!(
            err.to_string().contains("not an address of this host"),
            "{err}"
        );
        assert_eq!(
            with("::1"),
            Err(NodeConfigError::Ipv6Network("::1".parse().unwrap()))
        );
    }
}
