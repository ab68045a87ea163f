//! # rmd-loop: the real-time loop of rmd-rt
//!
//! Runs a [`Controller`] at a fixed rate for one or more CAN buses of up to four RMD motors
//! each. Every tick it sends one 0x280 multi-motor torque frame per bus, collects the 0xA1
//! replies of motors 1..=4 (matched by id, late ones recognised), hands the controller fresh
//! feedback, and measures itself: wake latency, round trip, controller time and work per tick
//! in HdrHistograms, deadline misses, missing and late replies. When it stops, for whatever
//! reason (request, emergency stop, fault, controller panic, dropped handle), it sends zero torque
//! and then motor-off to every motor, and reports why.
//!
//! It runs on any [`CanBus`](rmd_bus::CanBus) (SocketCAN, the simulator) and any
//! [`Clock`](rmd_bus::Clock) (real time, or virtual time for fast deterministic tests).
//!
//! - [`config`]: the robot description (TOML or builder).
//! - [`Controller`]: what you write; [`RtLoop`]: what runs it; [`LoopHandle`]: its remote control.
//! - [`schedule`]: the absolute-deadline scheduler (also used by `rmd bench jitter`).
//! - [`mailbox`]: lock-free channels to and from the loop thread.
//!
//! Real-time rules the loop keeps, and asks of controllers: after start-up, a tick allocates no
//! memory, takes no lock and blocks only in the bus I/O and the timed wait.

pub mod config;
pub mod controller;
pub mod engine;
mod exchange;
pub mod handle;
pub mod jitter;
pub mod joint;
pub mod mailbox;
pub mod os;
pub mod report;
mod safety;
pub mod schedule;
pub mod stats;
pub mod telemetry;

pub use config::{BusConfig, MotorConfig, RobotConfig};
pub use controller::{Commands, Controller, Feedback, Flow, MotorFeedback, TickContext};
pub use engine::{BuildError, LoopOutcome, RtLoop, RunLimit, Stopper};
pub use handle::{LoopHandle, LoopThreadDied, SpawnError};
pub use report::{Fault, LoopReport, SafeStopReport, StopReason};
pub use stats::{LoopStats, Percentiles, StatsSummary};
pub use telemetry::TelemetrySample;
