//! Simulated motors that match a robot description.
//!
//! [`sim_motor`] builds a simulated motor with the joint's gear ratio, torque constant and
//! encoder width, and mounts its encoder so that the loop's joint angle is the simulated joint's
//! true angle. That holds, as on a real geared motor, only when the joint powers up inside its
//! [`power_up_window`](rmd_loop::mapping::power_up_window): the loop sees one motor turn of the
//! single-turn encoder at start-up, which is `360 / gear_ratio` degrees of joint (40 degrees
//! with a 1:9 gearbox), starting at `-zero_offset_deg`. A robot description sets each
//! `zero_offset_deg` so that the joint's power-up pose lies in that window (see
//! docs/getting-started.md, "Homing a geared joint").

use rmd_loop::robot::Robot;
use rmd_loop::robot::{BusSpec, JointSpec};
use rmd_sim::{SimConfig, WireTiming};

/// Simulated buses matching every bus of `robot` ([`sim_config`]), seeded `seed`, `seed + 1`, ...
pub fn sim_configs(robot: &Robot, seed: u64) -> Vec<SimConfig> {
    robot
        .buses()
        .iter()
        .zip(seed..)
        .map(|(bus, seed)| sim_config(robot, bus, seed))
        .collect()
}

/// A simulated bus matching `bus` of `robot`: its bit rate, and a [`sim_motor`] for each of its
/// joints, with no load (add the robot's loads and power-up pose to the returned motors).
pub fn sim_config(robot: &Robot, bus: &BusSpec, seed: u64) -> SimConfig {
    let mut config = SimConfig::with_motors(0).seed(seed);
    config.bus.timing = WireTiming::Bitrate(bus.bitrate);
    config.motors = bus.joints().map(|j| sim_motor(robot.spec(j))).collect();
    config
}

/// A simulated motor matching `joint` (RMD-X8-class defaults for everything the description
/// does not say): same id, firmware family (the joint's dialect), gear ratio, encoder width,
/// MyActuator V3 brake and watchdog and, when given, output torque constant;
/// its encoder mounted so that the loop reads the joint's true angle whenever the joint powers
/// up inside its power-up window. The simulated output angle is `direction * joint angle` (see
/// [`sim_output_angle_deg`]).
///
/// ```
/// use rmd_loop::robot::Robot;
/// let robot = Robot::from_toml(r#"
///     [[bus]]
///     interface = "sim"
///     [[bus.motor]]
///     id = 3
///     name = "knee"
///     gear_ratio = 9.0
///     torque_constant_nm_per_amp = 2.09
///     zero_offset_deg = 110.0
/// "#)?;
/// let sim = rmd_rig::sim::sim_motor(robot.spec(robot.joint("knee")?));
/// assert_eq!(sim.id.get(), 3);
/// assert_eq!(sim.motor.gear_ratio, 9.0);
/// assert!((sim.motor.torque_constant_nm_per_a * 9.0 - 2.09).abs() < 1e-12);
/// # Ok::<(), rmd_loop::robot::RobotError>(())
/// ```
pub fn sim_motor(joint: &JointSpec) -> rmd_sim::SimMotorConfig {
    let mut sim = rmd_sim::SimMotorConfig::new(joint.motor);
    sim.firmware.speak(joint.dialect);
    sim.motor.gear_ratio = joint.gear_ratio;
    if let Some(kt) = joint.torque_constant_nm_per_amp {
        sim.motor.torque_constant_nm_per_a = kt / joint.gear_ratio;
    }
    sim.firmware.encoder_width = joint.encoder;
    // A V3 motor as described: its brake fitted, its watchdog in ROM (as `rmd watchdog --robot`
    // writes it).
    sim.firmware.v3.has_brake = joint.brake;
    sim.firmware.v3.watchdog = joint.watchdog.unwrap_or(rmd_protocol::WatchdogTimeout::OFF);
    // The loop reads joint = s * m / G - z from the first reading m in [0, 360) degrees of
    // motor; the simulated encoder reads (G * output + 360 * offset) mod 360. With
    // offset = s * z * G / 360 the two agree (joint = s * output) as long as the first reading
    // did not wrap, i.e. inside the power-up window.
    let turns = joint.direction.sign() * joint.zero_offset_deg * joint.gear_ratio / 360.0;
    sim.motor.encoder_mount_offset_turns = turns.rem_euclid(1.0);
    sim
}

/// The simulated output angle (degrees) at which a [`sim_motor`] of `joint` shows `joint_deg`
/// to the loop: `direction * joint_deg` (for a simulated motor's `initial_output_angle_deg`,
/// and for its gravity link's angle).
pub fn sim_output_angle_deg(joint: &JointSpec, joint_deg: f64) -> f64 {
    joint.direction.sign() * joint_deg
}

/// Powers every simulated joint of `sims` (built by [`sim_configs`] for `robot`) up in the
/// middle of its [`power_up_window`](rmd_loop::mapping::power_up_window), where the loop reads
/// its true angle: for programs with no pose of their own to give the motors (`rmd status
/// --robot FILE --sim`). A joint whose window is centred on 0 stays at 0.
///
/// ```
/// use rmd_loop::robot::Robot;
/// let robot = Robot::from_toml(r#"
///     [[bus]]
///     interface = "sim"
///     [[bus.motor]]
///     id = 1
///     gear_ratio = 9.0
///     zero_offset_deg = -50.0
/// "#)?;
/// let mut sims = rmd_rig::sim::sim_configs(&robot, 1);
/// rmd_rig::sim::power_up_centred(&robot, &mut sims);
/// // Window 50..90 degrees of joint: powered up at 70.
/// assert_eq!(sims[0].motors[0].initial_output_angle_deg, 70.0);
/// # Ok::<(), rmd_loop::robot::RobotError>(())
/// ```
pub fn power_up_centred(robot: &Robot, sims: &mut [SimConfig]) {
    for (bus, sim) in robot.buses().iter().zip(sims) {
        for (joint, motor) in bus.joints().zip(&mut sim.motors) {
            let spec = robot.spec(joint);
            let (low, high) = rmd_loop::mapping::power_up_window(spec);
            motor.initial_output_angle_deg = sim_output_angle_deg(spec, (low + high) / 2.0);
        }
    }
}

#[cfg(test)]
mod tests {
    use rmd_loop::robot::Robot;
    use rmd_protocol::WatchdogTimeout;

    #[test]
    fn a_simulated_v3_motor_has_the_described_brake_and_watchdog() {
        let robot = Robot::from_toml(
            r#"
            [[bus]]
            interface = "sim"
            protocol = "myactuator-v3"
            [[bus.motor]]
            id = 1
            brake = true
            watchdog_ms = 50
            [[bus.motor]]
            id = 2
            "#,
        )
        .unwrap();
        let described = super::sim_motor(&robot.joints()[0]);
        assert!(described.firmware.v3.has_brake);
        assert_eq!(
            described.firmware.v3.watchdog,
            WatchdogTimeout::from_millis(50)
        );
        let plain = super::sim_motor(&robot.joints()[1]);
        assert!(!plain.firmware.v3.has_brake);
        assert!(plain.firmware.v3.watchdog.is_off());
    }
}
