//! Telemetry of a Python-driven loop, off the real-time thread: a plain Rust thread takes the
//! loop's per-tick samples (`RtLoop::telemetry`), turns each into an rmd-telemetry
//! `TickRecord`, and pushes it into whichever sinks Python switched on: an MCAP file, a live
//! Foxglove server, each its own rmd-telemetry pipeline that can start and stop while the loop
//! runs. With no sink on, the samples are taken and dropped.
//!
//! A sink takes the ticks of a window of loop time: from the loop time when it was switched
//! on, to the loop time when it was switched off. Switching off waits for the thread to have
//! taken every tick up to then (the loop may publish faster than the thread takes, in virtual
//! time or on a busy machine), so a file ends exactly where it was stopped.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use crate::process::Owner;
use rmd_loop::{
    robot::Robot,
    telemetry::{TelemetryReceiver, TelemetrySample},
};
use rmd_telemetry::{
    JointInfo, LiveOptions, LiveSink, LoopTiming, McapOptions, McapSink, Pipeline, PipelineStats,
    Producer, RunLayout, Telemetry, TickRecord,
};

/// How often the thread looks for new samples.
const POLL: Duration = Duration::from_millis(2);
/// The longest a switch-off waits for the thread to take the ticks up to it (the thread is
/// stuck, or the OS does not run it).
const SWITCH_OFF_WAIT: Duration = Duration::from_secs(5);

/// One sink's pipeline while it is on, and its window of loop time.
struct Active {
    producer: Producer,
    pipeline: Pipeline,
    /// Ticks from this loop time on.
    from_s: f64,
    /// Ticks up to this loop time (set when it is switched off).
    until_s: Option<f64>,
}

impl Active {
    fn start(sink: impl rmd_telemetry::Sink, from_s: f64) -> Result<Self, String> {
        let (producer, pipeline) = Telemetry::builder()
            .sink(sink)
            .start()
            .map_err(|e| e.to_string())?;
        Ok(Self {
            producer,
            pipeline,
            from_s,
            until_s: None,
        })
    }

    /// Whether the tick at loop time `time_s` is in the window.
    fn takes(&self, time_s: f64) -> bool {
        time_s >= self.from_s && self.until_s.is_none_or(|until| time_s <= until)
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
    /// The loop time of the latest sample taken (`f64` bits).
    taken_s: AtomicU64,
    /// How often the thread found no sample left.
    idle_passes: AtomicU64,
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
            taken_s: AtomicU64::new(f64::NEG_INFINITY.to_bits()),
            idle_passes: AtomicU64::new(0),
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

    /// Starts writing an MCAP file at `path` (replacing the file) with the ticks from loop time
    /// `from_s` on, unless one is being written.
    pub(crate) fn start_mcap(
        &self,
        path: PathBuf,
        compress: bool,
        from_s: f64,
    ) -> Result<(), String> {
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
        sinks.mcap = Some((path, Active::start(sink, from_s)?));
        Ok(())
    }

    /// Stops the MCAP file after the ticks up to loop time `until_s` (closed with its summary
    /// and index); its counts, or `None` if none was being written.
    pub(crate) fn stop_mcap(&self, until_s: f64) -> Option<PipelineStats> {
        self.control.sinks().mcap.as_mut()?.1.until_s = Some(until_s);
        self.wait_for_ticks_until(until_s);
        let active = self.control.sinks().mcap.take();
        active.map(|(_, active)| active.pipeline.shutdown())
    }

    /// Starts the live Foxglove server on `addr` (port 0: any free port) with the ticks from
    /// loop time `from_s` on; the address it listens on.
    pub(crate) fn start_live(
        &self,
        addr: SocketAddr,
        rate_hz: f64,
        from_s: f64,
    ) -> Result<SocketAddr, String> {
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
        sinks.live = Some((bound, Active::start(sink, from_s)?));
        Ok(bound)
    }

    /// Stops the live server after the ticks up to loop time `until_s`; its counts, or `None`
    /// if it was not running.
    pub(crate) fn stop_live(&self, until_s: f64) -> Option<PipelineStats> {
        self.control.sinks().live.as_mut()?.1.until_s = Some(until_s);
        self.wait_for_ticks_until(until_s);
        let active = self.control.sinks().live.take();
        active.map(|(_, active)| active.pipeline.shutdown())
    }

    /// Waits until the thread has taken the samples up to loop time `until_s`, or has found the
    /// queue empty twice since the call (the loop published nothing later), or the thread has
    /// ended; at most [`SWITCH_OFF_WAIT`].
    fn wait_for_ticks_until(&self, until_s: f64) {
        let control = &self.control;
        let idle_before = control.idle_passes.load(Ordering::Acquire);
        let give_up = Instant::now() + SWITCH_OFF_WAIT;
        while f64::from_bits(control.taken_s.load(Ordering::Acquire)) < until_s
            && control.idle_passes.load(Ordering::Acquire) < idle_before + 2
            && self.thread.as_ref().is_some_and(|t| !t.is_finished())
            && Instant::now() < give_up
        {
            std::thread::sleep(POLL / 2);
        }
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
        // Every sample was taken: nothing is left to wait for.
        let _ = self.stop_mcap(f64::NEG_INFINITY);
        let _ = self.stop_live(f64::NEG_INFINITY);
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
            .filter(|a| a.takes(sample.time_s))
            {
                let _ = active.producer.push(&record);
            }
            control
                .taken_s
                .store(sample.time_s.to_bits(), Ordering::Release);
        }
        control.idle_passes.fetch_add(1, Ordering::AcqRel);
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
        *slot = rmd_rig::telemetry::joint_record(joint, sample.taken_at);
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
