//! # rmd-drill: fault drills judged by the simulated firmware
//!
//! A PD position hold on simulated motors, faults injected at chosen times, and the verdict from
//! the simulated firmware's ground truth. Above `rmd-rig`; `rmd drill` runs it.
//!
//! A drill holds every joint of `buses` x `motors` RMD-X8-class motors (1:9, each swinging a
//! 1 kg arm, about 0.8 A to hold) with the loop as every program runs it (supervised), injects
//! one [`DrillFault`] at `--at`, and then asks the simulated motors, not the loop: which are
//! still energised, and how long after the fault every one of them was safe. `rmd drill` is the
//! command; [`run`] and [`chaos`](chaos::chaos) are the library.
//!
//! ```
//! use core::time::Duration;
//! use rmd_drill::{DrillFault, DrillSpec};
//! use rmd_rig::SimTime;
//! // Bus 0 goes bus-off for 50 ms at 0.2 s, on a two-bus robot, in virtual time.
//! let drill = rmd_drill::run(
//!     &DrillSpec::new("bus-off:50".parse::<DrillFault>()?)
//!         .buses(2)
//!         .at(Duration::from_millis(200))
//!         .seconds(Duration::from_millis(500))
//!         .time(SimTime::Virtual),
//! )?;
//! assert!(drill.passed(), "{}", drill.to_json());
//! assert!(drill.time_to_safe_ms.unwrap() >= 50.0); // it waited for the restart
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod chaos;
mod controller;
mod error;
mod fault;
mod robot;
mod run;
mod spec;
mod verdict;

pub use error::DrillError;
pub use fault::{DrillFault, FaultParseError, Probability};
pub use run::run;
pub use spec::{DrillSpec, MAX_BUSES, MAX_SECONDS};
pub use verdict::{Drill, SimMotorRef};
