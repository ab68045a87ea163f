//! A second `ros2-client` participant on loopback, for the tests that drive the node over DDS
//! in this process.
#![allow(dead_code, unreachable_pub)]

use std::net::{IpAddr, Ipv4Addr};
use std::time::{Duration, Instant};

use rmd_ros2::msg::RosMessage;
use ros2_client::dds::rustdds::DomainParticipantBuilder;
use ros2_client::dds::{Context, Node, Publisher, Subscription};
use ros2_client::{MessageTypeName, Name, NodeName, NodeOptions, QosProfile};
use serde::Serialize;
use serde::de::DeserializeOwned;

/// DDS on loopback only.
pub const LOOPBACK: IpAddr = IpAddr::V4(Ipv4Addr::LOCALHOST);

/// A domain id of this test process's own (other DDS users of the host stay apart).
pub fn private_domain(base: u16) -> u16 {
    base + (std::process::id() % 50) as u16
}

/// Waits until `f` holds (at most 30 s).
pub fn wait_for(what: &str, mut f: impl FnMut() -> bool) {
    let t0 = Instant::now();
    while !f() {
        assert!(
            t0.elapsed() < Duration::from_secs(30),
            "timed out waiting for {what}"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// A ROS 2 peer of the node.
pub struct Client {
    pub node: Node,
}

impl Client {
    pub fn new(domain: u16) -> Client {
        let dp = DomainParticipantBuilder::new(domain)
            .with_only_networks([LOOPBACK])
            .build()
            .unwrap();
        let ctx = Context::from_domain_participant(dp).unwrap();
        let node = ctx
            .new_node(
                NodeName::new("/", "test_client").unwrap(),
                NodeOptions::new()
                    .enable_rosout(false)
                    .start_parameter_services(false),
            )
            .unwrap();
        Client { node }
    }

    pub fn topic<M: RosMessage>(
        &mut self,
        name: &str,
        qos: &QosProfile,
    ) -> ros2_client::dds::rustdds::Topic {
        self.node
            .create_topic(
                &Name::parse(name).unwrap(),
                MessageTypeName::new(M::PACKAGE, M::NAME),
                qos,
            )
            .unwrap()
    }

    pub fn publisher<M: RosMessage + Serialize>(&mut self, name: &str) -> Publisher<M> {
        let qos = QosProfile::publisher_default();
        let t = self.topic::<M>(name, &qos);
        self.node.create_publisher(&t, Some(qos)).unwrap()
    }

    pub fn subscription<M: RosMessage + DeserializeOwned + 'static>(
        &mut self,
        name: &str,
        qos: QosProfile,
    ) -> Subscription<M> {
        let t = self.topic::<M>(name, &qos);
        self.node.create_subscription(&t, Some(qos)).unwrap()
    }
}

/// Takes everything waiting; the newest sample and how many there were.
pub fn drain<M: 'static + DeserializeOwned>(s: &Subscription<M>) -> (Option<M>, usize) {
    let mut last = None;
    let mut n = 0;
    while let Ok(Some((m, _))) = s.take() {
        last = Some(m);
        n += 1;
    }
    (last, n)
}
