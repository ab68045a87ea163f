//! `Robot`: a robot description, checked, and the start of its loop with the joint servo.

use std::path::PathBuf;
use std::time::Instant;

use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use rmd_loop::{Controller, RunLimit};
use rmd_rig::placement::Overrides;
use rmd_rig::{PlacementDefault, Rig, sim};
use rmd_servo::{ServoConfig, ServoController};

use crate::args;
use crate::errors::{ConfigError, LoopError, guard};
use crate::running::{LoopInner, RobotLoop};
use crate::sim::SimBusView;
use crate::telemetry::{TelemetryWorker, layout};
use crate::wait::interruptible;

/// The longest `start` waits for the loop's first state, s.
const MAX_START_TIMEOUT_S: f64 = 600.0;

/// A robot description (the TOML of `examples/robots/`), checked: its buses, joints and loop
/// settings. `Robot.from_toml(path)`, then `start(...)` runs its loop.
#[pyclass(module = "rmd_rt._native", frozen)]
pub(crate) struct Robot {
    robot: rmd_loop::robot::Robot,
    source: String,
}

/// `iface`: one interface name, or a list (by bus order, or `BUS=IFACE` by bus name).
fn interfaces(iface: Option<&Bound<'_, PyAny>>) -> PyResult<Vec<String>> {
    let Some(iface) = iface else {
        return Ok(Vec::new());
    };
    if iface.is_none() {
        return Ok(Vec::new());
    }
    if let Ok(one) = iface.extract::<String>() {
        return Ok(vec![one]);
    }
    iface.extract::<Vec<String>>().map_err(|_| {
        ConfigError::new_err("iface must be an interface name or a list of them".to_owned())
    })
}

#[pymethods]
impl Robot {
    /// Reads and checks the robot description at `path` (TOML).
    #[staticmethod]
    fn from_toml(path: PathBuf) -> PyResult<Self> {
        guard(|| {
            let robot = rmd_loop::robot::Robot::from_file(&path)
                .map_err(|e| ConfigError::new_err(format!("{}: {e}", path.display())))?;
            Ok(Self {
                robot,
                source: path.display().to_string(),
            })
        })
    }

    /// Checks the robot description `text` (TOML).
    #[staticmethod]
    fn from_toml_str(text: &str) -> PyResult<Self> {
        guard(|| {
            let robot = rmd_loop::robot::Robot::from_toml(text)
                .map_err(|e| ConfigError::new_err(e.to_string()))?;
            Ok(Self {
                robot,
                source: "<string>".to_owned(),
            })
        })
    }

    /// The joints' names, in description order.
    #[getter]
    fn joint_names(&self) -> Vec<String> {
        self.robot.joints().iter().map(|j| j.name.clone()).collect()
    }

    /// Ticks per second.
    #[getter]
    fn rate_hz(&self) -> f64 {
        self.robot.settings().period.hz()
    }

    /// The buses: a list of dicts with `name`, `interface` (`"sim"` for always simulated),
    /// `bitrate` and `joints` (names).
    #[getter]
    fn buses<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        let list = PyList::empty(py);
        for bus in self.robot.buses() {
            let d = PyDict::new(py);
            d.set_item("name", &bus.name)?;
            let interface = match &bus.interface {
                rmd_loop::robot::Interface::SocketCan(name) => name.clone(),
                rmd_loop::robot::Interface::Simulator => "sim".to_owned(),
            };
            d.set_item("interface", interface)?;
            d.set_item("bitrate", bus.bitrate)?;
            let joints: Vec<&str> = bus
                .joints()
                .map(|j| self.robot.spec(j).name.as_str())
                .collect();
            d.set_item("joints", joints)?;
            list.append(d)?;
        }
        Ok(list)
    }

    /// Starts the loop with the joint servo (rmd-servo) on its own Rust thread and returns its
    /// `RobotLoop` once the servo has published its first state (every motor answered; the
    /// servo holds each joint where it is).
    ///
    /// Where the motors are: each bus on the interface the description names, unless
    /// `sim=True` (simulated motors matching the description, powered up in the middle of each
    /// joint's power-up window) or `iface` (one name, or a list: by bus order, or
    /// `"BUS=IFACE"` by bus name). `virtual_time=True` runs simulated motors in virtual time
    /// (deterministic, as fast as the CPU allows). The servo's gains and limits: `servo_toml`
    /// (TOML text) or `servo_file` (a path), else the defaults (docs/servo.md). `seed` seeds the
    /// simulator; `sim_initial_deg` (`{"knee": 55.0}`) powers simulated joints up elsewhere in
    /// their window. Raises `ConfigError` for a bad description, placement or servo file,
    /// `LoopError` if the loop does not start within `start_timeout_s` (0..=600 s). Ctrl-C while
    /// it waits stops the loop (motors made safe) and raises `KeyboardInterrupt`.
    #[pyo3(signature = (
        sim=false, iface=None, virtual_time=false, servo_toml=None, servo_file=None, seed=1,
        sim_initial_deg=None, start_timeout_s=5.0
    ))]
    #[allow(clippy::too_many_arguments)]
    fn start(
        &self,
        py: Python<'_>,
        sim: bool,
        iface: Option<&Bound<'_, PyAny>>,
        virtual_time: bool,
        servo_toml: Option<&str>,
        servo_file: Option<PathBuf>,
        seed: u64,
        sim_initial_deg: Option<std::collections::HashMap<String, f64>>,
        start_timeout_s: f64,
    ) -> PyResult<RobotLoop> {
        guard(|| {
            let start_timeout =
                args::seconds("start_timeout_s", start_timeout_s, MAX_START_TIMEOUT_S)?;
            let robot = &self.robot;
            let overrides = Overrides {
                simulate: sim,
                interfaces: interfaces(iface)?,
                virtual_time,
            };
            let placement =
                rmd_rig::Placement::resolve(robot, &overrides, PlacementDefault::Described)
                    .map_err(|e| ConfigError::new_err(e.to_string()))?;
            let config = match (servo_toml, servo_file) {
                (Some(_), Some(_)) => {
                    return Err(ConfigError::new_err(
                        "give servo_toml or servo_file, not both".to_owned(),
                    ));
                }
                (Some(text), None) => ServoConfig::from_toml(robot, text),
                (None, Some(path)) => ServoConfig::from_file(robot, path),
                (None, None) => ServoConfig::defaults(robot),
            }
            .map_err(|e| ConfigError::new_err(e.to_string()))?;
            let mut sims = sim::sim_configs(robot, seed);
            sim::power_up_centred(robot, &mut sims);
            for (name, deg) in sim_initial_deg.unwrap_or_default() {
                let deg = args::finite(&format!("sim_initial_deg[{name:?}]"), deg)?;
                let joint = robot
                    .joint(&name)
                    .map_err(|e| ConfigError::new_err(format!("sim_initial_deg: {e}")))?;
                let spec = robot.spec(joint);
                let bus = &robot.buses()[spec.bus];
                let k = bus
                    .joint_range()
                    .position(|j| j == joint.index())
                    .unwrap_or(0);
                if let Some(motor) = sims.get_mut(spec.bus).and_then(|s| s.motors.get_mut(k)) {
                    motor.initial_output_angle_deg = sim::sim_output_angle_deg(spec, deg);
                }
            }
            let (servo, handle) = ServoController::new(config);
            let signals = servo.signals();
            let layout = layout(robot, &signals).map_err(ConfigError::new_err)?;
            let rig = Rig::open(robot, &placement, sims)
                .map_err(|e| ConfigError::new_err(e.to_string()))?;
            let views: Vec<SimBusView> = rig
                .buses
                .iter()
                .zip(robot.buses())
                .filter_map(|(bus, spec)| {
                    bus.sim().map(|s| SimBusView {
                        bus: s.clone(),
                        joints: spec
                            .joints()
                            .map(|j| {
                                let joint = robot.spec(j);
                                (joint.motor, joint.name.clone())
                            })
                            .collect(),
                    })
                })
                .collect();
            let placement_text = placement.to_string();
            let mut rt = rig
                .into_loop(robot.clone(), servo)
                .map_err(|e| ConfigError::new_err(e.to_string()))?;
            let samples = rt.telemetry();
            let running = rt
                .spawn(RunLimit::Forever)
                .map_err(|e| LoopError::new_err(e.to_string()))?;
            let telemetry = TelemetryWorker::start(samples, layout).map_err(|e| {
                LoopError::new_err(format!("cannot start the telemetry thread: {e}"))
            })?;
            let inner = LoopInner::new(
                running,
                handle,
                robot.joints().iter().map(|j| j.name.clone()).collect(),
                (!views.is_empty()).then_some(views),
                telemetry,
                placement_text,
            );
            // Wait for the servo's first state, or the loop's end (the motors did not answer).
            let give_up = Instant::now() + start_timeout;
            let started = interruptible(py, |until| {
                loop {
                    if inner.servo().state().is_some() {
                        return Some(Ok(()));
                    }
                    if !inner.is_running() {
                        return Some(Err(None));
                    }
                    let now = Instant::now();
                    if now >= give_up {
                        return Some(Err(Some(start_timeout_s)));
                    }
                    if now >= until {
                        return None;
                    }
                    std::thread::sleep(std::time::Duration::from_millis(1));
                }
            });
            let started = match started {
                Ok(started) => started,
                Err(interrupt) => {
                    // Ctrl-C: the loop stops (its motors made safe) before the interrupt goes on.
                    py.detach(|| inner.stop());
                    return Err(interrupt);
                }
            };
            match started {
                Ok(()) => Ok(RobotLoop::new(inner)),
                Err(timeout) => {
                    let report = py.detach(|| inner.stop());
                    let why = report
                        .as_ref()
                        .and_then(|r| r.get("stop_reason"))
                        .and_then(|v| v.as_str())
                        .map(str::to_owned)
                        .unwrap_or_else(|| "no report".to_owned());
                    Err(LoopError::new_err(match timeout {
                        Some(s) => format!(
                            "the loop did not start within {s:?} s (the servo published no state); \
                             stopped: {why}"
                        ),
                        None => format!("the loop ended at start: {why}"),
                    }))
                }
            }
        })
    }

    fn __repr__(&self) -> String {
        format!(
            "<rmd_rt.Robot {} joints={:?}>",
            self.source,
            self.joint_names()
        )
    }
}
