//! A whole program from its flags to its exit status: the loop flags reach the robot the setup
//! sees, the run lasts `--duration` or the program's own, the CSV goes to the program's file
//! unless `--csv` names another, the status sees every tick and the results read it, and the
//! exit status is 0, 1 when the results say the aim was missed, 2 when the setup fails.

use std::path::Path;
use std::process::ExitCode;
use std::time::Duration;

use rmd_loop::{Commands, Controller, Feedback, Flow, TickContext, telemetry::TelemetrySample};
use rmd_rig::args::{LoopArgs, OutputArgs, RobotArgs};
use rmd_rig::program::{Launch, Program, Verdict};
use rmd_rig::runner::Status;
use rmd_rig::sim;

/// One motor on one bus: the program's own description.
const ROBOT: &str =
    "[[bus]]\ninterface = \"can0\"\n[[bus.motor]]\nid = 1\nname = \"arm\"\ngear_ratio = 9.0";

/// The standard flags: `--virtual-time --quiet`, `--rate`, `--duration` and `--csv` as given.
struct Args {
    robot: RobotArgs,
    run: LoopArgs,
    output: OutputArgs,
}

fn args(rate: Option<f64>, duration: Option<Duration>, csv: Option<&Path>) -> Args {
    let mut output = OutputArgs {
        quiet: true,
        ..OutputArgs::default()
    };
    output.telemetry.csv = csv.map(Path::to_path_buf);
    Args {
        robot: RobotArgs {
            virtual_time: true,
            ..RobotArgs::default()
        },
        run: LoopArgs {
            rate,
            duration,
            ..LoopArgs::default()
        },
        output,
    }
}

struct Idle;

impl Controller for Idle {
    fn update(&mut self, _: &TickContext, _: &Feedback<'_>, _: &mut Commands<'_>) -> Flow {
        Flow::Continue
    }
}

/// Counts the ticks it sees.
#[derive(Default)]
struct Ticks(u64);

impl Status for Ticks {
    fn observe(&mut self, _: &TelemetrySample) {
        self.0 += 1;
    }
    fn line(&self) -> String {
        format!("{} ticks", self.0)
    }
}

/// Results whose aim is a number of ticks.
struct Counted {
    seen: u64,
    wanted: u64,
}

impl std::fmt::Display for Counted {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "saw {} ticks of {}", self.seen, self.wanted)
    }
}

impl Verdict for Counted {
    fn ok(&self) -> bool {
        self.seen == self.wanted
    }
}

/// Runs the one-motor program with `args`, its own duration 1 s and CSV file `csv`, and results
/// that want `wanted` ticks; returns the exit status, the rate and duration its setup saw, and
/// the ticks its results saw.
fn run(args: &Args, csv: &Path, wanted: u64) -> (ExitCode, Option<(f64, Option<Duration>)>, u64) {
    let mut seen_by_setup = None;
    let mut seen_by_results = 0;
    let code = Program::new("test", ROBOT, &args.robot, &args.run, &args.output)
        .duration(Duration::from_secs(1))
        .csv(csv)
        .main(
            |site| {
                seen_by_setup = Some((site.robot.settings().period.hz(), site.duration));
                Ok(Launch {
                    banner: "test: one motor".into(),
                    motion: "nothing moves".into(),
                    sims: sim::sim_configs(site.robot, args.robot.seed),
                    controller: Idle,
                    status: Ticks::default(),
                })
            },
            |finished, status, robot| {
                assert_eq!(robot.joint_count(), 1);
                assert_eq!(finished.outcome.report.stats.ticks, status.0);
                seen_by_results = status.0;
                Counted {
                    seen: status.0,
                    wanted,
                }
            },
        );
    (code, seen_by_setup, seen_by_results)
}

#[test]
fn the_flags_reach_the_setup_and_the_run_and_the_results_set_the_exit_status() {
    let dir = tempfile::tempdir().unwrap();
    let own = dir.path().join("own.csv");
    // The program's duration, at the flag's rate: 500 ticks, seen by the status and the results.
    let (code, setup, ticks) = run(&args(Some(500.0), None, None), &own, 500);
    assert_eq!(code, ExitCode::SUCCESS);
    assert_eq!(setup, Some((500.0, Some(Duration::from_secs(1)))));
    assert_eq!(ticks, 500);
    let rows = std::fs::read_to_string(&own).unwrap().lines().count();
    assert_eq!(rows, 1 + 500, "a header and a row a tick");

    // --duration and --csv replace the program's own; results that miss their aim exit 1.
    let other = dir.path().join("other.csv");
    std::fs::remove_file(&own).unwrap();
    let flags = args(Some(500.0), Some(Duration::from_millis(200)), Some(&other));
    let (code, setup, ticks) = run(&flags, &own, 500);
    assert_eq!(code, ExitCode::from(rmd_rig::runner::EXIT_FAULT));
    assert_eq!(setup, Some((500.0, Some(Duration::from_millis(200)))));
    assert_eq!(ticks, 100);
    assert!(!own.exists());
    assert_eq!(
        std::fs::read_to_string(&other).unwrap().lines().count(),
        1 + 100
    );
}

#[test]
fn a_setup_that_fails_or_a_bad_description_exits_2_before_anything_runs() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("never.csv");
    let args = args(None, None, None);
    let code = Program::new("test", ROBOT, &args.robot, &args.run, &args.output)
        .csv(&csv)
        .main(
            |_| -> Result<Launch<Idle, Ticks>, Box<dyn std::error::Error>> {
                Err("no plan".into())
            },
            |_, _, _| -> String { unreachable!("nothing ran") },
        );
    assert_eq!(code, ExitCode::from(rmd_rig::runner::EXIT_USAGE));
    assert!(!csv.exists());

    // The description is checked before the setup runs.
    let code = Program::new("test", "[[bus]]", &args.robot, &args.run, &args.output).main(
        |_| -> Result<Launch<Idle, Ticks>, Box<dyn std::error::Error>> {
            unreachable!("the description is invalid")
        },
        |_, _, _| -> String { unreachable!("nothing ran") },
    );
    assert_eq!(code, ExitCode::from(rmd_rig::runner::EXIT_USAGE));
}
