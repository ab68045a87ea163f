//! # rmd-traj
//!
//! Time-optimal, jerk-limited, multi-axis trajectories; `no_std`, allocation-free, depends on
//! `libm` only. Stands alone in rmd-rt: controllers and the `rmd` tool use it.
//!
//! Time-optimal, jerk-limited trajectory generation from any state to any target state, for
//! several axes that arrive together, in the style of Ruckig (Berscheid & Kröger, RSS 2021).
//! `no_std` (disable the default `std` feature; `libm` supplies the float functions) and
//! allocation-free in [`calculate`] and sampling, so it can re-plan every cycle of a control loop.
//!
//! ```
//! use rmd_traj::{calculate, Input};
//! // Two axes, limits in deg/s, deg/s², deg/s³.
//! let mut input = Input::<2>::with_limits([180.0, 90.0], [720.0, 360.0], [7200.0, 3600.0]);
//! input.current_position = [0.0, 10.0];
//! input.target_position = [90.0, -20.0];
//! let traj = calculate(&input)?;
//! let mid = traj.state_at(traj.duration() / 2.0);
//! assert!(mid[0].velocity > 0.0 && mid[1].velocity < 0.0);
//! # Ok::<(), rmd_traj::TrajectoryError>(())
//! ```
//!
//! See `docs/trajectory.md` for the algorithm and its numerical tolerances.
#![cfg_attr(not(feature = "std"), no_std)]
// `!(x <= limit)` is used on purpose throughout: it rejects NaN, which `x > limit` would let
// through. Every value that reaches such a comparison may be NaN for degenerate inputs.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

mod block;
mod brake;
mod calculator;
mod cand;
mod error;
mod input;
mod math;
mod online;
mod position1;
mod position2;
mod profile;
mod roots;
mod trajectory;
mod velocity;

pub use calculator::MAX_SYNCHRONIZED_DURATION;
pub use error::{InputField, InvalidOption, InvalidReason, TrajectoryError};
pub use input::{ControlInterface, DurationDiscretization, Input, Synchronization};
pub use online::{OnlineGenerator, OnlineStatus};
pub use profile::{
    AxisProfile, AxisState, Direction, MAX_BRAKE_PHASES, MAX_PHASES, Phase, ProfileKind,
    ReachedLimits,
};
pub use trajectory::{Trajectory, calculate};
