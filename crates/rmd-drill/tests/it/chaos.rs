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
        firmware: rmd_protocol::ProtocolFamily::V161,
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

/// The same on MyActuator V3 motors (per-motor exchange, up to three per bus): every drill
/// ends with every motor safe by the firmware's ground truth.
#[test]
fn a_short_chaos_run_on_v3_motors_leaves_every_motor_safe() {
    let spec = ChaosSpec {
        seconds: Duration::from_secs(20),
        seed: 2027,
        time: SimTime::Virtual,
        signals: None,
        firmware: rmd_protocol::ProtocolFamily::MyActuatorV3,
    };
    let report = chaos(&spec, |_| {});
    assert!(
        report.passed(),
        "{}",
        serde_json::to_string_pretty(&report).unwrap()
    );
    assert!(report.drills.len() >= 25, "{}", report.drills.len());
    assert!(report.drills.iter().all(|d| d.motors <= 3));
}
