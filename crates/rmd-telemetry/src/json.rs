//! The JSON channels (no ROS message fits them): per-motor state, loop timing, user signals. Each
//! message is an object whose keys come from the layout; each channel has a JSON Schema that says
//! so. Values that do not exist (no reply yet, no torque constant, no voltage reading) are `null`.

use serde::Serialize;
use serde::ser::{SerializeMap, Serializer};
use serde_json::{Value, json};

use crate::layout::RunLayout;
use crate::record::{JointRecord, TickRecord};
use crate::sink::SinkError;

/// A number that may be missing: `null` when `None` or not finite.
fn number(value: Option<f64>) -> Option<f64> {
    value.filter(|v| v.is_finite())
}

/// One motor's state in `/motor_states`.
#[derive(Serialize)]
struct MotorState {
    temperature_c: Option<f64>,
    voltage_v: Option<f64>,
    current_a: Option<f64>,
    commanded_a: Option<f64>,
    fresh: bool,
    reply_age_us: Option<u32>,
    reply_age_ticks: Option<u32>,
    error_flags: Option<u8>,
}

impl MotorState {
    fn of(joint: &JointRecord) -> Self {
        let replied = joint.has_reply();
        let measured = |v: f64| number(replied.then_some(v));
        Self {
            temperature_c: measured(joint.temperature_c),
            voltage_v: number(joint.voltage_v.filter(|_| replied)),
            current_a: measured(joint.current_a),
            commanded_a: number(Some(joint.commanded_a)),
            fresh: joint.is_fresh(),
            reply_age_us: joint.reply.map(|r| r.micros),
            reply_age_ticks: joint.reply.map(|r| r.ticks),
            error_flags: joint.error_flags.map(rmd_protocol::ErrorState::raw),
        }
    }
}

/// `/motor_states`: `{ "<joint>": MotorState, ... }`.
pub(crate) struct MotorStates<'a> {
    pub(crate) layout: &'a RunLayout,
    pub(crate) record: &'a TickRecord,
}

impl Serialize for MotorStates<'_> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let joints = self.layout.joints();
        let mut map = serializer.serialize_map(Some(joints.len()))?;
        for (info, joint) in joints.iter().zip(&self.record.joints) {
            map.serialize_entry(info.name(), &MotorState::of(joint))?;
        }
        map.end()
    }
}

/// `/loop_timing`.
#[derive(Serialize)]
pub(crate) struct LoopTimingMessage {
    tick: u64,
    time_s: f64,
    wake_latency_us: Option<f64>,
    round_trip_us: Option<f64>,
    controller_us: Option<f64>,
    work_us: Option<f64>,
    deadline_missed: bool,
    misses: u64,
    missing_replies: u64,
    late_replies: u64,
}

impl LoopTimingMessage {
    pub(crate) fn of(record: &TickRecord) -> Self {
        let t = &record.timing;
        Self {
            tick: record.tick,
            time_s: record.time_s(),
            wake_latency_us: number(Some(t.wake_latency_us)),
            round_trip_us: number(t.round_trip_us),
            controller_us: number(Some(t.controller_us)),
            work_us: number(Some(t.work_us)),
            deadline_missed: t.deadline_missed,
            misses: t.misses,
            missing_replies: t.missing_replies,
            late_replies: t.late_replies,
        }
    }
}

/// `/signals`: `{ "<signal>": value, ... }`.
pub(crate) struct SignalsMessage<'a> {
    pub(crate) layout: &'a RunLayout,
    pub(crate) record: &'a TickRecord,
}

impl Serialize for SignalsMessage<'_> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let names = self.layout.signals();
        let mut map = serializer.serialize_map(Some(names.len()))?;
        for (name, value) in names.iter().zip(&self.record.signals) {
            map.serialize_entry(name, &number(Some(*value)))?;
        }
        map.end()
    }
}

/// Encodes `message` as JSON into `out` (cleared first).
pub(crate) fn encode_json<T: Serialize>(
    message: &T,
    what: &'static str,
    out: &mut Vec<u8>,
) -> Result<(), SinkError> {
    out.clear();
    serde_json::to_writer(&mut *out, message).map_err(|e| SinkError::Encode {
        what,
        detail: e.to_string(),
    })
}

fn nullable(kind: &str, description: &str) -> Value {
    json!({ "type": [kind, "null"], "description": description })
}

/// The JSON Schema of `/motor_states` for this layout.
pub(crate) fn motor_states_schema(layout: &RunLayout) -> Value {
    let motor = json!({
        "type": "object",
        "properties": {
            "temperature_c": nullable("number", "motor temperature (degC); null before the first reply"),
            "voltage_v": nullable("number", "supply voltage (V); null until a reply carries it"),
            "current_a": nullable("number", "measured current, q axis (A); null before the first reply"),
            "commanded_a": nullable("number", "current commanded this tick (A)"),
            "fresh": { "type": "boolean", "description": "the motor replied this tick" },
            "reply_age_us": nullable("integer", "microseconds since the last reply was received"),
            "reply_age_ticks": nullable("integer", "ticks since the last reply (0 = this tick)"),
            "error_flags": nullable("integer", "the motor's error byte (bit 0 low voltage, bit 3 over temperature)"),
        },
    });
    let properties: serde_json::Map<String, Value> = layout
        .joints()
        .iter()
        .map(|j| {
            let mut schema = motor.clone();
            schema["description"] = Value::String(format!(
                "motor {} on bus {} driving joint {}",
                j.motor(),
                j.bus(),
                j.name()
            ));
            (j.name().to_owned(), schema)
        })
        .collect();
    json!({
        "title": "rmd_rt.MotorStates",
        "description": "Per-motor state of one loop tick, keyed by joint name",
        "type": "object",
        "properties": properties,
    })
}

/// The JSON Schema of `/loop_timing`.
pub(crate) fn loop_timing_schema() -> Value {
    json!({
        "title": "rmd_rt.LoopTiming",
        "description": "Timing of one loop tick",
        "type": "object",
        "properties": {
            "tick": { "type": "integer", "description": "tick index from 0" },
            "time_s": { "type": "number", "description": "time since the start (s)" },
            "wake_latency_us": nullable("number", "wake-up latency after the scheduled time (us)"),
            "round_trip_us": nullable("number", "first frame sent to last reply received (us); null without replies"),
            "controller_us": nullable("number", "time in the controller (us)"),
            "work_us": nullable("number", "the tick's whole work (us)"),
            "deadline_missed": { "type": "boolean", "description": "this tick missed its deadline" },
            "misses": { "type": "integer", "description": "deadline misses since the start" },
            "missing_replies": { "type": "integer", "description": "replies that never came, since the start" },
            "late_replies": { "type": "integer", "description": "replies after their deadline, since the start" },
        },
    })
}

/// The JSON Schema of `/signals` for this layout.
pub(crate) fn signals_schema(layout: &RunLayout) -> Value {
    let properties: serde_json::Map<String, Value> = layout
        .signals()
        .iter()
        .map(|s| (s.clone(), nullable("number", "user signal")))
        .collect();
    json!({
        "title": "rmd_rt.Signals",
        "description": "The controller's user signals of one tick",
        "type": "object",
        "properties": properties,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::layout::JointInfo;
    use crate::record::ReplyAge;
    use rmd_protocol::{ErrorState, MotorId};

    fn layout() -> RunLayout {
        RunLayout::builder(100.0)
            .joint(JointInfo::new("hip", 0, MotorId::new(1).unwrap()))
            .joint(JointInfo::new("knee", 0, MotorId::new(2).unwrap()))
            .signal("target")
            .build()
            .unwrap()
    }

    #[test]
    fn motor_states_are_keyed_by_joint_and_null_before_a_reply() {
        let layout = layout();
        let mut record = TickRecord::new(3, 30_000_000, 0);
        record.joints[0] = JointRecord {
            temperature_c: 40.0,
            current_a: 1.25,
            commanded_a: 1.5,
            voltage_v: Some(24.0),
            error_flags: Some(ErrorState::OVER_TEMPERATURE),
            reply: Some(ReplyAge {
                ticks: 2,
                micros: 2500,
            }),
            ..JointRecord::EMPTY
        };
        record.joints[1].commanded_a = 0.5;
        let mut out = Vec::new();
        encode_json(
            &MotorStates {
                layout: &layout,
                record: &record,
            },
            "m",
            &mut out,
        )
        .unwrap();
        let v: Value = serde_json::from_slice(&out).unwrap();
        assert_eq!(v["hip"]["current_a"], 1.25);
        assert_eq!(v["hip"]["fresh"], false);
        assert_eq!(v["hip"]["reply_age_ticks"], 2);
        assert_eq!(v["hip"]["error_flags"], 8);
        assert_eq!(v["knee"]["temperature_c"], Value::Null);
        assert_eq!(v["knee"]["commanded_a"], 0.5);
        assert_eq!(v.as_object().unwrap().len(), 2);
    }

    #[test]
    fn signals_and_timing_carry_names_and_nulls() {
        let layout = layout();
        let mut record = TickRecord::new(1, 10_000_000, 0);
        record.signals[0] = f64::NAN;
        record.signals[1] = 9.0; // past the layout: ignored
        record.timing.round_trip_us = None;
        record.timing.work_us = 42.0;
        let mut out = Vec::new();
        encode_json(
            &SignalsMessage {
                layout: &layout,
                record: &record,
            },
            "s",
            &mut out,
        )
        .unwrap();
        assert_eq!(out, br#"{"target":null}"#);
        encode_json(&LoopTimingMessage::of(&record), "t", &mut out).unwrap();
        let v: Value = serde_json::from_slice(&out).unwrap();
        assert_eq!(v["round_trip_us"], Value::Null);
        assert_eq!(v["work_us"], 42.0);
        assert_eq!(v["tick"], 1);
        let schema = motor_states_schema(&layout);
        assert!(schema["properties"]["knee"]["properties"]["fresh"].is_object());
        assert!(signals_schema(&layout)["properties"]["target"].is_object());
    }
}
