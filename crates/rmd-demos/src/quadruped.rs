//! The `quadruped` example: four legs on four buses (sixteen motors, one loop, four 0x280
//! frames per tick) stand up from a crouch and hold the pose.
//!
//! The robot powers up lying on its belly with its legs folded (the crouch, hips
//! [`CROUCH_HEIGHT_M`] above the feet). The controller plans one trajectory of all sixteen foot
//! coordinates (x, y, z, pitch of each foot), synchronized so that every foot arrives at the same
//! time, from where the feet are to the standing pose, follows it with a Cartesian
//! [impedance law](crate::impedance) per leg and then holds the pose.
//!
//! The simulated robot is on a stand: each joint carries its leg's weight, but there is no
//! ground contact, so the body's weight on the feet is not simulated.

use core::fmt;

use nalgebra::Vector4;
use rmd_loop::{
    Commands, Controller, Feedback, Flow, JointId, LoopReport, TickContext, robot::Robot,
    telemetry::TelemetrySample,
};
use rmd_rig::program::Verdict;
use rmd_rig::runner::Status;
use rmd_sim::SimConfig;
use rmd_traj::{Input, Trajectory, TrajectoryError, calculate};

use crate::error::DemoError;
use crate::impedance::{self, ErrorStats, ImpedanceGains, LegState};
use crate::leg::{self, JOINT_NAMES, JOINTS, LegJoints, LegModel};
use crate::support::MotorExtremes;

/// Legs of the robot.
pub const LEGS: usize = 4;

/// The legs, in bus order: front left, front right, hind left, hind right (also the bus names
/// in examples/robots/quadruped.toml).
pub const LEG_NAMES: [&str; LEGS] = ["front_left", "front_right", "hind_left", "hind_right"];

/// The prefix of each leg's joint names (`fl_hip_aa`, ..., `hr_ankle`).
pub const LEG_PREFIXES: [&str; LEGS] = ["fl_", "fr_", "hl_", "hr_"];

/// Hip height above the feet when crouching (power-up), m.
pub const CROUCH_HEIGHT_M: f64 = 0.15;

/// Hip height above the feet when standing, m.
pub const STAND_HEIGHT_M: f64 = 0.28;

/// Axes of the stand-up trajectory: x, y, z, pitch of each foot.
const AXES: usize = 4 * LEGS;

/// The names of the user signals the controller writes every tick; their positions are the
/// constants in [`signal`].
pub const SIGNALS: [&str; 8] = [
    "phase",
    "target_height_m",
    "body_height_m",
    "fl_height_m",
    "fr_height_m",
    "hl_height_m",
    "hr_height_m",
    "max_foot_error_mm",
];

/// Positions of the user signals in [`SIGNALS`].
pub mod signal {
    /// 0 rising, 1 holding ([`StandPhase::code`](super::StandPhase::code)).
    pub const PHASE: usize = 0;
    /// The target hip height above the feet, m.
    pub const TARGET_HEIGHT_M: usize = 1;
    /// The body height (mean hip height above the feet), m.
    pub const BODY_HEIGHT_M: usize = 2;
    /// Each leg's hip height above its foot (m), in [`LEG_NAMES`](super::LEG_NAMES) order,
    /// from here on.
    pub const LEG_HEIGHT_M: usize = 3;
    /// Largest foot position error of any leg, mm.
    pub const MAX_FOOT_ERROR_MM: usize = 7;
}

/// The model of each leg (left legs as modelled, right legs mirrored).
pub fn leg_models() -> [LegModel; LEGS] {
    let left = LegModel::new();
    let right = left.mirrored();
    [left.clone(), right.clone(), left, right]
}

/// A foot under its hip flexion axis, `height` below the hip, vertical.
pub fn foot_under_hip(model: &LegModel, height: f64) -> Vector4<f64> {
    Vector4::new(0.0, model.hip_offset_m, -height, 0.0)
}

/// The joint angles (degrees) of a leg with its foot `height` below the hip.
pub fn pose_deg(model: &LegModel, height: f64) -> Result<[f64; JOINTS], DemoError> {
    model
        .inverse(&foot_under_hip(model, height))
        .map(|q| leg::deg(&q))
        .ok_or_else(|| DemoError::OutOfReach {
            what: format!("a foot {height} m below the hip"),
        })
}

/// Each leg's joints in `robot`, in [`LEG_NAMES`] order.
pub fn legs(robot: &Robot) -> Result<[LegJoints; LEGS], DemoError> {
    let [fl, fr, hl, hr] = LEG_PREFIXES;
    Ok([
        LegJoints::find(robot, fl)?,
        LegJoints::find(robot, fr)?,
        LegJoints::find(robot, hl)?,
        LegJoints::find(robot, hr)?,
    ])
}

/// The simulated robot: motors matching `robot`, the legs powered up in the crouch, each joint
/// loaded by its leg's weight fitted at the standing pose.
pub fn sims(robot: &Robot, seed: u64) -> Result<Vec<SimConfig>, DemoError> {
    let mut sims = rmd_rig::sim::sim_configs(robot, seed);
    for (model, joints) in leg_models().iter().zip(legs(robot)?) {
        leg::simulate_leg(
            model,
            robot,
            &joints,
            &mut sims,
            pose_deg(model, CROUCH_HEIGHT_M)?,
            pose_deg(model, STAND_HEIGHT_M)?,
        );
    }
    Ok(sims)
}

/// What the robot is doing while it stands up: rising, then holding the pose.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum StandPhase {
    /// Standing up.
    Rise,
    /// Holding the standing pose.
    Hold,
}

impl StandPhase {
    /// The phase as a number, for a telemetry signal: 0 rising, 1 holding.
    pub fn code(self) -> f64 {
        match self {
            StandPhase::Rise => 0.0,
            StandPhase::Hold => 1.0,
        }
    }
}

/// Why the controller stopped the run by itself.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum Halt {
    /// A joint went beyond its limit.
    JointLimit {
        /// The joint.
        joint: JointId,
        /// Its leg's prefix (`fl_`, ...).
        leg: &'static str,
        /// Its name in the leg (`hip_aa`, ...).
        name: &'static str,
        /// Its angle, degrees.
        deg: f64,
    },
    /// The stand-up could not be planned.
    Plan(TrajectoryError),
}

impl fmt::Display for Halt {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Halt::JointLimit { leg, name, deg, .. } => write!(
                f,
                "{leg}{name} at {deg:.1} deg is beyond its limit: stopped (check the homing: \
                 zero_offset_deg and the power-up pose)"
            ),
            Halt::Plan(e) => write!(f, "cannot plan the stand-up: {e}"),
        }
    }
}

/// The stand-up controller.
#[derive(Clone, Debug)]
pub struct StandController {
    models: [LegModel; LEGS],
    legs: [LegJoints; LEGS],
    gains: ImpedanceGains,
    stand_height_m: f64,
    input: Input<AXES>,
    plan: Trajectory<AXES>,
    t0: f64,
    /// Each leg's hip height above its foot at the last tick, m.
    pub heights_m: [f64; LEGS],
    /// When the body height first came within 5 mm of the target, s after the start.
    pub reached_at_s: Option<f64>,
    /// Foot position error (m) of every leg while holding.
    pub hold_error: ErrorStats,
    /// Duration of the planned stand-up, s.
    pub rise_s: f64,
    /// Why the controller stopped the run, if it did.
    pub halt: Option<Halt>,
}

impl StandController {
    /// A controller that stands `robot` (legs `fl_` .. `hr_`) up to `stand_height_m`; a
    /// height the legs cannot reach is an error.
    pub fn new(robot: &Robot, stand_height_m: f64) -> Result<Self, DemoError> {
        let models = leg_models();
        for model in &models {
            pose_deg(model, stand_height_m)?;
        }
        // A calm stand-up: about 1.2 s.
        let input = Input::with_limits([0.15; AXES], [0.6; AXES], [6.0; AXES]);
        Ok(Self {
            legs: legs(robot)?,
            models,
            gains: ImpedanceGains::new(),
            stand_height_m,
            input,
            plan: Trajectory::EMPTY,
            t0: 0.0,
            heights_m: [0.0; LEGS],
            reached_at_s: None,
            hold_error: ErrorStats::default(),
            rise_s: 0.0,
            halt: None,
        })
    }

    /// The target height, m.
    pub fn stand_height_m(&self) -> f64 {
        self.stand_height_m
    }

    fn halt_at(&mut self, l: usize, state: &LegState, i: usize) {
        self.halt = Some(Halt::JointLimit {
            joint: self.legs[l].ids()[i],
            leg: LEG_PREFIXES[l],
            name: JOINT_NAMES[i],
            deg: state.q[i].to_degrees(),
        });
    }

    /// What the run achieved, with the loop's `report`.
    pub fn results(&self, report: &LoopReport) -> StandResults {
        StandResults {
            heights_m: self.heights_m,
            target_m: self.stand_height_m,
            reached_at_s: self.reached_at_s,
            rise_s: self.rise_s,
            hold_error: self.hold_error,
            halt: self.halt,
            clamped_commands: report.stats.clamped_commands(),
        }
    }
}

impl Controller for StandController {
    fn signals(&self) -> Vec<String> {
        SIGNALS.map(String::from).to_vec()
    }

    fn start(&mut self, ctx: &TickContext, feedback: &Feedback<'_>) {
        self.t0 = ctx.time_s();
        for l in 0..LEGS {
            let state = LegState::read(feedback, &self.legs[l]);
            let model = &self.models[l];
            if let Some(i) = model.limit_violation(&state.q) {
                return self.halt_at(l, &state, i);
            }
            let from = model.foot(&state.q);
            let to = foot_under_hip(model, self.stand_height_m);
            for a in 0..4 {
                self.input.current_position[l * 4 + a] = from[a];
                self.input.target_position[l * 4 + a] = to[a];
            }
        }
        // Every foot coordinate arrives at the same time (the default synchronization).
        match calculate(&self.input) {
            Ok(plan) => {
                self.plan = plan;
                self.rise_s = plan.duration();
            }
            Err(e) => self.halt = Some(Halt::Plan(e)),
        }
    }

    fn update(
        &mut self,
        ctx: &TickContext,
        feedback: &Feedback<'_>,
        cmd: &mut Commands<'_>,
    ) -> Flow {
        if self.halt.is_some() {
            return Flow::Halt("the robot cannot start: see its results");
        }
        let t = ctx.time_s() - self.t0;
        let plan = self.plan.state_at(t);
        let phase = if t < self.plan.duration() {
            StandPhase::Rise
        } else {
            StandPhase::Hold
        };
        let mut max_error: f64 = 0.0;
        for l in 0..LEGS {
            let state = LegState::read(feedback, &self.legs[l]);
            let target = Vector4::from_fn(|a, _| plan[l * 4 + a].position);
            let velocity = Vector4::from_fn(|a, _| plan[l * 4 + a].velocity);
            let out =
                impedance::impedance(&self.models[l], &self.gains, &state, &target, &velocity);
            if let Some(i) = out.beyond_limit {
                self.halt_at(l, &state, i);
                return Flow::Halt("a joint went beyond its limit");
            }
            for (i, joint) in self.legs[l].ids().into_iter().enumerate() {
                cmd.set_torque(joint, out.torque[i]);
            }
            self.heights_m[l] = -out.foot.z;
            let error = out.position_error_m(&target);
            max_error = max_error.max(error);
            if phase == StandPhase::Hold {
                self.hold_error.add(error);
            }
        }
        let body_height = self.heights_m.iter().sum::<f64>() / LEGS as f64;
        if self.reached_at_s.is_none() && (body_height - self.stand_height_m).abs() < 0.005 {
            self.reached_at_s = Some(t);
        }
        cmd.set_signal(signal::PHASE, phase.code());
        cmd.set_signal(signal::TARGET_HEIGHT_M, self.stand_height_m);
        cmd.set_signal(signal::BODY_HEIGHT_M, body_height);
        for (l, h) in self.heights_m.iter().enumerate() {
            cmd.set_signal(signal::LEG_HEIGHT_M + l, *h);
        }
        cmd.set_signal(signal::MAX_FOOT_ERROR_MM, max_error * 1000.0);
        Flow::Continue
    }
}

/// The robot's part of the status line: phase, body height, largest foot error, largest
/// current and temperature.
#[derive(Clone, Debug, Default)]
pub struct StandStatus {
    signals: Option<[f64; SIGNALS.len()]>,
    motors: MotorExtremes,
}

impl Status for StandStatus {
    fn observe(&mut self, sample: &TelemetrySample) {
        self.motors.observe(sample);
        self.signals = sample.signals().try_into().ok();
    }

    fn line(&self) -> String {
        let Some(s) = &self.signals else {
            return format!("starting | {}", self.motors);
        };
        format!(
            "{} body height {:.3} m (target {:.3})  foot error <= {:4.1} mm | {}",
            if s[signal::PHASE] == StandPhase::Rise.code() {
                "rise"
            } else {
                "hold"
            },
            s[signal::BODY_HEIGHT_M],
            s[signal::TARGET_HEIGHT_M],
            s[signal::MAX_FOOT_ERROR_MM],
            self.motors
        )
    }
}

/// What a run of the quadruped achieved.
#[derive(Clone, Debug, PartialEq)]
pub struct StandResults {
    /// Each leg's hip height above its foot at the end, m.
    pub heights_m: [f64; LEGS],
    /// The target height, m.
    pub target_m: f64,
    /// When the body height came within 5 mm of the target, s.
    pub reached_at_s: Option<f64>,
    /// Planned duration of the stand-up, s.
    pub rise_s: f64,
    /// Foot error while holding, m.
    pub hold_error: ErrorStats,
    /// Why the controller stopped by itself.
    pub halt: Option<Halt>,
    /// Commands the loop clamped to a current limit, all joints.
    pub clamped_commands: u64,
}

impl StandResults {
    /// Whether the robot stood up and the controller did not stop the run itself.
    pub fn ok(&self) -> bool {
        self.halt.is_none() && self.reached_at_s.is_some()
    }
}

impl Verdict for StandResults {
    fn ok(&self) -> bool {
        StandResults::ok(self)
    }
}

impl fmt::Display for StandResults {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "quadruped results")?;
        match self.reached_at_s {
            Some(t) => writeln!(
                f,
                "  stood up       body height within 5 mm of {:.3} m after {t:.2} s (planned rise {:.2} s)",
                self.target_m, self.rise_s
            )?,
            None => writeln!(
                f,
                "  DID NOT STAND  body height never came within 5 mm of {:.3} m",
                self.target_m
            )?,
        }
        for (name, h) in LEG_NAMES.iter().zip(self.heights_m) {
            writeln!(f, "  {name:<12}   hip {h:.4} m above the foot")?;
        }
        writeln!(
            f,
            "  holding        foot error rms {:.2} mm, max {:.2} mm",
            self.hold_error.rms() * 1000.0,
            self.hold_error.max * 1000.0
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
