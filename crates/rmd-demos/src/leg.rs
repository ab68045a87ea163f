//! The 4-motor leg of the examples: geometry, masses and joint limits; forward kinematics,
//! Jacobian, inverse kinematics and gravity torques (nalgebra, fixed-size, no allocation); a
//! leg's joints found by name in a robot description; and the simulated leg.
//!
//! Frames: the hip frame has x forward, y to the left, z up. The joints, from the body out:
//!
//! 1. hip abduction/adduction (`hip_aa`): about x, at the hip origin;
//! 2. hip flexion/extension (`hip_fe`): about y, `hip_offset_m` to the side of the hip;
//! 3. `knee`: about y, `thigh_m` below the hip flexion axis (positive: knee bent forward);
//! 4. `ankle`: about y, `shank_m` below the knee; the foot link (`foot_m`) ends at the sole.
//!
//! All four at zero: the leg hangs straight down. The task coordinates of the foot are its sole
//! point (x, y, z) in the hip frame and its pitch `q2 + q3 + q4` (0: foot link vertical), so the
//! Jacobian is square (4 x 4).
//!
//! ```
//! use rmd_demos::leg::{self, LegModel};
//! let model = LegModel::new();
//! let q = leg::rad([0.0, -30.0, 60.0, -30.0]);
//! let foot = model.foot(&q);
//! // Folded: the sole 38.6 cm below the hip, under the hip flexion axis, foot vertical.
//! assert!((foot.z + 0.3864).abs() < 1e-3 && foot.x.abs() < 1e-12 && foot[3].abs() < 1e-12);
//! let back = model.inverse(&foot).unwrap();
//! assert!((back - q).norm() < 1e-9);
//! ```

use nalgebra::{Matrix4, Rotation3, Vector3, Vector4};
use rmd_loop::{JointId, robot::Robot};
use rmd_sim::{GravityLink, STANDARD_GRAVITY, SimConfig};

use crate::error::DemoError;

/// Number of joints (and motors) of a leg.
pub const JOINTS: usize = 4;

/// The leg's joint names, from the body out (a robot description names them with a prefix per
/// leg, e.g. `fl_knee`).
pub const JOINT_NAMES: [&str; JOINTS] = ["hip_aa", "hip_fe", "knee", "ankle"];

/// A joint's allowed range, degrees.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct JointLimit {
    /// Lowest angle.
    pub min_deg: f64,
    /// Highest angle.
    pub max_deg: f64,
}

impl JointLimit {
    /// Whether `deg` lies in the range.
    pub fn contains(&self, deg: f64) -> bool {
        (self.min_deg..=self.max_deg).contains(&deg)
    }
}

/// Geometry, masses and joint limits of one leg (its motors, gear ratios, torque constants and
/// current limits are in the robot description).
#[derive(Clone, Debug, PartialEq)]
pub struct LegModel {
    /// Side offset of the hip flexion axis from the hip abduction axis, m (+ left leg, - right).
    pub hip_offset_m: f64,
    /// Hip flexion axis to knee, m.
    pub thigh_m: f64,
    /// Knee to ankle, m.
    pub shank_m: f64,
    /// Ankle to sole, m.
    pub foot_m: f64,
    /// Masses of the hip link (hip flexion motor), thigh, shank and foot, kg.
    pub mass_kg: [f64; 4],
    /// Distance of each link's centre of mass from its proximal joint along the link, m (the
    /// hip link's is at the hip flexion axis).
    pub com_m: [f64; 4],
    /// Joint limits, degrees.
    pub limits: [JointLimit; JOINTS],
}

impl LegModel {
    /// The examples' leg (a left leg): 0.2 m thigh and shank, 2.4 kg in all.
    pub fn new() -> Self {
        Self {
            hip_offset_m: 0.08,
            thigh_m: 0.20,
            shank_m: 0.20,
            foot_m: 0.04,
            mass_kg: [0.9, 1.0, 0.45, 0.15],
            com_m: [0.0, 0.06, 0.08, 0.02],
            limits: [
                JointLimit {
                    min_deg: -25.0,
                    max_deg: 25.0,
                },
                JointLimit {
                    min_deg: -100.0,
                    max_deg: 40.0,
                },
                JointLimit {
                    min_deg: 5.0,
                    max_deg: 165.0,
                },
                JointLimit {
                    min_deg: -110.0,
                    max_deg: 30.0,
                },
            ],
        }
    }

    /// The mirror image of this leg (a right leg from a left one).
    pub fn mirrored(&self) -> Self {
        let mut m = self.clone();
        m.hip_offset_m = -self.hip_offset_m;
        let aa = self.limits[0];
        m.limits[0] = JointLimit {
            min_deg: -aa.max_deg,
            max_deg: -aa.min_deg,
        };
        m
    }

    /// Total mass, kg.
    pub fn total_mass_kg(&self) -> f64 {
        self.mass_kg.iter().sum()
    }

    /// Joint positions, axes, centres of mass and the sole, in the hip frame, at `q` (radians).
    pub fn frames(&self, q: &Vector4<f64>) -> Frames {
        let down = |l: f64| Vector3::new(0.0, 0.0, -l);
        let r1 = Rotation3::from_axis_angle(&Vector3::x_axis(), q[0]);
        let r2 = r1 * Rotation3::from_axis_angle(&Vector3::y_axis(), q[1]);
        let r3 = r2 * Rotation3::from_axis_angle(&Vector3::y_axis(), q[2]);
        let r4 = r3 * Rotation3::from_axis_angle(&Vector3::y_axis(), q[3]);
        let o1 = Vector3::zeros();
        let o2 = r1 * Vector3::new(0.0, self.hip_offset_m, 0.0);
        let o3 = o2 + r2 * down(self.thigh_m);
        let o4 = o3 + r3 * down(self.shank_m);
        let sole = o4 + r4 * down(self.foot_m);
        let y = Vector3::y();
        Frames {
            origins: [o1, o2, o3, o4],
            axes: [Vector3::x(), r1 * y, r2 * y, r3 * y],
            coms: [
                o2,
                o2 + r2 * down(self.com_m[1]),
                o3 + r3 * down(self.com_m[2]),
                o4 + r4 * down(self.com_m[3]),
            ],
            sole,
        }
    }

    /// The foot's task coordinates (x, y, z in m, pitch in rad) at `q` (rad).
    pub fn foot(&self, q: &Vector4<f64>) -> Vector4<f64> {
        let s = self.frames(q).sole;
        Vector4::new(s.x, s.y, s.z, q[1] + q[2] + q[3])
    }

    /// The foot's task coordinates and the Jacobian `d foot / d q` at `q` (rad).
    pub fn foot_and_jacobian(&self, q: &Vector4<f64>) -> (Vector4<f64>, Matrix4<f64>) {
        let f = self.frames(q);
        let mut j = Matrix4::zeros();
        for i in 0..JOINTS {
            let v = f.axes[i].cross(&(f.sole - f.origins[i]));
            j[(0, i)] = v.x;
            j[(1, i)] = v.y;
            j[(2, i)] = v.z;
            j[(3, i)] = if i == 0 { 0.0 } else { 1.0 };
        }
        let foot = Vector4::new(f.sole.x, f.sole.y, f.sole.z, q[1] + q[2] + q[3]);
        (foot, j)
    }

    /// The joint torques gravity exerts on the leg at `q` (rad), N*m. A controller adds their
    /// negative to hold the leg's weight.
    pub fn gravity_torques(&self, q: &Vector4<f64>) -> Vector4<f64> {
        let f = self.frames(q);
        let g = Vector3::new(0.0, 0.0, -STANDARD_GRAVITY);
        let mut tau = Vector4::zeros();
        for i in 0..JOINTS {
            // Link k (0 hip link, 1 thigh, 2 shank, 3 foot) moves with joint i if k >= i.
            for k in i..JOINTS {
                let r = f.coms[k] - f.origins[i];
                tau[i] += f.axes[i].cross(&r).dot(&(g * self.mass_kg[k]));
            }
        }
        tau
    }

    /// The joint angles (rad) that put the sole at `foot` (x, y, z in m, pitch in rad) with the
    /// knee bent forward (positive) and the hip abduction nearest zero, or `None` if out of reach.
    pub fn inverse(&self, foot: &Vector4<f64>) -> Option<Vector4<f64>> {
        let (px, py, pz, pitch) = (foot[0], foot[1], foot[2], foot[3]);
        // Hip abduction: in the frame turned by -q1 about x, the sole's y is the hip offset:
        // py cos q1 + pz sin q1 = d.
        let r = py.hypot(pz);
        if r < self.hip_offset_m.abs() || r == 0.0 {
            return None;
        }
        let alpha = pz.atan2(py);
        let beta = (self.hip_offset_m / r).acos();
        let q1 = [alpha + beta, alpha - beta]
            .into_iter()
            .map(wrap_pi)
            .min_by(|a, b| a.abs().total_cmp(&b.abs()))?;
        // The sole in the leg plane (x forward, z down the leg), relative to the hip flexion axis.
        let z_plane = -py * q1.sin() + pz * q1.cos();
        // Ankle = sole - foot link at the given pitch.
        let ax = px + self.foot_m * pitch.sin();
        let az = z_plane + self.foot_m * pitch.cos();
        let (l1, l2) = (self.thigh_m, self.shank_m);
        let d2 = ax * ax + az * az;
        let c3 = (d2 - l1 * l1 - l2 * l2) / (2.0 * l1 * l2);
        if !(-1.0..=1.0).contains(&c3) {
            return None;
        }
        let q3 = c3.acos();
        // Ankle = (-l1 sin q2 - l2 sin(q2 + q3), -l1 cos q2 - l2 cos(q2 + q3)).
        let q2 = (-ax).atan2(-az) - (l2 * q3.sin()).atan2(l1 + l2 * q3.cos());
        let q4 = pitch - q2 - q3;
        Some(Vector4::new(q1, wrap_pi(q2), q3, wrap_pi(q4)))
    }

    /// The first joint (index) outside its limits at `q` (rad), if any.
    pub fn limit_violation(&self, q: &Vector4<f64>) -> Option<usize> {
        (0..JOINTS).find(|&i| !self.limits[i].contains(q[i].to_degrees()))
    }

    /// The simulated loads of the four motors: for each joint, its distal links as one gravity
    /// link (exact when the other joints are at `pose`, rad) and their inertia about its axis.
    ///
    /// The simulator drives each motor's load on its own (no coupling between joints), so this
    /// is the best per-joint picture of the leg: a controller's multi-body gravity model
    /// ([`gravity_torques`](Self::gravity_torques)) matches it exactly at `pose` and
    /// approximately around it.
    pub fn sim_loads(&self, pose: &Vector4<f64>) -> [(GravityLink, f64); JOINTS] {
        core::array::from_fn(|i| {
            let at = |qi: f64| {
                let mut q = *pose;
                q[i] = qi;
                self.gravity_torques(&q)[i]
            };
            // Gravity on joint i with the other joints fixed: -A sin(q_i + phi).
            let (t0, t90) = (at(pose[i]), at(pose[i] + core::f64::consts::FRAC_PI_2));
            let amplitude = t0.hypot(t90);
            let psi = (-t0).atan2(-t90);
            let distal_mass: f64 = self.mass_kg[i..].iter().sum();
            let length = amplitude / (distal_mass * STANDARD_GRAVITY);
            // Inertia about the axis: the links as point masses plus each link as a rod, minus
            // the point mass the simulator already counts for the gravity link.
            let f = self.frames(pose);
            let lengths = [self.hip_offset_m, self.thigh_m, self.shank_m, self.foot_m];
            let inertia: f64 = (i..JOINTS)
                .map(|k| {
                    let r = f.coms[k] - f.origins[i];
                    let perp = r - f.axes[i] * f.axes[i].dot(&r);
                    self.mass_kg[k] * (perp.norm_squared() + lengths[k] * lengths[k] / 12.0)
                })
                .sum();
            let extra = (inertia - distal_mass * length * length).max(0.0);
            (
                GravityLink {
                    mass_kg: distal_mass,
                    length_m: length,
                    angle_offset_deg: (psi - pose[i]).to_degrees(),
                },
                extra,
            )
        })
    }
}

impl Default for LegModel {
    fn default() -> Self {
        Self::new()
    }
}

/// Where the parts of the leg are at one pose (hip frame, m).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Frames {
    /// A point on each joint's axis.
    pub origins: [Vector3<f64>; JOINTS],
    /// Each joint's axis (unit vector).
    pub axes: [Vector3<f64>; JOINTS],
    /// Centres of mass of the hip link, thigh, shank and foot.
    pub coms: [Vector3<f64>; JOINTS],
    /// The sole.
    pub sole: Vector3<f64>,
}

fn wrap_pi(a: f64) -> f64 {
    (a + core::f64::consts::PI).rem_euclid(core::f64::consts::TAU) - core::f64::consts::PI
}

/// Degrees to a joint vector in radians.
pub fn rad(deg: [f64; JOINTS]) -> Vector4<f64> {
    Vector4::from(deg.map(f64::to_radians))
}

/// A joint vector in radians to degrees.
pub fn deg(q: &Vector4<f64>) -> [f64; JOINTS] {
    [0, 1, 2, 3].map(|i| q[i].to_degrees())
}

/// One leg's four joints in a robot description: `hip_aa`, `hip_fe`, `knee`, `ankle`, each
/// name after a prefix (`""` for a robot of one leg, `"fl_"` for the front left leg of a
/// quadruped).
///
/// ```
/// use rmd_demos::leg::LegJoints;
/// use rmd_loop::robot::Robot;
/// let mut text = String::from("[[bus]]\ninterface = \"can0\"\n");
/// for (id, name) in [(1, "fl_hip_aa"), (2, "fl_hip_fe"), (3, "fl_knee"), (4, "fl_ankle")] {
///     text += &format!("[[bus.motor]]\nid = {id}\nname = \"{name}\"\ntorque_constant_nm_per_amp = 2.09\n");
/// }
/// let robot = Robot::from_toml(&text)?;
/// let leg = LegJoints::find(&robot, "fl_")?;
/// assert_eq!(leg.ids()[2], robot.joint("fl_knee")?);
/// assert!(LegJoints::find(&robot, "fr_").is_err());
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct LegJoints {
    ids: [JointId; JOINTS],
}

impl LegJoints {
    /// The joints `{prefix}hip_aa`, `{prefix}hip_fe`, `{prefix}knee`, `{prefix}ankle` of
    /// `robot`. Each must have a torque constant: the leg's controllers command torques.
    pub fn find(robot: &Robot, prefix: &str) -> Result<Self, DemoError> {
        let names = JOINT_NAMES.map(|name| format!("{prefix}{name}"));
        let ids = robot.joints_named(names.each_ref().map(String::as_str))?;
        for id in ids {
            let spec = robot.spec(id);
            if spec.torque_constant_nm_per_amp.is_none() {
                return Err(DemoError::NoTorqueConstant {
                    joint: spec.name.clone(),
                });
            }
        }
        Ok(Self { ids })
    }

    /// The joints, from the body out.
    pub fn ids(&self) -> [JointId; JOINTS] {
        self.ids
    }

    /// Whether `joint` is one of this leg's, and which (0 = `hip_aa` .. 3 = `ankle`).
    pub fn position(&self, joint: JointId) -> Option<usize> {
        self.ids.iter().position(|&id| id == joint)
    }
}

/// The simulated motor of `joint` among `sims` (one simulator configuration per bus of `robot`,
/// motors in description order, as [`rmd_rig::sim::sim_configs`] builds them).
///
/// # Panics
/// If `sims` does not match `robot`.
pub fn sim_motor_mut<'a>(
    sims: &'a mut [SimConfig],
    robot: &Robot,
    joint: JointId,
) -> &'a mut rmd_sim::SimMotorConfig {
    let spec = robot.spec(joint);
    let first = robot.buses()[spec.bus].joint_range().start;
    &mut sims[spec.bus].motors[joint.index() - first]
}

/// Makes the simulated motors of one leg (`joints` of `robot`, among `sims`) that leg: powered
/// up at `power_up_deg`, each joint carrying the leg's weight as [`LegModel::sim_loads`] fitted
/// at `working_pose_deg` (where the leg spends its time).
pub fn simulate_leg(
    model: &LegModel,
    robot: &Robot,
    joints: &LegJoints,
    sims: &mut [SimConfig],
    power_up_deg: [f64; JOINTS],
    working_pose_deg: [f64; JOINTS],
) {
    let loads = model.sim_loads(&rad(working_pose_deg));
    for (i, (link, inertia)) in loads.into_iter().enumerate() {
        let joint = joints.ids[i];
        let spec = robot.spec(joint);
        let sign = spec.direction.sign();
        let motor = sim_motor_mut(sims, robot, joint);
        motor.initial_output_angle_deg = rmd_rig::sim::sim_output_angle_deg(spec, power_up_deg[i]);
        // The link is fitted in joint angles; the simulated output turns `sign` times the joint.
        motor.load.gravity = Some(GravityLink {
            angle_offset_deg: sign * link.angle_offset_deg,
            ..link
        });
        motor.load.output_inertia_kg_m2 = inertia;
    }
}
