//! The motors a live command talks to: motor ids on one bus (`--iface`/`--sim` and `IDS`), or the
//! joints of a robot description by name (`--robot FILE [JOINT...]`), each on its own bus, with
//! the joint's mapping for joint units.

use std::path::Path;
use std::time::Duration;

use rmd_bus::MonotonicClock;
use rmd_loop::mapping::JointMap;
use rmd_loop::robot::Robot;
use rmd_protocol::{EncoderWidth, MotorId, Reply, Request};
use rmd_rig::placement::{BusTarget, Overrides, Placement, PlacementDefault};
use rmd_sim::SimBus;

use crate::args::bus::BusArgs;
use crate::args::ids;
use crate::live::connect::{Connection, Filter, open_interface};
use crate::live::exchange::{ExchangeError, Setup};
use crate::output::report::CliError;

/// A joint of the robot description.
#[derive(Clone, Debug)]
pub(crate) struct Joint {
    /// Its name.
    pub(crate) name: String,
    /// Its bus's name.
    pub(crate) bus_name: String,
    /// Motor <-> joint.
    pub(crate) map: JointMap,
}

/// One motor of a command.
#[derive(Clone, Debug)]
pub(crate) struct Motor {
    /// Its id.
    pub(crate) id: MotorId,
    /// Its connection (index).
    pub(crate) bus: usize,
    /// Its encoder width.
    pub(crate) width: EncoderWidth,
    /// Its joint, with `--robot`.
    pub(crate) joint: Option<Joint>,
}

impl Motor {
    /// `knee` or `motor 3`, for messages.
    pub(crate) fn label(&self) -> String {
        match &self.joint {
            Some(j) => j.name.clone(),
            None => format!("motor {}", self.id),
        }
    }

    /// `knee (motor 3 on bus leg)` or `motor 3`, for a motor's heading.
    pub(crate) fn title(&self) -> String {
        match &self.joint {
            Some(j) => format!("{} (motor {} on bus {})", j.name, self.id, j.bus_name),
            None => format!("motor {}", self.id),
        }
    }
}

/// The open buses and the motors on them.
pub(crate) struct Motors {
    buses: Vec<Connection>,
    motors: Vec<Motor>,
}

impl Motors {
    /// Opens what `args` names and selects `targets`: joint names with `--robot` (none: every
    /// joint), otherwise motor ids (`1`, `1-4`, `1,3`; required).
    pub(crate) fn open(
        args: &BusArgs,
        targets: &[String],
        default_timeout: Duration,
        default_retries: u32,
    ) -> Result<Self, CliError> {
        match &args.robot {
            Some(path) => Self::open_robot(args, path, targets, default_timeout, default_retries),
            None => {
                let text = targets.join(",");
                if text.is_empty() {
                    return Err(CliError::Usage(
                        "which motors? give their ids (e.g. 1-4), or --robot FILE for a robot's \
                         joints"
                            .to_owned(),
                    ));
                }
                let ids = ids::parse(&text).map_err(CliError::Usage)?;
                let bus = Connection::open(args, default_timeout, default_retries)?;
                let width = bus.width();
                Ok(Self {
                    buses: vec![bus],
                    motors: ids
                        .ids()
                        .iter()
                        .map(|&id| Motor {
                            id,
                            bus: 0,
                            width,
                            joint: None,
                        })
                        .collect(),
                })
            }
        }
    }

    fn open_robot(
        args: &BusArgs,
        path: &Path,
        names: &[String],
        default_timeout: Duration,
        default_retries: u32,
    ) -> Result<Self, CliError> {
        let robot = Robot::from_file(path).map_err(|e| CliError::Usage(e.to_string()))?;
        if let Some(protocol) = args.protocol.protocol {
            return Err(CliError::Usage(format!(
                "--protocol {protocol}: with --robot, each motor speaks the protocol {} names \
                 (its `protocol`, `lk_series` or `model`)",
                path.display()
            )));
        }
        let overrides = Overrides {
            simulate: args.sim,
            interfaces: args.iface.iter().cloned().collect(),
            virtual_time: false,
        };
        let placement = Placement::resolve(&robot, &overrides, PlacementDefault::Described)
            .map_err(|e| CliError::Usage(e.to_string()))?;
        if args.log.is_some() && robot.buses().len() > 1 {
            // `rmd log` beside this command records an interface; simulated buses live in this
            // process only.
            let logs: Vec<String> = placement
                .buses()
                .iter()
                .filter_map(|target| match target {
                    BusTarget::SocketCan(iface) => {
                        Some(format!("`rmd log --iface {iface} {iface}.log`"))
                    }
                    BusTarget::Simulator => None,
                })
                .collect();
            let instead = if logs.is_empty() {
                String::new()
            } else {
                format!(": run {} beside it instead", logs.join(" and "))
            };
            return Err(CliError::Usage(format!(
                "--log records one bus, and {} has {}{instead}",
                path.display(),
                robot.buses().len()
            )));
        }
        // Each simulated joint powered up where the description reads it right.
        let mut sims = rmd_rig::sim::sim_configs(&robot, 1);
        rmd_rig::sim::power_up_centred(&robot, &mut sims);
        let mut buses = Vec::new();
        for ((spec, target), sim) in robot.buses().iter().zip(placement.buses()).zip(sims) {
            let (bus, setup): (Box<dyn rmd_bus::CanBus>, Setup) = match target {
                BusTarget::Simulator => (
                    Box::new(
                        SimBus::new(MonotonicClock, sim)
                            .map_err(|e| CliError::Failed(format!("simulator: {e}")))?,
                    ),
                    Setup::Robot(path.display().to_string()),
                ),
                BusTarget::SocketCan(iface) => (
                    open_interface(iface, Filter::Motors)
                        .map_err(|e| CliError::Failed(format!("bus {}: {e}", spec.name)))?,
                    Setup::Interface(iface.clone()),
                ),
            };
            // The encoder width is per joint (below); this one is only for `--log`'s decoding.
            let width = spec
                .joints()
                .next()
                .map_or(EncoderWidth::DEFAULT, |j| robot.spec(j).encoder);
            buses.push(Connection::on(
                bus,
                setup,
                args,
                width,
                default_timeout,
                default_retries,
            )?);
        }
        let joints = if names.is_empty() {
            robot.joint_ids().collect()
        } else {
            names
                .iter()
                .flat_map(|n| n.split(','))
                .map(|name| robot.joint(name.trim()))
                .collect::<Result<Vec<_>, _>>()
                .map_err(|e| CliError::Usage(e.to_string()))?
        };
        let motors = joints
            .into_iter()
            .map(|j| {
                let spec = robot.spec(j);
                buses[spec.bus].name_protocol(spec.motor, spec.dialect);
                Motor {
                    id: spec.motor,
                    bus: spec.bus,
                    width: spec.encoder,
                    joint: Some(Joint {
                        name: spec.name.clone(),
                        bus_name: robot.buses()[spec.bus].name.clone(),
                        map: JointMap::from_spec(spec),
                    }),
                }
            })
            .collect();
        Ok(Self { buses, motors })
    }

    /// The selected motors, in order.
    pub(crate) fn motors(&self) -> &[Motor] {
        &self.motors
    }

    /// Sends `request` to `motor` and returns its reply.
    pub(crate) fn request(
        &mut self,
        motor: &Motor,
        request: &Request,
    ) -> Result<Reply, ExchangeError> {
        self.buses[motor.bus].request(motor.id, request)
    }

    /// The dialect to send `command` to `motor` in (see [`Connection::dialect`]).
    pub(crate) fn dialect(
        &mut self,
        motor: &Motor,
        command: rmd_protocol::Command,
    ) -> Result<rmd_protocol::Dialect, ExchangeError> {
        self.buses[motor.bus].dialect(motor.id, command)
    }

    /// Keeps the motors for which `keep` holds.
    pub(crate) fn retain(&mut self, keep: impl FnMut(&Motor) -> bool) {
        self.motors.retain(keep);
    }

    /// The connection of `motor`.
    pub(crate) fn connection(&mut self, motor: &Motor) -> &mut Connection {
        &mut self.buses[motor.bus]
    }

    /// Ends every connection (flushing a recording).
    pub(crate) fn finish(self) -> Result<(), CliError> {
        for bus in self.buses {
            bus.finish()?;
        }
        Ok(())
    }
}
