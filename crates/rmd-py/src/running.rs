//! `RobotLoop`: a loop running with the joint servo on its own Rust thread, driven from Python.
//!
//! Every method returns at once (setpoints and trajectories go through the servo's lock-free
//! queue; planning happens on the caller's thread) except `stop`, `sleep` and `stats`, which
//! wait with the GIL released; `sleep` and `stats` run Python's signal handlers every few
//! milliseconds meanwhile (`wait`), so Ctrl-C interrupts them. The loop is stopped, and the
//! motors made safe (zero torque, then motor-off, confirmed), when `stop()` or `estop()` is
//! called, when the Python object is dropped, and when the interpreter exits (`stop_all_loops`,
//! registered with `atexit` by `rmd_rt`), in the process that started it; a forked child can
//! do none of this (`process`). A command to a loop that has ended raises `LoopStoppedError`.

use std::collections::HashMap;
use std::sync::{Arc, Mutex, PoisonError, Weak};
use std::time::{Duration, Instant};

use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rmd_loop::LoopHandle;
use rmd_servo::{
    JointStatus, JointTrajectory, JointTrajectoryPoint, ServoController, ServoHandle, ServoState,
    Setpoint, TrajectoryReceipt, TrajectoryStart,
};
use serde_json::Value;

use crate::args;
use crate::errors::{
    ArgumentError, LoopStoppedError, SetpointError, TelemetryError, guard, servo_error,
};
use crate::process::Owner;
use crate::sim::{SimBusView, Simulator};
use crate::telemetry::TelemetryWorker;
use crate::wait::interruptible;

/// The longest `stats` waits for the loop's answer.
const MAX_STATS_TIMEOUT_S: f64 = 60.0;
/// The longest wall-clock timeout of `sleep` (about 11.6 days).
const MAX_SLEEP_TIMEOUT_S: f64 = 1e6;
/// The highest rate of the live server, messages per second (as `--foxglove-rate`).
const MAX_LIVE_RATE_HZ: f64 = 10_000.0;

/// Every loop started from Python that may still run: `stop_all_loops` stops them.
static LOOPS: Mutex<Vec<Weak<LoopInner>>> = Mutex::new(Vec::new());

/// What a `RobotLoop` owns; dropping it stops the loop, then the telemetry.
pub(crate) struct LoopInner {
    owner: Owner,
    handle: Mutex<Option<LoopHandle<ServoController>>>,
    report: Mutex<Option<Value>>,
    servo: ServoHandle,
    joints: Vec<String>,
    sims: Option<Vec<SimBusView>>,
    telemetry: Mutex<TelemetryWorker>,
    placement: String,
}

impl LoopInner {
    /// The loop's parts, registered for `stop_all_loops`.
    pub(crate) fn new(
        handle: LoopHandle<ServoController>,
        servo: ServoHandle,
        joints: Vec<String>,
        sims: Option<Vec<SimBusView>>,
        telemetry: TelemetryWorker,
        placement: String,
    ) -> Arc<Self> {
        let inner = Arc::new(Self {
            owner: Owner::here(),
            handle: Mutex::new(Some(handle)),
            report: Mutex::new(None),
            servo,
            joints,
            sims,
            telemetry: Mutex::new(telemetry),
            placement,
        });
        let mut loops = LOOPS.lock().unwrap_or_else(PoisonError::into_inner);
        loops.retain(|w| w.strong_count() > 0);
        loops.push(Arc::downgrade(&inner));
        inner
    }

    /// The servo's handle.
    pub(crate) fn servo(&self) -> &ServoHandle {
        &self.servo
    }

    /// `ForkedProcessError` unless this is the process that started the loop.
    fn usable(&self) -> PyResult<()> {
        self.owner.check("loop")
    }

    /// `LoopStoppedError` unless the loop runs (and `ForkedProcessError` in a forked child).
    fn running(&self) -> PyResult<()> {
        self.usable()?;
        if self.is_running() {
            Ok(())
        } else {
            Err(stopped_error())
        }
    }

    /// Whether the loop thread still runs.
    pub(crate) fn is_running(&self) -> bool {
        self.handle
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .as_ref()
            .is_some_and(LoopHandle::is_running)
    }

    /// Stops the loop (motors made safe) and the telemetry (files closed); the loop's report as
    /// JSON. Later calls return the same report.
    pub(crate) fn stop(&self) -> Option<Value> {
        let handle = self
            .handle
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .take();
        if let Some(handle) = handle {
            let report = match handle.stop() {
                Ok(outcome) => serde_json::to_value(&outcome.report).ok(),
                Err(died) => Some(serde_json::json!({
                    "stop_reason": died.to_string(),
                    "normal_stop": false,
                })),
            };
            *self.report.lock().unwrap_or_else(PoisonError::into_inner) = report;
        }
        self.telemetry
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .finish();
        self.report
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .clone()
    }
}

impl Drop for LoopInner {
    fn drop(&mut self) {
        if self.owner.is_here() {
            let _ = self.stop();
        } else {
            // A forked child's copy: the loop thread and its supervisor are the parent's, which
            // keeps running them. Dropping the handle would ask them to stop (they are not
            // here) and wait for them forever; the copy is left as it is.
            let handle = self
                .handle
                .get_mut()
                .unwrap_or_else(PoisonError::into_inner)
                .take();
            std::mem::forget(handle);
        }
    }
}

/// The error of a command to a loop that has ended.
fn stopped_error() -> PyErr {
    LoopStoppedError::new_err(
        "the loop is no longer running (it was stopped, e-stopped or ended on a fault, and made \
         its motors safe): stop() returns its report with the reason; start a new loop to go on"
            .to_owned(),
    )
}

/// Stops every loop still running (registered with `atexit` by `rmd_rt`): the motors are made
/// safe before the interpreter exits.
#[pyfunction]
pub(crate) fn stop_all_loops(py: Python<'_>) {
    // A forked child's copies of its parent's loops are not its own to stop.
    let loops: Vec<Arc<LoopInner>> = LOOPS
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .drain(..)
        .filter_map(|w| w.upgrade())
        .filter(|inner| inner.owner.is_here())
        .collect();
    py.detach(|| {
        for inner in &loops {
            let _ = inner.stop();
        }
    });
}

fn joint_dict<'py>(py: Python<'py>, j: &JointStatus) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("position_rad", j.position_rad)?;
    d.set_item("velocity_rad_s", j.velocity_rad_s)?;
    d.set_item("effort_nm", j.effort_nm)?;
    d.set_item("fresh", j.fresh)?;
    d.set_item("received_at_s", j.received_at.as_nanos() as f64 * 1e-9)?;
    d.set_item("temperature_celsius", j.temperature_celsius)?;
    d.set_item("current_amps", j.current_amps)?;
    d.set_item("mode", j.mode.name())?;
    match j.reference {
        Some(r) => {
            let reference = PyDict::new(py);
            reference.set_item("position_rad", r.position_rad)?;
            reference.set_item("velocity_rad_s", r.velocity_rad_s)?;
            reference.set_item("acceleration_rad_s2", r.acceleration_rad_s2)?;
            d.set_item("reference", reference)?;
        }
        None => d.set_item("reference", py.None())?,
    }
    d.set_item("effort_ff_nm", j.effort_ff_nm)?;
    d.set_item("commanded_effort_nm", j.commanded_effort_nm)?;
    d.set_item("position_error_rad", j.position_error_rad)?;
    d.set_item("stale", j.stale)?;
    let c = &j.counters;
    let counters = PyDict::new(py);
    counters.set_item("setpoints", c.setpoints)?;
    counters.set_item("trajectories", c.trajectories)?;
    counters.set_item("replans", c.replans)?;
    counters.set_item("trajectory_failures", c.trajectory_failures)?;
    counters.set_item("stale_events", c.stale_events)?;
    counters.set_item("clamped", c.clamped)?;
    counters.set_item("rejected", c.rejected)?;
    d.set_item("counters", counters)?;
    Ok(d)
}

fn receipt_dict<'py>(py: Python<'py>, r: &TrajectoryReceipt) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("duration_s", r.duration_s)?;
    d.set_item("max_lateness_s", r.max_lateness_s)?;
    match &r.latest {
        Some((joint, point)) => {
            d.set_item("latest_joint", joint)?;
            d.set_item("latest_point", point)?;
        }
        None => {
            d.set_item("latest_joint", py.None())?;
            d.set_item("latest_point", py.None())?;
        }
    }
    Ok(d)
}

fn stats_dict<'py>(
    py: Python<'py>,
    stats: &rmd_telemetry::PipelineStats,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("offered", stats.offered)?;
    d.set_item("intake_dropped", stats.intake_dropped)?;
    let (mut written, mut dropped, mut errors) = (0, 0, 0);
    let mut first_error = None;
    for sink in &stats.sinks {
        written += sink.written;
        dropped += sink.dropped;
        errors += sink.errors;
        first_error = first_error.or_else(|| sink.first_error.clone());
    }
    d.set_item("written", written)?;
    d.set_item("dropped", dropped)?;
    d.set_item("errors", errors)?;
    d.set_item("first_error", first_error)?;
    Ok(d)
}

/// A running loop (from `Robot.start`). Stopped, with the motors made safe, by `stop()`,
/// `estop()`, dropping the object, leaving a `with` block, or the interpreter's exit.
#[pyclass(module = "rmd_rt._native", frozen)]
pub(crate) struct RobotLoop {
    inner: Arc<LoopInner>,
}

impl RobotLoop {
    pub(crate) fn new(inner: Arc<LoopInner>) -> Self {
        Self { inner }
    }

    fn state_now(&self) -> Option<ServoState> {
        self.inner.servo.state()
    }
}

#[pymethods]
impl RobotLoop {
    /// The joints' names, in the robot's order (the order of `positions()`).
    #[getter]
    fn joint_names(&self) -> Vec<String> {
        self.inner.joints.clone()
    }

    /// Where the motors are: `"simulated motors, real time"`, `"SocketCAN can0"`, ...
    #[getter]
    fn placement(&self) -> String {
        self.inner.placement.clone()
    }

    /// Whether the loop still runs (it may have stopped on its own: a fault, an e-stop).
    fn is_running(&self) -> PyResult<bool> {
        guard(|| {
            self.inner.usable()?;
            Ok(self.inner.is_running())
        })
    }

    /// Position setpoint for one joint (rad), with velocity (rad/s) and effort (N·m)
    /// feed-forward; applied at the next tick.
    #[pyo3(signature = (joint, position_rad, velocity_ff_rad_s=0.0, effort_ff_nm=0.0))]
    fn set_position(
        &self,
        joint: &str,
        position_rad: f64,
        velocity_ff_rad_s: f64,
        effort_ff_nm: f64,
    ) -> PyResult<()> {
        guard(|| {
            self.inner.running()?;
            self.inner
                .servo
                .set_position(joint, position_rad, velocity_ff_rad_s, effort_ff_nm)
                .map_err(servo_error)
        })
    }

    /// Velocity setpoint for one joint (rad/s) with effort feed-forward (N·m).
    #[pyo3(signature = (joint, velocity_rad_s, effort_ff_nm=0.0))]
    fn set_velocity(&self, joint: &str, velocity_rad_s: f64, effort_ff_nm: f64) -> PyResult<()> {
        guard(|| {
            self.inner.running()?;
            self.inner
                .servo
                .set_velocity(joint, velocity_rad_s, effort_ff_nm)
                .map_err(servo_error)
        })
    }

    /// Effort (torque) setpoint for one joint, N·m.
    fn set_effort(&self, joint: &str, effort_nm: f64) -> PyResult<()> {
        guard(|| {
            self.inner.running()?;
            self.inner
                .servo
                .set_effort(joint, effort_nm)
                .map_err(servo_error)
        })
    }

    /// Position setpoints for several joints (`{"knee": 0.3, ...}`, rad), applied in the same
    /// tick; all or nothing.
    fn set_positions(&self, positions: HashMap<String, f64>) -> PyResult<()> {
        guard(|| {
            self.inner.running()?;
            let batch = positions.iter().map(|(joint, &position_rad)| {
                (
                    joint.as_str(),
                    Setpoint::Position {
                        position_rad,
                        velocity_ff_rad_s: 0.0,
                        effort_ff_nm: 0.0,
                    },
                )
            });
            self.inner.servo.set_many(batch).map_err(servo_error)
        })
    }

    /// A trajectory through points for some joints: `times_s[k]` (from its start, increasing)
    /// and `positions[k]` (one value per joint of `joints`, rad); optional `velocities` and
    /// `accelerations` of the same shape; it starts now, or at loop time `start_at_s`. Planned
    /// here (jerk-limited, within each joint's limits); returns the receipt: `duration_s`,
    /// `max_lateness_s`, `latest_joint`, `latest_point`.
    #[pyo3(signature = (joints, times_s, positions, velocities=None, accelerations=None, start_at_s=None))]
    #[allow(clippy::too_many_arguments)]
    fn send_trajectory<'py>(
        &self,
        py: Python<'py>,
        joints: Vec<String>,
        times_s: Vec<f64>,
        positions: Vec<Vec<f64>>,
        velocities: Option<Vec<Vec<f64>>>,
        accelerations: Option<Vec<Vec<f64>>>,
        start_at_s: Option<f64>,
    ) -> PyResult<Bound<'py, PyDict>> {
        guard(|| {
            self.inner.running()?;
            let times: Vec<Duration> = times_s
                .iter()
                .enumerate()
                .map(|(k, &t)| time_from_start(&format!("times_s[{k}]"), t))
                .collect::<PyResult<_>>()?;
            let trajectory = trajectory(
                joints,
                &times,
                positions,
                velocities,
                accelerations,
                start_at_s,
            )?;
            let receipt = py
                .detach(|| self.inner.servo.send_trajectory(&trajectory))
                .map_err(servo_error)?;
            receipt_dict(py, &receipt)
        })
    }

    /// Moves the joints of `targets` (`{"knee": 0.3, ...}`, rad) there in `duration_s`,
    /// smoothly (a one-point trajectory), and holds them there; the receipt.
    fn move_to<'py>(
        &self,
        py: Python<'py>,
        targets: HashMap<String, f64>,
        duration_s: f64,
    ) -> PyResult<Bound<'py, PyDict>> {
        guard(|| {
            self.inner.running()?;
            let duration = time_from_start("duration_s", duration_s)?;
            let (joints, positions): (Vec<String>, Vec<f64>) = targets.into_iter().unzip();
            let trajectory = trajectory(joints, &[duration], vec![positions], None, None, None)?;
            let receipt = py
                .detach(|| self.inner.servo.send_trajectory(&trajectory))
                .map_err(servo_error)?;
            receipt_dict(py, &receipt)
        })
    }

    /// Every joint goes to zero torque at the next tick (the loop keeps running); setpoints are
    /// refused until `enable()`.
    fn disable(&self) -> PyResult<()> {
        guard(|| {
            self.inner.running()?;
            self.inner.servo.disable();
            Ok(())
        })
    }

    /// Every joint holds where it is; setpoints are taken again.
    fn enable(&self) -> PyResult<()> {
        guard(|| {
            self.inner.running()?;
            self.inner.servo.enable();
            Ok(())
        })
    }

    /// Emergency stop: at the next tick zero torque, then motor-off for every motor, and the
    /// loop ends. Returns at once; `stop()` waits for the report. Final; on a loop that has
    /// ended already, it does nothing.
    fn estop(&self) -> PyResult<()> {
        guard(|| {
            self.inner.usable()?;
            self.inner.servo.estop();
            if let Some(handle) = self
                .inner
                .handle
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
                .as_ref()
            {
                handle.emergency_stop();
            }
            Ok(())
        })
    }

    /// The latest tick's state (None before the first): `tick`, `time_s` (loop time), `enabled`,
    /// `estopped`, and `joints`: per joint name a dict with `position_rad`, `velocity_rad_s`,
    /// `effort_nm`, `fresh`, `received_at_s`, `temperature_celsius`, `current_amps`, `mode`,
    /// `reference`, `effort_ff_nm`, `commanded_effort_nm`, `position_error_rad`, `stale`,
    /// `counters`. After the loop ended: its last tick's.
    fn state<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        guard(|| {
            self.inner.usable()?;
            let Some(state) = self.state_now() else {
                return Ok(None);
            };
            let d = PyDict::new(py);
            d.set_item("tick", state.tick)?;
            d.set_item("time_s", state.time_s)?;
            d.set_item("enabled", state.enabled)?;
            d.set_item("estopped", state.estopped)?;
            let joints = PyDict::new(py);
            for (name, j) in self.inner.joints.iter().zip(state.joints()) {
                joints.set_item(name, joint_dict(py, j)?)?;
            }
            d.set_item("joints", joints)?;
            Ok(Some(d))
        })
    }

    /// The joints' measured positions (rad) of the latest tick, in `joint_names` order, as a
    /// NumPy array (None before the first tick).
    fn positions<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyArray1<f64>>>> {
        guard(|| {
            self.inner.usable()?;
            Ok(self.state_now().map(|state| {
                let values: Vec<f64> = state.joints().iter().map(|j| j.position_rad).collect();
                PyArray1::from_vec(py, values)
            }))
        })
    }

    /// The loop time of the latest tick, s since tick 0 (None before it).
    fn loop_time_s(&self) -> PyResult<Option<f64>> {
        guard(|| {
            self.inner.usable()?;
            Ok(self.inner.servo.loop_time_s())
        })
    }

    /// Waits until the loop time has advanced by `seconds` (≥ 0; also in virtual time, where it
    /// runs faster than the wall clock), with the GIL released; Ctrl-C interrupts it
    /// (`KeyboardInterrupt`). Raises `LoopStoppedError` if the loop ends first, `LoopError` if
    /// `timeout_s` of wall time pass (default: ten times `seconds`, plus 5 s).
    #[pyo3(signature = (seconds, timeout_s=None))]
    fn sleep(&self, py: Python<'_>, seconds: f64, timeout_s: Option<f64>) -> PyResult<()> {
        guard(|| {
            let seconds = args::finite("seconds", seconds)?;
            if seconds < 0.0 {
                return Err(ArgumentError::new_err(format!(
                    "seconds = {seconds:?}: a sleep cannot be negative"
                )));
            }
            let wall = match timeout_s {
                Some(t) => args::seconds("timeout_s", t, MAX_SLEEP_TIMEOUT_S)?,
                None => Duration::from_secs_f64((seconds * 10.0 + 5.0).min(MAX_SLEEP_TIMEOUT_S)),
            };
            self.inner.running()?;
            let start = self.inner.servo.loop_time_s().ok_or_else(|| {
                crate::errors::LoopError::new_err("the loop has published no state".to_owned())
            })?;
            let target = start + seconds;
            let give_up = Instant::now() + wall;
            let servo = &self.inner.servo;
            interruptible(py, |until| {
                loop {
                    if servo.loop_time_s().is_some_and(|t| t >= target) {
                        return Some(Ok(()));
                    }
                    if !self.inner.is_running() {
                        return Some(Err(stopped_error()));
                    }
                    let now = Instant::now();
                    if now >= give_up {
                        return Some(Err(crate::errors::LoopError::new_err(format!(
                            "the loop time did not advance by {seconds:?} s within {:?} s of \
                             wall time",
                            wall.as_secs_f64()
                        ))));
                    }
                    if now >= until {
                        return None;
                    }
                    std::thread::sleep(Duration::from_micros(500));
                }
            })?
        })
    }

    /// The loop's statistics so far (ticks, deadline misses, missing and late replies, timing
    /// percentiles in µs, per-motor and per-bus counters), read between two ticks; None if the
    /// loop does not answer within `timeout_s` (0..=60 s). Ctrl-C interrupts the wait; raises
    /// `LoopStoppedError` once the loop has ended (`stop()` returns its final statistics).
    #[pyo3(signature = (timeout_s=0.5))]
    fn stats<'py>(&self, py: Python<'py>, timeout_s: f64) -> PyResult<Option<Bound<'py, PyAny>>> {
        guard(|| {
            let timeout = args::seconds("timeout_s", timeout_s, MAX_STATS_TIMEOUT_S)?;
            self.inner.running()?;
            let give_up = Instant::now() + timeout;
            let summary = interruptible(py, |until| {
                let slice = until.min(give_up).saturating_duration_since(Instant::now());
                let summary = self
                    .inner
                    .handle
                    .lock()
                    .unwrap_or_else(PoisonError::into_inner)
                    .as_ref()
                    .and_then(|h| h.snapshot(slice));
                let over = Instant::now() >= give_up || !self.inner.is_running();
                match summary {
                    Some(s) => Some(Some(s)),
                    None if over => Some(None),
                    None => None,
                }
            })?;
            match summary {
                Some(s) => Ok(Some(pythonize::pythonize(py, &s)?)),
                None if !self.inner.is_running() => Err(stopped_error()),
                None => Ok(None),
            }
        })
    }

    /// Stops the loop (zero torque, then motor-off for every motor, confirmed) and the
    /// telemetry (files closed), and returns the loop's report as a dict (`stop_reason`,
    /// `normal_stop`, `ticks`, `safe_stop`, timing, ...). Later calls return the same report.
    /// The safe stop is not interrupted by Ctrl-C.
    fn stop<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        guard(|| {
            self.inner.usable()?;
            let report = py.detach(|| self.inner.stop());
            match report {
                Some(report) => Ok(pythonize::pythonize(py, &report)?),
                None => Err(crate::errors::LoopError::new_err(
                    "the loop left no report".to_owned(),
                )),
            }
        })
    }

    /// The simulated motors' ground truth (None when every bus is real).
    fn simulator(&self) -> PyResult<Option<Simulator>> {
        guard(|| {
            self.inner.usable()?;
            Ok(self
                .inner
                .sims
                .clone()
                .map(|sims| Simulator::new(sims, self.inner.owner)))
        })
    }

    /// Starts writing the telemetry to an MCAP file at `path`: every tick from now on (joint
    /// states, motor states, loop timing, the servo's signals, diagnostics; see
    /// docs/telemetry.md).
    #[pyo3(signature = (path, compress=true))]
    fn record_mcap(&self, path: std::path::PathBuf, compress: bool) -> PyResult<()> {
        guard(|| {
            self.inner.running()?;
            self.telemetry()
                .start_mcap(path, compress, self.now_s())
                .map_err(TelemetryError::new_err)
        })
    }

    /// Stops the MCAP file after every tick up to now (closed with its summary and index); its
    /// counts (`offered`, `written`, `dropped`, `errors`, `first_error`), or None if none was
    /// being written.
    fn stop_mcap<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        guard(|| {
            self.inner.usable()?;
            let stats = py.detach(|| self.telemetry().stop_mcap(self.now_s()));
            stats.map(|s| stats_dict(py, &s)).transpose()
        })
    }

    /// Starts the live Foxglove WebSocket server on `addr` (loopback by default; port 0 picks a
    /// free port), publishing at most `rate_hz` (above 0, up to 10000); returns the address it
    /// listens on (`"127.0.0.1:8765"`).
    #[pyo3(signature = (addr="127.0.0.1:8765", rate_hz=100.0))]
    fn serve_live(&self, addr: &str, rate_hz: f64) -> PyResult<String> {
        guard(|| {
            let rate_hz = args::finite("rate_hz", rate_hz)?;
            if !(rate_hz > 0.0 && rate_hz <= MAX_LIVE_RATE_HZ) {
                return Err(ArgumentError::new_err(format!(
                    "rate_hz = {rate_hz:?}: give messages per second, above 0 and up to \
                     {MAX_LIVE_RATE_HZ}"
                )));
            }
            let addr = addr.parse().map_err(|_| {
                ArgumentError::new_err(format!("`{addr}` is not a socket address (IP:PORT)"))
            })?;
            self.inner.running()?;
            self.telemetry()
                .start_live(addr, rate_hz, self.now_s())
                .map(|a| a.to_string())
                .map_err(TelemetryError::new_err)
        })
    }

    /// Stops the live server; its counts, or None if it was not running.
    fn stop_live<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        guard(|| {
            self.inner.usable()?;
            let stats = py.detach(|| self.telemetry().stop_live(self.now_s()));
            stats.map(|s| stats_dict(py, &s)).transpose()
        })
    }

    /// Which telemetry sinks are on: `{"mcap": {"path": ..., counts...} | None, "live":
    /// {"addr": ..., counts...} | None}`.
    fn telemetry_status<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        guard(|| {
            self.inner.usable()?;
            let status = self.telemetry().status();
            let d = PyDict::new(py);
            match status.mcap {
                Some((path, stats)) => {
                    let m = stats_dict(py, &stats)?;
                    m.set_item("path", path.display().to_string())?;
                    d.set_item("mcap", m)?;
                }
                None => d.set_item("mcap", py.None())?,
            }
            match status.live {
                Some((addr, stats)) => {
                    let l = stats_dict(py, &stats)?;
                    l.set_item("addr", addr.to_string())?;
                    d.set_item("live", l)?;
                }
                None => d.set_item("live", py.None())?,
            }
            Ok(d)
        })
    }

    fn __enter__(slf: Py<Self>) -> Py<Self> {
        slf
    }

    #[pyo3(signature = (*_args))]
    fn __exit__(&self, py: Python<'_>, _args: &Bound<'_, pyo3::types::PyTuple>) -> PyResult<bool> {
        guard(|| {
            self.inner.usable()?;
            let _ = py.detach(|| self.inner.stop());
            Ok(false)
        })
    }

    fn __repr__(&self) -> String {
        let status = if !self.inner.owner.is_here() {
            "of the parent process"
        } else if self.inner.is_running() {
            "running"
        } else {
            "stopped"
        };
        format!(
            "<rmd_rt.RobotLoop {} joints={:?} {status}>",
            self.inner.placement, self.inner.joints
        )
    }
}

/// A time from a trajectory's start: finite, above 0, and a duration Rust can hold.
fn time_from_start(name: &str, t: f64) -> PyResult<Duration> {
    if !(t.is_finite() && t > 0.0) {
        return Err(SetpointError::new_err(format!(
            "{name} = {t:?}: times from the trajectory's start must be finite and above 0"
        )));
    }
    Duration::try_from_secs_f64(t).map_err(|_| {
        SetpointError::new_err(format!(
            "{name} = {t:?} s: too far from the trajectory's start"
        ))
    })
}

/// The trajectory of `send_trajectory`'s arguments (times already checked), one row per point.
fn trajectory(
    joints: Vec<String>,
    times: &[Duration],
    positions: Vec<Vec<f64>>,
    velocities: Option<Vec<Vec<f64>>>,
    accelerations: Option<Vec<Vec<f64>>>,
    start_at_s: Option<f64>,
) -> PyResult<JointTrajectory> {
    let count = times.len();
    for (name, rows) in [
        ("positions", Some(positions.len())),
        ("velocities", velocities.as_ref().map(Vec::len)),
        ("accelerations", accelerations.as_ref().map(Vec::len)),
    ] {
        if let Some(rows) = rows
            && rows != count
        {
            return Err(SetpointError::new_err(format!(
                "{name} has {rows} points but times_s has {count}: give one row per point"
            )));
        }
    }
    let mut velocities = velocities.map(Vec::into_iter);
    let mut accelerations = accelerations.map(Vec::into_iter);
    let mut trajectory = JointTrajectory::new(joints);
    for (&t, p) in times.iter().zip(positions) {
        let mut point = JointTrajectoryPoint::at(t, p);
        if let Some(v) = velocities.as_mut().and_then(Iterator::next) {
            point = point.with_velocities(v);
        }
        if let Some(a) = accelerations.as_mut().and_then(Iterator::next) {
            point = point.with_accelerations(a);
        }
        trajectory = trajectory.point(point);
    }
    if let Some(t) = start_at_s {
        trajectory = trajectory.starting(TrajectoryStart::AtLoopTime(t));
    }
    Ok(trajectory)
}

impl RobotLoop {
    /// The loop time of the latest tick (before the first: any time at all).
    fn now_s(&self) -> f64 {
        self.inner.servo.loop_time_s().unwrap_or(f64::NEG_INFINITY)
    }

    fn telemetry(&self) -> std::sync::MutexGuard<'_, TelemetryWorker> {
        self.inner
            .telemetry
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
    }
}
