//! `rmd completions SHELL`: the bash script is loaded into a real bash and asked to complete, as
//! the shell would on Tab; the other shells' scripts are checked for what they must declare.

use std::io::Write;
use std::process::{Command, Stdio};

use crate::support;
use support::{fails, ok};

/// Loads the bash script into bash, completes `words` (the last one being typed) and returns
/// the candidates.
fn bash_complete(script: &str, words: &[&str]) -> Vec<String> {
    let quoted: Vec<String> = words.iter().map(|w| format!("'{w}'")).collect();
    let cword = words.len() - 1;
    let program = format!(
        "{script}\nCOMP_WORDS=({}); COMP_CWORD={cword}; COMP_LINE='{}'; COMP_POINT=${{#COMP_LINE}}\n\
         _rmd rmd '{}' '{}'\nprintf '%s\\n' \"${{COMPREPLY[@]}}\"\n",
        quoted.join(" "),
        words.join(" "),
        words[cword],
        words[cword.saturating_sub(1)],
    );
    // The script is larger than one command-line argument may be: bash reads it on stdin.
    let mut bash = Command::new("bash")
        .args(["--norc", "--noprofile", "-s"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run bash");
    bash.stdin
        .take()
        .unwrap()
        .write_all(program.as_bytes())
        .unwrap();
    let out = bash.wait_with_output().unwrap();
    assert!(
        out.status.success(),
        "bash: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(str::to_owned)
        .collect()
}

#[test]
fn bash_completes_subcommands_flags_and_values() {
    let script = ok(&["completions", "bash"]);
    assert_eq!(bash_complete(&script, &["rmd", "st"]), ["status", "stop"]);
    assert_eq!(
        bash_complete(&script, &["rmd", "bench", "loop", "--du"]),
        ["--duration"]
    );
    assert_eq!(
        bash_complete(&script, &["rmd", "bench", "loop", "--fifo-p"]),
        ["--fifo-priority"]
    );
    let shells = bash_complete(&script, &["rmd", "completions", ""]);
    for shell in ["bash", "zsh", "fish", "elvish", "powershell"] {
        assert!(shells.iter().any(|s| s == shell), "{shell} in {shells:?}");
    }
}

#[test]
fn other_shells_get_their_own_scripts() {
    for (shell, marker) in [
        ("zsh", "#compdef rmd"),
        ("fish", "complete -c rmd"),
        ("elvish", "edit:completion:arg-completer[rmd]"),
        ("powershell", "Register-ArgumentCompleter"),
    ] {
        let script = ok(&["completions", shell]);
        assert!(script.contains(marker), "{shell}: no `{marker}`");
        for word in ["status", "monitor", "duration", "rate-hz"] {
            assert!(script.contains(word), "{shell}: no `{word}`");
        }
    }
}

#[test]
fn an_unknown_shell_is_a_usage_error() {
    let err = fails(2, &["completions", "tcsh"]);
    assert!(err.contains("possible values"), "{err}");
}
