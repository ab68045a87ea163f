//! A test alone in a process of its own, under `cargo nextest` as under `cargo test`.

use std::process::Command;

/// Set in the child that [`ran_in_own_process`] starts: there, the test goes on.
const CHILD: &str = "RMD_TEST_SUPPORT_OWN_PROCESS";

/// Runs the calling test alone in a process of its own unless it already is in one, for a test
/// that changes process-wide state (a signal, `SIGSTOP`, the environment, a panic hook) or
/// counts every thread's allocations.
///
/// Returns `false` when this process is the test's own, and the caller goes on with the test:
/// under `cargo nextest` (a process per test), in the child this function starts, or when the
/// harness runs the tests one at a time on its main thread (`--test-threads=1`). Otherwise
/// (`cargo test` runs the tests of a binary as parallel threads of one process) it runs the test
/// binary again for this test alone, passes its output on, and returns `true` once the test
/// passed there: the caller returns.
///
/// ```no_run
/// #[test]
/// fn a_stopped_process_is_a_stall() {
///     if rmd_test_support::ran_in_own_process() {
///         return;
///     }
///     // Alone in this process from here on.
/// }
/// ```
///
/// # Panics
///
/// When the test failed in the child, the child ran no test, or it could not be started.
pub fn ran_in_own_process() -> bool {
    if std::env::var_os(CHILD).is_some()
        || std::env::var("NEXTEST_EXECUTION_MODE").as_deref() == Ok("process-per-test")
    {
        return false;
    }
    // The harness names the thread of a test run in parallel after the test.
    let thread = std::thread::current();
    let Some(name) = thread.name().filter(|name| *name != "main") else {
        return false;
    };
    let exe = std::env::current_exe().expect("the test binary's path");
    let output = Command::new(&exe)
        .args([name, "--exact", "--test-threads=1", "--nocapture"])
        .env(CHILD, "1")
        .output()
        .unwrap_or_else(|e| panic!("cannot run {} for `{name}` alone: {e}", exe.display()));
    let stdout = String::from_utf8_lossy(&output.stdout);
    print!("{stdout}");
    eprint!("{}", String::from_utf8_lossy(&output.stderr));
    assert!(
        output.status.success(),
        "`{name}` failed in a process of its own ({})",
        output.status
    );
    assert!(
        stdout.contains("test result: ok. 1 passed"),
        "`{name}` did not run in a process of its own: the child ran no test"
    );
    true
}
