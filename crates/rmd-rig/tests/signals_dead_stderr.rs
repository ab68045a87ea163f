//! The signal policy when stderr cannot be written: a closed pipe (EPIPE) or a full disk
//! (`/dev/full`, ENOSPC). The first SIGINT still stops the loop (zero torque, motor off), the
//! second still is an emergency stop, and the run's MCAP file is finished; proved against the
//! simulated firmware's ground truth, not the loop's belief.
//!
//! Its own test binary without the test harness (the handler is process-wide, and the harness
//! would capture stderr): the parent runs itself once per dead stderr, and the child reports on
//! stdout and by its exit status.

use core::time::Duration;
use std::io::Write;
use std::process::{Command, ExitCode, Stdio};
use std::time::Instant;

use nix::sys::signal::{Signal, raise};
use rmd_loop::{
    Commands, Controller, Feedback, Flow, JointId, RunLimit, StopReason, TickContext, robot::Robot,
};
use rmd_rig::runner::Runner;
use rmd_rig::{Placement, Rig, SharedSim, SimTime, signals, sim};

/// The variable that makes this binary the child, naming the case.
const CHILD: &str = "RMD_SIGNALS_DEAD_STDERR_CHILD";
/// How long the child's run would last without a signal: far longer than any stop takes.
const LIMIT: Duration = Duration::from_secs(20);
/// The longest the parent waits for a child (a lost signal lets the run go on to `LIMIT`).
const GIVE_UP: Duration = Duration::from_secs(60);

/// Drives every joint with a constant current: the motors are energised until stopped.
struct Drive(Vec<JointId>);

impl Controller for Drive {
    fn update(&mut self, _: &TickContext, _: &Feedback<'_>, commands: &mut Commands<'_>) -> Flow {
        for &joint in &self.0 {
            commands.set_current(joint, 0.3);
        }
        Flow::Continue
    }
}

const ROBOT: &str = "[[bus]]\ninterface = \"sim\"\n\
    [[bus.motor]]\nid = 1\ngear_ratio = 9.0\ncurrent_limit_amps = 2.0\n\
    [[bus.motor]]\nid = 2\ngear_ratio = 9.0\ncurrent_limit_amps = 2.0\n";

/// A real-time rig (the signal must stop a loop that would run on), and its simulators.
fn open() -> (
    rmd_loop::RtLoop<rmd_rig::AnyBus, rmd_rig::AnyClock, Drive>,
    Vec<SharedSim>,
) {
    let robot = Robot::from_toml(ROBOT).unwrap();
    let placement = Placement::simulated(&robot, SimTime::Real);
    let rig = Rig::open(&robot, &placement, sim::sim_configs(&robot, 3)).unwrap();
    let sims = rig.buses.iter().filter_map(|b| b.sim().cloned()).collect();
    let drive = Drive(robot.joint_ids().collect());
    (rig.into_loop(robot, drive).unwrap(), sims)
}

/// Motors the simulated firmware says are still energised.
fn energised(sims: &[SharedSim]) -> usize {
    sims.iter()
        .map(|sim| {
            let mut sim = sim.lock();
            let ids: Vec<_> = sim.motors().iter().map(|m| m.id()).collect();
            ids.into_iter()
                .filter(|&id| sim.snapshot(id).is_none_or(|s| s.energising))
                .count()
        })
        .sum()
}

/// Says `line` on stdout (the child's only way to speak: its stderr is dead).
fn say(line: &str) {
    let mut out = std::io::stdout();
    let _ = writeln!(out, "{line}");
    let _ = out.flush();
}

/// Raises SIGINT and waits until the handler counted `count` signals.
fn raise_and_wait(signals: &signals::Signals, count: u32) -> Result<(), String> {
    raise(Signal::SIGINT).map_err(|e| e.to_string())?;
    let give_up = Instant::now() + Duration::from_secs(10);
    while signals.count() < count {
        if Instant::now() > give_up {
            return Err(format!("the handler never counted signal {count}"));
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    Ok(())
}

/// The child: one stop by a first signal, one emergency stop by a second.
fn child() -> Result<(), String> {
    let signals = signals::install().map_err(|e| e.to_string())?;
    let dir = tempfile::tempdir().map_err(|e| e.to_string())?;
    let mcap = dir.path().join("run.mcap");

    // 1. The first signal stops a loop that runs with the motors energised.
    let (rt, sims) = open();
    let stopper = rt.stopper();
    let raiser = std::thread::spawn(move || {
        while !stopper.is_running() {
            std::thread::sleep(Duration::from_millis(1));
        }
        std::thread::sleep(Duration::from_millis(300));
        raise(Signal::SIGINT)
    });
    let finished = Runner::new()
        .mcap(Some(&mcap))
        .run(rt, RunLimit::Duration(LIMIT))
        .map_err(|e| e.to_string())?;
    raiser
        .join()
        .map_err(|_| "the raiser panicked")?
        .map_err(|e| e.to_string())?;
    let report = &finished.outcome.report;
    say(&format!(
        "first signal: stop {}, after {:.1} s, {} motor(s) energised",
        report.stop_reason,
        finished.wall_time.as_secs_f64(),
        energised(&sims)
    ));
    if report.stop_reason != StopReason::Requested || !finished.interrupted {
        return Err(format!(
            "the first signal did not stop the run: {}",
            report.stop_reason
        ));
    }
    if energised(&sims) != 0 {
        return Err("a motor is still energised after the stop (simulated firmware)".into());
    }
    let telemetry = finished.telemetry.as_ref().ok_or("no telemetry report")?;
    let bytes = std::fs::read(&mcap).map_err(|e| e.to_string())?;
    let magic = [0x89, b'M', b'C', b'A', b'P', 0x30, b'\r', b'\n'];
    if !(telemetry.complete() && bytes.starts_with(&magic) && bytes.ends_with(&magic)) {
        return Err(format!("the MCAP file was not finished: {telemetry}"));
    }

    // 2. The second signal is an emergency stop (both counted before the loop runs; the second
    // after the window in which the same signal from the same process repeats the first).
    signals.reset();
    let (rt, sims) = open();
    let watch = signals.watch(rt.stopper());
    raise_and_wait(&signals, 1)?;
    std::thread::sleep(signals::REPEAT_WINDOW);
    raise_and_wait(&signals, 2)?;
    let outcome = rt.run(RunLimit::Duration(LIMIT));
    drop(watch);
    say(&format!(
        "second signal: stop {}, {} motor(s) energised",
        outcome.report.stop_reason,
        energised(&sims)
    ));
    if outcome.report.stop_reason != StopReason::EmergencyStop {
        return Err(format!(
            "not an emergency stop: {}",
            outcome.report.stop_reason
        ));
    }
    if energised(&sims) != 0 {
        return Err("a motor is still energised after the emergency stop".into());
    }
    Ok(())
}

/// Runs the child with `stderr`, returns (exit status, stdout).
fn run_child(case: &str, stderr: Stdio, close_read_end: bool) -> (Option<i32>, String) {
    let mut child = Command::new(std::env::current_exe().unwrap())
        .env(CHILD, case)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(stderr)
        .spawn()
        .unwrap();
    if close_read_end {
        // The reader of its stderr is gone before it writes: every write fails with EPIPE.
        drop(child.stderr.take());
    }
    let out = child.stdout.take().unwrap();
    let reader = std::thread::spawn(move || std::io::read_to_string(out).unwrap_or_default());
    let start = Instant::now();
    let code = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status.code();
        }
        if start.elapsed() > GIVE_UP {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    (code, reader.join().unwrap())
}

fn main() -> ExitCode {
    if std::env::var_os(CHILD).is_some() {
        return match child() {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                say(&format!("FAILED: {e}"));
                ExitCode::FAILURE
            }
        };
    }
    // Listed as one test (nextest asks with `--list`, and `--list --ignored`: none ignored);
    // running it runs the whole binary.
    let args: Vec<String> = std::env::args().collect();
    if args.iter().any(|a| a == "--list") {
        if !args.iter().any(|a| a == "--ignored") {
            println!("signals_act_on_a_dead_stderr: test");
        }
        return ExitCode::SUCCESS;
    }
    let full = std::fs::OpenOptions::new()
        .write(true)
        .open("/dev/full")
        .unwrap();
    let cases = [
        ("stderr /dev/full (ENOSPC)", Stdio::from(full), false),
        ("stderr a closed pipe (EPIPE)", Stdio::piped(), true),
    ];
    let mut failed = false;
    for (case, stderr, close) in cases {
        let (code, out) = run_child(case, stderr, close);
        let ok = code == Some(0);
        failed |= !ok;
        println!("{case}: exit {code:?}\n{out}");
    }
    if failed {
        println!("signals_act_on_a_dead_stderr: FAILED");
        ExitCode::FAILURE
    } else {
        println!("signals_act_on_a_dead_stderr: ok");
        ExitCode::SUCCESS
    }
}
