//! A foot step cycle planned with the trajectory generator (`rmd-traj`): a stance at
//! constant speed along the ground, then a swing that lifts the foot, carries it forward and
//! puts it down moving backwards at the ground speed again. Every segment is a time-optimal,
//! jerk-limited trajectory of the foot's four task coordinates (x, y, z in m, pitch in rad),
//! synchronized so that they arrive together; position, velocity and acceleration are
//! continuous around the cycle.
//!
//! The cycle is planned once, before the loop starts; the approach from wherever the foot is to
//! the start of the cycle is planned in the loop's first tick ([`StepCycle::plan_approach`]: the
//! generator is allocation-free). Sampling is a lookup and a polynomial evaluation.

use nalgebra::Vector4;
use rmd_traj::{Input, Trajectory, TrajectoryError, calculate};

/// Axes of the foot trajectory: x, y, z (m) and pitch (rad).
pub const AXES: usize = 4;

/// The shape and speed of a step.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct StepParams {
    /// The middle of the step (x, y, z in m, pitch in rad, hip frame): the foot passes under it
    /// in the stance.
    pub center: Vector4<f64>,
    /// Step length along x, m.
    pub length_m: f64,
    /// How high the swing lifts the foot, m.
    pub height_m: f64,
    /// Duration of the stance, s (sets the ground speed `length / stance`).
    pub stance_s: f64,
    /// Shortest duration of the swing, s.
    pub swing_s: f64,
    /// Velocity limits of the swing and approach (m/s, rad/s).
    pub max_velocity: [f64; AXES],
    /// Acceleration limits (m/s², rad/s²).
    pub max_acceleration: [f64; AXES],
    /// Jerk limits (m/s³, rad/s³).
    pub max_jerk: [f64; AXES],
}

impl StepParams {
    /// A 12 cm step, 6 cm high, 0.5 s stance and 0.5 s swing, around `center`.
    pub fn new(center: Vector4<f64>) -> Self {
        Self {
            center,
            length_m: 0.12,
            height_m: 0.06,
            stance_s: 0.5,
            swing_s: 0.5,
            max_velocity: [1.0, 0.5, 0.8, 2.0],
            max_acceleration: [10.0, 5.0, 10.0, 20.0],
            max_jerk: [400.0, 200.0, 400.0, 500.0],
        }
    }

    /// Ground speed of the stance, m/s.
    pub fn ground_speed(&self) -> f64 {
        self.length_m / self.stance_s
    }

    /// Where the stance starts (front) and ends (back).
    fn touchdown(&self) -> Vector4<f64> {
        self.center + Vector4::new(self.length_m / 2.0, 0.0, 0.0, 0.0)
    }
    fn liftoff(&self) -> Vector4<f64> {
        self.center - Vector4::new(self.length_m / 2.0, 0.0, 0.0, 0.0)
    }
}

/// What the foot is doing in the step cycle.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum StepPhase {
    /// Moving from where it was to the start of the cycle.
    Approach,
    /// On the ground (or where the ground would be), moving backwards at the ground speed.
    Stance,
    /// In the air, moving forwards.
    Swing,
}

impl StepPhase {
    /// A short name, for displays and CSV files.
    pub fn name(self) -> &'static str {
        match self {
            StepPhase::Approach => "approach",
            StepPhase::Stance => "stance",
            StepPhase::Swing => "swing",
        }
    }

    /// The phase as a number, for a telemetry signal: 0 approach, 1 stance, 2 swing.
    pub fn code(self) -> f64 {
        match self {
            StepPhase::Approach => 0.0,
            StepPhase::Stance => 1.0,
            StepPhase::Swing => 2.0,
        }
    }

    /// The phase a [`code`](Self::code) stands for.
    ///
    /// ```
    /// use rmd_demos::step_cycle::StepPhase;
    /// for phase in [StepPhase::Approach, StepPhase::Stance, StepPhase::Swing] {
    ///     assert_eq!(StepPhase::from_code(phase.code()), Some(phase));
    /// }
    /// assert_eq!(StepPhase::from_code(0.5), None);
    /// ```
    pub fn from_code(code: f64) -> Option<Self> {
        [StepPhase::Approach, StepPhase::Stance, StepPhase::Swing]
            .into_iter()
            .find(|p| p.code() == code)
    }
}

/// The desired foot state at one instant.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct FootTarget {
    /// The phase.
    pub phase: StepPhase,
    /// Position (m, rad).
    pub position: Vector4<f64>,
    /// Velocity (m/s, rad/s).
    pub velocity: Vector4<f64>,
    /// Completed cycles before this instant.
    pub cycle: u64,
}

/// A planned step cycle and the approach to it.
#[derive(Copy, Clone, Debug)]
pub struct StepCycle {
    params: StepParams,
    /// Stance, swing up to the apex, swing down to touchdown.
    segments: [Trajectory<AXES>; 3],
    period_s: f64,
    approach: Trajectory<AXES>,
}

fn input(params: &StepParams) -> Input<AXES> {
    Input::with_limits(
        params.max_velocity,
        params.max_acceleration,
        params.max_jerk,
    )
}

fn segment(
    params: &StepParams,
    from: (Vector4<f64>, Vector4<f64>),
    to: (Vector4<f64>, Vector4<f64>),
    max_velocity_x: Option<f64>,
    minimum_duration: Option<f64>,
) -> Result<Trajectory<AXES>, TrajectoryError> {
    let mut input = input(params);
    if let Some(v) = max_velocity_x {
        input.max_velocity[0] = v;
    }
    input.current_position = from.0.into();
    input.current_velocity = from.1.into();
    input.target_position = to.0.into();
    input.target_velocity = to.1.into();
    input.minimum_duration = minimum_duration;
    calculate(&input)
}

impl StepCycle {
    /// Plans the cycle (not the approach).
    pub fn plan(params: StepParams) -> Result<Self, TrajectoryError> {
        let v = params.ground_speed();
        let back = Vector4::new(-v, 0.0, 0.0, 0.0);
        let apex = params.center + Vector4::new(0.0, 0.0, params.height_m, 0.0);
        // Forward at the apex: fast enough to cover the step in the swing.
        let apex_velocity = Vector4::new(1.5 * params.length_m / params.swing_s, 0.0, 0.0, 0.0);
        // The stance: a cruise at exactly the ground speed (the x limit is the ground speed).
        let stance = segment(
            &params,
            (params.touchdown(), back),
            (params.liftoff(), back),
            Some(v),
            None,
        )?;
        let up = segment(
            &params,
            (params.liftoff(), back),
            (apex, apex_velocity),
            None,
            Some(params.swing_s / 2.0),
        )?;
        let down = segment(
            &params,
            (apex, apex_velocity),
            (params.touchdown(), back),
            None,
            Some(params.swing_s / 2.0),
        )?;
        let segments = [stance, up, down];
        Ok(Self {
            params,
            period_s: segments.iter().map(Trajectory::duration).sum(),
            segments,
            approach: Trajectory::EMPTY,
        })
    }

    /// The step's parameters.
    pub fn params(&self) -> &StepParams {
        &self.params
    }

    /// Duration of one cycle, s.
    pub fn period_s(&self) -> f64 {
        self.period_s
    }

    /// Duration of the stance, s.
    pub fn stance_s(&self) -> f64 {
        self.segments[0].duration()
    }

    /// Duration of the approach, s (0 until it is planned).
    pub fn approach_s(&self) -> f64 {
        self.approach.duration()
    }

    /// Plans the approach from `from` (at rest) to the start of the stance. Allocation-free: runs
    /// in the controller's first tick.
    pub fn plan_approach(&mut self, from: Vector4<f64>) -> Result<(), TrajectoryError> {
        let v = self.params.ground_speed();
        let mut params = self.params;
        // A calmer approach than the swing.
        params.max_velocity = params.max_velocity.map(|x| x * 0.3);
        params.max_acceleration = params.max_acceleration.map(|x| x * 0.2);
        self.approach = segment(
            &params,
            (from, Vector4::zeros()),
            (self.params.touchdown(), Vector4::new(-v, 0.0, 0.0, 0.0)),
            None,
            None,
        )?;
        Ok(())
    }

    /// The desired foot state `t` seconds after the start of the approach.
    pub fn at(&self, t: f64) -> FootTarget {
        let state = |traj: &Trajectory<AXES>, t: f64| {
            let s = traj.state_at(t);
            (
                Vector4::from(s.map(|a| a.position)),
                Vector4::from(s.map(|a| a.velocity)),
            )
        };
        let t_cycle = t - self.approach.duration();
        if t_cycle < 0.0 {
            let (position, velocity) = state(&self.approach, t.max(0.0));
            return FootTarget {
                phase: StepPhase::Approach,
                position,
                velocity,
                cycle: 0,
            };
        }
        let cycle = (t_cycle / self.period_s).floor();
        let mut tau = t_cycle - cycle * self.period_s;
        let mut index = 0;
        while index < 2 && tau >= self.segments[index].duration() {
            tau -= self.segments[index].duration();
            index += 1;
        }
        let (position, velocity) = state(&self.segments[index], tau);
        FootTarget {
            phase: if index == 0 {
                StepPhase::Stance
            } else {
                StepPhase::Swing
            },
            position,
            velocity,
            cycle: cycle as u64,
        }
    }
}
