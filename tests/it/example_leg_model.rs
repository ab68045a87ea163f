//! The examples' leg model: kinematics, Jacobian, inverse kinematics, gravity, and the simulated
//! leg's loads, checked against independent computations (finite differences, potential energy).

use nalgebra::Vector4;
use rmd_demos::leg::{self, JOINTS, LegModel};
use rmd_rt::sim::STANDARD_GRAVITY;

/// Poses across the leg's range (degrees).
const POSES: [[f64; JOINTS]; 5] = [
    [0.0, -30.0, 60.0, -30.0],
    [10.0, -55.0, 110.0, -55.0],
    [-15.0, -10.0, 25.0, 20.0],
    [20.0, -80.0, 150.0, -90.0],
    [-5.0, 30.0, 10.0, -40.0],
];

fn models() -> [LegModel; 2] {
    let left = LegModel::new();
    let right = left.mirrored();
    [left, right]
}

#[test]
fn the_jacobian_is_the_derivative_of_the_foot_coordinates() {
    let h = 1e-6;
    for model in models() {
        for pose in POSES {
            let q = leg::rad(pose);
            let (_, j) = model.foot_and_jacobian(&q);
            for i in 0..JOINTS {
                let mut dq = Vector4::zeros();
                dq[i] = h;
                let numeric = (model.foot(&(q + dq)) - model.foot(&(q - dq))) / (2.0 * h);
                let analytic = j.column(i);
                assert!(
                    (numeric - analytic).norm() < 1e-6,
                    "pose {pose:?}, joint {i}: {numeric} vs {analytic}"
                );
            }
        }
    }
}

#[test]
fn inverse_kinematics_inverts_forward_kinematics() {
    for model in models() {
        for pose in POSES {
            let q = leg::rad(pose);
            let foot = model.foot(&q);
            let back = model.inverse(&foot).expect("a reachable foot");
            // The knee-forward solution with the smallest abduction is unique: the same pose.
            assert!(
                (back - q).norm() < 1e-9,
                "pose {pose:?}: got {:?}",
                leg::deg(&back)
            );
            assert!((model.foot(&back) - foot).norm() < 1e-12);
        }
        // Beyond the leg's length: no solution.
        assert!(model.inverse(&Vector4::new(0.0, 0.08, -0.5, 0.0)).is_none());
    }
}

#[test]
fn gravity_torques_are_the_slope_of_the_potential_energy() {
    // tau_i = -dV/dq_i with V = sum m_k g z_k.
    let h = 1e-6;
    for model in models() {
        let energy = |q: &Vector4<f64>| {
            let f = model.frames(q);
            (0..JOINTS)
                .map(|k| model.mass_kg[k] * STANDARD_GRAVITY * f.coms[k].z)
                .sum::<f64>()
        };
        for pose in POSES {
            let q = leg::rad(pose);
            let tau = model.gravity_torques(&q);
            for i in 0..JOINTS {
                let mut dq = Vector4::zeros();
                dq[i] = h;
                let slope = (energy(&(q + dq)) - energy(&(q - dq))) / (2.0 * h);
                assert!((tau[i] + slope).abs() < 1e-6, "pose {pose:?}, joint {i}");
            }
        }
    }
    // Hanging straight down, only the hip link's side offset loads the abduction joint.
    let model = LegModel::new();
    let tau = model.gravity_torques(&Vector4::zeros());
    let expected = -model.total_mass_kg() * STANDARD_GRAVITY * model.hip_offset_m;
    assert!((tau[0] - expected).abs() < 1e-9, "{tau}");
    assert!(tau.fixed_rows::<3>(1).norm() < 1e-12);
}

#[test]
fn the_simulated_loads_match_the_model_around_their_fitting_pose() {
    // Each simulated joint carries one gravity link: exact when only that joint moves away from
    // the fitting pose (the simulator does not couple joints).
    let model = LegModel::new();
    let pose = leg::rad([0.0, -51.3, 102.6, -51.3]);
    let loads = model.sim_loads(&pose);
    for (i, (link, extra_inertia)) in loads.iter().enumerate() {
        assert!(*extra_inertia >= 0.0);
        assert!((link.mass_kg - model.mass_kg[i..].iter().sum::<f64>()).abs() < 1e-12);
        for offset_deg in [-40.0, -10.0, 0.0, 15.0, 60.0] {
            let mut q = pose;
            q[i] += f64::to_radians(offset_deg);
            let expected = model.gravity_torques(&q)[i];
            let simulated = link.torque_nm(q[i]);
            assert!(
                (expected - simulated).abs() < 1e-9,
                "joint {i} at {offset_deg:+} deg: model {expected}, simulated {simulated}"
            );
        }
    }
}

#[test]
fn joint_limits_are_checked() {
    let model = LegModel::new();
    assert_eq!(
        model.limit_violation(&leg::rad([0.0, -30.0, 60.0, -30.0])),
        None
    );
    assert_eq!(
        model.limit_violation(&leg::rad([0.0, -30.0, 170.0, -30.0])),
        Some(2)
    );
    assert_eq!(
        model.limit_violation(&leg::rad([30.0, -30.0, 60.0, -30.0])),
        Some(0)
    );
    // A right leg's abduction range is the mirror image of a left leg's.
    let right = model.mirrored();
    assert_eq!(right.limits[0].min_deg, -model.limits[0].max_deg);
}

#[test]
fn the_simulated_leg_matches_the_description_either_way_round() {
    // One leg whose knee and ankle turn against their motors: the simulated loads, seen from
    // the joints (through the description's direction), are still the model's gravity.
    let mut text = String::from("[[bus]]\ninterface = \"can0\"\n");
    for (id, name, direction) in [
        (1, "hip_aa", "normal"),
        (2, "hip_fe", "normal"),
        (3, "knee", "reversed"),
        (4, "ankle", "reversed"),
    ] {
        text += &format!(
            "[[bus.motor]]\nid = {id}\nname = \"{name}\"\ndirection = \"{direction}\"\n\
             gear_ratio = 9.0\ntorque_constant_nm_per_amp = 2.09\n"
        );
    }
    let robot = rmd_rt::Robot::from_toml(&text).unwrap();
    let joints = leg::LegJoints::find(&robot, "").unwrap();
    let model = LegModel::new();
    let pose = [0.0, -45.0, 90.0, -45.0];
    let mut sims = rmd_rt::rig::sim::sim_configs(&robot, 1);
    leg::simulate_leg(&model, &robot, &joints, &mut sims, pose, pose);
    for (i, id) in joints.ids().into_iter().enumerate() {
        let sign = robot.spec(id).direction.sign();
        let motor = &sims[0].motors[i];
        assert_eq!(motor.initial_output_angle_deg, sign * pose[i]);
        let link = motor.load.gravity.clone().unwrap();
        for offset_deg in [-30.0, 0.0, 20.0] {
            let mut q = leg::rad(pose);
            q[i] += f64::to_radians(offset_deg);
            // The joint's torque is `sign` times the output's, at output angle `sign * q`.
            let simulated = sign * link.torque_nm(sign * q[i]);
            let expected = model.gravity_torques(&q)[i];
            assert!(
                (simulated - expected).abs() < 1e-9,
                "joint {i} at {offset_deg:+}: simulated {simulated}, model {expected}"
            );
        }
    }
}
