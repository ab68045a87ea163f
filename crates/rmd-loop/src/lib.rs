//! # rmd-loop: the real-time loop of rmd-rt
//!
//! The robot description, the `Controller` API, the engine, the exchange, the safe stop and the
//! supervisor. Above `rmd-protocol` and `rmd-bus`; `rmd-rig` opens buses for it.
//!
//! Runs a [`Controller`] at a fixed rate for a [`Robot`](robot::Robot) of one or more CAN buses
//! of up to four RMD motors each. Every tick it sends one 0x280 multi-motor torque frame per bus,
//! collects the 0xA1 replies of motors 1..=4 (matched to their requests, late ones recognised),
//! hands the controller each joint's feedback by [`JointId`], and measures itself: wake latency,
//! round trip, controller time and work per tick in HdrHistograms, deadline misses, missing and
//! late replies. When it stops, for whatever reason (request, emergency stop, fault, controller
//! panic, dropped handle), it sends zero torque and then motor-off to every motor, and reports why.
//!
//! It sits above `rmd-bus` (any [`CanBus`](rmd_bus::CanBus), any [`Clock`](rmd_bus::Clock)) and
//! `rmd-protocol`; `rmd-rig` opens real or simulated buses for it.
//!
//! - [`robot`]: the robot description (TOML or builder), parsed once into a checked
//!   [`Robot`](robot::Robot).
//! - [`Controller`] with [`Feedback`] and [`Commands`]: what you write; [`RtLoop`]: what runs it;
//!   [`LoopHandle`]: its remote control; [`Stopper`]: a stop button for any thread.
//! - [`schedule`]: the absolute-deadline scheduler (also used by `rmd bench jitter`).
//! - [`mailbox`]: lock-free channels to and from the loop thread; [`telemetry`]: what it publishes.
//!
//! Below every controller the loop enforces each joint's limits from the description
//! (`position_min_deg`, `position_max_deg`, `velocity_limit_dps`): torque that pushes a joint
//! further past one is refused (zero torque, counted as `limited`), and a joint further past one
//! than its margin is a [`Fault::JointLimit`].
//!
//! Real-time rules the loop keeps, and asks of controllers: after start-up, a tick allocates no
//! memory, takes no lock and blocks only in the bus I/O and the timed wait.
//!
//! Inside, each file has one job: `engine` (the tick sequence), `startup` (thread setup and the
//! probe), `exchange/` (send, collect, match, account), `guard` (the joint limits), `stop`
//! (stop requests), `safe_stop`
//! (zero torque then motor off), `finish` (the report).

mod bus_link;
mod commands;
mod controller;
mod engine;
mod exchange;
mod feedback;
mod finish;
mod guard;
mod handle;
mod health;
pub mod jitter;
mod joint;
mod joint_array;
mod loop_link;
mod loop_parts;
pub mod mailbox;
pub mod mapping;
mod motion;
pub mod os;
mod panics;
mod protection;
mod rejection;
mod report;
pub mod robot;
mod safe_stop;
pub mod schedule;
mod stall;
mod startup;
pub mod stats;
mod stop;
mod stopper;
pub mod supervisor;
pub mod telemetry;
mod versions;
mod vitals;

pub use commands::{Commands, MAX_SIGNALS, Rejection};
pub use controller::{Controller, Flow, TickContext};
pub use engine::{BuildError, RtLoop, RunLimit, Running};
pub use feedback::{
    Feedback, Freshness, JointFeedback, JointSide, MotorSide, RawMotion, RawReply, RawStatus,
};
pub use finish::LoopOutcome;
pub use guard::{LimitBreach, LimitKind};
pub use handle::{LoopHandle, LoopThreadDied, SpawnError};
pub use health::{ErrorFlags, MotorFlag, MotorHealth};
pub use joint::JointId;
pub use joint_array::JointArray;
pub use motion::{CommandKind, MotionCommand};
pub use protection::{MotorProtection, Protection};
pub use report::{
    BusSafeStop, BusStopOutcome, Fault, IdentifiedMotor, LoopReport, MotorRef, MotorSafeStop,
    PanicReport, SafeStopBy, SafeStopReport, StopReason,
};
pub use stall::{StallCause, TickStage};
pub use stop::StopRequest;
pub use stopper::Stopper;
