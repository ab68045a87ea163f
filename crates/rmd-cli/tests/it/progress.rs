//! Progress of the long commands: drawn on a terminal (here a pseudo-terminal made by util-linux
//! `script`, which Debian always has), nothing extra with `--json` or without a terminal.

use std::process::{Command, Output, Stdio};

/// Runs `rmd ARGS` on a pseudo-terminal (stdin, stdout and stderr), returning what the terminal
/// showed, both streams merged.
fn on_terminal(args: &str) -> String {
    let rmd = env!("CARGO_BIN_EXE_rmd");
    let out = Command::new("script")
        .args([
            "--quiet",
            "--return",
            "--flush",
            "--command",
            &format!("stty cols 100 rows 30; {rmd} {args}"),
            "/dev/null",
        ])
        .stdin(Stdio::null())
        .output()
        .expect("run script (util-linux)");
    let shown = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(out.status.success(), "rmd {args}: {shown}");
    shown
}

/// A small vectors file of the trajectory checker.
const VECTORS: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../rmd-traj-vectors/tests/data/regressions.json"
);

/// Runs `rmd ARGS` with pipes for stdout and stderr.
fn piped(args: &str) -> Output {
    Command::new(env!("CARGO_BIN_EXE_rmd"))
        .args(args.split_whitespace())
        .stdin(Stdio::null())
        .output()
        .unwrap()
}

#[test]
fn long_commands_show_progress_on_a_terminal() {
    // (command, what the display counts, whether it is a bar or a spinner)
    for (args, counting, bar) in [
        (
            "bench loop --virtual-time --duration 300ms",
            "/300 ticks",
            true,
        ),
        ("bench jitter --duration 600ms", "/0.6 s", true),
        (
            "bench rate --virtual-time --rate 1000 --duration 100ms",
            "trial 1 at 1000.0 Hz",
            true,
        ),
        ("scan --sim --ids 1-8", "/8 ids", true),
        ("torque 2 --amps 0.2 --duration 400ms --sim", "/0.4 s", true),
        (&format!("traj check {VECTORS}"), "checking", false),
    ] {
        let shown = on_terminal(args);
        assert!(
            shown.contains(counting),
            "rmd {args}: `{counting}` not in {shown:?}"
        );
        assert_eq!(shown.contains("] "), bar, "rmd {args}: {shown:?}");
        // The display is cleared when the command ends: the last line is the command's own.
        assert!(shown.contains("\u{1b}[2K"), "rmd {args}: {shown:?}");
    }
}

#[test]
fn json_on_a_terminal_is_the_json_alone() {
    let shown = on_terminal("bench loop --virtual-time --duration 300ms --json");
    let lines: Vec<&str> = shown.lines().map(|l| l.trim_end_matches('\r')).collect();
    assert_eq!(lines.len(), 1, "{shown:?}");
    assert!(
        lines[0].starts_with('{') && lines[0].ends_with('}'),
        "{shown:?}"
    );
    let shown = on_terminal("scan --sim --ids 1-4 --json");
    assert!(shown.trim_end().starts_with('['), "{shown:?}");
    assert!(!shown.contains("ids found"), "{shown:?}");
}

#[test]
fn without_a_terminal_nothing_extra() {
    for args in [
        "bench loop --virtual-time --duration 300ms",
        "bench loop --virtual-time --duration 300ms --json",
        &format!("traj check {VECTORS}"),
    ] {
        let out = piped(args);
        assert!(out.status.success(), "rmd {args}");
        assert!(
            out.stderr.is_empty(),
            "rmd {args}: {:?}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    // What scan always said on stderr, and nothing more.
    let out = piped("scan --sim --ids 1-4");
    assert_eq!(
        String::from_utf8_lossy(&out.stderr),
        "4 motors answered on the simulated bus: 1, 2, 3, 4\n"
    );
}
