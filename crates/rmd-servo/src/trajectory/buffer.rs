//! A trajectory buffer: one planned trajectory, allocated once at its full capacity, filled on
//! the caller's thread, read by the loop thread, returned for reuse.

use rmd_loop::JointId;

use super::TrajectoryStart;
use super::segment::Segment;

/// One planned trajectory: segment `[point][column]` is the motion of the trajectory's
/// `column`-th joint to its `point`-th point.
#[derive(Debug)]
pub(crate) struct TrajectoryBuffer {
    /// The enable epoch it was sent in (a disable in between drops it).
    pub(crate) epoch: u64,
    /// When it starts.
    pub(crate) start: TrajectoryStart,
    /// Its joints, in column order.
    joints: Vec<JointId>,
    points: usize,
    segments: Vec<Segment>,
    /// Loop time it started at (set by the loop thread).
    pub(crate) started_at: f64,
    max_points: usize,
    max_joints: usize,
}

impl TrajectoryBuffer {
    /// A buffer for up to `max_points` points of up to `max_joints` joints (allocates).
    pub(crate) fn new(max_points: usize, max_joints: usize) -> Self {
        Self {
            epoch: 0,
            start: TrajectoryStart::Now,
            joints: Vec::with_capacity(max_joints),
            points: 0,
            segments: Vec::with_capacity(max_points * max_joints),
            started_at: 0.0,
            max_points,
            max_joints,
        }
    }

    /// Empties it for `joints` and `points` points, every segment empty (within capacity: no
    /// allocation).
    pub(crate) fn reset(&mut self, joints: &[JointId], points: usize) {
        self.joints.clear();
        self.joints.extend_from_slice(joints);
        self.points = points;
        self.segments.clear();
        self.segments.resize(points * joints.len(), Segment::EMPTY);
        self.started_at = 0.0;
    }

    /// Whether it holds `points` points of `joints` joints.
    pub(crate) fn fits(&self, points: usize, joints: usize) -> bool {
        points <= self.max_points(joints)
    }

    /// The most points it holds for `joints` joints.
    pub(crate) fn max_points(&self, joints: usize) -> usize {
        if joints == 0 || joints > self.max_joints {
            0
        } else {
            self.max_points
        }
    }

    /// Its joints, in column order.
    pub(crate) fn joints(&self) -> &[JointId] {
        &self.joints
    }

    /// Its number of points.
    pub(crate) fn points(&self) -> usize {
        self.points
    }

    /// Whether the two trajectories share a joint.
    pub(crate) fn overlaps(&self, other: &TrajectoryBuffer) -> bool {
        self.joints.iter().any(|j| other.joints.contains(j))
    }

    /// The motion of column `column` to point `point`.
    pub(crate) fn segment(&self, point: usize, column: usize) -> &Segment {
        &self.segments[point * self.joints.len() + column]
    }

    /// The same, to write.
    pub(crate) fn segment_mut(&mut self, point: usize, column: usize) -> &mut Segment {
        let width = self.joints.len();
        &mut self.segments[point * width + column]
    }
}
