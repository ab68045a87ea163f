//! Joint handles: a [`JointId`] names one joint of a [`Robot`](crate::robot::Robot) (resolved once
//! from its name, then used every tick; [`JointArray`](crate::JointArray) holds one value per
//! joint).

use core::fmt;

/// One joint of a robot: its position in the robot description (bus by bus, motor by motor).
///
/// Get it from the joint's name with [`Robot::joint`](crate::robot::Robot::joint), or iterate
/// with [`Robot::joint_ids`](crate::robot::Robot::joint_ids).
/// It is an index: cheap to copy, and valid for the robot it came from.
#[derive(Copy, Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct JointId(u16);

impl JointId {
    /// The joint at `index` in description order (no check against a robot: prefer
    /// [`Robot::joint`](crate::robot::Robot::joint) or
    /// [`Robot::joint_ids`](crate::robot::Robot::joint_ids)).
    pub const fn from_index(index: usize) -> Self {
        Self(index as u16)
    }

    /// The position in description order (also the index into per-joint slices).
    pub const fn index(self) -> usize {
        self.0 as usize
    }
}

impl fmt::Display for JointId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "joint #{}", self.0)
    }
}
