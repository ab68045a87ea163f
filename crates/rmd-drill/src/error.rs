//! What can keep a drill from running.

/// Why a drill could not run (a drill that ran and found motors energised is not an error: its
/// [`Drill`](crate::Drill) says so).
#[derive(Debug, thiserror::Error)]
pub enum DrillError {
    /// `--buses` out of range.
    #[error("--buses {0}: a drill runs on 1 to {max} buses", max = crate::spec::MAX_BUSES)]
    Buses(u8),
    /// `--motors` out of range.
    #[error("--motors {0}: a drill runs 1 to 4 motors per bus (one 0x280 frame drives ids 1..=4)")]
    Motors(u8),
    /// `--seconds` zero or too long.
    #[error("--seconds: a drill runs for more than 0 s and at most {max} s", max = crate::spec::MAX_SECONDS)]
    Seconds,
    /// The fault would come after the end of the run.
    #[error("--at {at} s is not before the end of the run (--seconds {seconds} s)")]
    AtAfterEnd {
        /// When the fault was asked for, seconds.
        at: f64,
        /// How long the run lasts, seconds.
        seconds: f64,
    },
    /// A fault names a motor the drill does not simulate.
    #[error("{fault}: bus 0 has motors 1..={motors}; name one of them (or raise --motors)")]
    NoSuchMotor {
        /// The fault as written.
        fault: String,
        /// Motors per bus.
        motors: u8,
    },
    /// The undescribed motor would leave bus 0 without a described motor.
    #[error("{fault}: bus 0 would have no described motor left; use --motors 2 or more")]
    NothingDescribed {
        /// The fault as written.
        fault: String,
    },
    /// The drill's robot or simulated motors could not be built (a bug in the drill).
    #[error("the drill's robot could not be built: {0}")]
    Robot(#[from] rmd_loop::robot::RobotError),
    /// The simulated buses or the loop could not be opened.
    #[error("the drill's loop could not be opened: {0}")]
    Rig(#[from] rmd_rig::RigError),
}
