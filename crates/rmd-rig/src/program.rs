//! A whole program around one controller, the way every example runs: the robot description
//! (the program's own, or `--robot FILE`) with the loop flags written in, its buses where the
//! flags place them (simulated motors unless `--iface` names interfaces), a first line saying
//! what runs, confirmation before real motors move, the supervised loop under the
//! [`Runner`] (signal policy, status line, telemetry), the report, the program's own results and
//! the exit status (0 normal, 1 fault or results not achieved, 2 could not start, 130 after a
//! signal). What stays the program's: its flags, its robot, its controller and what it says.
//!
//! ```no_run
//! use std::process::ExitCode;
//! use std::time::Duration;
//!
//! use clap::Parser;
//! use rmd_loop::{Commands, Controller, Feedback, Flow, TickContext, telemetry::TelemetrySample};
//! use rmd_rig::args::{LoopArgs, OutputArgs, RobotArgs};
//! use rmd_rig::program::{Launch, Program};
//! use rmd_rig::runner::Status;
//! use rmd_rig::sim;
//!
//! struct Idle;
//! impl Controller for Idle {
//!     fn update(&mut self, _: &TickContext, _: &Feedback<'_>, _: &mut Commands<'_>) -> Flow {
//!         Flow::Continue
//!     }
//! }
//!
//! /// The status line's part: the newest tick's time.
//! #[derive(Default)]
//! struct Clock(f64);
//! impl Status for Clock {
//!     fn observe(&mut self, sample: &TelemetrySample) {
//!         self.0 = sample.time_s;
//!     }
//!     fn line(&self) -> String {
//!         format!("t = {:.1} s", self.0)
//!     }
//! }
//!
//! #[derive(Parser)]
//! struct Args {
//!     #[command(flatten)]
//!     robot: RobotArgs,
//!     #[command(flatten)]
//!     run: LoopArgs,
//!     #[command(flatten)]
//!     output: OutputArgs,
//! }
//!
//! const ROBOT: &str = "[[bus]]\ninterface = \"can0\"\n[[bus.motor]]\nid = 1\ngear_ratio = 9.0";
//!
//! fn main() -> ExitCode {
//!     let args = Args::parse();
//!     Program::new("idle", ROBOT, &args.robot, &args.run, &args.output)
//!         .duration(Duration::from_secs(2))
//!         .main(
//!             |site| {
//!                 Ok(Launch {
//!                     banner: format!("idle: {} joint(s) on {}", site.robot.joint_count(), site.placement),
//!                     motion: "nothing moves: zero torque for two seconds".into(),
//!                     sims: sim::sim_configs(site.robot, args.robot.seed),
//!                     controller: Idle,
//!                     status: Clock::default(),
//!                 })
//!             },
//!             |finished, _, _| format!("idle for {:.1} s\n", finished.outcome.report.duration_s),
//!         )
//! }
//! ```

use core::fmt;
use std::error::Error;
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use rmd_loop::{Controller, robot::Robot};
use rmd_sim::SimConfig;

use crate::args::{LoopArgs, OutputArgs, RobotArgs};
use crate::error::RigError;
use crate::open::Rig;
use crate::placement::{Placement, PlacementDefault};
use crate::runner::{EXIT_FAULT, EXIT_OK, Finished, Runner, Status, exit_with_error};

/// A program's run from its standard flags to its exit status ([`main`](Self::main)).
#[derive(Debug)]
pub struct Program<'a> {
    name: &'a str,
    description: &'a str,
    robot: &'a RobotArgs,
    run: &'a LoopArgs,
    output: &'a OutputArgs,
    duration: Option<Duration>,
    csv: Option<PathBuf>,
    time_line: bool,
    gap_before_results: bool,
}

/// Where the program runs, for its setup: the robot as the flags made it, where its buses are,
/// and how long the run lasts.
#[derive(Debug)]
pub struct Site<'a> {
    /// The robot, the loop flags written in.
    pub robot: &'a Robot,
    /// Where each bus is for this run.
    pub placement: &'a Placement,
    /// How long the run lasts: `--duration`, else the program's (`None`: until stopped).
    pub duration: Option<Duration>,
}

/// What a program brings to its run once it knows its robot.
#[derive(Debug)]
pub struct Launch<K, S> {
    /// The first line on standard output, saying what runs (not with `--quiet` or `--json`;
    /// empty: none).
    pub banner: String,
    /// What is about to move, said before real motors move (see [`RobotArgs::confirm_motion`]).
    pub motion: String,
    /// The simulated motors of each bus, in bus order (used where the placement simulates).
    pub sims: Vec<SimConfig>,
    /// The controller.
    pub controller: K,
    /// The program's part of the status line (`()`: none); handed to the results after the run.
    pub status: S,
}

/// What a program says after the report (not with `--json`; an empty text: nothing), and whether
/// the run did what it set out to do.
pub trait Verdict: fmt::Display {
    /// Whether the program achieved its aim: `false` turns the exit status of a run that ended
    /// normally into 1.
    fn ok(&self) -> bool {
        true
    }
}

/// Results that are only said (`String::new()`: nothing to say).
impl Verdict for String {}

impl<'a> Program<'a> {
    /// The program `name` (the prefix of its error messages) on the robot `description` (a
    /// TOML robot description, replaced by `--robot FILE`), run as its standard flags say.
    pub fn new(
        name: &'a str,
        description: &'a str,
        robot: &'a RobotArgs,
        run: &'a LoopArgs,
        output: &'a OutputArgs,
    ) -> Self {
        Self {
            name,
            description,
            robot,
            run,
            output,
            duration: None,
            csv: None,
            time_line: false,
            gap_before_results: false,
        }
    }

    /// How long to run unless `--duration` says otherwise (default: until stopped).
    pub fn duration(mut self, duration: Duration) -> Self {
        self.duration = Some(duration);
        self
    }

    /// Writes every tick to this CSV file unless `--csv` names another (default: no CSV file
    /// without `--csv`).
    pub fn csv(mut self, path: impl Into<PathBuf>) -> Self {
        self.csv = Some(path.into());
        self
    }

    /// Says `ran 10.0 s of loop time in 0.6 s of wall time` before the report (not with
    /// `--quiet` or `--json`).
    pub fn time_line(mut self) -> Self {
        self.time_line = true;
        self
    }

    /// Leaves a blank line between the report and the results.
    pub fn gap_before_results(mut self) -> Self {
        self.gap_before_results = true;
        self
    }

    /// Runs the program and returns its exit status: `setup` builds what runs from the robot
    /// and its placement before anything moves, `results` reads the run (its loop outcome, the
    /// status, the robot) after the report. An error from either, or from opening the robot,
    /// is printed as `name: error` with exit status 2.
    pub fn main<K, S, R>(
        self,
        setup: impl FnOnce(&Site<'_>) -> Result<Launch<K, S>, Box<dyn Error>>,
        results: impl FnOnce(&Finished<K>, &S, &Robot) -> R,
    ) -> ExitCode
    where
        K: Controller + 'static,
        S: Status,
        R: Verdict,
    {
        let name = self.name;
        self.run_to_end(setup, results)
            .unwrap_or_else(|e| exit_with_error(name, &e))
    }

    /// [`main`](Self::main) with the errors returned.
    fn run_to_end<K, S, R>(
        self,
        setup: impl FnOnce(&Site<'_>) -> Result<Launch<K, S>, Box<dyn Error>>,
        results: impl FnOnce(&Finished<K>, &S, &Robot) -> R,
    ) -> Result<ExitCode, Box<dyn Error>>
    where
        K: Controller + 'static,
        S: Status,
        R: Verdict,
    {
        let mut description = self.robot.description(self.description)?;
        self.run.apply(&mut description);
        let robot = Robot::try_from(description)?;
        let placement = self.robot.placement(&robot, PlacementDefault::Simulated)?;
        let duration = self.run.duration.or(self.duration);
        let mut launch = setup(&Site {
            robot: &robot,
            placement: &placement,
            duration,
        })?;
        let json = self.output.json;
        let chatty = !(self.output.quiet || json);
        if chatty && !launch.banner.is_empty() {
            say(&launch.banner);
        }
        if !self.robot.confirm_motion(&placement, &launch.motion) {
            return Err(RigError::NotConfirmed.into());
        }
        let rig = Rig::open(&robot, &placement, launch.sims)?;
        let rt = rig.into_loop(robot.clone(), launch.controller)?;

        let mut runner = Runner::from_args(self.output);
        if let (None, Some(csv)) = (&self.output.telemetry.csv, &self.csv) {
            runner = runner.csv(Some(csv.as_path()));
        }
        let finished = runner
            .status(&mut launch.status)
            .run(rt, self.run.limit(self.duration))?;
        if chatty && self.time_line {
            say(format_args!(
                "ran {:.1} s of loop time in {:.1} s of wall time",
                finished.outcome.report.duration_s,
                finished.wall_time.as_secs_f64()
            ));
        }
        finished.print_report(json);
        let verdict = results(&finished, &launch.status, &robot);
        let said = verdict.to_string();
        if !json && !said.is_empty() {
            let gap = if self.gap_before_results { "\n" } else { "" };
            say(format_args!("{gap}{said}"));
        }
        Ok(match finished.exit_status() {
            EXIT_OK if !verdict.ok() => ExitCode::from(EXIT_FAULT),
            status => ExitCode::from(status),
        })
    }
}

/// Prints `text` and a line break on standard output; a closed standard output (`| head`) is
/// ignored: printing never stops a run.
fn say(text: impl fmt::Display) {
    let _ = writeln!(std::io::stdout(), "{text}");
}
