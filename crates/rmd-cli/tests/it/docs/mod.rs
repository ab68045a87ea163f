//! Docs that run: every shell command in README.md and docs/*.md runs as printed on a fresh
//! clone, or its line says what it needs that a test machine cannot give (`# needs: can0`, ...).
//! The rules are docs/getting-started.md's "The commands in these docs"; this test enforces them:
//! it runs every unmarked command (in a copy of the repository, documents in parallel) and
//! asserts its exit status, and checks that every file a command names ships.

mod extract;
mod sandbox;

use std::collections::BTreeMap;
use std::fs;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Mutex, PoisonError};
use std::time::{Duration, Instant};

use extract::{DocCommand, Need, commands};
use sandbox::{Sandbox, repository};

/// Commands the checker runs shorter than printed (they would run for 10 s of real time each):
/// how the printed command starts, and what the checker appends to it.
const SHORTER: [(&str, &str); 2] = [
    ("cargo run --release --example leg4", "--duration 2s"),
    ("rmd bench jitter", "--duration 2s"),
];

/// How long a command documented to run `until Ctrl-C` runs before the checker presses it.
const INTERRUPT_AFTER: Duration = Duration::from_secs(3);

/// The longest any one command may take before it counts as hung.
const TIMEOUT: Duration = Duration::from_secs(120);

/// The stop reasons of a real-time run on simulated motors that a loaded machine causes (the
/// simulator's or the loop's thread waited for a CPU): with exit status 1 and one of these, a run
/// passes, and the summary counts it (the rule of rmd-cli's real-time bench tests).
const LOAD_FAULTS: [&str; 2] = ["gave no fresh feedback for", "did not complete within"];

/// Documents checked at the same time.
const WORKERS: usize = 2;

/// The documents: README.md and every docs/*.md, by path in the repository.
fn documents() -> Vec<PathBuf> {
    let repo = repository();
    let mut docs: Vec<PathBuf> = fs::read_dir(repo.join("docs"))
        .expect("docs/")
        .map(|entry| entry.expect("docs/ entry").path())
        .filter(|path| path.extension().is_some_and(|ext| ext == "md"))
        .map(|path| Path::new("docs").join(path.file_name().expect("a name")))
        .collect();
    docs.sort();
    docs.insert(0, PathBuf::from("README.md"));
    docs
}

/// The command the checker runs for a printed one: `cargo run [--release] -p rmd-cli -- ARGS`
/// is `rmd ARGS` (this test's build of the tool), `cargo run [--release] --example NAME [--
/// ARGS]` the example's build in this test's profile; then the `SHORTER` arguments.
fn as_run(printed: &str) -> Result<String, String> {
    let mut command = printed.to_owned();
    if let Some(at) = command.find("cargo ") {
        let tokens: Vec<&str> = command[at..].split_whitespace().collect();
        if tokens.get(1) != Some(&"run") {
            return Err(format!(
                "`{}` builds: mark it `# needs: long`, or run the program it builds",
                tokens[..2.min(tokens.len())].join(" ")
            ));
        }
        let mut program = None;
        let mut used = 2;
        while let Some(token) = tokens.get(used) {
            match *token {
                "--release" => used += 1,
                "-p" | "--package" | "--example" | "--bin" => {
                    let value = tokens.get(used + 1).ok_or("`cargo run` ends early")?;
                    match (*token, *value) {
                        ("-p" | "--package", "rmd-cli") | ("--bin", "rmd") => {
                            program = program.or(Some("rmd".to_owned()));
                        }
                        ("--example", name) => {
                            program =
                                Some(format!("'{}'", rmd_test_support::example(name)?.display()));
                        }
                        _ => return Err(format!("`cargo run {token} {value}`: not known here")),
                    }
                    used += 2;
                }
                "--" => {
                    used += 1;
                    break;
                }
                _ => break,
            }
        }
        let program = program.ok_or("`cargo run` of what?")?;
        let rest = tokens[used..].join(" ");
        command = format!("{}{program} {rest}", &command[..at])
            .trim_end()
            .to_owned();
    }
    for (start, extra) in SHORTER {
        if printed.starts_with(start) && !printed.contains("--duration") {
            command = format!("{command} {extra}");
        }
    }
    Ok(command)
}

/// The repository files a command names (`examples/robots/leg4.toml`, `benches/x.sh`, ...):
/// words that look like a relative path to such a file, outside `target/`.
fn named_files(command: &str) -> Vec<&str> {
    const KINDS: [&str; 8] = [".toml", ".json", ".md", ".py", ".sh", ".rs", ".txt", ".csv"];
    command
        .split_whitespace()
        .map(|word| word.rsplit('=').next().unwrap_or(word))
        .map(|word| word.trim_matches(|c| c == '\'' || c == '"'))
        .map(|word| word.strip_prefix("./").unwrap_or(word))
        .filter(|word| KINDS.iter().any(|kind| word.ends_with(kind)))
        .filter(|word| {
            !word.starts_with(['/', '~', '$', '<', '-'])
                && !word.starts_with("target/")
                && !word.contains(['*', '<', '('])
        })
        .collect()
}

/// Whether `output` has the line `shown`, spacing aside (column widths may change).
fn printed(output: &str, shown: &str) -> bool {
    let shown: Vec<&str> = shown.split_whitespace().collect();
    output
        .lines()
        .any(|line| line.split_whitespace().eq(shown.iter().copied()))
}

/// What checking one document found.
#[derive(Default)]
struct Checked {
    /// Commands it prints.
    commands: usize,
    /// Commands run, and how long they took.
    ran: Vec<(String, Duration)>,
    /// Marked commands by reason (a command with two reasons counts under each).
    needs: BTreeMap<Need, usize>,
    /// Marked commands (once each).
    marked: usize,
    /// What failed: one message per command.
    failures: Vec<String>,
    /// Real-time runs on simulated motors that ended in a fault of a loaded machine.
    load_faults: Vec<String>,
}

/// Runs every unmarked command of `doc` in order in a fresh copy of the repository (a command
/// may use what an earlier one of the same document made), and checks every command's files.
fn check(doc: &Path) -> Checked {
    let mut checked = Checked::default();
    let text = fs::read_to_string(repository().join(doc)).expect("read the document");
    let found = match commands(&text) {
        Ok(found) => found,
        Err(e) => {
            checked
                .failures
                .push(format!("{}:{}: {}", doc.display(), e.line, e.message));
            return checked;
        }
    };
    checked.commands = found.len();
    if found.is_empty() {
        return checked;
    }
    let sandbox = Sandbox::new();
    for DocCommand {
        line,
        text,
        needs,
        until_ctrl_c,
        shown,
    } in found
    {
        let place = format!("{}:{line}", doc.display());
        // The files a command names exist before it runs, or (what it writes) after.
        let shipped = |checked: &mut Checked| {
            for file in named_files(&text) {
                if !sandbox.repo().join(file).exists() {
                    checked.failures.push(format!(
                        "{place}: `{text}` names {file}, which the repository does not ship"
                    ));
                }
            }
        };
        if !needs.is_empty() {
            shipped(&mut checked);
            checked.marked += 1;
            for need in needs {
                *checked.needs.entry(need).or_default() += 1;
            }
            continue;
        }
        let command = match as_run(&text) {
            Ok(command) => command,
            Err(e) => {
                checked.failures.push(format!("{place}: `{text}`: {e}"));
                continue;
            }
        };
        let ended = sandbox.run(&command, until_ctrl_c.then_some(INTERRUPT_AFTER), TIMEOUT);
        shipped(&mut checked);
        let expected: &[i32] = if until_ctrl_c { &[0, 130] } else { &[0] };
        let load_fault = LOAD_FAULTS
            .iter()
            .find(|fault| ended.output.contains(*fault))
            .filter(|_| ended.code == Some(1) && ended.stopped != Some("timeout"));
        let problem = if ended.stopped == Some("timeout") {
            Some(format!("still running after {TIMEOUT:?}"))
        } else if let Some(fault) = load_fault {
            checked.load_faults.push(format!("{place} ({fault} ...)"));
            None
        } else if ended.ended_early {
            Some("documented to run until Ctrl-C, it ended by itself".to_owned())
        } else if !ended.code.is_some_and(|code| expected.contains(&code)) {
            Some(format!(
                "exit status {:?} (expected {expected:?})",
                ended.code
            ))
        } else {
            shown
                .filter(|shown| !printed(&ended.output, shown))
                .map(|shown| format!("the document shows `{shown}`, its output has no such line"))
        };
        println!(
            "{place}: {:>6.2} s  {}  {command}",
            ended.took.as_secs_f64(),
            match (&problem, load_fault) {
                (Some(_), _) => "FAILED",
                (None, Some(_)) => "load fault",
                (None, None) => "ok",
            }
        );
        match problem {
            Some(problem) => {
                let tail: Vec<&str> = ended.output.lines().rev().take(15).collect();
                let tail: Vec<&str> = tail.into_iter().rev().collect();
                checked.failures.push(format!(
                    "{place}: `{text}` (run as `{command}`): {problem}; its last output:\n    {}",
                    tail.join("\n    ")
                ));
            }
            None => checked.ran.push((place, ended.took)),
        }
    }
    checked
}

#[test]
fn every_command_in_the_docs_runs_as_printed_or_says_what_it_needs() {
    let started = Instant::now();
    let docs = documents();
    let next = AtomicUsize::new(0);
    let results: Mutex<Vec<(PathBuf, Checked)>> = Mutex::new(Vec::new());
    std::thread::scope(|scope| {
        for _ in 0..WORKERS {
            scope.spawn(|| {
                while let Some(doc) = docs.get(next.fetch_add(1, Ordering::Relaxed)) {
                    let checked = check(doc);
                    results
                        .lock()
                        .unwrap_or_else(PoisonError::into_inner)
                        .push((doc.clone(), checked));
                }
            });
        }
    });
    let mut results = results.into_inner().unwrap_or_else(PoisonError::into_inner);
    results.sort_by(|a, b| a.0.cmp(&b.0));

    let mut total = Checked::default();
    for (doc, checked) in results {
        println!(
            "docs: {}: {} commands, {} run and passed, {} marked",
            doc.display(),
            checked.commands,
            checked.ran.len(),
            checked.marked
        );
        total.commands += checked.commands;
        total.ran.extend(checked.ran);
        total.marked += checked.marked;
        for (need, count) in checked.needs {
            *total.needs.entry(need).or_default() += count;
        }
        total.failures.extend(checked.failures);
        total.load_faults.extend(checked.load_faults);
    }
    let by_reason: Vec<String> = total
        .needs
        .iter()
        .map(|(need, count)| format!("{need} {count}"))
        .collect();
    println!(
        "docs: {} commands in {} documents: {} run and passed ({} of them ended by a loaded \
         machine's fault: {}), {} failed, {} marked (by reason: {}); {:.1} s",
        total.commands,
        docs.len(),
        total.ran.len(),
        total.load_faults.len(),
        total.load_faults.join(", "),
        total.failures.len(),
        total.marked,
        by_reason.join(", "),
        started.elapsed().as_secs_f64()
    );
    assert!(
        total.failures.is_empty(),
        "{} documented command(s) do not run as printed (mark what needs hardware with \
         `# needs: REASON`, docs/getting-started.md \"The commands in these docs\"):\n\n{}",
        total.failures.len(),
        total.failures.join("\n\n")
    );
    // Every command either ran or is marked: nothing is skipped.
    assert_eq!(total.ran.len() + total.marked, total.commands);
}

#[test]
fn cargo_run_becomes_the_test_build() {
    assert_eq!(
        as_run("cargo run -p rmd-cli -- encode torque --id 1").unwrap(),
        "rmd encode torque --id 1"
    );
    assert_eq!(
        as_run("candump -L can0 | cargo run --release -p rmd-cli -- decode").unwrap(),
        "candump -L can0 | rmd decode"
    );
    assert_eq!(
        as_run("rmd bench jitter --fifo 80").unwrap(),
        "rmd bench jitter --fifo 80 --duration 2s"
    );
    assert!(as_run("cargo build --release -p rmd-cli").is_err());
}

#[test]
fn named_files_are_the_repository_paths_a_command_names() {
    assert_eq!(
        named_files(
            "./tests/run.sh --robot examples/robots/leg4.toml --servo=x/s.toml \
             > ~/.zfunc/_rmd target/leg4.csv '/proc/interrupts' --json"
        ),
        ["tests/run.sh", "examples/robots/leg4.toml", "x/s.toml"]
    );
}

/// The robot description docs/getting-started.md walks through ships as the file its commands
/// name.
#[test]
fn the_getting_started_robot_file_is_the_one_it_shows() {
    let repo = repository();
    let doc = fs::read_to_string(repo.join("docs/getting-started.md")).unwrap();
    let shown = doc
        .split("```toml\n")
        .nth(1)
        .and_then(|rest| rest.split("```").next())
        .expect("a toml block");
    let shipped = fs::read_to_string(repo.join("examples/robots/arm.toml")).unwrap();
    assert!(
        shipped.ends_with(shown),
        "examples/robots/arm.toml ends with the description docs/getting-started.md shows"
    );
    assert!(doc.contains("--robot examples/robots/arm.toml"));
}

#[test]
fn a_shown_output_line_is_found_whatever_its_spacing() {
    let output = "id  firmware   note\n 1  v1.61      none\n";
    assert!(printed(output, "id firmware note"));
    assert!(printed(output, " 1  v1.61  none"));
    assert!(!printed(output, "id firmware"));
    assert!(!printed(output, "motor 1"));
}
