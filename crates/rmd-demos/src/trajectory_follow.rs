//! The `trajectory_follow` example: the leg of `leg4` moved in joint space, from where it is
//! through each waypoint (four joint angles), pausing at each.
//!
//! Every move is a time-optimal, jerk-limited trajectory of the four joints from the online
//! generator (`rmd_traj::OnlineGenerator`), synchronized so that all joints start and arrive
//! together; a joint-space PD law with gravity compensation follows it:
//!
//! ```text
//! torque = Kp (q_d - q) + Kd (q_d' - q') + gravity compensation
//! ```

use core::fmt;

use nalgebra::Vector4;
use rmd_loop::{
    Commands, Controller, Feedback, Flow, TickContext, robot::Robot, telemetry::TelemetrySample,
};
use rmd_rig::program::Verdict;
use rmd_rig::runner::Status;
use rmd_sim::SimConfig;
use rmd_traj::{Input, OnlineGenerator, OnlineStatus, TrajectoryError};

use crate::error::DemoError;
use crate::impedance::LegState;
use crate::leg::{self, JOINT_NAMES, JOINTS, LegJoints, LegModel};
use crate::support::MotorExtremes;

/// The leg's pose when the motors are switched on (as in `leg4`, whose robot description this
/// example uses), degrees.
pub const POWER_UP_DEG: [f64; JOINTS] = crate::leg4::POWER_UP_DEG;

/// The default tour: fold, stretch out to the side, fold the other way, back to rest (degrees:
/// `hip_aa`, `hip_fe`, `knee`, `ankle`).
pub const WAYPOINTS_DEG: [[f64; JOINTS]; 4] = [
    [0.0, -55.0, 110.0, -55.0],
    [12.0, -15.0, 30.0, -15.0],
    [-12.0, -70.0, 130.0, -40.0],
    [0.0, -30.0, 60.0, -30.0],
];

/// The names of the user signals the follower writes every tick; their positions are the
/// constants in [`signal`].
pub const SIGNALS: [&str; 6] = [
    "waypoint",
    "hip_aa_des_deg",
    "hip_fe_des_deg",
    "knee_des_deg",
    "ankle_des_deg",
    "following_error_deg",
];

/// Positions of the user signals in [`SIGNALS`].
pub mod signal {
    /// The waypoint being approached or paused at, numbered from 1.
    pub const WAYPOINT: usize = 0;
    /// The desired joint angles (degrees), `hip_aa` .. `ankle`, from here on.
    pub const DESIRED_DEG: usize = 1;
    /// The largest difference between a joint's desired and measured angle, degrees.
    pub const FOLLOWING_ERROR_DEG: usize = 5;
}

/// Parses `--waypoint` values (`DEG,DEG,DEG,DEG`) and checks them against the joint limits;
/// none gives the default tour [`WAYPOINTS_DEG`].
///
/// ```
/// use rmd_demos::leg::LegModel;
/// use rmd_demos::trajectory_follow::parse_waypoints;
/// let model = LegModel::new();
/// assert_eq!(parse_waypoints(&model, &["0,-40,80,-40".into()])?, [[0.0, -40.0, 80.0, -40.0]]);
/// assert!(parse_waypoints(&model, &["0,-40,170,-40".into()]).unwrap_err().to_string().contains("knee"));
/// # Ok::<(), rmd_demos::DemoError>(())
/// ```
pub fn parse_waypoints(model: &LegModel, args: &[String]) -> Result<Vec<[f64; JOINTS]>, DemoError> {
    if args.is_empty() {
        return Ok(WAYPOINTS_DEG.to_vec());
    }
    args.iter()
        .enumerate()
        .map(|(n, text)| {
            let number = n + 1;
            let bad = |problem: String| DemoError::Waypoint {
                number,
                text: text.clone(),
                problem,
            };
            let values: Vec<f64> = text
                .split(',')
                .map(|v| v.trim().parse::<f64>())
                .collect::<Result<_, _>>()
                .map_err(|e| bad(e.to_string()))?;
            if let Some(v) = values.iter().find(|v| !v.is_finite()) {
                return Err(bad(format!("{v} is not an angle")));
            }
            let deg: [f64; JOINTS] = values
                .try_into()
                .map_err(|v: Vec<f64>| bad(format!("it has {} angles, needs {JOINTS}", v.len())))?;
            for (i, &angle) in deg.iter().enumerate() {
                let limit = model.limits[i];
                if !limit.contains(angle) {
                    return Err(DemoError::WaypointBeyondLimits {
                        number,
                        joint: JOINT_NAMES[i],
                        angle_deg: angle,
                        min_deg: limit.min_deg,
                        max_deg: limit.max_deg,
                    });
                }
            }
            Ok(deg)
        })
        .collect()
}

/// Joint-space gains: stiffness (N*m/rad) and damping (N*m*s/rad) per joint.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct JointGains {
    /// Stiffness.
    pub kp: Vector4<f64>,
    /// Damping.
    pub kd: Vector4<f64>,
}

impl JointGains {
    /// 120 / 120 / 80 / 40 N*m/rad and 3 / 3 / 2 / 0.6 N*m*s/rad.
    pub fn new() -> Self {
        Self {
            kp: Vector4::new(120.0, 120.0, 80.0, 40.0),
            kd: Vector4::new(3.0, 3.0, 2.0, 0.6),
        }
    }
}

impl Default for JointGains {
    fn default() -> Self {
        Self::new()
    }
}

/// How close the leg came to one waypoint.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Reached {
    /// The waypoint (index).
    pub waypoint: usize,
    /// When the move to it started, s.
    pub started_s: f64,
    /// How long the planned move took, s.
    pub move_s: f64,
    /// Each joint's angle minus the waypoint's after the pause, degrees.
    pub error_deg: [f64; JOINTS],
}

impl Reached {
    /// The largest joint error, degrees.
    pub fn max_error_deg(&self) -> f64 {
        self.error_deg.iter().fold(0.0f64, |m, e| m.max(e.abs()))
    }
}

/// What the follower is doing.
#[derive(Copy, Clone, Debug, PartialEq)]
enum Stage {
    /// Moving to waypoint `i` (started at `since`).
    Moving { i: usize, since: f64 },
    /// Pausing at waypoint `i` until `until`.
    Pausing {
        i: usize,
        until: f64,
        since: f64,
        move_s: f64,
    },
}

/// The joint-space trajectory follower.
#[derive(Clone, Debug)]
pub struct Follower {
    model: LegModel,
    joints: LegJoints,
    gains: JointGains,
    waypoints: Vec<[f64; JOINTS]>,
    pause_s: f64,
    input: Input<JOINTS>,
    generator: OnlineGenerator<JOINTS>,
    stage: Stage,
    t0: f64,
    /// One entry per waypoint reached (capacity reserved up front: pushing never allocates).
    pub reached: Vec<Reached>,
    /// A planning error, if one stopped the run.
    pub error: Option<TrajectoryError>,
}

impl Follower {
    /// A follower of the leg `hip_aa` .. `ankle` of `robot` through `waypoints` (degrees),
    /// pausing `pause_s` at each.
    pub fn new(
        robot: &Robot,
        model: LegModel,
        waypoints: Vec<[f64; JOINTS]>,
        pause_s: f64,
    ) -> Result<Self, DemoError> {
        if !(pause_s.is_finite() && pause_s >= 0.0) {
            return Err(DemoError::Usage(format!(
                "a pause of {pause_s} s: give a duration of zero or more seconds"
            )));
        }
        let period_s = robot.settings().period.get().as_secs_f64();
        Ok(Self {
            joints: LegJoints::find(robot, "")?,
            model,
            gains: JointGains::new(),
            reached: Vec::with_capacity(waypoints.len()),
            waypoints,
            pause_s,
            // deg/s, deg/s², deg/s³ per joint.
            input: Input::with_limits([90.0; JOINTS], [400.0; JOINTS], [4000.0; JOINTS]),
            generator: OnlineGenerator::new(period_s).map_err(|source| DemoError::Plan {
                what: "the moves at the loop's rate",
                source,
            })?,
            stage: Stage::Moving { i: 0, since: 0.0 },
            t0: 0.0,
            error: None,
        })
    }

    /// The waypoints, degrees.
    pub fn waypoints(&self) -> &[[f64; JOINTS]] {
        &self.waypoints
    }

    /// What the run achieved.
    pub fn results(&self) -> FollowResults {
        FollowResults {
            waypoints: self.waypoints.len(),
            reached: self.reached.clone(),
            error: self.error,
        }
    }
}

impl Controller for Follower {
    fn signals(&self) -> Vec<String> {
        SIGNALS.map(String::from).to_vec()
    }

    fn start(&mut self, ctx: &TickContext, feedback: &Feedback<'_>) {
        self.t0 = ctx.time_s();
        let state = LegState::read(feedback, &self.joints);
        self.input.current_position = leg::deg(&state.q);
        if let Some(first) = self.waypoints.first() {
            self.input.target_position = *first;
        }
    }

    fn update(
        &mut self,
        ctx: &TickContext,
        feedback: &Feedback<'_>,
        cmd: &mut Commands<'_>,
    ) -> Flow {
        if self.waypoints.is_empty() || self.error.is_some() {
            return Flow::Stop;
        }
        let t = ctx.time_s() - self.t0;
        let state = LegState::read(feedback, &self.joints);
        // The desired state of this tick: the generator's next state while moving, the waypoint
        // (at rest) while pausing.
        match self.stage {
            Stage::Moving { i, since } => match self.generator.step(&mut self.input) {
                Ok(OnlineStatus::Working) => {}
                Ok(OnlineStatus::Finished) => {
                    self.stage = Stage::Pausing {
                        i,
                        until: t + self.pause_s,
                        since,
                        move_s: self.generator.trajectory().duration(),
                    };
                }
                Err(e) => {
                    self.error = Some(e);
                    return Flow::Halt("a move could not be planned");
                }
            },
            Stage::Pausing {
                i,
                until,
                since,
                move_s,
            } if t >= until => {
                let q = leg::deg(&state.q);
                let wp = self.waypoints[i];
                if self.reached.len() < self.reached.capacity() {
                    self.reached.push(Reached {
                        waypoint: i,
                        started_s: since,
                        move_s,
                        error_deg: [0, 1, 2, 3].map(|j| q[j] - wp[j]),
                    });
                }
                if i + 1 == self.waypoints.len() {
                    return Flow::Stop;
                }
                self.input.target_position = self.waypoints[i + 1];
                self.stage = Stage::Moving { i: i + 1, since: t };
            }
            Stage::Pausing { .. } => {}
        }
        let q_des = leg::rad(self.input.current_position);
        let qd_des = leg::rad(self.input.current_velocity);
        let torque = self.gains.kp.component_mul(&(q_des - state.q))
            + self.gains.kd.component_mul(&(qd_des - state.qd))
            - self.model.gravity_torques(&state.q);
        for (i, joint) in self.joints.ids().into_iter().enumerate() {
            cmd.set_torque(joint, torque[i]);
        }
        let waypoint = match self.stage {
            Stage::Moving { i, .. } | Stage::Pausing { i, .. } => i,
        };
        cmd.set_signal(signal::WAYPOINT, (waypoint + 1) as f64);
        let q = leg::deg(&state.q);
        let mut following_error: f64 = 0.0;
        for (j, desired) in self.input.current_position.into_iter().enumerate() {
            cmd.set_signal(signal::DESIRED_DEG + j, desired);
            following_error = following_error.max((desired - q[j]).abs());
        }
        cmd.set_signal(signal::FOLLOWING_ERROR_DEG, following_error);
        Flow::Continue
    }
}

/// The simulated leg of `robot`: motors matching the description, powered up at
/// [`POWER_UP_DEG`], loaded by the leg's weight fitted there.
pub fn sims(robot: &Robot, seed: u64) -> Result<Vec<SimConfig>, DemoError> {
    let joints = LegJoints::find(robot, "")?;
    let mut sims = rmd_rig::sim::sim_configs(robot, seed);
    leg::simulate_leg(
        &LegModel::new(),
        robot,
        &joints,
        &mut sims,
        POWER_UP_DEG,
        POWER_UP_DEG,
    );
    Ok(sims)
}

/// The follower's part of the status line: the waypoint and the following error, largest
/// current and temperature.
#[derive(Clone, Debug)]
pub struct FollowStatus {
    waypoints: usize,
    latest: Option<(f64, f64)>,
    motors: MotorExtremes,
}

impl FollowStatus {
    /// A status line for a tour of `waypoints` waypoints.
    pub fn new(waypoints: usize) -> Self {
        Self {
            waypoints,
            latest: None,
            motors: MotorExtremes::default(),
        }
    }
}

impl Status for FollowStatus {
    fn observe(&mut self, sample: &TelemetrySample) {
        self.motors.observe(sample);
        let s = sample.signals();
        if let (Some(&w), Some(&e)) = (s.get(signal::WAYPOINT), s.get(signal::FOLLOWING_ERROR_DEG))
        {
            self.latest = Some((w, e));
        }
    }

    fn line(&self) -> String {
        match self.latest {
            Some((w, e)) => format!(
                "waypoint {w:.0}/{}  following error {e:4.2} deg | {}",
                self.waypoints, self.motors
            ),
            None => format!("starting | {}", self.motors),
        }
    }
}

/// What a tour achieved.
#[derive(Clone, Debug, PartialEq)]
pub struct FollowResults {
    /// Waypoints in the tour.
    pub waypoints: usize,
    /// How close the leg came to each waypoint it reached.
    pub reached: Vec<Reached>,
    /// A planning error, if one stopped the run.
    pub error: Option<TrajectoryError>,
}

impl FollowResults {
    /// Whether every waypoint was reached without a planning error.
    pub fn ok(&self) -> bool {
        self.error.is_none() && self.reached.len() == self.waypoints
    }
}

impl Verdict for FollowResults {
    fn ok(&self) -> bool {
        FollowResults::ok(self)
    }
}

impl fmt::Display for FollowResults {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "trajectory_follow results (joint error after the pause, degrees)"
        )?;
        writeln!(
            f,
            "  {:<9}{:>8}{:>8}{:>9}{:>9}{:>9}{:>9}{:>9}",
            "waypoint", "start s", "move s", "hip_aa", "hip_fe", "knee", "ankle", "max"
        )?;
        for r in &self.reached {
            let e = r.error_deg;
            writeln!(
                f,
                "  {:<9}{:>8.2}{:>8.2}{:>9.3}{:>9.3}{:>9.3}{:>9.3}{:>9.3}",
                r.waypoint + 1,
                r.started_s,
                r.move_s,
                e[0],
                e[1],
                e[2],
                e[3],
                r.max_error_deg()
            )?;
        }
        if self.reached.len() < self.waypoints {
            writeln!(
                f,
                "  only {} of {} waypoints reached",
                self.reached.len(),
                self.waypoints
            )?;
        }
        if let Some(e) = &self.error {
            writeln!(f, "  STOPPED: trajectory planning failed: {e}")?;
        }
        Ok(())
    }
}
