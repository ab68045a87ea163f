//! The simulated motors' ground truth, as Python sees it: what the simulator's physics and
//! firmware are doing, not what the bus reported (for tests and for looking inside).

use pyo3::prelude::*;
use pyo3::types::PyDict;
use rmd_protocol::{MotorId, PidParams};
use rmd_rig::SharedSim;
use rmd_sim::{ControlMode, MotorSnapshot};

use crate::errors::guard;
use crate::process::Owner;

/// One simulated bus and the joint names of its motors (none for a plain `Bus`).
#[derive(Clone, Debug)]
pub(crate) struct SimBusView {
    /// The bus.
    pub(crate) bus: SharedSim,
    /// `(motor, joint name)` for the motors a robot description names.
    pub(crate) joints: Vec<(MotorId, String)>,
}

/// The simulated motors behind a `Bus` or a `RobotLoop` (`bus.simulator()`,
/// `loop.simulator()`): snapshots of their true state. It keeps the simulated buses alive, so
/// it can be read after the loop stopped or its object was dropped.
#[pyclass(module = "rmd_rt._native", frozen)]
pub(crate) struct Simulator {
    buses: Vec<SimBusView>,
    /// The process whose threads drive the buses (a lock they held at a fork stays held).
    owner: Owner,
}

impl Simulator {
    /// A view of `buses`, in bus order, driven by `owner`'s threads.
    pub(crate) fn new(buses: Vec<SimBusView>, owner: Owner) -> Self {
        Self { buses, owner }
    }
}

fn pid<'py>(py: Python<'py>, p: &PidParams) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("angle_pid_kp", p.angle_pid_kp)?;
    d.set_item("angle_pid_ki", p.angle_pid_ki)?;
    d.set_item("speed_pid_kp", p.speed_pid_kp)?;
    d.set_item("speed_pid_ki", p.speed_pid_ki)?;
    d.set_item("iq_pid_kp", p.iq_pid_kp)?;
    d.set_item("iq_pid_ki", p.iq_pid_ki)?;
    Ok(d)
}

/// The motion-mode setpoint the firmware obeys (output side: rad from the motor's zero, rad/s,
/// N·m per rad, N·m per rad/s, N·m), or None outside motion mode.
fn motion<'py>(py: Python<'py>, mode: ControlMode) -> PyResult<Option<Bound<'py, PyDict>>> {
    let ControlMode::Motion {
        position_rad,
        velocity_rad_s,
        kp,
        kd,
        torque_nm,
    } = mode
    else {
        return Ok(None);
    };
    let d = PyDict::new(py);
    d.set_item("position_rad", position_rad)?;
    d.set_item("velocity_rad_s", velocity_rad_s)?;
    d.set_item("kp_nm_per_rad", kp)?;
    d.set_item("kd_nm_s_per_rad", kd)?;
    d.set_item("torque_nm", torque_nm)?;
    Ok(Some(d))
}

fn mode_name(mode: ControlMode) -> &'static str {
    match mode {
        ControlMode::Off => "off",
        ControlMode::Torque { .. } => "torque",
        ControlMode::Speed { .. } => "speed",
        ControlMode::Position { .. } => "position",
        ControlMode::Motion { .. } => "motion",
    }
}

fn snapshot_dict<'py>(
    py: Python<'py>,
    bus: usize,
    joint: Option<&str>,
    s: &MotorSnapshot,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("bus", bus)?;
    d.set_item("id", s.id.get())?;
    d.set_item("joint", joint)?;
    d.set_item("time_s", s.at.as_nanos() as f64 * 1e-9)?;
    d.set_item("motor_angle_deg", s.motor_angle_deg)?;
    d.set_item("output_angle_deg", s.output_angle_deg)?;
    d.set_item("motor_speed_dps", s.motor_speed_dps)?;
    d.set_item("current_a", s.current_a)?;
    d.set_item("output_torque_nm", s.output_torque_nm)?;
    d.set_item("temperature_c", s.temperature_c)?;
    d.set_item("voltage_v", s.voltage_v)?;
    d.set_item("error_state", s.error_state.raw())?;
    d.set_item("mode", mode_name(s.mode))?;
    d.set_item("motion", motion(py, s.mode)?)?;
    d.set_item("stopped", s.stopped)?;
    d.set_item("energising", s.energising)?;
    d.set_item("safe", s.safe_since.is_some())?;
    d.set_item("pid_ram", pid(py, &s.pid_ram)?)?;
    d.set_item("pid_rom", pid(py, &s.pid_rom)?)?;
    Ok(d)
}

#[pymethods]
impl Simulator {
    /// Every simulated motor's true state now, bus by bus: a list of dicts with `bus`, `id`,
    /// `joint` (or None), `time_s` (simulator clock), `motor_angle_deg`, `output_angle_deg`,
    /// `motor_speed_dps`, `current_a`, `output_torque_nm`, `temperature_c`, `voltage_v`,
    /// `error_state`, `mode` (`"off"`, `"torque"`, `"speed"`, `"position"`, `"motion"`),
    /// `motion` (in motion mode, the setpoint obeyed: `position_rad` from the motor's zero,
    /// `velocity_rad_s`, `kp_nm_per_rad`, `kd_nm_s_per_rad`, `torque_nm`, output side; else
    /// None), `stopped`,
    /// `energising` (applies or is commanded torque), `safe` (applies none and is commanded
    /// none: off, stopped, tripped or at zero torque), `pid_ram`, `pid_rom`.
    fn motors<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        guard(|| self.snapshots(py))
    }

    /// Whether every simulated motor is safe now (see `motors()`).
    fn all_safe(&self, py: Python<'_>) -> PyResult<bool> {
        guard(|| {
            Ok(self.snapshots(py)?.iter().all(|d| {
                d.get_item("safe")
                    .ok()
                    .flatten()
                    .is_some_and(|v| v.is_truthy().unwrap_or(false))
            }))
        })
    }

    fn __repr__(&self) -> String {
        format!("<rmd_rt.Simulator of {} bus(es)>", self.buses.len())
    }
}

impl Simulator {
    fn snapshots<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        self.owner.check("simulator")?;
        let mut snapshots = Vec::new();
        for (b, view) in self.buses.iter().enumerate() {
            let taken: Vec<MotorSnapshot> = py.detach(|| {
                let mut bus = view.bus.lock();
                let ids: Vec<MotorId> = bus.motors().iter().map(|m| m.id()).collect();
                ids.into_iter().filter_map(|id| bus.snapshot(id)).collect()
            });
            for s in &taken {
                let joint = view
                    .joints
                    .iter()
                    .find(|(m, _)| *m == s.id)
                    .map(|(_, name)| name.as_str());
                snapshots.push(snapshot_dict(py, b, joint, s)?);
            }
        }
        Ok(snapshots)
    }
}
