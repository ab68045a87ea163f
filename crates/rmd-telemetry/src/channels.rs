//! The telemetry's Foxglove channels on one context, and how a record becomes their messages.
//! The MCAP sink and the live server each own one [`Channels`] on their own context, so each can
//! run at its own rate behind its own queue.

use std::collections::BTreeMap;
use std::sync::Arc;

use foxglove::{Context, PartialMetadata, RawChannel, Schema};

use crate::health::Health;
use crate::json::{self, LoopTimingMessage, MotorStates, SignalsMessage};
use crate::layout::RunLayout;
use crate::record::TickRecord;
use crate::ros2::{self, DiagnosticArray, Header, JointState, Time};
use crate::sink::SinkError;

/// Topic of the joint states (`sensor_msgs/msg/JointState`, CDR).
pub const JOINT_STATES_TOPIC: &str = "/joint_states";
/// Topic of the per-motor state (JSON).
pub const MOTOR_STATES_TOPIC: &str = "/motor_states";
/// Topic of the loop timing (JSON).
pub const LOOP_TIMING_TOPIC: &str = "/loop_timing";
/// Topic of the user signals (JSON); absent when the layout names no signal.
pub const SIGNALS_TOPIC: &str = "/signals";
/// Topic of the 1 Hz health (`diagnostic_msgs/msg/DiagnosticArray`, CDR).
pub const DIAGNOSTICS_TOPIC: &str = "/diagnostics";

/// The channels of one context and the buffers that fill them.
pub(crate) struct Channels {
    layout: Arc<RunLayout>,
    joint_states: Arc<RawChannel>,
    motor_states: Arc<RawChannel>,
    loop_timing: Arc<RawChannel>,
    signals: Option<Arc<RawChannel>>,
    diagnostics: Arc<RawChannel>,
    health: Health,
    last_since_start_ns: u64,
    buffer: Vec<u8>,
    position: Vec<f64>,
    velocity: Vec<f64>,
    effort: Vec<f64>,
    names: Vec<String>,
}

fn cdr_channel(
    context: &Arc<Context>,
    topic: &str,
    schema_name: &str,
    schema: String,
) -> Result<Arc<RawChannel>, SinkError> {
    context
        .channel_builder(topic)
        .message_encoding("cdr")
        .schema(Schema::new(schema_name, "ros2msg", schema.into_bytes()))
        .build_raw()
        .map_err(|e| SinkError::foxglove(format!("creating channel {topic}"), e))
}

fn json_channel(
    context: &Arc<Context>,
    topic: &str,
    schema: &serde_json::Value,
) -> Result<Arc<RawChannel>, SinkError> {
    let name = schema["title"].as_str().unwrap_or(topic).to_owned();
    let data = serde_json::to_vec(schema).map_err(|e| SinkError::Encode {
        what: "a JSON schema",
        detail: e.to_string(),
    })?;
    context
        .channel_builder(topic)
        .message_encoding("json")
        .schema(Schema::new(name, "jsonschema", data))
        .build_raw()
        .map_err(|e| SinkError::foxglove(format!("creating channel {topic}"), e))
}

impl Channels {
    /// Creates the channels on `context`.
    pub(crate) fn new(context: &Arc<Context>, layout: Arc<RunLayout>) -> Result<Self, SinkError> {
        let joint_states = cdr_channel(
            context,
            JOINT_STATES_TOPIC,
            ros2::JOINT_STATE_NAME,
            ros2::joint_state_schema(),
        )?;
        let diagnostics = cdr_channel(
            context,
            DIAGNOSTICS_TOPIC,
            ros2::DIAGNOSTIC_ARRAY_NAME,
            ros2::diagnostic_array_schema(),
        )?;
        let motor_states = json_channel(
            context,
            MOTOR_STATES_TOPIC,
            &json::motor_states_schema(&layout),
        )?;
        let loop_timing = json_channel(context, LOOP_TIMING_TOPIC, &json::loop_timing_schema())?;
        let signals = if layout.signals().is_empty() {
            None
        } else {
            Some(json_channel(
                context,
                SIGNALS_TOPIC,
                &json::signals_schema(&layout),
            )?)
        };
        let n = layout.joints().len();
        Ok(Self {
            names: layout
                .joints()
                .iter()
                .map(|j| j.name().to_owned())
                .collect(),
            layout,
            joint_states,
            motor_states,
            loop_timing,
            signals,
            diagnostics,
            health: Health::new(),
            last_since_start_ns: 0,
            buffer: Vec::with_capacity(4096),
            position: Vec::with_capacity(n),
            velocity: Vec::with_capacity(n),
            effort: Vec::with_capacity(n),
        })
    }

    /// The run layout as MCAP metadata (`rmd_rt.run`).
    pub(crate) fn metadata(&self) -> BTreeMap<String, String> {
        let layout = &self.layout;
        let joints: Vec<serde_json::Value> = layout
            .joints()
            .iter()
            .map(|j| {
                serde_json::json!({
                    "name": j.name(),
                    "bus": j.bus(),
                    "motor_id": j.motor().get(),
                    "torque_constant_known": j.torque_constant_known(),
                })
            })
            .collect();
        BTreeMap::from([
            ("rate_hz".to_owned(), layout.rate_hz().to_string()),
            ("bus_count".to_owned(), layout.bus_count().to_string()),
            (
                "joints".to_owned(),
                serde_json::Value::Array(joints).to_string(),
            ),
            (
                "signals".to_owned(),
                serde_json::to_string(layout.signals()).unwrap_or_default(),
            ),
            (
                "start_unix_ns".to_owned(),
                layout.start_unix_ns().to_string(),
            ),
        ])
    }

    /// Feeds `record` to the health window; logs `/diagnostics` when a second completes.
    /// Returns the bytes of the message logged (0: none).
    pub(crate) fn observe(&mut self, record: &TickRecord) -> Result<usize, SinkError> {
        self.last_since_start_ns = record.since_start_ns;
        match self.health.observe(&self.layout, record) {
            Some(statuses) => self.log_diagnostics(record.since_start_ns, statuses),
            None => Ok(0),
        }
    }

    /// Logs the unfinished second's `/diagnostics` (end of run), if it has any tick.
    pub(crate) fn flush_health(&mut self) -> Result<(), SinkError> {
        let last_ns = self.last_since_start_ns;
        if let Some(statuses) = self.health.flush(&self.layout) {
            self.log_diagnostics(last_ns, statuses)?;
        }
        Ok(())
    }

    fn log_diagnostics(
        &mut self,
        since_start_ns: u64,
        status: Vec<ros2::DiagnosticStatus>,
    ) -> Result<usize, SinkError> {
        let unix_ns = self.layout.unix_ns(since_start_ns);
        let message = DiagnosticArray {
            header: Header {
                stamp: Time::from_unix_ns(unix_ns),
                frame_id: "",
            },
            status,
        };
        ros2::encode_cdr(&message, DIAGNOSTICS_TOPIC, &mut self.buffer)?;
        self.diagnostics
            .log_with_meta(&self.buffer, PartialMetadata::with_log_time(unix_ns));
        Ok(self.buffer.len())
    }

    /// Logs `record` on every per-tick channel. Returns the bytes of the messages logged.
    pub(crate) fn publish(&mut self, record: &TickRecord) -> Result<usize, SinkError> {
        let unix_ns = self.layout.unix_ns(record.since_start_ns);
        let meta = PartialMetadata::with_log_time(unix_ns);
        self.fill_joint_arrays(record);
        let joint_state = JointState {
            header: Header {
                stamp: Time::from_unix_ns(unix_ns),
                frame_id: "",
            },
            name: &self.names,
            position: &self.position,
            velocity: &self.velocity,
            effort: &self.effort,
        };
        ros2::encode_cdr(&joint_state, JOINT_STATES_TOPIC, &mut self.buffer)?;
        self.joint_states.log_with_meta(&self.buffer, meta);
        let mut bytes = self.buffer.len();

        let layout = &*self.layout;
        json::encode_json(
            &MotorStates { layout, record },
            MOTOR_STATES_TOPIC,
            &mut self.buffer,
        )?;
        self.motor_states.log_with_meta(&self.buffer, meta);
        bytes += self.buffer.len();

        json::encode_json(
            &LoopTimingMessage::of(record),
            LOOP_TIMING_TOPIC,
            &mut self.buffer,
        )?;
        self.loop_timing.log_with_meta(&self.buffer, meta);
        bytes += self.buffer.len();

        if let Some(signals) = &self.signals {
            json::encode_json(
                &SignalsMessage { layout, record },
                SIGNALS_TOPIC,
                &mut self.buffer,
            )?;
            signals.log_with_meta(&self.buffer, meta);
            bytes += self.buffer.len();
        }
        Ok(bytes)
    }

    /// The `JointState` arrays: NaN for a joint that never replied; effort NaN for a joint
    /// without torque constant, and empty when no joint has one.
    fn fill_joint_arrays(&mut self, record: &TickRecord) {
        self.position.clear();
        self.velocity.clear();
        self.effort.clear();
        let with_effort = self.layout.any_torque();
        for (info, joint) in self.layout.joints().iter().zip(&record.joints) {
            let replied = joint.has_reply();
            let value = |v: f64| if replied { v } else { f64::NAN };
            self.position.push(value(joint.position_rad));
            self.velocity.push(value(joint.velocity_rad_s));
            if with_effort {
                let effort = joint
                    .effort_nm
                    .filter(|_| info.torque_constant_known())
                    .map_or(f64::NAN, value);
                self.effort.push(effort);
            }
        }
    }

    /// Closes every channel (the context's sinks see them go).
    pub(crate) fn close(&self) {
        self.joint_states.close();
        self.motor_states.close();
        self.loop_timing.close();
        if let Some(signals) = &self.signals {
            signals.close();
        }
        self.diagnostics.close();
    }
}
