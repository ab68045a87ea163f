//! docs/foxglove-layout.json is the layout `foxglove_layout` makes for the examples' leg
//! (joints hip_aa, hip_fe, knee, ankle on one bus, torque constants known). Regenerate it with
//! `RMD_WRITE_LAYOUT=1 cargo test -p rmd-telemetry --test it layout_doc::`.

use std::path::PathBuf;

use rmd_protocol::MotorId;
use rmd_telemetry::{JointInfo, RunLayout, foxglove_layout};

fn leg_layout() -> RunLayout {
    let mut builder = RunLayout::builder(1000.0).bus_count(1);
    for (i, name) in ["hip_aa", "hip_fe", "knee", "ankle"].iter().enumerate() {
        let id = MotorId::new(u8::try_from(i + 1).unwrap()).unwrap();
        builder = builder.joint(JointInfo::new(*name, 0, id).with_torque_constant(true));
    }
    builder.build().unwrap()
}

#[test]
fn the_shipped_layout_is_the_generated_one() {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../docs/foxglove-layout.json");
    let generated = serde_json::to_string_pretty(&foxglove_layout(&leg_layout())).unwrap() + "\n";
    if std::env::var_os("RMD_WRITE_LAYOUT").is_some() {
        std::fs::write(&path, &generated).unwrap();
    }
    let shipped = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("{}: {e} (RMD_WRITE_LAYOUT=1 writes it)", path.display()));
    assert_eq!(
        shipped, generated,
        "docs/foxglove-layout.json is stale: RMD_WRITE_LAYOUT=1 rewrites it"
    );
}

#[test]
fn every_plot_path_names_a_channel_and_field_of_the_telemetry() {
    let layout = foxglove_layout(&leg_layout());
    let configs = layout["configById"].as_object().unwrap();
    let mut paths = 0;
    for (id, config) in configs {
        for path in config["paths"].as_array().into_iter().flatten() {
            let value = path["value"].as_str().unwrap();
            let known = [
                "/joint_states.",
                "/motor_states.",
                "/loop_timing.",
                "/signals.",
            ];
            assert!(known.iter().any(|k| value.starts_with(k)), "{id}: {value}");
            paths += 1;
        }
    }
    // 4 angles, 4 torques, 8 currents, 4 timings, 3 counters.
    assert_eq!(paths, 23);
    assert_eq!(
        configs["DiagnosticSummary!health"]["topicToRender"],
        "/diagnostics"
    );
}
