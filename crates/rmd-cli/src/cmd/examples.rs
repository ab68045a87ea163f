//! An example in every command's `--help`: one table, appended to each command's after-help
//! text when `rmd` builds its parser ([`attach`]).
//!
//! A line is a command line as a user types it, optionally followed by `# what it does`. Every
//! line parses with `rmd`'s own parser (tested below); the ones that need no hardware run as
//! printed (tests/it/helpful.rs runs them), with the files they name shipped in the repository,
//! relative to its root. `rmd ros2` keeps the examples of its own help text.

use clap::Command;

/// `(command path, examples)`: the path as typed after `rmd` (`pid get`).
const EXAMPLES: &[(&str, &[&str])] = &[
    (
        "encode",
        &[
            "rmd encode torque --id 1 --amps 1.5                 # 141#A10000005E000000",
            "rmd encode multi-torque --amps 1,-1,0,0.5           # the 0x280 frame of motors 1..=4",
            "rmd encode --protocol lk-v2.3x --lk-series mf torque --id 1 --amps 8.25",
            "rmd encode read-status-1 --id 2 | rmd decode --as request",
        ],
    ),
    ("encode read-pid", &["rmd encode read-pid --id 1"]),
    (
        "encode write-pid-ram",
        &[
            "rmd encode write-pid-ram --id 1 --angle-pid-kp 100 --angle-pid-ki 100 \
           --speed-pid-kp 50 --speed-pid-ki 40 --iq-pid-kp 50 --iq-pid-ki 50",
        ],
    ),
    (
        "encode write-pid-rom",
        &[
            "rmd encode write-pid-rom --id 1 --angle-pid-kp 100 --angle-pid-ki 100 \
           --speed-pid-kp 50 --speed-pid-ki 40 --iq-pid-kp 50 --iq-pid-ki 50",
        ],
    ),
    ("encode read-accel", &["rmd encode read-accel --id 1"]),
    (
        "encode write-accel-ram",
        &["rmd encode write-accel-ram --id 1 --accel 10000    # 10000 dps/s"],
    ),
    ("encode read-encoder", &["rmd encode read-encoder --id 1"]),
    (
        "encode write-encoder-offset",
        &["rmd encode write-encoder-offset --id 1 --encoder-offset 8192"],
    ),
    (
        "encode write-zero-rom",
        &["rmd encode write-zero-rom --id 1"],
    ),
    (
        "encode read-multi-turn-angle",
        &["rmd encode read-multi-turn-angle --id 1"],
    ),
    (
        "encode read-single-turn-angle",
        &["rmd encode read-single-turn-angle --id 1"],
    ),
    ("encode read-status-1", &["rmd encode read-status-1 --id 1"]),
    ("encode clear-error", &["rmd encode clear-error --id 1"]),
    ("encode read-status-2", &["rmd encode read-status-2 --id 1"]),
    ("encode read-status-3", &["rmd encode read-status-3 --id 1"]),
    ("encode motor-off", &["rmd encode motor-off --id 1"]),
    ("encode motor-stop", &["rmd encode motor-stop --id 1"]),
    ("encode motor-run", &["rmd encode motor-run --id 1"]),
    (
        "encode torque",
        &[
            "rmd encode torque --id 1 --amps 1.5",
            "rmd encode torque --id 1 --iq-control 100           # raw, 32/2000 A per LSB",
        ],
    ),
    ("encode speed", &["rmd encode speed --id 2 --dps 360"]),
    (
        "encode position-1",
        &["rmd encode position-1 --id 1 --deg 90"],
    ),
    (
        "encode position-2",
        &["rmd encode position-2 --id 1 --deg 90 --max-speed 360"],
    ),
    (
        "encode position-3",
        &["rmd encode position-3 --id 1 --deg 270 --spin-direction ccw"],
    ),
    (
        "encode position-4",
        &["rmd encode position-4 --id 1 --deg 270 --spin-direction cw --max-speed 180"],
    ),
    (
        "encode read-firmware-date",
        &["rmd encode --protocol myactuator-v3 read-firmware-date --id 1"],
    ),
    (
        "encode read-model",
        &[
            "rmd encode --protocol myactuator-v3 read-model --id 1             # V4.3: the whole model",
            "rmd encode --protocol myactuator-v3 read-model --id 1 --index 1   # V4.4: 5 characters",
        ],
    ),
    (
        "encode set-watchdog",
        &["rmd encode --protocol myactuator-v3 set-watchdog --id 1 --timeout-ms 50   # ROM write"],
    ),
    (
        "encode function-control",
        &[
            "rmd encode --protocol myactuator-v3 function-control --id 1 --function error-status-transmission --value 1",
        ],
    ),
    (
        "encode reset",
        &["rmd encode --protocol myactuator-v3 reset --id 1"],
    ),
    (
        "encode brake-release",
        &["rmd encode --protocol myactuator-v3 brake-release --id 1"],
    ),
    (
        "encode brake-lock",
        &["rmd encode --protocol myactuator-v3 brake-lock --id 1"],
    ),
    (
        "encode motion",
        &["rmd encode --protocol myactuator-v3 motion --id 1 --p-des 0.5 --kp 20 --kd 1"],
    ),
    (
        "encode multi-torque",
        &["rmd encode multi-torque --amps 1,-1,0,0.5"],
    ),
    (
        "decode",
        &[
            "rmd decode data/sample-leg.log                     # a candump -L log, JSON lines",
            "rmd encode torque --id 1 --amps 1 | rmd decode --as request",
            "rmd log --iface can0 - | rmd decode                # live",
        ],
    ),
    (
        "sim",
        &[
            "rmd sim --iface vcan0 --ids 1-4",
            "rmd sim --iface vcan0 --ids 1,2 --drop 0.01 --late 0.01,5 --seed 7   # with faults",
        ],
    ),
    (
        "scan",
        &[
            "rmd scan --iface can0",
            "rmd scan --sim --sim-firmware lk-v2.3x --json",
        ],
    ),
    (
        "status",
        &[
            "rmd status 1 --sim",
            "rmd status 1-4 --iface can0 --json",
            "rmd status --robot examples/robots/leg4.toml --sim knee ankle",
        ],
    ),
    (
        "pid",
        &[
            "rmd pid get 1 --sim",
            "rmd pid set 1 --speed-pid-kp 60 --iface can0",
        ],
    ),
    (
        "pid get",
        &["rmd pid get 1 --sim", "rmd pid get 1 --iface can0 --json"],
    ),
    (
        "pid set",
        &[
            "rmd pid set 1 --speed-pid-kp 60 --sim              # RAM: lost at power off",
            "rmd pid set 1 --angle-pid-kp 120 --rom --iface can0   # ROM: asks first",
        ],
    ),
    (
        "accel",
        &[
            "rmd accel get 1 --sim",
            "rmd accel set 1 20000 --iface can0",
        ],
    ),
    (
        "accel get",
        &[
            "rmd accel get 1 --sim",
            "rmd accel get 1 --iface can0 --json",
        ],
    ),
    (
        "accel set",
        &["rmd accel set 1 20000 --sim                       # 20000 dps/s, in RAM"],
    ),
    (
        "encoder",
        &[
            "rmd encoder get 1 --sim",
            "rmd encoder offset 1 --here --iface can0",
        ],
    ),
    (
        "encoder get",
        &[
            "rmd encoder get 1 --sim",
            "rmd encoder get 1 --iface can0 --encoder-bits 18",
        ],
    ),
    (
        "encoder offset",
        &[
            "rmd encoder offset 1 --here --sim                 # reads 0 where it is",
            "rmd encoder offset 1 8192 --iface can0",
        ],
    ),
    (
        "watchdog",
        &[
            "rmd watchdog 1 100ms --sim --sim-firmware myactuator-v3 --yes   # written to ROM",
            "rmd watchdog 1 100ms --iface can0                 # asks first",
            "rmd watchdog 1 off --iface can0 --yes",
            "rmd watchdog --robot examples/robots/leg4-v3.toml --sim --yes   # each motor's watchdog_ms",
        ],
    ),
    (
        "zero",
        &[
            "rmd zero 1 --iface can0                            # asks first; then power-cycle",
            "rmd zero 1 --yes --sim",
        ],
    ),
    (
        "off",
        &[
            "rmd off 1-4 --iface can0",
            "rmd off --robot examples/robots/leg4.toml --sim knee ankle",
            "rmd off --robot examples/robots/leg4.toml --sim    # every joint",
        ],
    ),
    (
        "stop",
        &[
            "rmd stop 1 --sim",
            "rmd stop 1-4 --iface can0             # `rmd run` resumes",
        ],
    ),
    ("run", &["rmd run 1 --sim", "rmd run 1-4 --iface can0"]),
    (
        "move",
        &[
            "rmd move 1 --deg 90 --sim",
            "rmd move 2 --deg 45 --max-speed 90 --min-deg -10 --max-deg 100 --iface can0",
            "rmd move --robot examples/robots/leg4.toml --sim knee --deg 45   # joint degrees",
        ],
    ),
    (
        "torque",
        &[
            "rmd torque 1 --amps 0.5 --duration 1s --sim",
            "rmd torque 1 --amps 1 --duration 2s --max-speed 200 --iface can0",
        ],
    ),
    (
        "speed",
        &[
            "rmd speed 1 --dps 90 --duration 1s --sim",
            "rmd speed 1 --dps -360 --duration 3s --iface can0",
        ],
    ),
    (
        "monitor",
        &[
            "rmd monitor --sim --demo --count 20                # something to watch (q quits)",
            "rmd monitor --iface can0 --rate 20 --json",
            "rmd monitor --robot examples/robots/leg4.toml --sim --ids knee,ankle --count 5",
        ],
    ),
    (
        "log",
        &[
            "rmd log --iface can0 session.log                   # until Ctrl-C",
            "rmd log --iface can0 - --duration 10s | rmd decode",
        ],
    ),
    (
        "replay",
        &[
            "rmd replay data/sample-leg.log --fast              # print its lines",
            "rmd replay data/sample-leg.log --fast --sim | rmd decode",
            "rmd replay session.log --iface vcan0 --speed 2",
        ],
    ),
    (
        "bench",
        &[
            "rmd bench loop --duration 2s --virtual-time",
            "rmd bench jitter --duration 1s",
            "rmd bench rate --buses 1,4 --rate 1000 --duration 2s",
        ],
    ),
    (
        "bench loop",
        &[
            "rmd bench loop --duration 2s --virtual-time",
            "rmd bench loop --motors 4 --buses 2 --duration 1s --virtual-time --mcap loop.mcap",
            "rmd bench loop --buses 4 --duration 30s --cpu 1 --fifo 80   # a real-time measurement",
        ],
    ),
    (
        "bench jitter",
        &[
            "rmd bench jitter --duration 1s",
            "rmd bench jitter --duration 60s --cpu 1 --fifo 80",
        ],
    ),
    (
        "bench rate",
        &[
            "rmd bench rate --buses 1 --duration 1s --virtual-time   # finds the wire limit",
            "rmd bench rate --buses 1,4 --rate 1000 --duration 2s    # one trial each at 1 kHz",
            "rmd bench rate --buses 1,2,4,8 --cpu 1 --fifo 80        # the search (minutes)",
        ],
    ),
    (
        "bench telemetry",
        &["rmd bench telemetry --rounds 2 --duration 1s"],
    ),
    (
        "drill",
        &[
            "rmd drill --fault bus-off:50 --buses 2",
            "rmd drill --all --virtual-time",
            "rmd drill --all --virtual-time --sim-firmware myactuator-v3   # V3 motors, per-motor exchange",
            "rmd drill --chaos --seconds 60 --seed 7 --virtual-time --json",
            "rmd drill --fault controller-hang:200 --virtual-time --mcap drill.mcap",
        ],
    ),
    (
        "traj",
        &["rmd traj check crates/rmd-traj-vectors/tests/data/regressions.json"],
    ),
    (
        "traj check",
        &["rmd traj check crates/rmd-traj-vectors/tests/data/regressions.json"],
    ),
    (
        "completions",
        &[
            "rmd completions bash",
            "mkdir -p ~/.local/share/bash-completion/completions && rmd completions bash > ~/.local/share/bash-completion/completions/rmd",
        ],
    ),
];

/// `rmd`'s command with the examples of [`EXAMPLES`] at the end of each command's help.
pub(crate) fn attach(command: Command) -> Command {
    attach_under(command, "")
}

/// Attaches the examples of every subcommand of `command`, whose path is `path`.
fn attach_under(mut command: Command, path: &str) -> Command {
    let names: Vec<String> = command
        .get_subcommands()
        .map(|sub| sub.get_name().to_owned())
        .collect();
    for name in names {
        let sub_path = if path.is_empty() {
            name.clone()
        } else {
            format!("{path} {name}")
        };
        command = command.mut_subcommand(&name, |sub| {
            let sub = match examples_of(&sub_path) {
                Some(lines) => with_examples(sub, lines),
                None => sub,
            };
            attach_under(sub, &sub_path)
        });
    }
    command
}

/// The examples of the command at `path`.
fn examples_of(path: &str) -> Option<&'static [&'static str]> {
    EXAMPLES
        .iter()
        .find(|(p, _)| *p == path)
        .map(|(_, lines)| *lines)
}

/// `command` with `lines` under `Examples:` after its other after-help text.
fn with_examples(command: Command, lines: &[&str]) -> Command {
    let mut text = command
        .get_after_help()
        .map(|before| format!("{before}\n\n"))
        .unwrap_or_default();
    text.push_str("Examples:");
    for line in lines {
        text.push_str("\n  ");
        text.push_str(line);
    }
    command.after_help(text)
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    /// Every command's path (`pid get`), depth first.
    fn paths(command: &Command, path: &str, into: &mut Vec<String>) {
        for sub in command.get_subcommands() {
            let sub_path = if path.is_empty() {
                sub.get_name().to_owned()
            } else {
                format!("{path} {}", sub.get_name())
            };
            into.push(sub_path.clone());
            paths(sub, &sub_path, into);
        }
    }

    fn every_path() -> Vec<String> {
        let mut all = Vec::new();
        paths(&crate::Cli::command(), "", &mut all);
        all
    }

    /// The `rmd ...` commands of an example line: its comment dropped, split at pipes and
    /// `&&`, each without a redirection.
    fn rmd_commands(line: &str) -> Vec<Vec<&str>> {
        let line = line.split(" # ").next().unwrap_or_default();
        line.split(['|', '&'])
            .map(|segment| segment.split('>').next().unwrap_or_default())
            .map(|segment| segment.split_whitespace().collect::<Vec<_>>())
            .filter(|words| words.first() == Some(&"rmd"))
            .collect()
    }

    /// The command at `path`, as derived (before [`attach`]).
    fn derived(path: &str) -> Command {
        let mut command = crate::Cli::command();
        for name in path.split(' ') {
            command = command.find_subcommand(name).unwrap().clone();
        }
        command
    }

    #[test]
    fn every_command_has_examples_and_every_entry_a_command() {
        let all = every_path();
        for path in &all {
            let own = derived(path)
                .get_after_help()
                .is_some_and(|h| h.to_string().contains("Examples:"));
            assert!(
                examples_of(path).is_some() != own,
                "`rmd {path}`: one list of examples, in EXAMPLES or (ros2) in its own help"
            );
        }
        for (path, lines) in EXAMPLES {
            assert!(all.contains(&path.to_string()), "no command `rmd {path}`");
            assert!(!lines.is_empty(), "`rmd {path}` has no example");
        }
    }

    #[test]
    fn every_example_parses_and_belongs_to_its_command() {
        let command = attach(crate::Cli::command());
        for (path, lines) in EXAMPLES {
            for line in *lines {
                let commands = rmd_commands(line);
                assert!(!commands.is_empty(), "`{line}` runs no rmd command");
                let words: Vec<&str> = path.split(' ').collect();
                assert!(
                    commands.iter().any(|c| c[1..].starts_with(&words)
                        || (path.starts_with("encode ") && c[1] == "encode")),
                    "`{line}` is no example of `rmd {path}`"
                );
                for args in commands {
                    if let Err(e) = command.clone().try_get_matches_from(&args) {
                        panic!("`{line}`: {e}");
                    }
                }
            }
        }
    }

    #[test]
    fn examples_follow_the_help_text_they_extend() {
        let command = attach(crate::Cli::command());
        let drill = command.find_subcommand("drill").unwrap();
        let text = drill.get_after_help().unwrap().to_string();
        assert!(text.starts_with("Fault kinds:"), "{text}");
        assert!(
            text.contains("\n\nExamples:\n  rmd drill --fault"),
            "{text}"
        );
    }
}
