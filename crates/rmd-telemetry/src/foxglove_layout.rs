//! A Foxglove layout for a run: joint angles, torques, motor currents, loop timing, misses and the
//! diagnostics, with the joints' names.

use serde_json::{Value, json};

use crate::channels::{
    DIAGNOSTICS_TOPIC, JOINT_STATES_TOPIC, LOOP_TIMING_TOPIC, MOTOR_STATES_TOPIC, SIGNALS_TOPIC,
};
use crate::layout::RunLayout;

/// Whether Foxglove's message-path syntax takes `name` as a plain field name.
fn plain_field(name: &str) -> bool {
    let mut chars = name.chars();
    chars
        .next()
        .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

fn series(path: String, label: &str) -> Value {
    json!({
        "value": path,
        "enabled": true,
        "timestampMethod": "receiveTime",
        "label": label,
    })
}

fn plot(title: &str, paths: Vec<Value>) -> Value {
    json!({
        "title": title,
        "paths": paths,
        "showXAxisLabels": true,
        "showYAxisLabels": true,
        "showLegend": true,
        "legendDisplay": "floating",
        "showPlotValuesInLegend": true,
        "isSynced": true,
        "xAxisVal": "timestamp",
        "sidebarDimension": 240,
    })
}

/// A column of panels with equal heights, as a Foxglove mosaic tree.
fn column(ids: &[String]) -> Value {
    match ids {
        [] => Value::Null,
        [only] => Value::String(only.clone()),
        [first, rest @ ..] => json!({
            "first": first,
            "second": column(rest),
            "direction": "column",
            "splitPercentage": 100.0 / ids.len() as f64,
        }),
    }
}

/// A Foxglove layout (File > Import layout, or drag the file onto the app) for `layout`'s
/// channels: on the left joint angles, joint torques and motor currents (measured and
/// commanded) per joint; on the right loop timing, deadline misses and missing replies, user
/// signals if any, and the `/diagnostics` summary.
///
/// Joints whose names are not plain identifiers (letters, digits, `_`) are left out of the
/// per-motor current plot, whose paths use the name as a field.
///
/// ```
/// use rmd_protocol::MotorId;
/// use rmd_telemetry::{JointInfo, RunLayout, foxglove_layout};
///
/// let layout = RunLayout::builder(1000.0)
///     .joint(JointInfo::new("knee", 0, MotorId::new(1)?))
///     .build()?;
/// let panels = foxglove_layout(&layout);
/// assert!(panels["configById"].as_object().is_some_and(|c| c.len() >= 5));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn foxglove_layout(layout: &RunLayout) -> Value {
    let joints = layout.joints();
    let angles = joints
        .iter()
        .enumerate()
        .map(|(i, j)| series(format!("{JOINT_STATES_TOPIC}.position[{i}]"), j.name()))
        .collect();
    let torques = joints
        .iter()
        .enumerate()
        .filter(|(_, j)| j.torque_constant_known())
        .map(|(i, j)| series(format!("{JOINT_STATES_TOPIC}.effort[{i}]"), j.name()))
        .collect();
    let currents = joints
        .iter()
        .filter(|j| plain_field(j.name()))
        .flat_map(|j| {
            let name = j.name();
            [
                series(
                    format!("{MOTOR_STATES_TOPIC}.{name}.current_a"),
                    &format!("{name} measured"),
                ),
                series(
                    format!("{MOTOR_STATES_TOPIC}.{name}.commanded_a"),
                    &format!("{name} commanded"),
                ),
            ]
        })
        .collect();
    let timing = [
        ("wake_latency_us", "wake latency"),
        ("round_trip_us", "round trip"),
        ("controller_us", "controller"),
        ("work_us", "work"),
    ]
    .iter()
    .map(|(field, label)| series(format!("{LOOP_TIMING_TOPIC}.{field}"), label))
    .collect();
    let misses = [
        ("misses", "deadline misses"),
        ("missing_replies", "missing replies"),
        ("late_replies", "late replies"),
    ]
    .iter()
    .map(|(field, label)| series(format!("{LOOP_TIMING_TOPIC}.{field}"), label))
    .collect();

    let mut configs = serde_json::Map::new();
    let mut left = Vec::new();
    let mut right = Vec::new();
    let mut add = |side: &mut Vec<String>, id: &str, config: Value| {
        configs.insert(id.to_owned(), config);
        side.push(id.to_owned());
    };
    add(
        &mut left,
        "Plot!joint-angles",
        plot("Joint angles (rad)", angles),
    );
    add(
        &mut left,
        "Plot!joint-torques",
        plot("Joint torques (N·m)", torques),
    );
    add(
        &mut left,
        "Plot!motor-currents",
        plot("Motor currents (A)", currents),
    );
    add(
        &mut right,
        "Plot!loop-timing",
        plot("Loop timing (µs)", timing),
    );
    add(
        &mut right,
        "Plot!loop-misses",
        plot("Misses since the start", misses),
    );
    if !layout.signals().is_empty() {
        let signals = layout
            .signals()
            .iter()
            .filter(|s| plain_field(s))
            .map(|s| series(format!("{SIGNALS_TOPIC}.{s}"), s))
            .collect();
        add(
            &mut right,
            "Plot!user-signals",
            plot("User signals", signals),
        );
    }
    add(
        &mut right,
        "DiagnosticSummary!health",
        json!({
            "topicToRender": DIAGNOSTICS_TOPIC,
            "minLevel": 0,
            "pinnedIds": [],
            "hardwareIdFilter": "",
            "sortByLevel": true,
        }),
    );
    json!({
        "configById": configs,
        "globalVariables": {},
        "userNodes": {},
        "playbackConfig": { "speed": 1 },
        "layout": {
            "first": column(&left),
            "second": column(&right),
            "direction": "row",
            "splitPercentage": 60,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plain_fields_are_identifiers() {
        assert!(plain_field("hip_fe") && plain_field("_a1"));
        assert!(!plain_field("") && !plain_field("1a") && !plain_field("left knee"));
    }

    #[test]
    fn a_column_nests_its_panels() {
        let ids = ["a".to_owned(), "b".to_owned(), "c".to_owned()];
        let tree = column(&ids);
        assert_eq!(tree["first"], "a");
        assert_eq!(tree["second"]["first"], "b");
        assert_eq!(tree["second"]["second"], "c");
    }
}
