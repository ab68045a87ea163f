//! `rmd traj check FILE`: counts, the last line, and the exit status.

use assert_cmd::Command;
use serde_json::Value;

/// The reference vectors shipped with the vector checker.
fn vectors() -> Value {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../rmd-traj-vectors/tests/data/ruckig-vectors.json"
    );
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// A vectors file with the first `n` cases of every category (mutated by `edit`).
fn subset(n: usize, edit: impl FnOnce(&mut Vec<Value>)) -> std::path::PathBuf {
    let mut all = vectors();
    let cases = all["cases"].as_array().unwrap();
    let mut kept: Vec<Value> = Vec::new();
    for case in cases {
        let category = &case["category"];
        if kept.iter().filter(|c| &c["category"] == category).count() < n {
            kept.push(case.clone());
        }
    }
    edit(&mut kept);
    all["cases"] = Value::Array(kept);
    let dir = std::env::temp_dir().join(format!("rmd-traj-check-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(format!("vectors-{}.json", rand_suffix()));
    std::fs::write(&path, serde_json::to_string(&all).unwrap()).unwrap();
    path
}

fn rand_suffix() -> u128 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_nanos()
}

fn last_line(stdout: &[u8]) -> String {
    String::from_utf8_lossy(stdout)
        .lines()
        .last()
        .unwrap_or_default()
        .to_string()
}

#[test]
fn a_file_of_valid_cases_passes_with_counts_per_category() {
    let file = subset(5, |_| {});
    let out = Command::cargo_bin("rmd")
        .unwrap()
        .args(["traj", "check"])
        .arg(&file)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(last_line(&out.stdout), "40 passed, 0 failed");
    let text = String::from_utf8_lossy(&out.stdout);
    for category in [
        "pos1_random",
        "pos1_rest",
        "pos3_sync",
        "pos6_sync",
        "vel1",
        "vel3_sync",
        "options",
        "degenerate",
    ] {
        assert!(
            text.contains(&format!("{category}: 5 passed, 0 failed")),
            "{text}"
        );
    }
}

#[test]
fn a_wrong_reference_duration_fails_the_case_and_the_exit_status() {
    let file = subset(3, |cases| {
        let case = cases
            .iter_mut()
            .find(|c| c["category"] == "pos1_rest")
            .unwrap();
        let d = case["expected"]["duration"].as_f64().unwrap();
        case["expected"]["duration"] = Value::from(d * 1.01);
    });
    let out = Command::cargo_bin("rmd")
        .unwrap()
        .args(["traj", "check"])
        .arg(&file)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert_eq!(last_line(&out.stdout), "23 passed, 1 failed");
}

#[test]
fn the_moving_target_cases_are_listed_as_better_than_reference() {
    let file = subset(100, |cases| {
        cases.retain(|c| c["id"] == "public-001901" || c["id"] == "public-000000");
    });
    let out = Command::cargo_bin("rmd")
        .unwrap()
        .args(["traj", "check"])
        .arg(&file)
        .output()
        .unwrap();
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("better than reference"), "{text}");
    assert!(text.contains("public-001901"), "{text}");
    assert_eq!(last_line(&out.stdout), "2 passed, 0 failed");
}

#[test]
fn an_unreadable_or_malformed_file_is_a_usage_error() {
    let out = Command::cargo_bin("rmd")
        .unwrap()
        .args(["traj", "check", "/nonexistent/vectors.json"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(out.stdout.is_empty());
    assert_eq!(String::from_utf8_lossy(&out.stderr).lines().count(), 1);
    let bad = std::env::temp_dir().join(format!("rmd-traj-bad-{}.json", rand_suffix()));
    std::fs::write(&bad, "{\"schema_version\": 1, \"cases\": [{\"id\": 3}]}").unwrap();
    let out = Command::cargo_bin("rmd")
        .unwrap()
        .args(["traj", "check"])
        .arg(&bad)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(out.stdout.is_empty());
}
