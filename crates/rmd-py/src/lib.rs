//! The Rust side of the Python package `rmd_rt` (the module `rmd_rt._native`): pyo3 bindings
//! over the Python-free crates of rmd-rt. The typed Python API, its docstrings and stubs are in
//! `python/rmd_rt/`; `docs/python.md` is the user's guide.
//!
//! - `protocol`: `encode` and `decode`, the same frames, keys and messages as `rmd encode` /
//!   `rmd decode` (both use `rmd-frames`);
//! - `bus`: one request, one reply, on SocketCAN or simulated motors, from any thread with the
//!   GIL released during the I/O (`exchange` does the waiting);
//! - `robot` and `running`: a robot description, and its loop with the joint servo on its
//!   own Rust thread (`telemetry` feeds the MCAP / Foxglove sinks off that thread);
//! - `sim`: the simulated motors' ground truth;
//! - `traj`: rmd-traj's trajectories sampled into NumPy arrays.
//!
//! Python never runs on the real-time thread: the loop thread and the telemetry thread are
//! plain Rust threads that never take the GIL.

// The workspace's `unsafe_code = deny` holds here too: pyo3's macros expand to their FFI glue
// with the spans of pyo3's own code, which the lint does not flag, and this crate writes no
// `unsafe` of its own.

mod bus;
mod errors;
mod exchange;
mod protocol;
mod robot;
mod running;
mod sim;
mod telemetry;
mod traj;

mod args;
mod fields;
mod process;
mod wait;

use pyo3::prelude::*;

/// The native module of `rmd_rt`: import `rmd_rt`, not this.
#[pymodule]
#[pyo3(name = "_native")]
fn native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    // The wheel's version is the crate's too (maturin takes it from Cargo.toml).
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(protocol::encode, m)?)?;
    m.add_function(wrap_pyfunction!(protocol::decode, m)?)?;
    m.add_function(wrap_pyfunction!(traj::plan, m)?)?;
    m.add_function(wrap_pyfunction!(running::stop_all_loops, m)?)?;
    m.add_class::<bus::NativeBus>()?;
    m.add_class::<sim::Simulator>()?;
    m.add_class::<robot::Robot>()?;
    m.add_class::<running::RobotLoop>()?;
    m.add_class::<traj::Trajectory>()?;
    Ok(())
}
