//! Opening a robot's buses where the [`Placement`] says: SocketCAN interfaces, or simulated
//! motors matching the description, on one clock.

use rmd_bus::Clock;
use rmd_loop::{Controller, RtLoop, robot::Robot};
use rmd_sim::{SimBus, SimConfig};

use crate::bus::{AnyBus, SharedSim};
use crate::clock::AnyClock;
use crate::error::RigError;
use crate::placement::{BusTarget, Placement};

/// A robot's buses, open, and the clock they run on: ready for
/// [`RtLoop::unsupervised`](rmd_loop::RtLoop::unsupervised).
#[derive(Debug)]
pub struct Rig {
    /// The clock.
    pub clock: AnyClock,
    /// One bus per bus of the robot description, in its order.
    pub buses: Vec<AnyBus>,
    /// Where they are.
    pub placement: Placement,
}

impl Rig {
    /// Opens every bus of `robot` where `placement` says. `sims` describes the simulated motors
    /// of each bus, in description order (usually [`sim_configs`](crate::sim::sim_configs) plus
    /// the robot's loads); entries of buses on real interfaces are not used.
    pub fn open(
        robot: &Robot,
        placement: &Placement,
        sims: Vec<SimConfig>,
    ) -> Result<Self, RigError> {
        if sims.len() != robot.buses().len() {
            return Err(RigError::SimCount {
                expected: robot.buses().len(),
                given: sims.len(),
            });
        }
        let clock = AnyClock::new(placement.time());
        let mut buses = Vec::with_capacity(sims.len());
        for ((spec, target), sim) in robot.buses().iter().zip(placement.buses()).zip(sims) {
            buses.push(match target {
                BusTarget::Simulator => AnyBus::Sim(SharedSim::new(
                    SimBus::new(clock.clone(), sim).map_err(|source| RigError::Sim {
                        bus: spec.name.clone(),
                        source,
                    })?,
                )),
                BusTarget::SocketCan(name) => open_socketcan(&spec.name, name)?,
            });
        }
        Ok(Self {
            clock,
            buses,
            placement: placement.clone(),
        })
    }

    /// Every bus of `robot` on simulated motors matching its description
    /// ([`sim_configs`](crate::sim::sim_configs), seeded [`Rig::SIM_SEED`]), in `time`: the
    /// shortest way to try a controller. [`Rig::open`] with [`Placement::resolve`] picks real
    /// interfaces from the command line instead.
    pub fn simulated(robot: &Robot, time: crate::SimTime) -> Result<Self, RigError> {
        Self::open(
            robot,
            &Placement::simulated(robot, time),
            crate::sim::sim_configs(robot, Self::SIM_SEED),
        )
    }

    /// The seed of [`Rig::simulated`]'s motors (their encoder noise and injected faults): runs
    /// repeat exactly.
    pub const SIM_SEED: u64 = 1;

    /// The loop of `robot` on these buses with `controller`, supervised: the supervisor gets its
    /// own way onto every bus (a second socket, or a second handle to the simulated bus).
    pub fn into_loop<K: Controller>(
        self,
        robot: Robot,
        controller: K,
    ) -> Result<RtLoop<AnyBus, AnyClock, K>, RigError> {
        let ports = self
            .buses
            .iter()
            .map(AnyBus::safety_port)
            .collect::<Result<Vec<_>, _>>()?;
        Ok(RtLoop::unsupervised(robot, self.clock, self.buses, controller)?.supervise(ports)?)
    }
}

#[cfg(target_os = "linux")]
fn open_socketcan(bus: &str, iface: &str) -> Result<AnyBus, RigError> {
    use rmd_bus::socketcan::SocketCanBus;
    SocketCanBus::open(iface, &crate::bus::loop_socket_options())
        .map(|bus| AnyBus::SocketCan(Box::new(bus)))
        .map_err(|source| RigError::Open {
            bus: bus.to_string(),
            source,
        })
}

#[cfg(not(target_os = "linux"))]
fn open_socketcan(_bus: &str, _iface: &str) -> Result<AnyBus, RigError> {
    Err(RigError::Unsupported)
}

/// Builds one simulated bus per configuration, all on `clock` (clones of one clock share one
/// time line). Tests use it to keep the buses and look at the simulated motors after a run.
pub fn sim_buses<C: Clock + Clone>(
    clock: &C,
    sims: Vec<SimConfig>,
) -> Result<Vec<SimBus<C>>, RigError> {
    sims.into_iter()
        .enumerate()
        .map(|(bus, config)| {
            SimBus::new(clock.clone(), config).map_err(|source| RigError::Sim {
                bus: format!("bus{bus}"),
                source,
            })
        })
        .collect()
}
