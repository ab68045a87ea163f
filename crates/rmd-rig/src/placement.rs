//! Where each bus's motors are for one run: the interface the description names, the simulator,
//! or an interface given on the command line (by bus order or by bus name).
//!
//! ```
//! use rmd_loop::robot::Robot;
//! use rmd_rig::placement::{BusTarget, Overrides, Placement, PlacementDefault};
//!
//! let robot = Robot::from_toml(r#"
//!     [[bus]]
//!     name = "front"
//!     interface = "can0"
//!     [[bus.motor]]
//!     id = 1
//!     [[bus]]
//!     name = "rear"
//!     interface = "can1"
//!     [[bus.motor]]
//!     id = 1
//! "#)?;
//! // As described.
//! let p = Placement::resolve(&robot, &Overrides::default(), PlacementDefault::Described)?;
//! assert_eq!(p.buses()[1], BusTarget::SocketCan("can1".into()));
//! // One bus moved by name.
//! let moved = Overrides { interfaces: vec!["rear=vcan1".into()], ..Overrides::default() };
//! let p = Placement::resolve(&robot, &moved, PlacementDefault::Described)?;
//! assert_eq!(p.buses()[1], BusTarget::SocketCan("vcan1".into()));
//! // Two buses on one interface is an error.
//! let clash = Overrides { interfaces: vec!["can0,can0".into()], ..Overrides::default() };
//! assert!(Placement::resolve(&robot, &clash, PlacementDefault::Described).is_err());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use core::fmt;

use rmd_loop::robot::Interface;
use rmd_loop::robot::Robot;

use crate::error::RigError;

/// Whether simulated motors run in real time or in virtual time.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub enum SimTime {
    /// Real time: a run takes as long as it would on real motors.
    #[default]
    Real,
    /// Virtual time: deterministic and as fast as the CPU allows.
    Virtual,
}

/// Where one bus's motors are.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum BusTarget {
    /// A SocketCAN interface.
    SocketCan(String),
    /// Simulated motors matching the description.
    Simulator,
}

impl fmt::Display for BusTarget {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BusTarget::SocketCan(name) => f.write_str(name),
            BusTarget::Simulator => f.write_str("simulated"),
        }
    }
}

/// What a program does when the command line names no target.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum PlacementDefault {
    /// Each bus where the description says (the `rmd` tool with `--robot`).
    Described,
    /// Simulated motors unless `--iface` is given (the examples: a demo never moves real
    /// motors by surprise).
    Simulated,
}

/// What the command line says about where the motors are.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Overrides {
    /// Simulate every bus (`--sim`).
    pub simulate: bool,
    /// `--iface` values: `IFACE[,IFACE...]` by bus order, or `BUS=IFACE[,BUS=IFACE...]` by bus
    /// name (repeatable).
    pub interfaces: Vec<String>,
    /// Simulated motors in virtual time (`--virtual-time`).
    pub virtual_time: bool,
}

/// Where every bus of a robot is for this run, checked: no two buses share an interface, and
/// virtual time only with simulated motors.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Placement {
    buses: Vec<BusTarget>,
    time: SimTime,
}

impl Placement {
    /// Every bus of `robot` simulated, in `time`.
    pub fn simulated(robot: &Robot, time: SimTime) -> Self {
        Self {
            buses: vec![BusTarget::Simulator; robot.buses().len()],
            time,
        }
    }

    /// Resolves the command line's `overrides` against `robot`'s description.
    pub fn resolve(
        robot: &Robot,
        overrides: &Overrides,
        default: PlacementDefault,
    ) -> Result<Self, RigError> {
        let entries: Vec<&str> = overrides
            .interfaces
            .iter()
            .flat_map(|arg| arg.split(','))
            .map(str::trim)
            .collect();
        if entries.iter().any(|e| e.is_empty()) {
            return Err(RigError::EmptyInterfaceName);
        }
        if overrides.simulate && !entries.is_empty() {
            return Err(RigError::SimAndInterfaces);
        }
        let simulate_all =
            overrides.simulate || (default == PlacementDefault::Simulated && entries.is_empty());
        let mut buses: Vec<BusTarget> = robot
            .buses()
            .iter()
            .map(|bus| match (&bus.interface, simulate_all) {
                (_, true) | (Interface::Simulator, _) => BusTarget::Simulator,
                (Interface::SocketCan(name), false) => BusTarget::SocketCan(name.clone()),
            })
            .collect();
        apply_interfaces(robot, &entries, &mut buses)?;
        for (b, target) in buses.iter().enumerate() {
            if let BusTarget::SocketCan(name) = target
                && let Some(first) = buses[..b].iter().position(|t| t == target)
            {
                return Err(RigError::SharedInterface {
                    interface: name.clone(),
                    first: robot.buses()[first].name.clone(),
                    second: robot.buses()[b].name.clone(),
                });
            }
        }
        let time = if overrides.virtual_time {
            if let Some(b) = buses.iter().position(|t| *t != BusTarget::Simulator) {
                return Err(RigError::VirtualTimeOnRealBus {
                    bus: robot.buses()[b].name.clone(),
                });
            }
            SimTime::Virtual
        } else {
            SimTime::Real
        };
        Ok(Self { buses, time })
    }

    /// Where each bus is, in description order.
    pub fn buses(&self) -> &[BusTarget] {
        &self.buses
    }

    /// Real or virtual time.
    pub fn time(&self) -> SimTime {
        self.time
    }

    /// Whether every bus is simulated.
    pub fn all_simulated(&self) -> bool {
        self.buses.iter().all(|t| *t == BusTarget::Simulator)
    }

    /// Whether any bus has real motors.
    pub fn has_real_motors(&self) -> bool {
        !self.all_simulated()
    }
}

impl fmt::Display for Placement {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.all_simulated() {
            return f.write_str(match self.time {
                SimTime::Real => "simulated motors, real time",
                SimTime::Virtual => "simulated motors, virtual time",
            });
        }
        let names: Vec<String> = self.buses.iter().map(ToString::to_string).collect();
        write!(f, "SocketCAN {}", names.join(", "))
    }
}

fn apply_interfaces(
    robot: &Robot,
    entries: &[&str],
    buses: &mut [BusTarget],
) -> Result<(), RigError> {
    if entries.is_empty() {
        return Ok(());
    }
    let named = entries.iter().filter(|e| e.contains('=')).count();
    if named == 0 {
        if entries.len() != buses.len() {
            return Err(RigError::InterfaceCount {
                expected: buses.len(),
                given: entries.len(),
            });
        }
        for (target, name) in buses.iter_mut().zip(entries) {
            *target = interface_target(name);
        }
        return Ok(());
    }
    if named != entries.len() {
        return Err(RigError::MixedInterfaceForms);
    }
    for entry in entries {
        let (bus, name) = entry.split_once('=').unwrap_or((entry, ""));
        let (bus, name) = (bus.trim(), name.trim());
        if name.is_empty() {
            return Err(RigError::EmptyInterfaceName);
        }
        let b = robot
            .buses()
            .iter()
            .position(|spec| spec.name == bus)
            .ok_or_else(|| RigError::UnknownBus {
                bus: bus.to_string(),
                known: robot
                    .buses()
                    .iter()
                    .map(|spec| spec.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
            })?;
        buses[b] = interface_target(name);
    }
    Ok(())
}

fn interface_target(name: &str) -> BusTarget {
    match Interface::parse(name) {
        Some(Interface::SocketCan(name)) => BusTarget::SocketCan(name),
        _ => BusTarget::Simulator,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn robot(interfaces: &[&str]) -> Robot {
        let mut text = String::new();
        for (b, iface) in interfaces.iter().enumerate() {
            text += &format!(
                "[[bus]]\nname = \"b{b}\"\ninterface = \"{iface}\"\n[[bus.motor]]\nid = 1\n"
            );
        }
        Robot::from_toml(&text).unwrap()
    }

    fn overrides(ifaces: &[&str]) -> Overrides {
        Overrides {
            interfaces: ifaces.iter().map(|s| s.to_string()).collect(),
            ..Overrides::default()
        }
    }

    fn can(name: &str) -> BusTarget {
        BusTarget::SocketCan(name.into())
    }

    #[test]
    fn the_description_decides_unless_the_command_line_overrides() {
        let r = robot(&["can0", "sim"]);
        let p = Placement::resolve(&r, &Overrides::default(), PlacementDefault::Described).unwrap();
        assert_eq!(p.buses(), [can("can0"), BusTarget::Simulator]);
        assert!(p.has_real_motors());
        // Examples simulate by default...
        let p = Placement::resolve(&r, &Overrides::default(), PlacementDefault::Simulated).unwrap();
        assert!(p.all_simulated());
        assert_eq!(p.to_string(), "simulated motors, real time");
        // ...and take the description's buses once an interface is named.
        let p =
            Placement::resolve(&r, &overrides(&["b1=vcan1"]), PlacementDefault::Simulated).unwrap();
        assert_eq!(p.buses(), [can("can0"), can("vcan1")]);
        // By order.
        let p = Placement::resolve(
            &r,
            &overrides(&["vcan0", "vcan1"]),
            PlacementDefault::Described,
        )
        .unwrap();
        assert_eq!(p.buses(), [can("vcan0"), can("vcan1")]);
        assert_eq!(p.to_string(), "SocketCAN vcan0, vcan1");
        // --sim.
        let sim = Overrides {
            simulate: true,
            virtual_time: true,
            ..Overrides::default()
        };
        let p = Placement::resolve(&r, &sim, PlacementDefault::Described).unwrap();
        assert!(p.all_simulated());
        assert_eq!(p.time(), SimTime::Virtual);
    }

    #[test]
    fn bad_overrides_are_errors_that_say_what_to_do() {
        let r = robot(&["can0", "can1"]);
        let err =
            |o: Overrides| Placement::resolve(&r, &o, PlacementDefault::Described).unwrap_err();
        assert!(matches!(
            err(overrides(&["can0"])),
            RigError::InterfaceCount {
                expected: 2,
                given: 1
            }
        ));
        assert!(matches!(
            err(overrides(&["can0,"])),
            RigError::EmptyInterfaceName
        ));
        assert!(matches!(
            err(overrides(&["b0=can3", "can4"])),
            RigError::MixedInterfaceForms
        ));
        let unknown = err(overrides(&["front=can3"]));
        assert_eq!(
            unknown.to_string(),
            "--iface names bus `front`, but the robot's buses are: b0, b1"
        );
        let shared = err(overrides(&["can0,can0"]));
        assert!(
            matches!(shared, RigError::SharedInterface { .. }),
            "{shared}"
        );
        assert!(shared.to_string().contains("b0 and b1"), "{shared}");
        let shared = err(overrides(&["b1=can0"]));
        assert!(matches!(shared, RigError::SharedInterface { .. }));
        let virtual_real = err(Overrides {
            virtual_time: true,
            ..Overrides::default()
        });
        assert!(matches!(
            virtual_real,
            RigError::VirtualTimeOnRealBus { .. }
        ));
        let both = err(Overrides {
            simulate: true,
            interfaces: vec!["can0,can1".into()],
            ..Overrides::default()
        });
        assert!(matches!(both, RigError::SimAndInterfaces));
    }
}
