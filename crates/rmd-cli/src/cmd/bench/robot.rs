//! The simulated robot the loop benchmarks run: `buses` simulated 1 Mbit/s CAN buses, each with
//! motors 1..=`motors` of the simulator's default kind (RMD-X8 class, 1:9), and the matching
//! robot description.

use rmd_bus::Clock;
use rmd_loop::robot::{BusConfig, MotorConfig, RobotConfig};
use rmd_sim::{FirmwareFamily, SimBus, SimConfig};

/// Gear ratio of the simulator's default motor.
const GEAR_RATIO: f64 = 9.0;
/// Output-side torque constant of the simulator's default motor, N*m/A.
const TORQUE_CONSTANT: f64 = 2.09;
/// Current limit of every motor in the benchmarks, A.
const CURRENT_LIMIT_A: f64 = 10.0;
/// Seed of bus 0; bus `b` uses `SEED + b` (runs are reproducible in virtual time).
const SEED: u64 = 0x5EED;

/// The robot description (file form, to adjust before building the `Robot`): `buses` simulated
/// buses named `sim0`, `sim1`, ... with motors 1..=`motors`.
pub(crate) fn robot(rate_hz: f64, buses: usize, motors: u8) -> RobotConfig {
    let mut robot = RobotConfig::new(rate_hz);
    for b in 0..buses {
        let mut bus = BusConfig::new("sim").name(&format!("sim{b}"));
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
