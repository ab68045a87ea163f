//! The robot descriptions the examples ship (examples/robots/*.toml): each parses into a valid
//! robot, names the joints its example's controller looks for, and centres every joint's
//! power-up window on the pose its example's robot is switched on in (the zero offsets are
//! computed numbers: this checks the computation).

use rmd_demos::leg::{JOINTS, LegJoints, LegModel};
use rmd_demos::quadruped::{self, CROUCH_HEIGHT_M, LEG_NAMES};
use rmd_demos::{leg4, pd_hold};
use rmd_rt::rig::{BusTarget, Placement, PlacementDefault, placement::Overrides};
use rmd_rt::rt::mapping::power_up_window;
use rmd_rt::rt::robot::{JointSpec, Mounting};
use rmd_rt::{JointId, Robot};

const PD_HOLD: &str = include_str!("../../examples/robots/pd_hold.toml");
const LEG4: &str = include_str!("../../examples/robots/leg4.toml");
const QUADRUPED: &str = include_str!("../../examples/robots/quadruped.toml");

/// The offsets are written with three decimals.
const ROUNDING_DEG: f64 = 0.001;

/// `joint`'s power-up window is centred on `pose_deg`, and 40 degrees wide (1:9 gearbox).
fn assert_centred(joint: &JointSpec, pose_deg: f64) {
    let (low, high) = power_up_window(joint);
    let centre = (low + high) / 2.0;
    assert!(
        (centre - pose_deg).abs() <= ROUNDING_DEG,
        "{}: window {low}..{high} deg, power-up pose {pose_deg} deg",
        joint.name
    );
    assert!((high - low - 40.0).abs() < 1e-9, "{}", joint.name);
}

/// Every bus is on the interface the description names, and the examples simulate them all
/// unless told otherwise.
fn assert_on(robot: &Robot, interfaces: &[&str]) {
    let described =
        Placement::resolve(robot, &Overrides::default(), PlacementDefault::Described).unwrap();
    let expected: Vec<_> = interfaces
        .iter()
        .map(|i| BusTarget::SocketCan(i.to_string()))
        .collect();
    assert_eq!(described.buses(), expected);
    let example =
        Placement::resolve(robot, &Overrides::default(), PlacementDefault::Simulated).unwrap();
    assert!(example.all_simulated());
}

#[test]
fn every_shipped_description_is_a_valid_robot() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/robots");
    let mut names = Vec::new();
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "toml") {
            let robot =
                Robot::from_file(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            assert!(robot.joint_count() > 0);
            // Every shipped joint carries limits (docs/safety.md, "Joint limits").
            for joint in robot.joints() {
                assert!(
                    joint
                        .limits
                        .position()
                        .is_some_and(|(lo, hi)| lo.is_finite() && hi.is_finite())
                        && joint.limits.velocity().is_some(),
                    "{}: {} has no limits",
                    path.display(),
                    joint.name
                );
            }
            names.push(path.file_name().unwrap().to_string_lossy().into_owned());
        }
    }
    names.sort();
    assert_eq!(
        names,
        [
            "arm.toml",
            "leg4-v3.toml",
            "leg4.toml",
            "pd_hold.toml",
            "quadruped.toml"
        ]
    );
}

#[test]
fn pd_hold_toml_is_the_arm_of_the_example() {
    let robot = Robot::from_toml(PD_HOLD).unwrap();
    assert_on(&robot, &["can0"]);
    let arm = robot.spec(robot.joint("arm").unwrap());
    assert_eq!((arm.motor.get(), arm.gear_ratio), (1, 9.0));
    assert_eq!(arm.current_limit.amps(), 3.0);
    assert_eq!(arm.torque_constant_nm_per_amp, Some(2.09));
    assert_centred(arm, pd_hold::POWER_UP_DEG);
    assert!(arm.limits.allows_position(pd_hold::POWER_UP_DEG));
}

/// The description's position limits of `joint` are the model's (`limit`).
fn assert_limits(joint: &JointSpec, limit: rmd_demos::leg::JointLimit) {
    assert_eq!(
        joint.limits.position(),
        Some((limit.min_deg, limit.max_deg)),
        "{}",
        joint.name
    );
}

#[test]
fn leg4_toml_is_the_leg_of_the_example() {
    let robot = Robot::from_toml(LEG4).unwrap();
    assert_on(&robot, &["can0"]);
    assert_eq!(robot.settings().period.hz(), 1000.0);
    let leg = LegJoints::find(&robot, "").unwrap();
    for (i, id) in leg.ids().into_iter().enumerate() {
        let joint = robot.spec(id);
        // Motor ids 1..=4 from the body out, every joint 1:9 and direction normal (the model's
        // joint angles are the motors' ways round).
        assert_eq!(joint.motor.get() as usize, i + 1);
        assert_eq!((joint.gear_ratio, joint.direction), (9.0, Mounting::Normal));
        assert_centred(joint, leg4::POWER_UP_DEG[i]);
        assert_limits(joint, LegModel::new().limits[i]);
    }
    // The power-up pose is inside the model's joint limits (the controller starts from it).
    let model = LegModel::new();
    assert_eq!(
        model.limit_violation(&rmd_demos::leg::rad(leg4::POWER_UP_DEG)),
        None
    );
    // The current limits: 6, 8, 8, 4 A.
    let limits: Vec<f64> = robot
        .joints()
        .iter()
        .map(|j| j.current_limit.amps())
        .collect();
    assert_eq!(limits, [6.0, 8.0, 8.0, 4.0]);
}

#[test]
fn quadruped_toml_is_the_robot_of_the_example() {
    let robot = Robot::from_toml(QUADRUPED).unwrap();
    assert_on(&robot, &["can0", "can1", "can2", "can3"]);
    let bus_names: Vec<&str> = robot.buses().iter().map(|b| b.name.as_str()).collect();
    assert_eq!(bus_names, LEG_NAMES);
    let legs = quadruped::legs(&robot).unwrap();
    for ((model, leg), bus) in quadruped::leg_models().iter().zip(legs).zip(robot.buses()) {
        let crouch = quadruped::pose_deg(model, CROUCH_HEIGHT_M).unwrap();
        let on_bus: Vec<JointId> = bus.joints().collect();
        assert_eq!(on_bus, leg.ids(), "{}", bus.name);
        for (i, id) in leg.ids().into_iter().enumerate() {
            let joint = robot.spec(id);
            assert_eq!(joint.motor.get() as usize, i + 1);
            assert_eq!((joint.gear_ratio, joint.direction), (9.0, Mounting::Normal));
            assert_centred(joint, crouch[i]);
            assert_limits(joint, model.limits[i]);
        }
        assert_eq!(model.limit_violation(&rmd_demos::leg::rad(crouch)), None);
    }
    assert_eq!(robot.joint_count(), 4 * JOINTS);
}
