//! Running an example's binary from its test: built once per test process with cargo (see
//! [`rmd_test_support::example`]: a no-op after a workspace test build, which builds the examples),
//! then run like a user would, with its exit status, standard output and standard error.

use std::path::{Path, PathBuf};
use std::process::Output;

/// The example `name`'s executable, built (in this test's profile) if needed.
pub(crate) fn example(name: &str) -> PathBuf {
    rmd_test_support::example(name).unwrap_or_else(|e| panic!("building example {name}: {e}"))
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
