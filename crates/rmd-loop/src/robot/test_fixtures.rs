//! What the tests of the robot description share: a leg described in TOML, the check that a
//! description is refused naming a key, a bus of MyActuator V3 motors.

use super::{BusConfig, MotorConfig, Robot, RobotError};

/// A leg on one bus: a described hip and a second motor with every default.
pub(super) const LEG: &str = r#"
        [loop]
        rate_hz = 500.0
        cpu = 1
        spin_margin_us = 20
        overrun = { policy = "fault", after = 5 }

        [[bus]]
        interface = "can0"

        [[bus.motor]]
        id = 1
        name = "hip"
        gear_ratio = 6.0
        direction = "reversed"
        current_limit_amps = 8.0
        torque_constant_nm_per_amp = 0.52

        [[bus.motor]]
        id = 2
    "#;

/// `text` is refused, naming `key`.
pub(super) fn expect_invalid(text: &str, key: &str) {
    match Robot::from_toml(text) {
        Err(RobotError::Invalid {
            key: k, problem, ..
        }) => assert_eq!(k, key, "{problem}"),
        other => panic!("expected an error on {key}, got {other:?}"),
    }
}

/// A `myactuator-v3` bus of `motors` motors, ids 1..=`motors`.
pub(super) fn v3_bus(motors: u8) -> BusConfig {
    let mut bus = BusConfig::new("can0").protocol("myactuator-v3");
    for id in 1..=motors {
        bus = bus.with_motor(MotorConfig::new(id));
    }
    bus
}
