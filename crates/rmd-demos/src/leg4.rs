//! The `leg4` example: one 4-motor leg (`hip_aa`, `hip_fe`, `knee`, `ankle`) stepping under
//! Cartesian impedance control.
//!
//! The controller moves the foot through a [step cycle](crate::step_cycle) (a stance at constant
//! ground speed, a swing that lifts the foot 6 cm) with the [impedance law](crate::impedance):
//!
//! ```text
//! torque = J^T (K (x_d - x) + D (v_d - v)) + gravity compensation
//! ```
//!
//! Joint limits are enforced (the planned cycle is checked against them with [`check_cycle`]; a
//! spring acts near each limit; a joint beyond its limit stops the run, see [`Halt`]) and so are
//! current limits (the loop clamps every command to the description's `current_limit_amps`).
//! Every tick's foot target, foot position, tracking error and phase go out as user signals
//! ([`SIGNALS`]), so the runner's CSV file carries them next to the joints.

use core::fmt;

use nalgebra::Vector4;
use rmd_loop::{
    Commands, Controller, Feedback, Flow, JointId, LoopReport, TickContext, robot::Robot,
    telemetry::TelemetrySample,
};
use rmd_rig::program::Verdict;
use rmd_rig::runner::Status;
use rmd_sim::SimConfig;
use rmd_traj::TrajectoryError;

use crate::error::DemoError;
use crate::impedance::{self, ErrorStats, ImpedanceGains, LegState};
use crate::leg::{self, JOINT_NAMES, JOINTS, LegJoints, LegModel};
use crate::step_cycle::{StepCycle, StepParams, StepPhase};
use crate::support::MotorExtremes;

/// The pose the leg is in when the motors are switched on (degrees: `hip_aa`, `hip_fe`,
/// `knee`, `ankle`): folded, foot 38.6 cm below the hip. examples/robots/leg4.toml centres each
/// joint's power-up window (40 degrees with a 1:9 gearbox) on it.
pub const POWER_UP_DEG: [f64; JOINTS] = [0.0, -30.0, 60.0, -30.0];

/// Height of the foot below the hip in the middle of the step, m.
pub const STEP_DEPTH_M: f64 = 0.30;

/// How far inside the joint limits the planned cycle must stay, degrees.
pub const CYCLE_MARGIN_DEG: f64 = 5.0;

/// The names of the user signals the controller writes every tick (the CSV columns after the
/// joints'); their positions are the constants in [`signal`].
pub const SIGNALS: [&str; 10] = [
    "phase",
    "foot_x_des_m",
    "foot_y_des_m",
    "foot_z_des_m",
    "foot_pitch_des_rad",
    "foot_x_m",
    "foot_y_m",
    "foot_z_m",
    "foot_pitch_rad",
    "foot_error_mm",
];

/// Positions of the user signals in [`SIGNALS`] (and in a telemetry sample's `signals()`).
pub mod signal {
    /// The step's phase: 0 approach, 1 stance, 2 swing ([`StepPhase::code`](crate::step_cycle::StepPhase::code)).
    pub const PHASE: usize = 0;
    /// The desired foot position: x, y, z (m), pitch (rad), from here on.
    pub const FOOT_DESIRED: usize = 1;
    /// The measured foot position: x, y, z (m), pitch (rad), from here on.
    pub const FOOT: usize = 5;
    /// Distance from the foot to its target, mm.
    pub const FOOT_ERROR_MM: usize = 9;
}

/// The middle of the step: under the hip flexion axis, [`STEP_DEPTH_M`] down, foot vertical.
pub fn step_center(model: &LegModel) -> Vector4<f64> {
    Vector4::new(0.0, model.hip_offset_m, -STEP_DEPTH_M, 0.0)
}

/// The joint angles (degrees) in the middle of the step.
pub fn working_pose_deg(model: &LegModel) -> Result<[f64; JOINTS], DemoError> {
    model
        .inverse(&step_center(model))
        .map(|q| leg::deg(&q))
        .ok_or_else(|| DemoError::OutOfReach {
            what: "the middle of the step".into(),
        })
}

/// The simulated leg of `robot` (joints `hip_aa` .. `ankle`): motors matching the description,
/// powered up at [`POWER_UP_DEG`], loaded by the leg's weight fitted at the working pose.
pub fn sims(robot: &Robot, seed: u64) -> Result<Vec<SimConfig>, DemoError> {
    let model = LegModel::new();
    let joints = LegJoints::find(robot, "")?;
    let mut sims = rmd_rig::sim::sim_configs(robot, seed);
    leg::simulate_leg(
        &model,
        robot,
        &joints,
        &mut sims,
        POWER_UP_DEG,
        working_pose_deg(&model)?,
    );
    Ok(sims)
}

/// Checks a planned cycle against the joint limits (kept `margin_deg` inside them), sampling it
/// every millisecond; the error names the joint, the angle and the time.
pub fn check_cycle(model: &LegModel, cycle: &StepCycle, margin_deg: f64) -> Result<(), DemoError> {
    let approach = cycle.approach_s();
    let steps = (cycle.period_s() * 1000.0).ceil() as usize;
    for k in 0..=steps {
        let t = approach + k as f64 / 1000.0;
        let target = cycle.at(t).position;
        let q = model
            .inverse(&target)
            .ok_or(DemoError::CycleOutOfReach { t_s: t })?;
        for (i, angle) in leg::deg(&q).into_iter().enumerate() {
            let limit = model.limits[i];
            let (low, high) = (limit.min_deg + margin_deg, limit.max_deg - margin_deg);
            if angle < low || angle > high {
                return Err(DemoError::CycleBeyondLimits {
                    joint: JOINT_NAMES[i],
                    angle_deg: angle,
                    t_s: t,
                    low_deg: low,
                    high_deg: high,
                    margin_deg,
                });
            }
        }
    }
    Ok(())
}

/// The example's step ([`StepParams::new`] around [`step_center`]), planned and checked against
/// the joint limits with [`CYCLE_MARGIN_DEG`].
pub fn plan_cycle(model: &LegModel) -> Result<StepCycle, DemoError> {
    let cycle =
        StepCycle::plan(StepParams::new(step_center(model))).map_err(|source| DemoError::Plan {
            what: "the step cycle",
            source,
        })?;
    check_cycle(model, &cycle, CYCLE_MARGIN_DEG)?;
    Ok(cycle)
}

/// The example's gains ([`ImpedanceGains::new`]) with the foot's stiffness (N/m) and damping (N*s/m)
/// along x, y and z, and gravity compensation on or off. Negative or non-finite values are
/// errors.
pub fn gains(
    gravity_compensation: bool,
    stiffness: f64,
    damping: f64,
) -> Result<ImpedanceGains, DemoError> {
    for (name, value) in [("stiffness", stiffness), ("damping", damping)] {
        if !(value.is_finite() && value >= 0.0) {
            return Err(DemoError::Usage(format!(
                "a foot {name} of {value}: give zero or a positive number"
            )));
        }
    }
    let mut gains = ImpedanceGains::new();
    gains.gravity_compensation = gravity_compensation;
    for axis in 0..3 {
        gains.stiffness[axis] = stiffness;
        gains.damping[axis] = damping;
    }
    Ok(gains)
}

/// Why the controller stopped the run by itself.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum Halt {
    /// A joint went beyond its limit.
    JointLimit {
        /// The joint.
        joint: JointId,
        /// Its name.
        name: &'static str,
        /// Its angle, degrees.
        deg: f64,
    },
    /// The approach to the cycle could not be planned (e.g. a joint started out of range).
    Approach(TrajectoryError),
}

impl fmt::Display for Halt {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Halt::JointLimit { name, deg, .. } => write!(
                f,
                "{name} at {deg:.1} deg is beyond its limit: stopped (check the homing: \
                 zero_offset_deg and the power-up pose)"
            ),
            Halt::Approach(e) => write!(f, "cannot plan the approach to the step cycle: {e}"),
        }
    }
}

/// The leg's controller: the step cycle, the impedance law, limits and statistics.
#[derive(Clone, Debug)]
pub struct StepController {
    model: LegModel,
    gains: ImpedanceGains,
    cycle: StepCycle,
    joints: LegJoints,
    t0: f64,
    /// Foot position error (m) over the step cycles (after the approach).
    pub tracking: ErrorStats,
    /// Foot position error (m) in the stance.
    pub stance_tracking: ErrorStats,
    /// Sum of the foot's height error (z - z_d, m) over the stance ticks (negative: sagging).
    pub stance_z_error_sum: f64,
    /// Completed step cycles.
    pub cycles: u64,
    /// Ticks in which some motor's feedback was not fresh.
    pub stale_ticks: u64,
    /// Why the controller stopped the run, if it did.
    pub halt: Option<Halt>,
}

impl StepController {
    /// A controller of the leg `hip_aa` .. `ankle` of `robot`, built like `model`, stepping
    /// through `cycle` (its approach is planned at start).
    pub fn new(
        robot: &Robot,
        model: LegModel,
        gains: ImpedanceGains,
        cycle: StepCycle,
    ) -> Result<Self, DemoError> {
        Ok(Self {
            joints: LegJoints::find(robot, "")?,
            model,
            gains,
            cycle,
            t0: 0.0,
            tracking: ErrorStats::default(),
            stance_tracking: ErrorStats::default(),
            stance_z_error_sum: 0.0,
            cycles: 0,
            stale_ticks: 0,
            halt: None,
        })
    }

    /// The step and gains in words: `step 12 cm x 6 cm every 1.00 s (stance 0.50 s at 0.24
    /// m/s), gravity compensation on`.
    pub fn describe(&self) -> String {
        let p = self.cycle.params();
        format!(
            "step {:.0} cm x {:.0} cm every {:.2} s (stance {:.2} s at {:.2} m/s), gravity compensation {}",
            p.length_m * 100.0,
            p.height_m * 100.0,
            self.cycle.period_s(),
            self.cycle.stance_s(),
            p.ground_speed(),
            if self.gains.gravity_compensation {
                "on"
            } else {
                "off"
            },
        )
    }

    /// Mean height error of the foot in the stance, m (negative: the foot sags below its path).
    pub fn stance_z_bias_m(&self) -> f64 {
        if self.stance_tracking.count == 0 {
            0.0
        } else {
            self.stance_z_error_sum / self.stance_tracking.count as f64
        }
    }

    fn halt_at(&mut self, state: &LegState, i: usize) {
        self.halt = Some(Halt::JointLimit {
            joint: self.joints.ids()[i],
            name: JOINT_NAMES[i],
            deg: state.q[i].to_degrees(),
        });
    }

    /// What the run achieved, with the loop's `report`.
    pub fn results(&self, report: &LoopReport) -> LegResults {
        LegResults {
            tracking: self.tracking,
            stance_tracking: self.stance_tracking,
            stance_z_bias_m: self.stance_z_bias_m(),
            cycles: self.cycles,
            gravity_compensation: self.gains.gravity_compensation,
            halt: self.halt,
            clamped_commands: report.stats.clamped_commands(),
        }
    }
}

impl Controller for StepController {
    fn signals(&self) -> Vec<String> {
        SIGNALS.map(String::from).to_vec()
    }

    fn start(&mut self, ctx: &TickContext, feedback: &Feedback<'_>) {
        self.t0 = ctx.time_s();
        let state = LegState::read(feedback, &self.joints);
        if let Some(i) = self.model.limit_violation(&state.q) {
            return self.halt_at(&state, i);
        }
        if let Err(e) = self.cycle.plan_approach(self.model.foot(&state.q)) {
            self.halt = Some(Halt::Approach(e));
        }
    }

    fn update(
        &mut self,
        ctx: &TickContext,
        feedback: &Feedback<'_>,
        cmd: &mut Commands<'_>,
    ) -> Flow {
        if self.halt.is_some() {
            return Flow::Halt("the leg cannot start: see its results");
        }
        let t = ctx.time_s() - self.t0;
        let state = LegState::read(feedback, &self.joints);
        if !state.fresh {
            self.stale_ticks += 1;
        }
        let target = self.cycle.at(t);
        let out = impedance::impedance(
            &self.model,
            &self.gains,
            &state,
            &target.position,
            &target.velocity,
        );
        if let Some(i) = out.beyond_limit {
            self.halt_at(&state, i);
            return Flow::Halt("a joint went beyond its limit");
        }
        for (i, joint) in self.joints.ids().into_iter().enumerate() {
            cmd.set_torque(joint, out.torque[i]);
        }
        let error = out.position_error_m(&target.position);
        if target.phase != StepPhase::Approach {
            self.tracking.add(error);
            if target.phase == StepPhase::Stance {
                self.stance_tracking.add(error);
                self.stance_z_error_sum += out.foot.z - target.position.z;
            }
            self.cycles = target.cycle;
        }
        cmd.set_signal(signal::PHASE, target.phase.code());
        for a in 0..4 {
            cmd.set_signal(signal::FOOT_DESIRED + a, target.position[a]);
            cmd.set_signal(signal::FOOT + a, out.foot[a]);
        }
        cmd.set_signal(signal::FOOT_ERROR_MM, error * 1000.0);
        Flow::Continue
    }
}

/// The leg's part of the status line: phase, foot error, largest foot error over the cycles,
/// largest current and temperature.
#[derive(Clone, Debug, Default)]
pub struct LegStatus {
    phase: Option<StepPhase>,
    error_mm: f64,
    max_error_mm: f64,
    motors: MotorExtremes,
}

impl Status for LegStatus {
    fn observe(&mut self, sample: &TelemetrySample) {
        self.motors.observe(sample);
        let signals = sample.signals();
        let (Some(&phase), Some(&error)) = (
            signals.get(signal::PHASE),
            signals.get(signal::FOOT_ERROR_MM),
        ) else {
            return;
        };
        self.phase = StepPhase::from_code(phase);
        self.error_mm = error;
        if self.phase.is_some_and(|p| p != StepPhase::Approach) {
            self.max_error_mm = self.max_error_mm.max(error);
        }
    }

    fn line(&self) -> String {
        let leg = match self.phase {
            None => "starting".to_string(),
            Some(StepPhase::Approach) => format!("approach foot error {:5.1} mm", self.error_mm),
            Some(phase) => format!(
                "{:<8} foot error {:5.1} mm (max {:4.1})",
                phase.name(),
                self.error_mm,
                self.max_error_mm
            ),
        };
        format!("{leg} | {}", self.motors)
    }
}

/// What a run of the leg achieved.
#[derive(Clone, Debug, PartialEq)]
pub struct LegResults {
    /// Foot error over the step cycles, m.
    pub tracking: ErrorStats,
    /// Foot error in the stance, m.
    pub stance_tracking: ErrorStats,
    /// Mean height error in the stance, m.
    pub stance_z_bias_m: f64,
    /// Completed cycles.
    pub cycles: u64,
    /// Whether gravity compensation was on.
    pub gravity_compensation: bool,
    /// Why the controller stopped by itself.
    pub halt: Option<Halt>,
    /// Commands the loop clamped to a current limit, all joints.
    pub clamped_commands: u64,
}

impl LegResults {
    /// Whether the controller ran as planned (it did not stop the run itself).
    pub fn ok(&self) -> bool {
        self.halt.is_none()
    }
}

impl Verdict for LegResults {
    fn ok(&self) -> bool {
        LegResults::ok(self)
    }
}

impl fmt::Display for LegResults {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "leg4 results")?;
        writeln!(
            f,
            "  foot tracking  rms {:.2} mm   max {:.2} mm over {} step cycle(s) (stance: rms {:.2} mm, max {:.2} mm)",
            self.tracking.rms() * 1000.0,
            self.tracking.max * 1000.0,
            self.cycles,
            self.stance_tracking.rms() * 1000.0,
            self.stance_tracking.max * 1000.0,
        )?;
        writeln!(
            f,
            "  foot height    {:+.2} mm on average in the stance (gravity compensation {})",
            self.stance_z_bias_m * 1000.0,
            if self.gravity_compensation {
                "on"
            } else {
                "off: the foot sags under the leg's weight"
            }
        )?;
        writeln!(
            f,
            "  current limit  {} command(s) clamped by the loop",
            self.clamped_commands
        )?;
        if let Some(halt) = &self.halt {
            writeln!(f, "  STOPPED        {halt}")?;
        }
        Ok(())
    }
}
