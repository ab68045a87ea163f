//! `rmd_rt.plan`: rmd-traj's time-optimal, jerk-limited trajectories for 1..=16 axes, sampled
//! into NumPy arrays.

use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rmd_traj::{
    AxisState, ControlInterface, DurationDiscretization, Input, Synchronization,
    Trajectory as Traj, calculate,
};

use crate::errors::{TrajectoryError, guard};

/// The most axes `plan` takes.
const MAX_AXES: usize = 16;

/// A calculated trajectory of any number of axes.
trait Axes: Send + Sync {
    fn duration(&self) -> f64;
    fn state_into(&self, t: f64, out: &mut [AxisState]);
    fn independent_min_durations(&self) -> Vec<f64>;
    fn limiting_axis(&self) -> Option<usize>;
}

impl<const N: usize> Axes for Traj<N> {
    fn duration(&self) -> f64 {
        Traj::duration(self)
    }

    fn state_into(&self, t: f64, out: &mut [AxisState]) {
        out.copy_from_slice(&self.state_at(t));
    }

    fn independent_min_durations(&self) -> Vec<f64> {
        Traj::independent_min_durations(self).to_vec()
    }

    fn limiting_axis(&self) -> Option<usize> {
        Traj::limiting_axis(self)
    }
}

/// The problem as Python gives it, one vector per quantity (all of the same length).
struct Problem {
    current: [Vec<f64>; 3],
    target: [Vec<f64>; 3],
    limits: [Vec<f64>; 3],
    min_velocity: Option<Vec<f64>>,
    min_acceleration: Option<Vec<f64>>,
    synchronization: Synchronization,
    interface: ControlInterface,
    discretization: DurationDiscretization,
    minimum_duration: Option<f64>,
}

fn array<const N: usize>(v: &[f64]) -> [f64; N] {
    let mut out = [0.0; N];
    out.copy_from_slice(v);
    out
}

fn solve<const N: usize>(p: &Problem) -> Result<Box<dyn Axes>, String> {
    let mut input = Input::<N>::with_limits(
        array(&p.limits[0]),
        array(&p.limits[1]),
        array(&p.limits[2]),
    );
    input.current_position = array(&p.current[0]);
    input.current_velocity = array(&p.current[1]);
    input.current_acceleration = array(&p.current[2]);
    input.target_position = array(&p.target[0]);
    input.target_velocity = array(&p.target[1]);
    input.target_acceleration = array(&p.target[2]);
    input.min_velocity = p.min_velocity.as_deref().map(array);
    input.min_acceleration = p.min_acceleration.as_deref().map(array);
    input.synchronization = p.synchronization;
    input.control_interface = p.interface;
    input.duration_discretization = p.discretization;
    input.minimum_duration = p.minimum_duration;
    calculate(&input)
        .map(|t| Box::new(t) as Box<dyn Axes>)
        .map_err(|e| e.to_string())
}

macro_rules! dispatch {
    ($problem:expr, $dofs:expr, $($n:literal),*) => {
        match $dofs {
            $($n => solve::<$n>($problem),)*
            other => Err(format!("{other} axes: plan takes 1..={MAX_AXES}")),
        }
    };
}

/// A trajectory calculated by `plan`: its duration, and its states at any times as NumPy
/// arrays.
#[pyclass(module = "rmd_rt._native", frozen)]
pub(crate) struct Trajectory {
    axes: Box<dyn Axes>,
    dofs: usize,
}

#[pymethods]
impl Trajectory {
    /// Number of axes.
    #[getter]
    fn dofs(&self) -> usize {
        self.dofs
    }

    /// Duration, s (every axis arrives at its target then, with the default synchronization).
    #[getter]
    fn duration(&self) -> f64 {
        self.axes.duration()
    }

    /// Each axis's own minimum duration (brake included), s.
    #[getter]
    fn independent_min_durations(&self) -> Vec<f64> {
        self.axes.independent_min_durations()
    }

    /// The axis that sets the duration, if any.
    #[getter]
    fn limiting_axis(&self) -> Option<usize> {
        self.axes.limiting_axis()
    }

    /// The states at `times` (s; before 0 is the start, after the duration continues at the
    /// target state): a dict of NumPy arrays `time` (T,) and `position`, `velocity`,
    /// `acceleration`, `jerk`, each (T, dofs).
    fn sample<'py>(&self, py: Python<'py>, times: Vec<f64>) -> PyResult<Bound<'py, PyDict>> {
        guard(|| self.sampled(py, times))
    }

    /// The states every `dt` s from 0 to the duration (both included), as `sample` returns
    /// them.
    fn sample_every<'py>(&self, py: Python<'py>, dt: f64) -> PyResult<Bound<'py, PyDict>> {
        guard(|| {
            let duration = self.axes.duration();
            if !(dt.is_finite() && dt > 0.0) {
                return Err(TrajectoryError::new_err(format!(
                    "dt {dt:?} must be a finite number above 0"
                )));
            }
            let steps = (duration / dt).floor();
            if steps > 10_000_000.0 {
                return Err(TrajectoryError::new_err(format!(
                    "dt {dt:?} s over {duration} s is more than 10 million samples"
                )));
            }
            let mut times: Vec<f64> = (0..=steps as usize).map(|k| k as f64 * dt).collect();
            if times.last().is_none_or(|&t| t < duration) {
                times.push(duration);
            }
            self.sampled(py, times)
        })
    }

    fn __repr__(&self) -> String {
        format!(
            "<rmd_rt.Trajectory dofs={} duration={:.6} s>",
            self.dofs,
            self.axes.duration()
        )
    }
}

impl Trajectory {
    fn sampled<'py>(&self, py: Python<'py>, times: Vec<f64>) -> PyResult<Bound<'py, PyDict>> {
        let n = self.dofs;
        let count = times.len();
        let mut kinds = [
            Vec::with_capacity(count * n),
            Vec::with_capacity(count * n),
            Vec::with_capacity(count * n),
            Vec::with_capacity(count * n),
        ];
        let mut states = vec![AxisState::default(); n];
        for &t in &times {
            if !t.is_finite() {
                return Err(TrajectoryError::new_err(format!(
                    "sample time {t} is not a finite number"
                )));
            }
            self.axes.state_into(t, &mut states);
            for s in &states {
                kinds[0].push(s.position);
                kinds[1].push(s.velocity);
                kinds[2].push(s.acceleration);
                kinds[3].push(s.jerk);
            }
        }
        let d = PyDict::new(py);
        d.set_item("time", PyArray1::from_vec(py, times))?;
        for (name, values) in ["position", "velocity", "acceleration", "jerk"]
            .into_iter()
            .zip(kinds)
        {
            let array: Bound<'py, PyArray2<f64>> = Array2::from_shape_vec((count, n), values)
                .map_err(|e| TrajectoryError::new_err(e.to_string()))?
                .into_pyarray(py);
            d.set_item(name, array)?;
        }
        Ok(d)
    }
}

fn same_length(name: &str, v: &[f64], dofs: usize) -> Result<(), String> {
    if v.len() == dofs {
        Ok(())
    } else {
        Err(format!(
            "{name} has {} values, expected {dofs} (one per axis, as current_position)",
            v.len()
        ))
    }
}

/// Calculates a time-optimal, jerk-limited trajectory (rmd-traj) from the current state to the
/// target state of every axis (units free but consistent, e.g. rad, rad/s, rad/s², rad/s³).
///
/// Every argument is a sequence with one value per axis (1..=16 axes): `current_*` the state
/// now, `target_*` the state to reach (velocity and acceleration default to 0), `max_*` the
/// limits (≥ 0), `min_velocity` / `min_acceleration` (≤ 0, default the negated maximum).
/// `synchronization`: `"time"` (every axis arrives together; default), `"time-if-necessary"`,
/// `"phase"` (straight line when possible) or `"none"`; `control_interface`: `"position"` or
/// `"velocity"` (reach the target velocity only); `minimum_duration` (s); `period`: round the
/// duration up to a multiple of it. Raises `TrajectoryError` when no trajectory exists for
/// the input (the message names the axis and the reason).
#[pyfunction]
#[pyo3(signature = (
    current_position, target_position, max_velocity, max_acceleration, max_jerk, *,
    current_velocity=None, current_acceleration=None, target_velocity=None,
    target_acceleration=None, min_velocity=None, min_acceleration=None,
    synchronization="time", control_interface="position", minimum_duration=None, period=None
))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn plan(
    current_position: Vec<f64>,
    target_position: Vec<f64>,
    max_velocity: Vec<f64>,
    max_acceleration: Vec<f64>,
    max_jerk: Vec<f64>,
    current_velocity: Option<Vec<f64>>,
    current_acceleration: Option<Vec<f64>>,
    target_velocity: Option<Vec<f64>>,
    target_acceleration: Option<Vec<f64>>,
    min_velocity: Option<Vec<f64>>,
    min_acceleration: Option<Vec<f64>>,
    synchronization: &str,
    control_interface: &str,
    minimum_duration: Option<f64>,
    period: Option<f64>,
) -> PyResult<Trajectory> {
    guard(|| {
        let dofs = current_position.len();
        let zeros = || vec![0.0; dofs];
        let problem = (|| {
            let problem = Problem {
                current: [
                    current_position,
                    current_velocity.unwrap_or_else(zeros),
                    current_acceleration.unwrap_or_else(zeros),
                ],
                target: [
                    target_position,
                    target_velocity.unwrap_or_else(zeros),
                    target_acceleration.unwrap_or_else(zeros),
                ],
                limits: [max_velocity, max_acceleration, max_jerk],
                min_velocity,
                min_acceleration,
                synchronization: match synchronization {
                    "time" => Synchronization::Time,
                    "time-if-necessary" => Synchronization::TimeIfNecessary,
                    "phase" => Synchronization::Phase,
                    "none" => Synchronization::None,
                    other => {
                        return Err(format!(
                            "unknown synchronization `{other}`: expected time, time-if-necessary, \
                             phase or none"
                        ));
                    }
                },
                interface: match control_interface {
                    "position" => ControlInterface::Position,
                    "velocity" => ControlInterface::Velocity,
                    other => {
                        return Err(format!(
                            "unknown control_interface `{other}`: expected position or velocity"
                        ));
                    }
                },
                discretization: match period {
                    None => DurationDiscretization::Continuous,
                    Some(period) => DurationDiscretization::Discrete { period },
                },
                minimum_duration,
            };
            let names = [
                [
                    "current_position",
                    "current_velocity",
                    "current_acceleration",
                ],
                ["target_position", "target_velocity", "target_acceleration"],
                ["max_velocity", "max_acceleration", "max_jerk"],
            ];
            for (group, names) in [&problem.current, &problem.target, &problem.limits]
                .into_iter()
                .zip(names)
            {
                for (v, name) in group.iter().zip(names) {
                    same_length(name, v, dofs)?;
                }
            }
            if let Some(v) = &problem.min_velocity {
                same_length("min_velocity", v, dofs)?;
            }
            if let Some(v) = &problem.min_acceleration {
                same_length("min_acceleration", v, dofs)?;
            }
            Ok(problem)
        })()
        .map_err(TrajectoryError::new_err)?;
        let axes = dispatch!(
            &problem, dofs, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16
        )
        .map_err(TrajectoryError::new_err)?;
        Ok(Trajectory { axes, dofs })
    })
}
