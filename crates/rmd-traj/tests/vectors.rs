//! Runs every case of the reference vectors (ruckig 0.19.4 oracle) with the comparison rules of
//! `shared/testdata/trajectory/SCHEMA.md` (see `rmd_traj::vectors`).

use rmd_traj::vectors::{CaseStatus, check_vectors};

fn load() -> String {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/ruckig-vectors.json"
    );
    std::fs::read_to_string(path).expect("vectors file")
}

#[test]
fn all_reference_vectors_pass() {
    let report = check_vectors(&load()).expect("valid vectors file");
    println!("{report}");
    assert_eq!(report.cases.len(), 2000);
    assert!(report.all_passed(), "{} cases failed", report.failed());
}
