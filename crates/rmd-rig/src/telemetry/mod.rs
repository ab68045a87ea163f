//! The loop's telemetry to files and a live view: [`TelemetryOutputs`] (the sinks a run writes:
//! `--csv`, `--mcap`, `--foxglove`) started as [`TelemetrySinks`] on the run's
//! [`RunLayout`], fed the loop's samples on an ordinary thread (the
//! runner's, or a thread of its own: [`spawn_feed`]), each turned into a
//! [`TickRecord`](rmd_telemetry::TickRecord) by a [`RecordAssembler`] and fanned out by
//! `rmd-telemetry`'s pipeline; a [`TelemetryReport`] at the end says what each sink got.
//!
//! What is lost where, and counted for whom:
//!
//! - The loop publishes into its own mailbox. On a real clock a full mailbox loses the oldest
//!   sample (the loop never waits); on a virtual clock the loop waits for room
//!   ([`TelemetryDelivery::Wait`]), so nothing is lost there. A sample lost there is lost for
//!   every sink and counted in each.
//! - The pipeline gives each sink its own queue: on a real clock a sink that cannot keep up
//!   loses records counted for it alone ([`Delivery::Lossy`]); on a virtual clock everything
//!   waits for the slowest sink ([`Delivery::Lossless`]), so a file gets one record per tick.
//! - Without sinks nothing is started, published or counted.
//!
//! ```
//! use rmd_loop::{Commands, Controller, Feedback, Flow, RunLimit, TickContext, robot::Robot};
//! use rmd_rig::telemetry::{TelemetryOutputs, TelemetrySinks};
//! use rmd_rig::{Placement, Rig, SimTime, sim};
//!
//! struct Idle;
//! impl Controller for Idle {
//!     fn update(&mut self, _: &TickContext, _: &Feedback<'_>, _: &mut Commands<'_>) -> Flow {
//!         Flow::Continue
//!     }
//! }
//! let dir = tempfile::tempdir()?;
//! let robot = Robot::from_toml("[[bus]]\ninterface = \"can0\"\n[[bus.motor]]\nid = 1")?;
//! let rig = Rig::open(&robot, &Placement::simulated(&robot, SimTime::Virtual), sim::sim_configs(&robot, 1))?;
//! let mut rt = rig.into_loop(robot, Idle)?;
//! let outputs = TelemetryOutputs {
//!     csv: Some(dir.path().join("run.csv")),
//!     ..TelemetryOutputs::default()
//! };
//! let sinks = TelemetrySinks::attach(&mut rt, &outputs)?.expect("one sink asked for");
//! let feed = rmd_rig::telemetry::spawn_feed(sinks)?;
//! let outcome = rt.run(RunLimit::Ticks(100));
//! let report = feed.finish(outcome.report.stats.telemetry_drops);
//! assert_eq!(report.sinks()[0].written, 100);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod feed;
mod record;

use std::fmt;
use std::io::Write;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};

use rmd_bus::{CanBus, Clock};
use rmd_loop::{
    Controller, RtLoop,
    robot::Robot,
    telemetry::{TelemetryDelivery, TelemetryReceiver, TelemetrySample},
};
use rmd_telemetry::{
    CsvSink, Delivery, JointInfo, LayoutError, LiveOptions, LiveSink, McapOptions, McapSink,
    PipelineError, PipelineStats, Producer, RunLayout, SinkError, SinkStats, Telemetry,
};

pub use feed::{FeedThread, spawn_feed};
pub use record::{RecordAssembler, joint_record};

/// The sinks a run writes (the `--csv`, `--mcap` and `--foxglove` flags); all `None`: no
/// telemetry at all.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TelemetryOutputs {
    /// One CSV row per tick.
    pub csv: Option<PathBuf>,
    /// An MCAP file with every tick (ROS 2 `/joint_states` and the other channels).
    pub mcap: Option<PathBuf>,
    /// A Foxglove WebSocket server with the same channels, decimated.
    pub live: Option<LiveOptions>,
}

impl TelemetryOutputs {
    /// Whether no sink is asked for.
    pub fn is_empty(&self) -> bool {
        self.csv.is_none() && self.mcap.is_none() && self.live.is_none()
    }
}

/// Why the telemetry of a run could not start. Each message names the file, address or limit.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TelemetryError {
    /// The robot or the controller's signals do not fit a telemetry record.
    #[error("telemetry: {0}")]
    Layout(#[from] LayoutError),
    /// A file's folder could not be created.
    #[error("telemetry: cannot create the folder {path}: {source}")]
    Folder {
        /// The folder.
        path: String,
        /// Why.
        source: std::io::Error,
    },
    /// A sink could not open its file or address.
    #[error("telemetry: {0}")]
    Sink(#[from] SinkError),
    /// The telemetry threads could not start.
    #[error("telemetry: {0}")]
    Pipeline(#[from] PipelineError),
}

/// The run layout of `robot` with a controller writing `signals`: its joints in description
/// order (name, bus, motor id, whether the torque is known), its bus count and loop rate.
///
/// # Errors
/// A [`LayoutError`] if the names or counts do not fit a record (the loop's own limits are
/// narrower, so a robot the loop runs always fits).
pub fn run_layout(robot: &Robot, signals: &[String]) -> Result<RunLayout, LayoutError> {
    RunLayout::builder(robot.settings().period.hz())
        .bus_count(robot.buses().len())
        .joints(robot.joints().iter().map(|j| {
            JointInfo::new(j.name.clone(), j.bus, j.motor)
                .with_torque_constant(j.torque_constant_nm_per_amp.is_some())
        }))
        .signals(signals.iter().cloned())
        .build()
}

/// The running sinks of one run, fed from the loop's telemetry mailbox: build with
/// [`TelemetrySinks::attach`], feed with [`TelemetrySinks::pump`] (or hand to [`spawn_feed`]),
/// end with [`TelemetrySinks::finish`].
pub struct TelemetrySinks {
    receiver: Option<TelemetryReceiver>,
    assembler: RecordAssembler,
    producer: Producer,
    pipeline: rmd_telemetry::Pipeline,
    samples: u64,
    live_addr: Option<SocketAddr>,
}

impl fmt::Debug for TelemetrySinks {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("TelemetrySinks")
            .field("pipeline", &self.pipeline)
            .field("samples", &self.samples)
            .finish()
    }
}

/// Creates the folder of `path` if it has one that does not exist.
fn make_folder(path: &Path) -> Result<(), TelemetryError> {
    match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => {
            std::fs::create_dir_all(dir).map_err(|source| TelemetryError::Folder {
                path: dir.display().to_string(),
                source,
            })
        }
        _ => Ok(()),
    }
}

impl TelemetrySinks {
    /// Opens the sinks `outputs` asks for on `layout` (files created, the server bound) and
    /// starts their threads, waiting for room when `lossless` (virtual time) and losing records
    /// per sink otherwise. `None` when no sink is asked for. Feed it samples with
    /// [`take`](Self::take).
    ///
    /// The live server's threads inherit this thread's CPU affinity: call it before pinning
    /// this thread to the real-time CPU (the loop pins its own thread, not this one).
    ///
    /// # Errors
    /// A [`TelemetryError`] naming the file or address that failed; nothing is left running.
    pub fn start(
        layout: &RunLayout,
        outputs: &TelemetryOutputs,
        lossless: bool,
    ) -> Result<Option<Self>, TelemetryError> {
        if outputs.is_empty() {
            return Ok(None);
        }
        let mut builder = Telemetry::builder().delivery(if lossless {
            Delivery::Lossless
        } else {
            Delivery::Lossy
        });
        if let Some(path) = &outputs.mcap {
            make_folder(path)?;
            builder = builder.sink(McapSink::create(path, layout, McapOptions::default())?);
        }
        let mut live_addr = None;
        if let Some(options) = &outputs.live {
            if let Some(warning) = options.exposure_warning() {
                // Said before the server starts, whatever the display: the user must know.
                let _ = writeln!(std::io::stderr(), "warning: {warning}");
            }
            let live = LiveSink::start(layout, options.clone())?;
            live_addr = Some(live.local_addr());
            builder = builder.sink(live);
        }
        if let Some(path) = &outputs.csv {
            make_folder(path)?;
            builder = builder.sink(CsvSink::create(path, layout)?);
        }
        let (producer, pipeline) = builder.start()?;
        Ok(Some(Self {
            receiver: None,
            assembler: RecordAssembler::new(),
            producer,
            pipeline,
            samples: 0,
            live_addr,
        }))
    }

    /// [`start`](Self::start) for the loop `rt`: the layout of its robot and controller, lossless
    /// on a virtual clock, and the loop's telemetry mailbox taken (waiting for room on a virtual
    /// clock, overwriting the oldest sample otherwise). `None` (and the loop untouched) when
    /// no sink is asked for.
    ///
    /// # Errors
    /// As [`start`](Self::start).
    pub fn attach<B, C, K>(
        rt: &mut RtLoop<B, C, K>,
        outputs: &TelemetryOutputs,
    ) -> Result<Option<Self>, TelemetryError>
    where
        B: CanBus,
        C: Clock + Clone + 'static,
        K: Controller,
    {
        let layout = run_layout(rt.robot(), &rt.controller().signals())?;
        let lossless = rt.clock().is_virtual();
        let Some(mut sinks) = Self::start(&layout, outputs, lossless)? else {
            return Ok(None);
        };
        sinks.receiver = Some(rt.telemetry_with(if lossless {
            TelemetryDelivery::Wait
        } else {
            TelemetryDelivery::Overwrite
        }));
        Ok(Some(sinks))
    }

    /// [`attach`](Self::attach) to a mailbox the caller took from the loop itself (the runner,
    /// which also shows the samples in its status line).
    pub fn with_receiver(mut self, receiver: TelemetryReceiver) -> Self {
        self.receiver = Some(receiver);
        self
    }

    /// The live server's address (port 0 resolved), if there is one.
    pub fn live_addr(&self) -> Option<SocketAddr> {
        self.live_addr
    }

    /// Takes every sample queued in the loop's mailbox now, shows each to `each`, and feeds
    /// it to the sinks; returns how many it took. Lossless, it waits while the sinks are full.
    pub fn pump(&mut self, mut each: impl FnMut(&TelemetrySample)) -> usize {
        let Some(receiver) = self.receiver.take() else {
            return 0;
        };
        let mut taken = 0;
        while let Some(sample) = receiver.try_recv() {
            each(&sample);
            self.take(&sample);
            taken += 1;
        }
        self.receiver = Some(receiver);
        taken
    }

    /// Feeds one sample to the sinks (its record goes out when the next sample completes it).
    pub fn take(&mut self, sample: &TelemetrySample) {
        self.samples += 1;
        if let Some(record) = self.assembler.push(sample) {
            self.producer.push(&record);
        }
    }

    /// Whether the loop can still publish (its mailbox has a sender) or samples are queued.
    pub fn loop_alive(&self) -> bool {
        self.receiver
            .as_ref()
            .is_some_and(|r| r.has_senders() || !r.is_empty())
    }

    /// Feeds what is still queued, sends the last record, closes every sink (the MCAP summary
    /// written, the server stopped, files flushed) and says what each got. `lost_in_loop`: the
    /// samples the loop's mailbox lost (the loop report's `telemetry_drops`), counted as dropped
    /// for every sink.
    pub fn finish(mut self, lost_in_loop: u64) -> TelemetryReport {
        self.pump(|_| {});
        if let Some(record) = self.assembler.finish() {
            self.producer.push(&record);
        }
        let mut stats = self.pipeline.shutdown();
        for sink in &mut stats.sinks {
            sink.dropped += lost_in_loop;
        }
        TelemetryReport {
            samples: self.samples,
            lost_in_loop,
            stats,
        }
    }
}

/// What the telemetry of a run produced, per sink.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TelemetryReport {
    /// Samples the telemetry received from the loop.
    pub samples: u64,
    /// Samples the loop's mailbox lost before the telemetry took them (in every sink's
    /// `dropped`).
    pub lost_in_loop: u64,
    /// The pipeline's counts; each sink's `dropped` includes [`lost_in_loop`](Self::lost_in_loop).
    pub stats: PipelineStats,
}

impl TelemetryReport {
    /// Each sink's counts, in the order `--mcap`, `--foxglove`, `--csv`.
    pub fn sinks(&self) -> &[SinkStats] {
        &self.stats.sinks
    }

    /// Whether every sink got every tick without an error.
    pub fn complete(&self) -> bool {
        self.sinks()
            .iter()
            .all(|s| s.dropped == 0 && s.failed == 0 && s.errors == 0)
    }

    /// Whether some sink failed: a record it could not write or an error (a full disk, a
    /// closed device). A run that asked for a recording and did not get it ends with a
    /// non-zero status; records dropped for lack of room (counted, real time only) are not a
    /// failure.
    pub fn failed(&self) -> bool {
        self.sinks().iter().any(|s| s.failed > 0 || s.errors > 0)
    }
}

impl fmt::Display for TelemetryReport {
    /// One line per sink: `telemetry: mcap run.mcap: 10000 written, 0 failed, 0 dropped, 0
    /// errors`, with the first error and the sink's note in parentheses.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, sink) in self.sinks().iter().enumerate() {
            if i > 0 {
                writeln!(f)?;
            }
            write!(f, "telemetry: {sink}")?;
        }
        Ok(())
    }
}
