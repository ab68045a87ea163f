//! A tool that helps: suggestions for mistyped commands and flags, an example in every
//! command's help, hints that work as printed.

mod support;

use support::fails;

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
