//! # rmd-rig: a robot on its buses, and the runner every program shares
//!
//! Where each bus is, opening SocketCAN or simulated motors, the signal policy, the runner and
//! the standard flags. Above `rmd-loop`, `rmd-sim` and `rmd-bus`; the `rmd` tool and examples use it.
//!
//! Opens a [`Robot`](rmd_loop::robot::Robot) where it is (each bus on the SocketCAN interface its
//! description names, or on simulated motors matching the description; `--iface` and `--sim`
//! override), handles signals one way for the whole project, and runs loops with a status line,
//! CSV telemetry, the report and the standard exit codes. It sits above `rmd-loop`, `rmd-sim` and
//! `rmd-bus`; the `rmd` tool and the examples sit on it.
//!
//! A complete program, on simulated motors in virtual time:
//!
//! ```
//! use rmd_loop::{Commands, Controller, Feedback, Flow, RunLimit, TickContext, robot::Robot};
//! use rmd_rig::{Placement, Rig, SimTime, sim};
//!
//! struct Idle;
//! impl Controller for Idle {
//!     fn update(&mut self, _: &TickContext, _: &Feedback<'_>, _: &mut Commands<'_>) -> Flow {
//!         Flow::Continue
//!     }
//! }
//!
//! let robot = Robot::from_toml("[[bus]]\ninterface = \"can0\"\n[[bus.motor]]\nid = 1\ngear_ratio = 9.0")?;
//! let placement = Placement::simulated(&robot, SimTime::Virtual);
//! let rig = Rig::open(&robot, &placement, sim::sim_configs(&robot, 7))?;
//! let rt = rig.into_loop(robot, Idle)?; // RtLoop::unsupervised + a supervisor on its own bus handles
//! let outcome = rt.run(RunLimit::Ticks(100));
//! assert_eq!(outcome.report.stats.ticks, 100);
//! assert!(outcome.report.safe_stop.all_off_confirmed());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! - [`placement`]: where each bus is for this run; [`open`](mod@open): opening it ([`Rig`]);
//! - [`sim`]: simulated motors that match a description;
//! - [`signals`]: Ctrl-C / SIGTERM: stop, then emergency stop, then exit;
//! - [`args`]: the standard flags (`--robot`, `--sim`, `--iface`, `--duration`, `--rate`, ...);
//! - [`runner`]: running a loop with a status line, CSV, the report and exit codes;
//! - [`program`]: a whole program around one controller, from its flags to its exit status.

pub mod args;
mod bus;
mod clock;
mod error;
pub mod open;
pub mod placement;
pub mod program;
pub mod runner;
pub mod signals;
pub mod sim;
pub mod telemetry;

pub use bus::{AnyBus, SharedSim};
pub use clock::AnyClock;
pub use error::RigError;
pub use open::Rig;
pub use placement::{BusTarget, Placement, PlacementDefault, SimTime};
