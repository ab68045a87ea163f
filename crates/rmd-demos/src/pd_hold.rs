//! The `pd_hold` example: the smallest useful controller. It turns every joint a given angle
//! from where it is and holds it there with a PD law on the joint angle; the simulated robot is
//! one RMD-X8-class motor (1:9 gearbox) swinging a 1 kg arm 0.2 m long.
//!
//! A PD law has no integral term: against gravity the arm settles short of the target by the
//! gravity torque over the stiffness, at most 1.96 N*m / 1.67 N*m per degree = 1.2 degrees here
//! (the gearbox's friction takes part of it).

use core::fmt;

use rmd_loop::{
    Commands, Controller, Feedback, Flow, JointArray, TickContext, robot::Robot,
    telemetry::TelemetrySample,
};
use rmd_rig::program::Verdict;
use rmd_rig::runner::Status;
use rmd_sim::{GravityLink, SimConfig};

use crate::support::MotorExtremes;

/// The joint angle (degrees) at which the simulated arm powers up: the middle of its power-up
/// window (`zero_offset_deg = 20` in examples/robots/pd_hold.toml with the 1:9 gearbox).
pub const POWER_UP_DEG: f64 = 0.0;

/// The simulated arm: hanging straight down is joint -60 degrees, so at power-up (joint 0) it
/// points 30 degrees below horizontal and horizontal is joint 30 (the default move).
pub const ARM: GravityLink = GravityLink {
    mass_kg: 1.0,
    length_m: 0.2,
    angle_offset_deg: 60.0,
};

/// Holds every joint `move_deg` away from where it was at the start:
/// current = kp * angle error - kd * velocity.
#[derive(Clone, Debug)]
pub struct PdHold {
    /// How far to turn each joint from its start angle, degrees.
    pub move_deg: f64,
    /// Amperes per degree of error.
    pub kp: f64,
    /// Amperes per degree per second of velocity.
    pub kd: f64,
    /// Each joint's target angle, set in the first tick.
    pub targets: JointArray<f64>,
}

impl PdHold {
    /// A controller for every joint of `robot` with the example's gains: 0.8 A per degree
    /// (1.7 N*m/deg at the output of a 2.09 N*m/A motor), 0.03 A per deg/s.
    pub fn new(robot: &Robot, move_deg: f64) -> Self {
        Self {
            move_deg,
            kp: 0.8,
            kd: 0.03,
            targets: JointArray::new(robot, 0.0),
        }
    }
}

impl Controller for PdHold {
    fn start(&mut self, _: &TickContext, feedback: &Feedback<'_>) {
        for (joint, state) in feedback.iter() {
            self.targets[joint] = state.joint.angle_deg + self.move_deg;
        }
    }

    fn update(&mut self, _: &TickContext, feedback: &Feedback<'_>, cmd: &mut Commands<'_>) -> Flow {
        for (joint, state) in feedback.iter() {
            let error = self.targets[joint] - state.joint.angle_deg;
            // Joint sign; the loop clamps it to the joint's current limit.
            cmd.set_current(joint, self.kp * error - self.kd * state.joint.velocity_dps);
        }
        Flow::Continue
    }
}

/// The simulated robot: motors matching `robot`, each powered up at [`POWER_UP_DEG`] and
/// swinging the [`ARM`].
pub fn sims(robot: &Robot, seed: u64) -> Vec<SimConfig> {
    let mut sims = rmd_rig::sim::sim_configs(robot, seed);
    for (bus, sim) in robot.buses().iter().zip(&mut sims) {
        for (joint, motor) in bus.joints().zip(&mut sim.motors) {
            let spec = robot.spec(joint);
            motor.initial_output_angle_deg = rmd_rig::sim::sim_output_angle_deg(spec, POWER_UP_DEG);
            motor.load.gravity = Some(GravityLink {
                angle_offset_deg: spec.direction.sign() * ARM.angle_offset_deg,
                ..ARM
            });
        }
    }
    sims
}

/// Where the joints ended, from the last tick's telemetry.
#[derive(Clone, Debug, Default)]
pub struct HoldStatus {
    last: Option<TelemetrySample>,
    motors: MotorExtremes,
}

impl Status for HoldStatus {
    fn observe(&mut self, sample: &TelemetrySample) {
        self.motors.observe(sample);
        self.last = Some(*sample);
    }

    fn line(&self) -> String {
        let angles = self
            .last
            .iter()
            .flat_map(|s| s.joints())
            .map(|j| format!("{:7.2} deg", j.feedback.joint.angle_deg));
        format!("{} | {}", angles.collect::<Vec<_>>().join(" "), self.motors)
    }
}

impl HoldStatus {
    /// The results of the run: each joint's final state against its target.
    pub fn results(&self, robot: &Robot, controller: &PdHold) -> HoldResults {
        let joints = match &self.last {
            Some(last) => robot
                .joint_ids()
                .zip(last.joints())
                .map(|(id, j)| FinalJoint {
                    name: robot.spec(id).name.clone(),
                    angle_deg: j.feedback.joint.angle_deg,
                    target_deg: controller.targets[id],
                    velocity_dps: j.feedback.joint.velocity_dps,
                    current_amps: j.feedback.motor.current_amps,
                })
                .collect(),
            None => Vec::new(),
        };
        HoldResults { joints }
    }
}

/// One joint at the end of the run.
#[derive(Clone, Debug, PartialEq)]
pub struct FinalJoint {
    /// Its name.
    pub name: String,
    /// Final angle, degrees.
    pub angle_deg: f64,
    /// Target, degrees.
    pub target_deg: f64,
    /// Final velocity, deg/s.
    pub velocity_dps: f64,
    /// Final torque current, A (motor sign).
    pub current_amps: f64,
}

/// What the hold achieved.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct HoldResults {
    /// Every joint (none if the loop never ticked).
    pub joints: Vec<FinalJoint>,
}

/// Said after the report; a hold has no aim of its own to miss.
impl Verdict for HoldResults {}

impl fmt::Display for HoldResults {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "pd_hold results")?;
        if self.joints.is_empty() {
            return writeln!(f, "  no tick ran: no final angle");
        }
        for j in &self.joints {
            writeln!(
                f,
                "  {:<10} final angle {:.2} deg (target {:.2} deg), velocity {:.2} deg/s, current {:.2} A",
                j.name, j.angle_deg, j.target_deg, j.velocity_dps, j.current_amps
            )?;
        }
        Ok(())
    }
}
