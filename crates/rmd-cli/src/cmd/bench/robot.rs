//! The simulated robot the loop benchmarks run: `buses` simulated 1 Mbit/s CAN buses, each with
//! motors 1..=`motors` of the simulator's default kind (RMD-X8 class, 1:9), and the matching
//! robot description; in real time each simulated bus runs on its own thread.

use core::time::Duration;

use rmd_bus::{Clock, MonotonicClock};
use rmd_loop::os::RtRequest;
use rmd_loop::robot::{BusConfig, ExchangeKind, MAX_MOTORS_PER_BUS, MotorConfig, RobotConfig};
use rmd_rig::args::RealtimeArgs;
use rmd_sim::threaded::{Lateness, SimPort, ThreadOptions, ThreadedSim};
use rmd_sim::{FirmwareFamily, SimBus, SimConfig};

/// Gear ratio of the simulator's default motor.
const GEAR_RATIO: f64 = 9.0;
/// Output-side torque constant of the simulator's default motor, N*m/A.
pub(crate) const TORQUE_CONSTANT: f64 = 2.09;
/// Current limit of every motor in the benchmarks, A.
const CURRENT_LIMIT_A: f64 = 10.0;
/// Seed of bus 0; bus `b` uses `SEED + b` (runs are reproducible in virtual time).
const SEED: u64 = 0x5EED;

/// The robot description (file form, to adjust before building the `Robot`): `buses` simulated
/// buses named `sim0`, `sim1`, ... with motors 1..=`motors`.
pub(crate) fn robot(rate_hz: f64, buses: usize, motors: u8) -> RobotConfig {
    robot_for(rate_hz, buses, motors, FirmwareFamily::V161, None)
}

/// [`robot`] for simulated motors running `family`'s firmware: MyActuator V3 motors are described
/// as such (their buses then exchange torque per motor, one 0xA1 each); any other family is
/// described as v1.61, so that the start-up identification refuses a family the description
/// does not name (`rmd bench loop --sim-firmware lk-v2.3x`). `exchange` (`--exchange`) sets every
/// bus's exchange; the description refuses one the motors cannot take.
pub(crate) fn robot_for(
    rate_hz: f64,
    buses: usize,
    motors: u8,
    family: FirmwareFamily,
    exchange: Option<ExchangeKind>,
) -> RobotConfig {
    let mut robot = RobotConfig::new(rate_hz);
    for b in 0..buses {
        let mut bus = BusConfig::new("sim").name(&format!("sim{b}"));
        if family == FirmwareFamily::MyActuatorV3 {
            bus = bus.protocol("myactuator-v3");
        }
        // One 0x280 frame drives ids 1..=4; more motors are driven per motor.
        if usize::from(motors) > MAX_MOTORS_PER_BUS {
            bus = bus.exchange(ExchangeKind::PerMotor);
        }
        if let Some(kind) = exchange {
            bus = bus.exchange(kind);
        }
        for id in 1..=motors {
            bus = bus.with_motor(
                MotorConfig::new(id)
                    .gear_ratio(GEAR_RATIO)
                    .torque_constant(TORQUE_CONSTANT)
                    .current_limit(CURRENT_LIMIT_A),
            );
        }
        robot = robot.with_bus(bus);
    }
    robot
}

/// The simulated buses on `clock`, with the simulator's default timing (1 Mbit/s, 200 us
/// turnaround + 0..20 us jitter).
pub(crate) fn sim_buses<C: Clock + Clone>(
    clock: &C,
    buses: usize,
    motors: u8,
) -> Result<Vec<SimBus<C>>, rmd_sim::ConfigError> {
    sim_buses_of(clock, buses, motors, FirmwareFamily::V161)
}

/// [`sim_buses`] whose motors run `family`'s firmware (`rmd bench loop --sim-firmware`).
pub(crate) fn sim_buses_of<C: Clock + Clone>(
    clock: &C,
    buses: usize,
    motors: u8,
    family: FirmwareFamily,
) -> Result<Vec<SimBus<C>>, rmd_sim::ConfigError> {
    (0..buses)
        .map(|b| {
            SimBus::new(
                clock.clone(),
                SimConfig::with_motors(motors)
                    .seed(SEED + b as u64)
                    .firmware_family(family),
            )
        })
        .collect()
}

/// Simulated buses on threads of their own (`rmd_sim::threaded`), as real motors are: the loop
/// thread only exchanges frames with them, so it is measured alone.
pub(crate) struct ThreadedBuses {
    /// The simulators (stop them to get the buses back, with their traces).
    pub(crate) sims: Vec<ThreadedSim>,
    /// The loop's port onto each.
    pub(crate) ports: Vec<SimPort>,
}

impl ThreadedBuses {
    /// How well the simulator threads kept up, all together.
    pub(crate) fn lateness(&self) -> Lateness {
        self.sims
            .iter()
            .map(ThreadedSim::lateness)
            .fold(Lateness::default(), |a, b| Lateness {
                late_items: a.late_items + b.late_items,
                max_late: a.max_late.max(b.max_late),
            })
    }

    /// When the items the simulator threads handed over late were due, and how late, all buses
    /// together.
    pub(crate) fn late_arrivals(&self) -> Vec<(rmd_bus::Timestamp, Duration)> {
        self.sims
            .iter()
            .flat_map(ThreadedSim::late_arrivals)
            .collect()
    }

    /// Stops every simulator and returns its bus.
    pub(crate) fn stop(self) -> Result<Vec<SimBus<MonotonicClock>>, String> {
        self.sims
            .into_iter()
            .map(|sim| sim.stop().map_err(|e| e.to_string()))
            .collect()
    }
}

/// `buses` threaded simulated buses with motors 1..=`motors` running `family`'s firmware, each
/// recording up to `trace_capacity` transmissions (0: none). Their threads run off the loop's CPU when it is
/// pinned and another CPU exists, at the loop's SCHED_FIFO priority when it has one (the motors
/// are hardware: they must not wait behind other programs); the loop's receive sleeps until
/// `receive_spin` before each reply's arrival, then busy-waits.
pub(crate) fn threaded_buses(
    buses: usize,
    motors: u8,
    family: FirmwareFamily,
    rt: &RealtimeArgs,
    receive_spin: Duration,
    trace_capacity: usize,
) -> Result<ThreadedBuses, String> {
    let cpu = sim_cpu(rt.cpu);
    let fifo = rt.fifo;
    let mut out = ThreadedBuses {
        sims: Vec::with_capacity(buses),
        ports: Vec::with_capacity(buses),
    };
    for b in 0..buses {
        let mut bus = SimBus::new(
            MonotonicClock,
            SimConfig::with_motors(motors)
                .seed(SEED + b as u64)
                .firmware_family(family),
        )
        .map_err(|e| format!("simulator: {e}"))?;
        if trace_capacity > 0 {
            bus.record_trace(trace_capacity);
        }
        let options = ThreadOptions {
            receive_spin,
            name: format!("rmd-sim{b}"),
            ..ThreadOptions::default()
        };
        let (sim, ports) = ThreadedSim::spawn(bus, &options, move || {
            let _ = rmd_loop::os::apply_to_current_thread(&RtRequest {
                cpu,
                fifo_priority: fifo,
                prefault_stack_bytes: 64 * 1024,
                ..RtRequest::default()
            });
        })
        .map_err(|e| format!("cannot start a simulator thread: {e}"))?;
        out.sims.push(sim);
        out.ports.extend(ports);
    }
    Ok(out)
}

/// The CPU for the simulator threads: not the loop's, when it is pinned and another exists.
fn sim_cpu(loop_cpu: Option<usize>) -> Option<usize> {
    let loop_cpu = loop_cpu?;
    core_affinity::get_core_ids()
        .unwrap_or_default()
        .into_iter()
        .map(|c| c.id)
        .find(|&id| id != loop_cpu)
}
