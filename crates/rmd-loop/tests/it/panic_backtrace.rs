//! With `RUST_BACKTRACE=1`, a controller's panic is reported with its backtrace, resolved after
//! the motors were made safe (the loop's panic hook records the frames and prints nothing). Alone
//! in a process of its own: the environment and the panic hook are process-wide.

use crate::common;

use common::*;

#[test]
fn the_backtrace_of_a_controller_panic_comes_with_the_report() {
    if rmd_test_support::ran_in_own_process() {
        return;
    }
    // SAFETY: the only thread of this process that reads the environment is this one,
    // before the loop starts (the backtrace setting is read once per process).
    #[allow(unsafe_code)]
    unsafe {
        std::env::set_var("RUST_BACKTRACE", "1")
    };
    let mut ctrl = PdTo::hold(4);
    ctrl.panic_at = Some(10);
    let (out, mut bus) = run_leg(31, &[], ctrl, 100);
    assert_safe(&mut bus, 4);
    assert!(out.report.safe_stop.all_off_confirmed());
    let panic = out.report.panic.expect("a panic report");
    let backtrace = panic.backtrace.expect("a backtrace with RUST_BACKTRACE=1");
    // Resolved: it names the controller's update and the loop's engine.
    assert!(backtrace.contains("update"), "{backtrace}");
    assert!(backtrace.contains("rmd_loop"), "{backtrace}");
}
