//! A tool that helps: suggestions for mistyped commands and flags, an example in every
//! command's help, hints that work as printed.

use std::path::Path;
use std::process::{Command, Stdio};

use crate::support;

use support::{fails, ok, text};

#[test]
fn a_mistyped_command_or_flag_gets_a_suggestion() {
    for (args, suggestion) in [
        (&["staus"][..], "did you mean 'status'?"),
        (
            &["torque", "1", "--sim", "--amp", "1"],
            "did you mean '--amps'?",
        ),
        (&["bench", "rat"], "did you mean 'rate'?"),
        (
            &["monitor", "--sim", "--rat", "5"],
            "did you mean '--rate'?",
        ),
    ] {
        let stderr = fails(2, args);
        assert_eq!(stderr.lines().count(), 1, "one line: {stderr:?}");
        assert!(stderr.starts_with("error: "), "{stderr}");
        assert!(
            stderr.contains(suggestion),
            "rmd {}: {stderr}",
            args.join(" ")
        );
    }
}

/// The commands a message names between backticks.
fn hinted(message: &str) -> Vec<Vec<String>> {
    message
        .split('`')
        .skip(1)
        .step_by(2)
        .filter(|quoted| quoted.starts_with("rmd "))
        .map(|command| {
            command
                .split_whitespace()
                .skip(1)
                .map(str::to_owned)
                .collect()
        })
        .collect()
}

/// A hint that names a command gives it whole (bus and protocol options), and it runs as
/// printed.
#[test]
fn a_hinted_command_runs_as_printed() {
    // `rmd pid set` without a gain names the read that shows them, on the same motors.
    let err = fails(
        2,
        &[
            "pid",
            "set",
            "2",
            "--sim",
            "--sim-ids",
            "2",
            "--encoder-bits",
            "16",
        ],
    );
    let commands = hinted(&err);
    assert_eq!(commands.len(), 1, "{err}");
    let args: Vec<&str> = commands[0].iter().map(String::as_str).collect();
    assert!(ok(&args).starts_with("motor 2: "), "{err}");

    // A robot on several interfaces cannot be recorded with --log: one `rmd log` per
    // interface, each complete (it fails here only because the interface does not exist).
    let robot = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../examples/robots/quadruped.toml"
    );
    let err = fails(
        2,
        &[
            "status",
            "--robot",
            robot,
            "--iface",
            "vcan91,vcan92,vcan93,vcan94",
            "--log",
            "/dev/null",
        ],
    );
    let commands = hinted(&err);
    assert_eq!(commands.len(), 4, "{err}");
    let dir = tempfile::tempdir().unwrap();
    for (command, iface) in commands
        .iter()
        .zip(["vcan91", "vcan92", "vcan93", "vcan94"])
    {
        assert_eq!(command[..3], ["log", "--iface", iface], "{err}");
        let out = Command::new(env!("CARGO_BIN_EXE_rmd"))
            .args(command)
            .current_dir(dir.path())
            .stdin(Stdio::null())
            .output()
            .unwrap();
        let stderr = text(&out.stderr);
        assert_eq!(
            out.status.code(),
            Some(1),
            "rmd {}: {stderr}",
            command.join(" ")
        );
        assert!(
            stderr.contains(&format!("ip link add dev {iface} type vcan")),
            "{stderr}"
        );
    }
    // An interface that cannot be opened leaves no empty log behind.
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

/// Simulated motors end with the command that runs them: no message sends the user to a
/// later command for them (`rmd off 1 --sim` would talk to new motors).
#[test]
fn no_hint_names_a_later_command_for_simulated_motors() {
    let out = ok(&["move", "1", "--deg", "10", "--sim"]);
    assert!(out.contains("holding the position"), "{out}");
    assert!(hinted(&out).is_empty(), "{out}");
    // A motor of another family than --protocol names: the simulated motors' firmware was
    // chosen by an option, so the hint names that option and no later command.
    let err = fails(
        1,
        &[
            "status",
            "1",
            "--sim",
            "--sim-firmware",
            "myactuator-v3",
            "--protocol",
            "v1.61",
        ],
    );
    assert!(hinted(&err).is_empty(), "{err}");
    assert!(err.contains("--sim-firmware chose"), "{err}");
}

/// The commands of `rmd PATH --help`'s command list, as paths.
fn subcommands(path: &[String]) -> Vec<Vec<String>> {
    let mut args: Vec<&str> = path.iter().map(String::as_str).collect();
    args.push("--help");
    let help = ok(&args);
    let Some(list) = help.split("\nCommands:\n").nth(1) else {
        return Vec::new();
    };
    list.lines()
        .take_while(|line| line.starts_with("  "))
        .filter_map(|line| line.split_whitespace().next())
        .filter(|name| *name != "help")
        .map(|name| path.iter().cloned().chain([name.to_owned()]).collect())
        .collect()
}

/// Every command's path (`["pid", "get"]`), from the help of `rmd` and of each command.
fn every_command() -> Vec<Vec<String>> {
    let mut all = Vec::new();
    let mut todo = subcommands(&[]);
    while let Some(path) = todo.pop() {
        todo.extend(subcommands(&path));
        all.push(path);
    }
    all
}

/// The example lines of a help text.
fn examples(help: &str) -> Vec<String> {
    help.split("\nExamples:\n")
        .nth(1)
        .unwrap_or_default()
        .lines()
        .take_while(|line| line.starts_with("  "))
        .map(|line| line.trim().to_owned())
        .collect()
}

#[test]
fn every_command_shows_an_example_of_itself() {
    let all = every_command();
    assert!(all.len() > 50, "{all:?}");
    for path in all {
        let mut args: Vec<&str> = path.iter().map(String::as_str).collect();
        args.push("--help");
        let help = ok(&args);
        let lines = examples(&help);
        assert!(
            !lines.is_empty(),
            "rmd {} --help has no example",
            path.join(" ")
        );
        let own = format!("rmd {}", path.join(" "));
        assert!(
            lines
                .iter()
                .any(|line| line.contains(&own) || path[0] == "encode"),
            "no example of `{own}` in {lines:?}"
        );
    }
}

/// Whether an example runs here, as printed, and ends by itself: no hardware (`--iface`), no
/// real-time privileges (`--fifo`, `--cpu`), no shell beyond a pipe (`>`, `~`, `&&`), and not
/// `rmd ros2` (a DDS node until Ctrl-C, tested in tests/ros2).
fn runs_here(line: &str) -> bool {
    !["--iface", "--fifo", "--cpu", ">", "~", "&&", "rmd ros2"]
        .iter()
        .any(|needs| line.contains(needs))
}

/// Every example that needs no hardware runs as printed, from the repository's root (the
/// files it names are shipped there), and succeeds.
#[test]
fn every_example_that_needs_no_hardware_runs_as_printed() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    // Files the examples write go to a fresh directory that sees the repository's files.
    let dir = tempfile::tempdir().unwrap();
    for shipped in ["data", "examples", "crates"] {
        std::os::unix::fs::symlink(root.join(shipped), dir.path().join(shipped)).unwrap();
    }
    let rmd_dir = Path::new(env!("CARGO_BIN_EXE_rmd")).parent().unwrap();
    let path = format!(
        "{}:{}",
        rmd_dir.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let mut ran = 0;
    for command in every_command() {
        let mut args: Vec<&str> = command.iter().map(String::as_str).collect();
        args.push("--help");
        for line in examples(&ok(&args)) {
            let line = line.split(" # ").next().unwrap().trim().to_owned();
            if !runs_here(&line) {
                continue;
            }
            let out = Command::new("bash")
                .args(["-c", &format!("set -e -o pipefail; {line}")])
                .env("PATH", &path)
                .current_dir(dir.path())
                .stdin(Stdio::null())
                .output()
                .unwrap();
            assert!(
                out.status.success(),
                "`{line}`: exit {:?}\nstdout: {}\nstderr: {}",
                out.status.code(),
                text(&out.stdout),
                text(&out.stderr)
            );
            ran += 1;
        }
    }
    assert!(ran > 40, "only {ran} examples ran");
}

/// GNU `timeout` sends its signal to the command and then to the command's process group (the
/// command again), microseconds apart: one request to stop, never an emergency stop. Sent here
/// as `timeout` sends it, several times, since whether the two arrive apart or merged is up to
/// the scheduler (apart, about one run in five before: then an emergency stop).
#[test]
fn gnu_timeouts_signal_pair_is_one_request() {
    use nix::sys::signal::{Signal, kill};
    use nix::unistd::Pid;
    use std::os::unix::process::CommandExt;

    let dir = tempfile::tempdir().unwrap();
    for run in 0..8 {
        let mcap = dir.path().join(format!("run{run}.mcap"));
        let child = Command::new(env!("CARGO_BIN_EXE_rmd"))
            .args([
                "bench",
                "loop",
                "--virtual-time",
                "--seconds",
                "3000",
                "--json",
                "--mcap",
            ])
            .arg(&mcap)
            .process_group(0)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // Under way: the MCAP file holds its first chunk (the handler is installed by then).
        let give_up = std::time::Instant::now() + std::time::Duration::from_secs(60);
        while std::fs::metadata(&mcap).map_or(0, |m| m.len()) <= 4096 {
            assert!(
                std::time::Instant::now() < give_up,
                "the run never got under way"
            );
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
        let pid = Pid::from_raw(i32::try_from(child.id()).unwrap());
        kill(pid, Signal::SIGTERM).unwrap();
        kill(Pid::from_raw(-pid.as_raw()), Signal::SIGTERM).unwrap();
        let out = child.wait_with_output().unwrap();
        let stderr = text(&out.stderr);
        assert_eq!(out.status.code(), Some(130), "run {run}: {stderr}");
        let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(
            report["stop_reason"], "stop requested",
            "run {run}: {stderr}"
        );
        assert!(!stderr.contains("EMERGENCY"), "run {run}: {stderr}");
        // When the two arrived apart, the note says which was taken for the other.
        if stderr.contains(" again, ") {
            let sender = format!("SIGTERM from process {} again", std::process::id());
            assert!(stderr.contains(&sender), "run {run}: {stderr}");
            assert!(
                stderr.contains("not an emergency stop"),
                "run {run}: {stderr}"
            );
        }
    }
}
