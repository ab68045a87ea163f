//! Trajectories: points with times for some joints, followed with rmd-traj's jerk-limited
//! motion between points.
//!
//! **Where the planning happens.** On the caller's thread, when the trajectory is submitted
//! ([`ServoHandle::send_trajectory`](crate::ServoHandle::send_trajectory)): every joint's motion
//! to every point is planned with `rmd_traj` (one axis, the point's time as the minimum
//! duration), checked against the joint's limits, and written into one of a fixed number of
//! trajectory buffers allocated when the servo was built. The filled buffer travels to the loop
//! thread through the servo's lock-free queue and comes back through another when no joint
//! follows it any more; the loop thread only samples it (a few multiply-adds per joint per
//! tick), never allocates or frees.
//!
//! The first segment is planned from the state the servo last published (the joint's
//! reference). When the trajectory starts, the loop thread compares that with the joint's
//! reference at that tick; if they differ (the joint moved in between: it was following a
//! velocity setpoint or another trajectory, or the trajectory starts later), it plans that one
//! segment again from where the joint is: one single-axis rmd-traj calculation per such joint,
//! bounded and allocation-free, once per trajectory. The later segments keep their plan and
//! shift in time by the difference.

pub(crate) mod buffer;
pub(crate) mod plan;
pub(crate) mod segment;

use core::time::Duration;

/// One point of a trajectory: one value per joint of the trajectory, in its joint order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct JointTrajectoryPoint {
    /// Positions, rad.
    pub positions: Vec<f64>,
    /// Velocities at the point, rad/s. Without them the servo chooses: zero where the motion
    /// turns round (the neighbouring points lie on the same side), else the harmonic mean of
    /// the slopes to the neighbouring points (within the velocity limit); zero at the last point.
    pub velocities: Option<Vec<f64>>,
    /// Accelerations at the point, rad/s² (zero without them).
    pub accelerations: Option<Vec<f64>>,
    /// When the joints are due at the point, from the trajectory's start.
    pub time_from_start: Duration,
}

impl JointTrajectoryPoint {
    /// A point with positions only.
    pub fn at(time_from_start: Duration, positions: impl Into<Vec<f64>>) -> Self {
        Self {
            positions: positions.into(),
            velocities: None,
            accelerations: None,
            time_from_start,
        }
    }

    /// The point with velocities.
    pub fn with_velocities(mut self, velocities: impl Into<Vec<f64>>) -> Self {
        self.velocities = Some(velocities.into());
        self
    }

    /// The point with accelerations.
    pub fn with_accelerations(mut self, accelerations: impl Into<Vec<f64>>) -> Self {
        self.accelerations = Some(accelerations.into());
        self
    }
}

/// When a trajectory starts.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub enum TrajectoryStart {
    /// At the first tick that takes it from the queue (default).
    #[default]
    Now,
    /// At this loop time, s since tick 0 (see [`ServoState::time_s`](crate::ServoState::time_s)
    /// and [`ServoHandle::loop_time_s`](crate::ServoHandle::loop_time_s)); a time already past
    /// starts at once. Until then the joints go on with what they do.
    AtLoopTime(f64),
}

/// A trajectory for some joints of the robot (the form of ROS's
/// `trajectory_msgs/JointTrajectory`).
///
/// ```
/// use std::time::Duration;
/// use rmd_servo::{JointTrajectory, JointTrajectoryPoint};
///
/// let wave = JointTrajectory::new(["hip", "knee"])
///     .point(JointTrajectoryPoint::at(Duration::from_millis(500), [0.2, -0.4]))
///     .point(JointTrajectoryPoint::at(Duration::from_millis(1000), [0.0, 0.0]));
/// assert_eq!(wave.points.len(), 2);
/// ```
#[derive(Clone, Debug, Default, PartialEq)]
pub struct JointTrajectory {
    /// The joints, by name; each point has one value per joint, in this order.
    pub joint_names: Vec<String>,
    /// The points, in time order.
    pub points: Vec<JointTrajectoryPoint>,
    /// When it starts.
    pub start: TrajectoryStart,
}

impl JointTrajectory {
    /// A trajectory for these joints, with no point yet, starting at once.
    pub fn new<S: Into<String>>(joint_names: impl IntoIterator<Item = S>) -> Self {
        Self {
            joint_names: joint_names.into_iter().map(Into::into).collect(),
            points: Vec::new(),
            start: TrajectoryStart::Now,
        }
    }

    /// The trajectory with one more point.
    pub fn point(mut self, point: JointTrajectoryPoint) -> Self {
        self.points.push(point);
        self
    }

    /// The trajectory starting at `start`.
    pub fn starting(mut self, start: TrajectoryStart) -> Self {
        self.start = start;
        self
    }
}

/// What the servo made of a trajectory it accepted.
#[derive(Clone, Debug, PartialEq)]
pub struct TrajectoryReceipt {
    /// When the last joint reaches the last point, s from the trajectory's start (as planned;
    /// the last point's `time_from_start` when every point is reached on time).
    pub duration_s: f64,
    /// The latest arrival at a point beyond its `time_from_start`, s (0 when every point is
    /// reached on time; points too close for the joint's velocity, acceleration and jerk limits
    /// are reached as early as the limits allow).
    pub max_lateness_s: f64,
    /// The joint and point of that latest arrival, if any arrived late.
    pub latest: Option<(String, usize)>,
}
