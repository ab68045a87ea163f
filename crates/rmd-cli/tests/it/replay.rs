//! `rmd replay` on hostile logs: a line of hundreds of megabytes is reported and skipped without
//! being read into memory, the frames around it still play; a pause of centuries between two
//! frames is played as `--max-gap` and said. No assertion depends on timing: a replay that
//! waits for the recorded pause simply never ends (the harness's limit catches it).

use std::io::Write;
use std::path::PathBuf;

use crate::support;
use support::{fails, ok, rmd, text};

/// A fresh file path in a per-test directory.
fn path(test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("rmd-replay-{}-{test}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join("bus.log")
}

/// Bytes of the over-long line.
const LONG_LINE: usize = 256 * 1024 * 1024;

#[test]
fn a_line_of_hundreds_of_megabytes_is_skipped_unread_and_the_rest_plays() {
    let log = path("long-line");
    {
        let mut file = std::io::BufWriter::new(std::fs::File::create(&log).unwrap());
        writeln!(file, "(1.000000) can0 141#9C00000000000000").unwrap();
        write!(file, "(1.000100) can0 141#").unwrap();
        let block = vec![b'A'; 1024 * 1024];
        for _ in 0..LONG_LINE / block.len() {
            file.write_all(&block).unwrap();
        }
        writeln!(file).unwrap();
        writeln!(file, "(1.000200) can0 142#9C00000000000000").unwrap();
    }
    let out = rmd(&["replay", log.to_str().unwrap(), "--fast"]);
    // The largest child's peak resident memory: rmd, the only child this test process starts
    // (nextest runs each test in a process of its own).
    let peak_kib = nix::sys::resource::getrusage(nix::sys::resource::UsageWho::RUSAGE_CHILDREN)
        .unwrap()
        .max_rss();
    let _ = std::fs::remove_file(&log);
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    let stdout = text(&out.stdout);
    let lines: Vec<&str> = stdout.lines().collect();
    assert_eq!(lines.len(), 2, "both frames around the long line play");
    assert!(lines[1].contains("142#9C"), "{lines:?}");
    assert!(
        stderr.contains("line 2: longer than 1024 bytes (268435476 bytes)"),
        "{stderr}"
    );
    // Holding the line would take at least its size; the reader holds at most 1 KiB of it.
    assert!(
        peak_kib < 64 * 1024,
        "rmd peaked at {peak_kib} KiB replaying a {} MiB line",
        LONG_LINE >> 20
    );
}

#[test]
fn a_pause_of_centuries_is_played_as_max_gap_and_said() {
    let log = path("gap");
    // 263 years between the two frames (and back to a sane spacing after).
    std::fs::write(
        &log,
        "(1.000000) can0 141#9C00000000000000\n\
         (8294000001.000000) can0 142#9C00000000000000\n\
         (8294000001.000100) can0 143#9C00000000000000\n",
    )
    .unwrap();
    let out = rmd(&["replay", log.to_str().unwrap(), "--max-gap", "50ms"]);
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    assert_eq!(text(&out.stdout).lines().count(), 3);
    assert!(
        stderr.contains("replay: line 2 comes 262years")
            && stderr.contains("after the frame before it: played 50ms later (--max-gap)"),
        "{stderr}"
    );
    // `--fast` plays no pause at all; a cap beyond a day is refused.
    assert_eq!(
        ok(&["replay", log.to_str().unwrap(), "--fast"])
            .lines()
            .count(),
        3
    );
    let err = fails(2, &["replay", log.to_str().unwrap(), "--max-gap", "2d"]);
    assert!(err.contains("--max-gap"), "{err}");
}
