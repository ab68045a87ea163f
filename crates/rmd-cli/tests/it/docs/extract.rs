//! The shell commands of a Markdown document: every command line of its ```sh / ```bash /
//! ```console blocks (and `$ ` prompts in unlabelled ones), with the markers of
//! docs/getting-started.md, "The commands in these docs".

use std::fmt;

/// Why a documented command cannot run on a fresh clone here: the marker `# needs: REASON`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) enum Need {
    /// A CAN adapter with motors on it (`can0`), or other hardware.
    Can0,
    /// Root and the `vcan` kernel module: a virtual CAN interface (tests/vcan/run.sh runs those
    /// paths in a VM).
    Vcan,
    /// Root on the machine being tuned, or its tuning tools (real-time kernel, IRQs, cpupower,
    /// cyclictest).
    Root,
    /// A ROS 2 installation (the `ros2` command).
    Ros2,
    /// Minutes or more: a benchmark, a release build, a whole test suite.
    Long,
    /// Installs or builds packages (pip, maturin, the wheel): tests/python/run.sh covers them.
    Install,
    /// A window on a display (plots), with the plotting tools.
    Display,
}

impl Need {
    /// Every reason, in the order reports list them.
    pub(crate) const ALL: [Need; 7] = [
        Need::Can0,
        Need::Vcan,
        Need::Root,
        Need::Ros2,
        Need::Long,
        Need::Install,
        Need::Display,
    ];

    /// The word of the marker.
    pub(crate) fn word(self) -> &'static str {
        match self {
            Need::Can0 => "can0",
            Need::Vcan => "vcan",
            Need::Root => "root",
            Need::Ros2 => "ros2",
            Need::Long => "long",
            Need::Install => "install",
            Need::Display => "display",
        }
    }

    fn from_word(word: &str) -> Option<Need> {
        Need::ALL.into_iter().find(|need| need.word() == word)
    }
}

impl fmt::Display for Need {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.word())
    }
}

/// One command as a document prints it.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct DocCommand {
    /// The line it starts on (1-based).
    pub(crate) line: usize,
    /// The command, continuation lines joined, without its comment and prompt.
    pub(crate) text: String,
    /// What it needs that this machine may not give (empty: it runs as printed).
    pub(crate) needs: Vec<Need>,
    /// Its comment says `until Ctrl-C`: it runs until interrupted.
    pub(crate) until_ctrl_c: bool,
    /// In a `console` block, the first line of output the document shows after it (none when
    /// it elides with `...`).
    pub(crate) shown: Option<String>,
}

/// A document's command that cannot be read.
#[derive(Debug, PartialEq)]
pub(crate) struct MarkerError {
    /// The line (1-based).
    pub(crate) line: usize,
    /// What is wrong.
    pub(crate) message: String,
}

/// The fence languages whose every line is shell.
const SHELL: [&str; 3] = ["sh", "bash", "shell"];
/// The fence languages whose `$ ` lines are commands and the rest output.
const SESSION: [&str; 3] = ["console", "shell-session", ""];

/// Every command of the Markdown text `doc`, in order.
pub(crate) fn commands(doc: &str) -> Result<Vec<DocCommand>, MarkerError> {
    let mut found: Vec<DocCommand> = Vec::new();
    let mut fence: Option<String> = None;
    // A block's own `# needs:` line: applies to the rest of the block.
    let mut block_needs: Vec<Need> = Vec::new();
    // A command continued with a backslash: its first line and text so far.
    let mut pending: Option<(usize, String)> = None;
    // The last command came from a `console` block and its output has not been seen yet.
    let mut awaiting_output = false;
    for (index, raw) in doc.lines().enumerate() {
        let number = index + 1;
        let trimmed = raw.trim_start();
        if let Some(info) = trimmed.strip_prefix("```") {
            awaiting_output = false;
            if fence.is_none() {
                let language = info.split([',', ' ']).next().unwrap_or("");
                fence = Some(language.to_owned());
                block_needs.clear();
            } else {
                if let Some((line, _)) = pending.take() {
                    return Err(MarkerError {
                        line,
                        message: "a command ends with `\\` at the end of its block".into(),
                    });
                }
                fence = None;
            }
            continue;
        }
        let Some(language) = fence.as_deref() else {
            continue;
        };
        let shell = SHELL.contains(&language);
        let (start, prefix, body) = if let Some((start, text)) = pending.take() {
            (start, text + " ", trimmed)
        } else if shell {
            if trimmed.is_empty() {
                continue;
            }
            if let Some(comment) = trimmed.strip_prefix('#') {
                // A comment of its own: a marker for the rest of the block, or prose.
                let (needs, _) = markers(comment, number)?;
                if !needs.is_empty() {
                    block_needs = needs;
                }
                continue;
            }
            (number, String::new(), trimmed)
        } else if SESSION.contains(&language) {
            match trimmed.strip_prefix("$ ") {
                Some(command) => (number, String::new(), command),
                None => {
                    if std::mem::take(&mut awaiting_output)
                        && !trimmed.is_empty()
                        && !trimmed.contains("...")
                        && let Some(last) = found.last_mut()
                    {
                        last.shown = Some(raw.trim_end().to_owned());
                    }
                    continue;
                }
            }
        } else {
            continue;
        };
        let (code, comment) = split_comment(body);
        let code = code.trim_end();
        if let Some(continued) = code.strip_suffix('\\') {
            if comment.is_some() {
                return Err(MarkerError {
                    line: number,
                    message: "a comment before a line continuation".into(),
                });
            }
            pending = Some((start, prefix + continued.trim_end()));
            continue;
        }
        let (mut needs, until_ctrl_c) = markers(comment.unwrap_or(""), number)?;
        for need in &block_needs {
            if !needs.contains(need) {
                needs.push(*need);
            }
        }
        needs.sort();
        found.push(DocCommand {
            line: start,
            text: prefix + code,
            needs,
            until_ctrl_c,
            shown: None,
        });
        awaiting_output = !shell;
    }
    Ok(found)
}

/// The code of a shell line and its comment: from the first `#` outside quotes that starts a
/// word.
fn split_comment(line: &str) -> (&str, Option<&str>) {
    let mut quote: Option<char> = None;
    let mut previous = ' ';
    for (at, c) in line.char_indices() {
        match quote {
            Some(open) if c == open => quote = None,
            Some(_) => {}
            None if c == '\'' || c == '"' => quote = Some(c),
            None if c == '#' && previous.is_whitespace() => {
                return (&line[..at], Some(&line[at + 1..]));
            }
            None => {}
        }
        previous = c;
    }
    (line, None)
}

/// The markers of a comment: `needs: REASON[, REASON...]` and `until Ctrl-C`.
fn markers(comment: &str, line: usize) -> Result<(Vec<Need>, bool), MarkerError> {
    let until_ctrl_c = comment.contains("until Ctrl-C");
    let Some(at) = comment.find("needs:") else {
        return Ok((Vec::new(), until_ctrl_c));
    };
    let mut needs = Vec::new();
    let mut rest = comment[at + "needs:".len()..].trim_start();
    loop {
        let end = rest
            .find(|c: char| !c.is_ascii_alphanumeric())
            .unwrap_or(rest.len());
        let word = &rest[..end];
        let need = Need::from_word(word).ok_or_else(|| MarkerError {
            line,
            message: format!(
                "`needs: {word}`: the reasons are {}",
                Need::ALL.map(Need::word).join(", ")
            ),
        })?;
        needs.push(need);
        rest = &rest[end..];
        match rest.strip_prefix(", ") {
            Some(next) => rest = next,
            None => break,
        }
    }
    Ok((needs, until_ctrl_c))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commands_markers_and_continuations() {
        let doc = "text\n\
            ```sh\n\
            rmd scan --sim   # which ids answer\n\
            \n\
            # a remark\n\
            rmd scan --iface can0   # needs: can0; which ids answer\n\
            rmd ros2 --sim   # the node, until Ctrl-C\n\
            benches/x.sh --a \\\n    --b 'q # not a comment'   # needs: long, root\n\
            ```\n\
            ```console\n\
            $ rmd status 1 --sim\n\
            motor 1\n\
            ```\n\
            ```text\n\
            $ not a command\n\
            ```\n\
            ```sh\n\
            # needs: ros2 (every line)\n\
            ros2 topic echo /joint_states\n\
            ros2 topic hz /joint_states   # needs: long\n\
            ```\n\
            ```rust\n\
            let x = 1; # no\n\
            ```\n";
        let found = commands(doc).unwrap();
        let texts: Vec<_> = found.iter().map(|c| c.text.as_str()).collect();
        assert_eq!(
            texts,
            [
                "rmd scan --sim",
                "rmd scan --iface can0",
                "rmd ros2 --sim",
                "benches/x.sh --a --b 'q # not a comment'",
                "rmd status 1 --sim",
                "ros2 topic echo /joint_states",
                "ros2 topic hz /joint_states",
            ]
        );
        let lines: Vec<_> = found.iter().map(|c| c.line).collect();
        assert_eq!(lines, [3, 6, 7, 8, 12, 20, 21]);
        assert_eq!(found[0].needs, []);
        assert_eq!(found[1].needs, [Need::Can0]);
        assert!(found[2].until_ctrl_c && found[2].needs.is_empty());
        assert_eq!(found[3].needs, [Need::Root, Need::Long]);
        assert_eq!(found[5].needs, [Need::Ros2]);
        assert_eq!(found[6].needs, [Need::Ros2, Need::Long]);
        assert_eq!(found[4].shown.as_deref(), Some("motor 1"));
        assert_eq!(found[0].shown, None);
    }

    #[test]
    fn an_unknown_reason_is_an_error_that_lists_the_known_ones() {
        let err = commands("```sh\nrmd x   # needs: a-robot\n```\n").unwrap_err();
        assert_eq!(err.line, 2);
        assert!(err.message.contains("`needs: a`"), "{}", err.message);
        assert!(err.message.contains("can0, vcan, root"), "{}", err.message);
    }

    #[test]
    fn a_block_that_ends_inside_a_command_is_an_error() {
        let err = commands("```sh\nrmd x \\\n```\n").unwrap_err();
        assert_eq!(err.line, 2);
    }
}
