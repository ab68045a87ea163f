//! Cartesian impedance control of one leg's foot:
//!
//! ```text
//! torque = J^T (K (x_d - x) + D (v_d - v)) + g(q) + joint-limit springs
//! ```
//!
//! with `x`, `v = J q'` the foot's task coordinates and velocity, `J` the 4 x 4 Jacobian, `K`, `D`
//! diagonal stiffness and damping, and `g(q)` the torques that hold the leg's weight
//! (the negative of [`LegModel::gravity_torques`]). Near a joint limit a one-sided spring pushes
//! the joint back; a joint beyond its limit is a fault the controller stops on.
//!
//! Everything is fixed-size nalgebra arithmetic on the stack: no allocation, suitable for the
//! loop's `update`.

use nalgebra::{Matrix4, Vector4};
use rmd_loop::Feedback;

use crate::leg::{JOINTS, LegJoints, LegModel};

/// Stiffness and damping of the foot, and the joint-limit springs.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ImpedanceGains {
    /// Stiffness along x, y, z (N/m) and about the pitch (N*m/rad).
    pub stiffness: Vector4<f64>,
    /// Damping along x, y, z (N*s/m) and about the pitch (N*m*s/rad).
    pub damping: Vector4<f64>,
    /// Whether to add the gravity torques.
    pub gravity_compensation: bool,
    /// Width of the zone inside each joint limit where the limit spring acts, rad.
    pub limit_zone_rad: f64,
    /// Stiffness of the limit springs, N*m/rad.
    pub limit_stiffness: f64,
}

impl ImpedanceGains {
    /// 3000 N/m and 60 N*s/m along the axes, 30 N*m/rad and 0.8 N*m*s/rad in pitch, gravity
    /// compensation on, 5 degree limit zones with 60 N*m/rad springs.
    pub fn new() -> Self {
        Self {
            stiffness: Vector4::new(3000.0, 3000.0, 3000.0, 30.0),
            damping: Vector4::new(60.0, 60.0, 60.0, 0.8),
            gravity_compensation: true,
            limit_zone_rad: 5f64.to_radians(),
            limit_stiffness: 60.0,
        }
    }
}

impl Default for ImpedanceGains {
    fn default() -> Self {
        Self::new()
    }
}

/// One leg's joint state read from the loop's feedback.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct LegState {
    /// Joint angles, rad.
    pub q: Vector4<f64>,
    /// Joint velocities, rad/s.
    pub qd: Vector4<f64>,
    /// Whether every motor's feedback is fresh this tick.
    pub fresh: bool,
}

impl LegState {
    /// The state of the leg whose joints are `joints`.
    pub fn read(feedback: &Feedback<'_>, joints: &LegJoints) -> Self {
        let mut s = Self {
            q: Vector4::zeros(),
            qd: Vector4::zeros(),
            fresh: true,
        };
        for (i, id) in joints.ids().into_iter().enumerate() {
            if let Some(f) = feedback.get(id) {
                s.q[i] = f.joint.angle_rad();
                s.qd[i] = f.joint.velocity_rad_s();
                s.fresh &= f.is_fresh();
            }
        }
        s
    }
}

/// What the impedance law computed in one tick.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ImpedanceOutput {
    /// Joint torques to command, N*m.
    pub torque: Vector4<f64>,
    /// The foot's task coordinates (m, rad).
    pub foot: Vector4<f64>,
    /// The foot's task velocity (m/s, rad/s).
    pub foot_velocity: Vector4<f64>,
    /// The first joint beyond its limit, if any (the caller stops).
    pub beyond_limit: Option<usize>,
}

impl ImpedanceOutput {
    /// Distance from the foot to `target` in x, y, z, m.
    pub fn position_error_m(&self, target: &Vector4<f64>) -> f64 {
        (target - self.foot).fixed_rows::<3>(0).norm()
    }
}

/// The impedance law for one leg.
pub fn impedance(
    model: &LegModel,
    gains: &ImpedanceGains,
    joints: &LegState,
    target: &Vector4<f64>,
    target_velocity: &Vector4<f64>,
) -> ImpedanceOutput {
    let (foot, jacobian): (Vector4<f64>, Matrix4<f64>) = model.foot_and_jacobian(&joints.q);
    let foot_velocity = jacobian * joints.qd;
    let force = gains.stiffness.component_mul(&(target - foot))
        + gains
            .damping
            .component_mul(&(target_velocity - foot_velocity));
    let mut torque = jacobian.transpose() * force;
    if gains.gravity_compensation {
        torque -= model.gravity_torques(&joints.q);
    }
    let mut beyond_limit = None;
    for i in 0..JOINTS {
        let (low, high) = (
            model.limits[i].min_deg.to_radians(),
            model.limits[i].max_deg.to_radians(),
        );
        let q = joints.q[i];
        if q < low || q > high {
            beyond_limit.get_or_insert(i);
        }
        let into_low = low + gains.limit_zone_rad - q;
        let into_high = q - (high - gains.limit_zone_rad);
        if into_low > 0.0 {
            torque[i] += gains.limit_stiffness * into_low;
        } else if into_high > 0.0 {
            torque[i] -= gains.limit_stiffness * into_high;
        }
    }
    ImpedanceOutput {
        torque,
        foot,
        foot_velocity,
        beyond_limit,
    }
}

/// Running statistics of a tracking error (allocation-free).
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct ErrorStats {
    /// Samples.
    pub count: u64,
    /// Sum of squares.
    pub sum_sq: f64,
    /// Largest error.
    pub max: f64,
}

impl ErrorStats {
    /// Adds one sample.
    pub fn add(&mut self, e: f64) {
        self.count += 1;
        self.sum_sq += e * e;
        self.max = self.max.max(e);
    }

    /// Root mean square (0 without samples).
    pub fn rms(&self) -> f64 {
        if self.count == 0 {
            0.0
        } else {
            (self.sum_sq / self.count as f64).sqrt()
        }
    }
}
