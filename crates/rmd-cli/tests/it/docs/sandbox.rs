//! Where a document's commands run: a fresh copy of the repository's tracked files (what a clone
//! has), a home folder of its own, the `rmd` tool on `PATH` (what `cargo install --path
//! crates/rmd-cli` gives), and a private network namespace with only the loopback interface.
//! Nothing a command writes reaches the repository, the user's home or a real network.

use std::fs;
use std::io::Read;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::OnceLock;
use std::thread::sleep;
use std::time::{Duration, Instant};

use nix::sys::signal::{Signal, killpg};
use nix::unistd::Pid;

/// The repository this test belongs to.
pub(crate) fn repository() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The repository's tracked files (relative paths), as `git ls-files` lists them.
pub(crate) fn tracked_files() -> &'static [PathBuf] {
    static FILES: OnceLock<Vec<PathBuf>> = OnceLock::new();
    FILES.get_or_init(|| {
        let out = Command::new("git")
            .arg("-C")
            .arg(repository())
            .args(["ls-files", "-z"])
            .output()
            .expect("git ls-files: the doc checker needs git and a clone of the repository");
        assert!(out.status.success(), "git ls-files failed");
        out.stdout
            .split(|&b| b == 0)
            .filter(|name| !name.is_empty())
            .map(|name| PathBuf::from(String::from_utf8_lossy(name).into_owned()))
            .collect()
    })
}

/// How commands enter a network namespace of their own: `unshare` with these arguments, and the
/// `ip` tool that brings its loopback interface up.
fn private_network() -> &'static (Vec<&'static str>, PathBuf) {
    static HOW: OnceLock<(Vec<&'static str>, PathBuf)> = OnceLock::new();
    HOW.get_or_init(|| {
        let ip = ["/usr/sbin/ip", "/sbin/ip", "/usr/bin/ip", "/bin/ip"]
            .into_iter()
            .map(PathBuf::from)
            .find(|path| path.exists())
            .expect("the doc checker needs `ip` (iproute2) to bring up its namespace's loopback");
        // As root a plain network namespace; otherwise inside a user namespace.
        for args in [vec!["--net"], vec!["--map-root-user", "--net"]] {
            let up = Command::new("unshare")
                .args(&args)
                .arg(&ip)
                .args(["link", "set", "lo", "up"])
                .stderr(Stdio::null())
                .status();
            if up.is_ok_and(|status| status.success()) {
                return (args, ip);
            }
        }
        panic!(
            "the doc checker runs every command in a private network namespace (`unshare --net`, \
             or `unshare --map-root-user --net` without root) so that nothing reaches a real \
             network, and neither works here"
        );
    })
}

/// One document's copy of the repository.
pub(crate) struct Sandbox {
    root: tempfile::TempDir,
}

/// How a command ended.
#[derive(Debug)]
pub(crate) struct Ended {
    /// Its exit status (`None`: killed by a signal, or by the checker after its timeout).
    pub(crate) code: Option<i32>,
    /// Its standard output and standard error, interleaved as written.
    pub(crate) output: String,
    /// How long it ran.
    pub(crate) took: Duration,
    /// Why the checker stopped it, if it did: `Ctrl-C` as documented, or a timeout.
    pub(crate) stopped: Option<&'static str>,
    /// It ended by itself before the checker pressed Ctrl-C.
    pub(crate) ended_early: bool,
}

impl Sandbox {
    /// A fresh copy of the tracked files (their content in the working tree), an empty
    /// `target/` (a clone after its first build), a home folder, and `rmd` on `PATH`.
    pub(crate) fn new() -> Sandbox {
        let root = tempfile::Builder::new()
            .prefix("rmd-docs-")
            .tempdir()
            .expect("temporary folder");
        let repo = repository();
        let copy = root.path().join("repo");
        for file in tracked_files() {
            let from = repo.join(file);
            // A file deleted in the working tree is not in the copy either.
            if !from.exists() {
                continue;
            }
            let to = copy.join(file);
            fs::create_dir_all(to.parent().expect("a file's folder")).expect("mkdir");
            fs::copy(&from, &to).unwrap_or_else(|e| panic!("copy {}: {e}", from.display()));
        }
        fs::create_dir_all(copy.join("target")).expect("mkdir target");
        fs::create_dir_all(root.path().join("home")).expect("mkdir home");
        let bin = root.path().join("bin");
        fs::create_dir_all(&bin).expect("mkdir bin");
        std::os::unix::fs::symlink(env!("CARGO_BIN_EXE_rmd"), bin.join("rmd")).expect("symlink");
        Sandbox { root }
    }

    /// The copy of the repository: where the commands run.
    pub(crate) fn repo(&self) -> PathBuf {
        self.root.path().join("repo")
    }

    /// Runs `command` with bash in the copy, standard input closed. With `interrupt_after`, it
    /// gets SIGINT (what Ctrl-C sends, to its whole process group) after that long; any
    /// command still running after `timeout` is killed.
    pub(crate) fn run(
        &self,
        command: &str,
        interrupt_after: Option<Duration>,
        timeout: Duration,
    ) -> Ended {
        let (unshare, ip) = private_network();
        let log = self.root.path().join("output.txt");
        let output = fs::File::create(&log).expect("output file");
        let path = format!(
            "{}:{}",
            self.root.path().join("bin").display(),
            std::env::var("PATH").unwrap_or_default()
        );
        let script = format!(
            "{} link set lo up || {{ echo 'cannot bring up lo' >&2; exit 97; }}\n{command}",
            ip.display()
        );
        let started = Instant::now();
        let mut child = Command::new("unshare")
            .args(unshare)
            .args(["bash", "-c", &script])
            .current_dir(self.repo())
            .env("HOME", self.root.path().join("home"))
            .env("PATH", path)
            .stdin(Stdio::null())
            .stdout(output.try_clone().expect("dup"))
            .stderr(output)
            .process_group(0)
            .spawn()
            .expect("run unshare and bash");
        let group = Pid::from_raw(i32::try_from(child.id()).expect("a pid"));
        let mut stopped = None;
        let mut ended_early = false;
        let status = loop {
            if let Some(status) = child.try_wait().expect("wait") {
                ended_early = interrupt_after.is_some() && stopped.is_none();
                break status;
            }
            let ran = started.elapsed();
            if stopped.is_none() && interrupt_after.is_some_and(|after| ran >= after) {
                let _ = killpg(group, Signal::SIGINT);
                stopped = Some("Ctrl-C");
            }
            if ran >= timeout {
                let _ = killpg(group, Signal::SIGKILL);
                stopped = Some("timeout");
                break child.wait().expect("wait");
            }
            sleep(Duration::from_millis(20));
        };
        let took = started.elapsed();
        // What the command left running in the background (`... &`) ends with it.
        let _ = killpg(group, Signal::SIGKILL);
        let mut text = String::new();
        let mut bytes = Vec::new();
        fs::File::open(&log)
            .and_then(|mut f| f.read_to_end(&mut bytes))
            .expect("read output");
        text.push_str(&String::from_utf8_lossy(&bytes));
        Ended {
            code: status.code(),
            output: text,
            took,
            stopped,
            ended_early,
        }
    }
}
