//! The 4-motor leg of the examples: geometry, masses and joint limits; forward kinematics,
//! Jacobian, inverse kinematics and gravity torques (nalgebra, fixed-size, no allocation); the
//! robot description for the loop; and the simulated leg.
//!
//! Frames: the hip frame has x forward, y to the left, z up. The joints, from the body out:
//!
//! 1. hip abduction/adduction (`hip_aa`, motor id 1): about x, at the hip origin;
//! 2. hip flexion/extension (`hip_fe`, id 2): about y, `hip_offset_m` to the side of the hip;
//! 3. knee (id 3): about y, `thigh_m` below the hip flexion axis (positive: knee bent forward);
//! 4. ankle (id 4): about y, `shank_m` below the knee; the foot link (`foot_m`) ends at the sole.
//!
//! All four at zero: the leg hangs straight down. The task coordinates of the foot are its sole
//! point (x, y, z) in the hip frame and its pitch `q2 + q3 + q4` (0: foot link vertical), so the
//! Jacobian is square (4 x 4).

use nalgebra::{Matrix4, Rotation3, Vector3, Vector4};
use rmd_rt::connect;
use rmd_rt::rt::config::Direction;
use rmd_rt::sim::{GravityLink, STANDARD_GRAVITY, SimConfig};
use rmd_rt::{BusConfig, MotorConfig, RobotConfig};

/// Number of joints (and motors) of a leg.
pub(crate) const JOINTS: usize = 4;

/// Joint names, in motor-id order (ids 1..=4).
pub(crate) const JOINT_NAMES: [&str; JOINTS] = ["hip_aa", "hip_fe", "knee", "ankle"];

/// Gear ratio of the leg's motors (RMD-X8-class, 1:9).
pub(crate) const GEAR_RATIO: f64 = 9.0;

/// Output torque constant of the leg's motors, N*m/A (RMD-X8 V2 datasheet).
pub(crate) const TORQUE_CONSTANT: f64 = 2.09;

/// A joint's allowed range, degrees.
#[derive(Copy, Clone, Debug, PartialEq)]
pub(crate) struct JointLimit {
    /// Lowest angle.
    pub(crate) min_deg: f64,
    /// Highest angle.
    pub(crate) max_deg: f64,
}

impl JointLimit {
    /// Whether `deg` lies in the range.
    pub(crate) fn contains(&self, deg: f64) -> bool {
        (self.min_deg..=self.max_deg).contains(&deg)
    }
}

/// Geometry, masses, limits and motor settings of one leg.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct LegModel {
    /// Side offset of the hip flexion axis from the hip abduction axis, m (+ left leg, - right).
    pub(crate) hip_offset_m: f64,
    /// Hip flexion axis to knee, m.
    pub(crate) thigh_m: f64,
    /// Knee to ankle, m.
    pub(crate) shank_m: f64,
    /// Ankle to sole, m.
    pub(crate) foot_m: f64,
    /// Masses of the hip link (hip flexion motor), thigh, shank and foot, kg.
    pub(crate) mass_kg: [f64; 4],
    /// Distance of each link's centre of mass from its proximal joint along the link, m (the
    /// hip link's is at the hip flexion axis).
    pub(crate) com_m: [f64; 4],
    /// Joint limits, degrees.
    pub(crate) limits: [JointLimit; JOINTS],
    /// Torque current limit of each motor, A (the loop clamps every command to it).
    pub(crate) current_limit_amps: [f64; JOINTS],
}

impl LegModel {
    /// The examples' leg (a left leg): 0.2 m thigh and shank, 2.4 kg in all.
    pub(crate) fn new() -> Self {
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
            current_limit_amps: [6.0, 8.0, 8.0, 4.0],
        }
    }

    /// The mirror image of this leg (a right leg from a left one).
    pub(crate) fn mirrored(&self) -> Self {
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
    pub(crate) fn total_mass_kg(&self) -> f64 {
        self.mass_kg.iter().sum()
    }

    /// Joint positions, axes, centres of mass and the sole, in the hip frame, at `q` (radians).
    pub(crate) fn frames(&self, q: &Vector4<f64>) -> Frames {
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
    pub(crate) fn foot(&self, q: &Vector4<f64>) -> Vector4<f64> {
        let s = self.frames(q).sole;
        Vector4::new(s.x, s.y, s.z, q[1] + q[2] + q[3])
    }

    /// The foot's task coordinates and the Jacobian `d foot / d q` at `q` (rad).
    pub(crate) fn foot_and_jacobian(&self, q: &Vector4<f64>) -> (Vector4<f64>, Matrix4<f64>) {
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
    pub(crate) fn gravity_torques(&self, q: &Vector4<f64>) -> Vector4<f64> {
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
    pub(crate) fn inverse(&self, foot: &Vector4<f64>) -> Option<Vector4<f64>> {
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
    pub(crate) fn limit_violation(&self, q: &Vector4<f64>) -> Option<usize> {
        (0..JOINTS).find(|&i| !self.limits[i].contains(q[i].to_degrees()))
    }

    /// The simulated loads of the four motors: for each joint, its distal links as one gravity
    /// link (exact when the other joints are at `pose`, rad) and their inertia about its axis.
    ///
    /// The simulator drives each motor's load on its own (no coupling between joints), so this
    /// is the best per-joint picture of the leg: a controller's multi-body gravity model
    /// ([`gravity_torques`](Self::gravity_torques)) matches it exactly at `pose` and
    /// approximately around it.
    pub(crate) fn sim_loads(&self, pose: &Vector4<f64>) -> [(GravityLink, f64); JOINTS] {
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

/// Where the parts of the leg are at one pose (hip frame, m).
#[derive(Copy, Clone, Debug, PartialEq)]
pub(crate) struct Frames {
    /// A point on each joint's axis.
    pub(crate) origins: [Vector3<f64>; JOINTS],
    /// Each joint's axis (unit vector).
    pub(crate) axes: [Vector3<f64>; JOINTS],
    /// Centres of mass of the hip link, thigh, shank and foot.
    pub(crate) coms: [Vector3<f64>; JOINTS],
    /// The sole.
    pub(crate) sole: Vector3<f64>,
}

fn wrap_pi(a: f64) -> f64 {
    (a + core::f64::consts::PI).rem_euclid(core::f64::consts::TAU) - core::f64::consts::PI
}

/// Degrees to a joint vector in radians.
pub(crate) fn rad(deg: [f64; JOINTS]) -> Vector4<f64> {
    Vector4::from(deg.map(f64::to_radians))
}

/// A joint vector in radians to degrees.
pub(crate) fn deg(q: &Vector4<f64>) -> [f64; JOINTS] {
    [0, 1, 2, 3].map(|i| q[i].to_degrees())
}

/// One leg's bus in the robot description: motors 1..=4 (RMD-X8-class, 1:9, 2.09 N*m/A), their
/// current limits, a 70 degC temperature limit, and zero offsets that centre each joint's
/// power-up window on `power_up_deg` (the pose the leg is in when the motors are switched on).
pub(crate) fn leg_bus(
    model: &LegModel,
    interface: &str,
    name: &str,
    power_up_deg: [f64; JOINTS],
) -> BusConfig {
    let mut bus = BusConfig::new(interface);
    bus.name = Some(name.to_string());
    for i in 0..JOINTS {
        bus = bus.with_motor(
            MotorConfig::new(i as u8 + 1)
                .name(&format!("{name}.{}", JOINT_NAMES[i]))
                .gear_ratio(GEAR_RATIO)
                .torque_constant(TORQUE_CONSTANT)
                .current_limit(model.current_limit_amps[i])
                .temperature_limit(70.0)
                .zero_offset_deg(connect::centred_zero_offset_deg(
                    GEAR_RATIO,
                    Direction::Normal,
                    power_up_deg[i],
                )),
        );
    }
    bus
}

/// A robot of one leg on one bus at `rate_hz`.
pub(crate) fn leg_robot(
    model: &LegModel,
    interface: &str,
    rate_hz: f64,
    power_up_deg: [f64; JOINTS],
) -> RobotConfig {
    RobotConfig::new(rate_hz).with_bus(leg_bus(model, interface, "leg", power_up_deg))
}

/// The simulated bus of one leg described by `bus`: motors matching the description, powered up
/// at `power_up_deg`, each carrying the leg's weight as [`LegModel::sim_loads`] fitted at
/// `working_pose_deg` (where the leg spends its time).
pub(crate) fn leg_sim(
    model: &LegModel,
    bus: &BusConfig,
    power_up_deg: [f64; JOINTS],
    working_pose_deg: [f64; JOINTS],
    seed: u64,
) -> SimConfig {
    let mut sim = connect::sim_config(bus, seed);
    let loads = model.sim_loads(&rad(working_pose_deg));
    for ((m, motor), (i, (link, inertia))) in sim
        .motors
        .iter_mut()
        .zip(&bus.motors)
        .zip(loads.into_iter().enumerate())
    {
        m.initial_output_angle_deg = connect::sim_output_angle_deg(motor, power_up_deg[i]);
        m.load.gravity = Some(link);
        m.load.output_inertia_kg_m2 = inertia;
    }
    sim
}
