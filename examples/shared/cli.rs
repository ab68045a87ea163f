//! The command-line options every example shares: where the motors are, real-time settings,
//! display, and the confirmation before real motors move.

use std::io::{BufRead, IsTerminal, Write};

use rmd_rt::RobotConfig;
use rmd_rt::connect::{ConnectError, Target};

use super::runner::Display;

/// Options shared by the examples (flattened into each example's own).
#[derive(clap::Args, Debug, Clone)]
pub(crate) struct CommonArgs {
    /// CAN interface of the robot's bus, e.g. `can0` (one per bus: repeat the option or give a
    /// comma-separated list). Without it the motors are simulated.
    #[arg(long = "iface", value_name = "IFACE")]
    pub(crate) iface: Vec<String>,
    /// Run the simulated motors in virtual time: deterministic, as fast as the CPU allows.
    #[arg(long)]
    pub(crate) virtual_time: bool,
    /// Loop rate, Hz.
    #[arg(long, value_name = "HZ", default_value_t = 1000.0)]
    pub(crate) rate_hz: f64,
    /// Pin the loop thread to this CPU (ideally an isolated one: see docs/realtime.md).
    #[arg(long, value_name = "CPU")]
    pub(crate) cpu: Option<usize>,
    /// Run the loop thread under SCHED_FIFO at this priority (1..=99; needs the privilege).
    #[arg(long, value_name = "PRIO")]
    pub(crate) fifo_priority: Option<u8>,
    /// Lock the process's memory (mlockall) when the loop starts.
    #[arg(long)]
    pub(crate) lock_memory: bool,
    /// Seed of the simulated motors (turnaround jitter).
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub(crate) seed: u64,
    /// No live display: only the final report.
    #[arg(long, short)]
    pub(crate) quiet: bool,
    /// Do not ask for confirmation before moving real motors.
    #[arg(long, short)]
    pub(crate) yes: bool,
}

impl CommonArgs {
    /// Where the motors are.
    pub(crate) fn target(&self) -> Result<Target, ConnectError> {
        Target::from_args(&self.iface, self.virtual_time)
    }

    /// Applies the real-time options to a robot description.
    pub(crate) fn apply(&self, robot: &mut RobotConfig) {
        robot.loop_config.cpu = self.cpu;
        robot.loop_config.fifo_priority = self.fifo_priority;
        robot.loop_config.lock_memory = self.lock_memory;
    }

    /// The live display to use: none with `--quiet`, a line updated in place on a terminal,
    /// a line per second otherwise (logs).
    pub(crate) fn display(&self) -> Display {
        if self.quiet {
            Display::Quiet
        } else if std::io::stdout().is_terminal() {
            Display::Terminal
        } else {
            Display::Lines
        }
    }

    /// With real motors, says what is about to move and waits for Enter (unless `--yes`);
    /// returns whether to go on. With simulated motors, always goes on.
    pub(crate) fn confirm_motion(&self, target: &Target, what: &str) -> bool {
        if target.is_simulated() || self.yes {
            return true;
        }
        say!("REAL MOTORS on {target}: {what}");
        say!("Make sure nothing and nobody is in the way. Ctrl-C stops the motors at any time.");
        say_raw!("Press Enter to start (or Ctrl-C to quit): ");
        let _ = std::io::stdout().flush();
        let mut line = String::new();
        matches!(std::io::stdin().lock().read_line(&mut line), Ok(n) if n > 0)
    }
}
