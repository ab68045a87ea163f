//! Telemetry of rmd-rt, off the real-time thread: the loop pushes one [`TickRecord`] per tick
//! through a [`Producer`] (a copy into a lock-free queue, nothing else); a fan-out thread hands it
//! to each [`Sink`] on its own thread and queue: an MCAP file ([`McapSink`]), a live Foxglove
//! server ([`LiveSink`]), a CSV file ([`CsvSink`]) or your own.
//!
//! Plain data in ([`RunLayout`] once, [`TickRecord`] per tick), no dependency on the loop: the
//! loop adapts its own per-tick sample into a record.
//!
//! ```no_run
//! use rmd_protocol::MotorId;
//! use rmd_telemetry::{
//!     CsvSink, JointInfo, JointRecord, LiveOptions, LiveSink, McapOptions, McapSink, ReplyAge,
//!     RunLayout, Telemetry, TickRecord,
//! };
//!
//! let layout = RunLayout::builder(1000.0)
//!     .joint(JointInfo::new("knee", 0, MotorId::new(1)?).with_torque_constant(true))
//!     .signal("knee_target_rad")
//!     .build()?;
//! let (producer, pipeline) = Telemetry::builder()
//!     .sink(McapSink::create("run.mcap", &layout, McapOptions::default())?)
//!     .sink(LiveSink::start(&layout, LiveOptions::default())?)
//!     .sink(CsvSink::create("run.csv", &layout)?)
//!     .start()?;
//!
//! // On the real-time thread, once per tick:
//! let mut record = TickRecord::new(0, 0, 0);
//! record.joints[0] = JointRecord {
//!     position_rad: 0.1,
//!     effort_nm: Some(0.4),
//!     reply: Some(ReplyAge::fresh(150)),
//!     ..JointRecord::EMPTY
//! };
//! producer.push(&record);
//!
//! // After the loop: drain, write summaries, close.
//! println!("{}", pipeline.shutdown());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! Channels, encodings and units: `docs/telemetry.md`.

mod channels;
mod csv_file;
mod foxglove_layout;
mod health;
mod json;
mod layout;
mod live;
mod mcap_file;
mod output;
mod pipeline;
mod record;
mod ros2;
mod sink;

pub use channels::{
    DIAGNOSTICS_TOPIC, JOINT_STATES_TOPIC, LOOP_TIMING_TOPIC, MOTOR_STATES_TOPIC, SIGNALS_TOPIC,
};
pub use csv_file::CsvSink;
pub use foxglove_layout::foxglove_layout;
pub use layout::{JointInfo, LayoutError, RunLayout, RunLayoutBuilder};
pub use live::{
    DEFAULT_LIVE_ADDR, DEFAULT_LIVE_RATE_HZ, DEFAULT_MAX_CLIENTS, FIRST_BYTES_WITHIN, LiveOptions,
    LiveSink,
};
pub use mcap_file::{McapOptions, McapSink};
pub use pipeline::{
    DEFAULT_QUEUE_CAPACITY, Delivery, Pipeline, PipelineError, PipelineStats, Producer,
    PushOutcome, Telemetry, TelemetryBuilder,
};
pub use record::{JointRecord, LoopTiming, MAX_JOINTS, MAX_SIGNALS, ReplyAge, TickRecord};
pub use sink::{Sink, SinkError, SinkStats};
