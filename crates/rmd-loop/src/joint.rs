//! Joint handles: a [`JointId`] names one joint of a [`Robot`] (resolved
//! once from its name, then used every tick), and a [`JointArray`] holds one value per joint.
//!
//! ```
//! use rmd_loop::robot::{BusConfig, MotorConfig, Robot, RobotConfig};
//! use rmd_loop::joint::JointArray;
//!
//! let robot = Robot::try_from(RobotConfig::new(1000.0).with_bus(
//!     BusConfig::new("can0")
//!         .with_motor(MotorConfig::new(1).name("hip"))
//!         .with_motor(MotorConfig::new(2).name("knee")),
//! ))?;
//! let knee = robot.joint("knee")?;
//! let mut targets = JointArray::new(&robot, 0.0_f64);
//! targets[knee] = 45.0;
//! assert_eq!(targets.iter().map(|(_, t)| *t).collect::<Vec<_>>(), [0.0, 45.0]);
//! # Ok::<(), rmd_loop::robot::RobotError>(())
//! ```

use core::fmt;
use core::ops::{Index, IndexMut};

use crate::robot::Robot;

/// One joint of a robot: its position in the robot description (bus by bus, motor by motor).
///
/// Get it from the joint's name with [`Robot::joint`], or iterate with [`Robot::joint_ids`].
/// It is an index: cheap to copy, and valid for the robot it came from.
#[derive(Copy, Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct JointId(u16);

impl JointId {
    /// The joint at `index` in description order (no check against a robot: prefer
    /// [`Robot::joint`] or [`Robot::joint_ids`]).
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

/// One value per joint of a robot, indexed by [`JointId`]: a controller's per-joint state,
/// sized to the robot (allocated when built, never on the real-time path).
#[derive(Clone, Debug, PartialEq)]
pub struct JointArray<T> {
    values: Vec<T>,
}

impl<T: Clone> JointArray<T> {
    /// `value` for every joint of `robot`.
    pub fn new(robot: &Robot, value: T) -> Self {
        Self {
            values: vec![value; robot.joint_count()],
        }
    }
}

impl<T> JointArray<T> {
    /// The value of each joint of `robot`, from a function of its id.
    pub fn from_fn(robot: &Robot, f: impl FnMut(JointId) -> T) -> Self {
        Self {
            values: robot.joint_ids().map(f).collect(),
        }
    }

    /// Number of joints.
    pub fn len(&self) -> usize {
        self.values.len()
    }

    /// Whether there are no joints.
    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }

    /// The value of joint `id`, if the robot has it.
    pub fn get(&self, id: JointId) -> Option<&T> {
        self.values.get(id.index())
    }

    /// Every joint with its value, in description order.
    pub fn iter(&self) -> impl Iterator<Item = (JointId, &T)> {
        self.values
            .iter()
            .enumerate()
            .map(|(i, v)| (JointId::from_index(i), v))
    }

    /// Every joint with its value, mutable.
    pub fn iter_mut(&mut self) -> impl Iterator<Item = (JointId, &mut T)> {
        self.values
            .iter_mut()
            .enumerate()
            .map(|(i, v)| (JointId::from_index(i), v))
    }

    /// The values in description order.
    pub fn as_slice(&self) -> &[T] {
        &self.values
    }

    /// The values in description order, mutable.
    pub fn as_mut_slice(&mut self) -> &mut [T] {
        &mut self.values
    }
}

impl<T> Index<JointId> for JointArray<T> {
    type Output = T;
    fn index(&self, id: JointId) -> &T {
        &self.values[id.index()]
    }
}

impl<T> IndexMut<JointId> for JointArray<T> {
    fn index_mut(&mut self, id: JointId) -> &mut T {
        &mut self.values[id.index()]
    }
}
