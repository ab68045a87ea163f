//! Running an example's binary from its test: built once per test process with cargo (through
//! `escargot`; a no-op when `cargo test` already built the examples, which it does), then run
//! like a user would, with its exit status, standard output and standard error.

use std::path::{Path, PathBuf};
use std::process::Output;
use std::sync::{Mutex, PoisonError};

/// Examples built so far in this process, by name.
static BUILT: Mutex<Vec<(String, PathBuf)>> = Mutex::new(Vec::new());

/// The example `name`'s executable, built (in this test's profile) if needed.
pub(crate) fn example(name: &str) -> PathBuf {
    let mut built = BUILT.lock().unwrap_or_else(PoisonError::into_inner);
    if let Some((_, path)) = built.iter().find(|(n, _)| n == name) {
        return path.clone();
    }
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR")).join("Cargo.toml");
    let run = escargot::CargoBuild::new()
        .manifest_path(manifest)
        .example(name)
        .current_release()
        .run()
        .unwrap_or_else(|e| panic!("building example {name}: {e}"));
    let path = run.path().to_path_buf();
    built.push((name.to_string(), path.clone()));
    path
}

/// What one run of an example did.
#[derive(Debug)]
pub(crate) struct Ran {
    /// Its exit status (`None`: killed by a signal).
    pub(crate) code: Option<i32>,
    /// Its standard output.
    pub(crate) stdout: String,
    /// Its standard error.
    pub(crate) stderr: String,
}

impl From<Output> for Ran {
    fn from(out: Output) -> Self {
        Self {
            code: out.status.code(),
            stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
            stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
        }
    }
}

/// Runs the example `name` with `args` (standard input closed), to its end.
pub(crate) fn run(name: &str, args: &[&str]) -> Ran {
    std::process::Command::new(example(name))
        .args(args)
        .stdin(std::process::Stdio::null())
        .output()
        .unwrap_or_else(|e| panic!("running example {name}: {e}"))
        .into()
}

/// A file path in the temporary folder, unique to this process and `name`.
pub(crate) fn temp_file(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("rmd-rt-{}-{name}", std::process::id()))
}

/// A CSV file: its header and rows, split at commas.
pub(crate) struct Csv {
    /// Column names.
    pub(crate) header: Vec<String>,
    /// Rows of fields.
    pub(crate) rows: Vec<Vec<String>>,
}

impl Csv {
    /// Reads and removes `path`.
    pub(crate) fn take(path: &Path) -> Self {
        let text = std::fs::read_to_string(path)
            .unwrap_or_else(|e| panic!("reading {}: {e}", path.display()));
        std::fs::remove_file(path).ok();
        let mut lines = text.lines();
        let split = |l: &str| l.split(',').map(str::to_string).collect::<Vec<_>>();
        let header = split(lines.next().expect("a header line"));
        let rows = lines.map(split).collect();
        Self { header, rows }
    }

    /// The position of column `name`.
    pub(crate) fn column(&self, name: &str) -> usize {
        self.header
            .iter()
            .position(|h| h == name)
            .unwrap_or_else(|| panic!("no column {name} in {:?}", self.header))
    }

    /// Column `name` of every row, as numbers.
    pub(crate) fn values(&self, name: &str) -> Vec<f64> {
        let c = self.column(name);
        self.rows
            .iter()
            .map(|r| {
                r[c].parse()
                    .unwrap_or_else(|e| panic!("{name}: {:?}: {e}", r[c]))
            })
            .collect()
    }
}
