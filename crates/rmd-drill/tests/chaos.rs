//! A short chaos run in virtual time: random faults from the matrix, drill after drill; none
//! may panic, hang, leave a motor energised or grow memory.

use core::time::Duration;

use rmd_drill::chaos::{ChaosSpec, chaos};
use rmd_rig::SimTime;

#[test]
fn a_short_chaos_run_leaves_every_motor_safe() {
    let spec = ChaosSpec {
        seconds: Duration::from_secs(60),
        seed: 2026,
        time: SimTime::Virtual,
        signals: None,
    };
    let report = chaos(&spec, |_| {});
    assert!(
        report.passed(),
        "{}",
        serde_json::to_string_pretty(&report).unwrap()
    );
    assert!(report.drills.len() >= 80, "{}", report.drills.len());
    // Several faults per drill, of many kinds.
    let kinds: std::collections::BTreeSet<_> = report
        .drills
        .iter()
        .flat_map(|d| {
            d.faults
                .iter()
                .map(|(f, _)| f.split(':').next().unwrap().to_string())
        })
        .collect();
    assert!(kinds.len() == 17, "{kinds:?}");
}
