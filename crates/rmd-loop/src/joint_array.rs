//! One value per joint of a robot, indexed by [`JointId`].
//!
//! ```
//! use rmd_loop::robot::{BusConfig, MotorConfig, Robot, RobotConfig};
//! use rmd_loop::JointArray;
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

use core::ops::{Index, IndexMut};

use crate::joint::JointId;
use crate::robot::Robot;

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
