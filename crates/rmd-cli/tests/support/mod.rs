//! Helpers shared by the tests that run the `rmd` binary and check its exit status and output.
//! Each test binary uses the ones it needs.
#![allow(dead_code)]

use std::process::{Command, Output, Stdio};

/// Runs `rmd ARGS` with an empty standard input (a confirmation prompt reads end of file).
pub(crate) fn rmd(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_rmd"))
        .args(args)
        .stdin(Stdio::null())
        .output()
        .expect("run rmd")
}

/// Process output as text (lossy UTF-8).
pub(crate) fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// Runs `rmd ARGS`, asserting success; returns stdout.
pub(crate) fn ok(args: &[&str]) -> String {
    let out = rmd(args);
    assert!(
        out.status.success(),
        "rmd {}: exit {:?}\nstdout: {}\nstderr: {}",
        args.join(" "),
        out.status.code(),
        text(&out.stdout),
        text(&out.stderr)
    );
    text(&out.stdout)
}

/// Runs `rmd ARGS`, asserting exit status `code`; returns stderr.
pub(crate) fn fails(code: i32, args: &[&str]) -> String {
    let out = rmd(args);
    assert_eq!(
        out.status.code(),
        Some(code),
        "rmd {}\nstdout: {}\nstderr: {}",
        args.join(" "),
        text(&out.stdout),
        text(&out.stderr)
    );
    text(&out.stderr)
}
