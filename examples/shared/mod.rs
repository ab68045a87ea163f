//! Code the examples share: the 4-motor leg (kinematics, gravity, description, simulation), the
//! Cartesian impedance law, the step cycle, the command-line options and the run loop with its
//! live display. Each example (and each example's test) includes this module; not every one uses
//! every item, hence the `dead_code` allowance where it is included.

pub(crate) mod cli;
pub(crate) mod impedance;
pub(crate) mod leg;
pub(crate) mod runner;
pub(crate) mod step_cycle;
