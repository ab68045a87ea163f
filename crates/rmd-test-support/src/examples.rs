//! The workspace's example programs, built for the tests that run them as a user would.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::OnceLock;

/// The features the test scripts build the workspace with (tests/workspace-build.sh), on when this
/// crate was built in such a build: rmd-bus's and rmd-cli's `kernel-tests` turn on this crate's.
const KERNEL_TEST_FEATURES: &str = "rmd-bus/kernel-tests,rmd-cli/kernel-tests";

/// The executable of the workspace's example `name`, in the calling test's profile (release when
/// it was built without debug assertions).
///
/// The first call in a process builds every binary and example of the workspace with one `cargo
/// build` that selects what the test scripts' builds select (tests/workspace-build.sh: the whole
/// workspace, and the kernel tests' features when this build had them). Cargo resolves the
/// dependencies' features for the packages a build selects: after `cargo nextest run
/// --workspace` (with or without those features) it finds everything built, where a build of
/// one example's package would compile the dependencies again for that package alone.
///
/// # Errors
///
/// The build failed (cargo's own messages went to standard error), or the workspace has no
/// example `name`.
pub fn example(name: &str) -> Result<PathBuf, String> {
    static BUILT: OnceLock<Result<BTreeMap<String, PathBuf>, String>> = OnceLock::new();
    let built = BUILT.get_or_init(build).as_ref().map_err(Clone::clone)?;
    built
        .get(name)
        .cloned()
        .ok_or_else(|| format!("the workspace has no example {name}"))
}

/// Builds every binary and example of the workspace: the examples' executables by name.
fn build() -> Result<BTreeMap<String, PathBuf>, String> {
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../Cargo.toml");
    let mut cargo = Command::new(std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into()));
    cargo
        .arg("build")
        .arg("--manifest-path")
        .arg(&manifest)
        .args([
            "--workspace",
            "--bins",
            "--examples",
            "--message-format=json",
        ]);
    if cfg!(feature = "kernel-tests") {
        cargo.args(["--features", KERNEL_TEST_FEATURES]);
    }
    if !cfg!(debug_assertions) {
        cargo.arg("--release");
    }
    let out = cargo
        .stderr(Stdio::inherit())
        .output()
        .map_err(|e| format!("could not run cargo to build the examples: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "cargo build of the workspace's examples failed ({}): see its messages above",
            out.status
        ));
    }
    Ok(String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(example_artifact)
        .collect())
}

/// The name and executable of an example that a line of cargo's JSON messages reports built.
fn example_artifact(line: &str) -> Option<(String, PathBuf)> {
    let message: serde_json::Value = serde_json::from_str(line).ok()?;
    let target = &message["target"];
    let is_example = message["reason"] == "compiler-artifact"
        && target["kind"]
            .as_array()
            .is_some_and(|kinds| kinds.iter().any(|kind| kind == "example"));
    let name = target["name"].as_str()?;
    let executable = message["executable"].as_str()?;
    is_example.then(|| (name.to_owned(), PathBuf::from(executable)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_example_artifact_gives_its_name_and_executable() {
        let line = r#"{"reason":"compiler-artifact","package_id":"path+file:///w#rmd-rt@0.1.0","manifest_path":"/w/Cargo.toml","target":{"kind":["example"],"crate_types":["bin"],"name":"leg4","src_path":"/w/examples/leg4.rs","edition":"2024","doctest":false,"test":false},"profile":{"opt_level":"0"},"features":[],"filenames":["/w/target/debug/examples/leg4"],"executable":"/w/target/debug/examples/leg4","fresh":true}"#;
        assert_eq!(
            example_artifact(line),
            Some((
                "leg4".to_owned(),
                PathBuf::from("/w/target/debug/examples/leg4")
            ))
        );
    }

    #[test]
    fn other_artifacts_and_messages_give_nothing() {
        let library = r#"{"reason":"compiler-artifact","target":{"kind":["lib"],"crate_types":["lib"],"name":"rmd_bus"},"executable":null,"fresh":true}"#;
        let binary = r#"{"reason":"compiler-artifact","target":{"kind":["bin"],"crate_types":["bin"],"name":"rmd"},"executable":"/w/target/debug/rmd","fresh":true}"#;
        let finished = r#"{"reason":"build-finished","success":true}"#;
        for line in [library, binary, finished, "not json"] {
            assert_eq!(example_artifact(line), None, "{line}");
        }
    }
}
