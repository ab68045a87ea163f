//! Telemetry of a Python-driven loop, off the real-time thread: a plain Rust thread takes the
//! loop's per-tick samples (`RtLoop::telemetry`), turns each into an rmd-telemetry
//! `TickRecord`, and pushes it into whichever sinks Python switched on: an MCAP file, a live
//! Foxglove server, each its own rmd-telemetry pipeline that can start and stop while the loop
//! runs. With no sink on, the samples are taken and dropped.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::thread::JoinHandle;
use std::time::Duration;

use crate::process::Owner;
use rmd_bus::Timestamp;
use rmd_loop::{Freshness, Robot, TelemetryReceiver, TelemetrySample};
use rmd_telemetry::{
    JointInfo, JointRecord, LiveOptions, LiveSink, LoopTiming, McapOptions, McapSink, Pipeline,
    PipelineStats, Producer, ReplyAge, RunLayout, Telemetry, TickRecord,
};

/// How often the thread looks for new samples.
const POLL: Duration = Duration::from_millis(2);

/// One sink's pipeline while it is on.
struct Active {
    producer: Producer,
    pipeline: Pipeline,
}

impl Active {
    fn start(sink: impl rmd_telemetry::Sink) -> Result<Self, String> {
        let (producer, pipeline) = Telemetry::builder()
            .sink(sink)
            .start()
            .map_err(|e| e.to_string())?;
        Ok(Self { producer, pipeline })
    }
}

#[derive(Default)]
struct Sinks {
    mcap: Option<(PathBuf, Active)>,
    live: Option<(SocketAddr, Active)>,
}

struct Control {
    stop: AtomicBool,
    sinks: Mutex<Sinks>,
    layout: RunLayout,
}

impl Control {
    fn sinks(&self) -> std::sync::MutexGuard<'_, Sinks> {
        self.sinks.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

/// Which sinks are on, and their counts so far.
pub(crate) struct SinkStatus {
    /// The MCAP file being written.
    pub(crate) mcap: Option<(PathBuf, PipelineStats)>,
    /// The live server's address.
    pub(crate) live: Option<(SocketAddr, PipelineStats)>,
}

/// The telemetry thread of one loop and its switchable sinks.
pub(crate) struct TelemetryWorker {
    owner: Owner,
    control: Arc<Control>,
    thread: Option<JoinHandle<()>>,
}

/// The layout of `robot`'s telemetry with the controller's `signals`.
pub(crate) fn layout(robot: &Robot, signals: &[String]) -> Result<RunLayout, String> {
    let rate_hz = robot.settings().period.hz();
    let joints = robot.joints().iter().map(|j| {
        JointInfo::new(j.name.clone(), j.bus, j.motor)
            .with_torque_constant(j.torque_constant_nm_per_amp.is_some())
    });
    let mut builder = RunLayout::builder(rate_hz)
        .bus_count(robot.buses().len())
        .joints(joints);
    for name in signals.iter().take(rmd_telemetry::MAX_SIGNALS) {
        builder = builder.signal(name.clone());
    }
    builder.build().map_err(|e| e.to_string())
}

impl TelemetryWorker {
    /// Starts the thread on the loop's samples.
    pub(crate) fn start(samples: TelemetryReceiver, layout: RunLayout) -> std::io::Result<Self> {
        let control = Arc::new(Control {
            stop: AtomicBool::new(false),
            sinks: Mutex::new(Sinks::default()),
            layout,
        });
        let thread = std::thread::Builder::new()
            .name("rmd-py-telemetry".to_owned())
            .spawn({
                let control = Arc::clone(&control);
                move || run(&samples, &control)
            })?;
        Ok(Self {
            owner: Owner::here(),
            control,
            thread: Some(thread),
        })
    }

    /// Starts writing an MCAP file at `path` (replacing the file), unless one is being written.
    pub(crate) fn start_mcap(&self, path: PathBuf, compress: bool) -> Result<(), String> {
        let mut sinks = self.control.sinks();
        if let Some((current, _)) = &sinks.mcap {
            return Err(format!(
                "an MCAP file is being written already ({}): stop it first",
                current.display()
            ));
        }
        let options = McapOptions {
            compress,
            ..McapOptions::default()
        };
        let sink =
            McapSink::create(&path, &self.control.layout, options).map_err(|e| e.to_string())?;
        sinks.mcap = Some((path, Active::start(sink)?));
        Ok(())
    }

    /// Stops the MCAP file (closed with its summary and index); its counts, or `None` if none
    /// was being written.
    pub(crate) fn stop_mcap(&self) -> Option<PipelineStats> {
        let active = self.control.sinks().mcap.take();
        active.map(|(_, active)| active.pipeline.shutdown())
    }

    /// Starts the live Foxglove server on `addr` (port 0: any free port); the address it
    /// listens on.
    pub(crate) fn start_live(&self, addr: SocketAddr, rate_hz: f64) -> Result<SocketAddr, String> {
        let mut sinks = self.control.sinks();
        if let Some((current, _)) = &sinks.live {
            return Err(format!(
                "the live server runs already (ws://{current}): stop it first"
            ));
        }
        let options = LiveOptions {
            addr,
            rate_hz,
            ..LiveOptions::default()
        };
        let sink = LiveSink::start(&self.control.layout, options).map_err(|e| e.to_string())?;
        let bound = sink.local_addr();
        sinks.live = Some((bound, Active::start(sink)?));
        Ok(bound)
    }

    /// Stops the live server; its counts, or `None` if it was not running.
    pub(crate) fn stop_live(&self) -> Option<PipelineStats> {
        let active = self.control.sinks().live.take();
        active.map(|(_, active)| active.pipeline.shutdown())
    }

    /// The sinks that are on, and their counts so far.
    pub(crate) fn status(&self) -> SinkStatus {
        let sinks = self.control.sinks();
        SinkStatus {
            mcap: sinks
                .mcap
                .as_ref()
                .map(|(path, a)| (path.clone(), a.pipeline.stats())),
            live: sinks
                .live
                .as_ref()
                .map(|(addr, a)| (*addr, a.pipeline.stats())),
        }
    }

    /// Takes the samples left, closes every sink and ends the thread (after the loop ended).
    pub(crate) fn finish(&mut self) {
        self.control.stop.store(true, Ordering::Release);
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
        let _ = self.stop_mcap();
        let _ = self.stop_live();
    }
}

impl Drop for TelemetryWorker {
    fn drop(&mut self) {
        if self.owner.is_here() {
            self.finish();
        } else {
            // A forked child's copy: the thread and the sinks' threads are the parent's;
            // joining them here would wait forever.
            std::mem::forget(self.thread.take());
        }
    }
}

fn run(samples: &TelemetryReceiver, control: &Control) {
    let mut misses = 0;
    loop {
        // Read the flag first: samples published before the loop ended are all taken below.
        let stopping = control.stop.load(Ordering::Acquire);
        let mut any = false;
        while let Some(sample) = samples.try_recv() {
            any = true;
            let record = record(&sample, misses);
            misses = sample.totals.deadline_misses;
            let sinks = control.sinks();
            for active in [
                sinks.mcap.as_ref().map(|(_, a)| a),
                sinks.live.as_ref().map(|(_, a)| a),
            ]
            .into_iter()
            .flatten()
            {
                let _ = active.producer.push(&record);
            }
        }
        if stopping {
            return;
        }
        if !any {
            std::thread::sleep(POLL);
        }
    }
}

/// The record of one sample; `misses_before` is the previous sample's count of deadline misses
/// (a tick missed its deadline when the count grew).
fn record(sample: &TelemetrySample, misses_before: u64) -> TickRecord {
    let since_start_ns = (sample.time_s.max(0.0) * 1e9).round() as u64;
    let mut record = TickRecord::new(sample.tick, since_start_ns, sample.scheduled.as_nanos());
    for (slot, joint) in record.joints.iter_mut().zip(sample.joints()) {
        let f = &joint.feedback;
        let reply = (f.received_at != Timestamp::ZERO).then(|| reply_age(f, sample.scheduled));
        *slot = JointRecord {
            position_rad: f.joint.angle_rad(),
            velocity_rad_s: f.joint.velocity_rad_s(),
            effort_nm: f.joint.torque_nm,
            current_a: f.motor.current_amps,
            commanded_a: joint.command_amps,
            temperature_c: f.motor.temperature_celsius,
            voltage_v: None,
            error_flags: None,
            reply,
        };
    }
    let times = &sample.times;
    record.timing = LoopTiming {
        wake_latency_us: times.wake_latency_ns as f64 * 1e-3,
        round_trip_us: times.round_trip_ns.map(|ns| ns as f64 * 1e-3),
        controller_us: times.controller_ns as f64 * 1e-3,
        work_us: times.previous_work_ns as f64 * 1e-3,
        deadline_missed: sample.totals.deadline_misses > misses_before,
        misses: sample.totals.deadline_misses,
        missing_replies: sample.totals.missing_replies,
        late_replies: sample.totals.late_replies,
    };
    for (slot, value) in record.signals.iter_mut().zip(sample.signals()) {
        *slot = *value;
    }
    record
}

/// How old a joint's reply is at its tick: ticks by the loop's freshness, microseconds from its
/// reception to the tick's scheduled time (0 for a reply received after it).
fn reply_age(f: &rmd_loop::JointFeedback, scheduled: Timestamp) -> ReplyAge {
    let ticks = match f.freshness {
        Freshness::Fresh { .. } => 0,
        Freshness::Late { age_ticks } => age_ticks.max(1),
        Freshness::Missing { ticks_since_reply } => ticks_since_reply.max(1),
    };
    let micros = scheduled.signed_nanos_since(f.received_at).max(0) / 1000;
    ReplyAge {
        ticks,
        micros: u32::try_from(micros).unwrap_or(u32::MAX),
    }
}
