//! One bus (`[[bus]]`), checked: where its motors are, its wire, the undriven motors it
//! acknowledges, and the worst-case wire time of one exchange on it.

use core::ops::Range;
use core::time::Duration;

use rmd_bus::wire;
use rmd_protocol::{MULTI_TORQUE_MOTORS, MotorId};

use super::error::{RobotError, invalid};
use super::file::{BusConfig, ExchangeKind};
use super::joint::JointSpec;
use crate::joint::JointId;

/// The motor ids one 0x280 frame drives (1..=4): a `multi-torque` bus drives higher ids with
/// 0xA1 requests of their own.
pub const MAX_MOTORS_PER_BUS: usize = MULTI_TORQUE_MOTORS;
/// The longest `turnaround_us` of a bus (a motor that takes longer is not answering).
pub const MAX_TURNAROUND: Duration = Duration::from_millis(100);

/// Where a bus's motors are.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum Interface {
    /// A SocketCAN interface, by name (e.g. `can0`).
    SocketCan(String),
    /// Simulated motors matching the description (`interface = "sim"`).
    Simulator,
}

impl Interface {
    /// `"sim"` is the simulator; anything else names a SocketCAN interface.
    pub fn parse(name: &str) -> Option<Self> {
        let name = name.trim();
        match name {
            "" => None,
            "sim" => Some(Interface::Simulator),
            _ => Some(Interface::SocketCan(name.to_string())),
        }
    }
}

impl core::fmt::Display for Interface {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Interface::SocketCan(name) => f.write_str(name),
            Interface::Simulator => f.write_str("sim"),
        }
    }
}

/// One bus, checked.
#[derive(Clone, Debug, PartialEq)]
pub struct BusSpec {
    /// Its name (from the description, or `bus<b>`).
    pub name: String,
    /// Where its motors are.
    pub interface: Interface,
    /// Bit rate, bit/s (10 000..=1 000 000).
    pub bitrate: u32,
    /// Expected motor turnaround, for the exchange budget.
    pub turnaround: Duration,
    /// How torque is exchanged with its motors every tick.
    pub exchange: ExchangeKind,
    /// Motors the description does not drive but acknowledges (`zero_torque_ids`): commanded
    /// zero torque every tick, made safe at the end.
    pub zero_torque_ids: Vec<MotorId>,
    /// Whether each tick also sends one status request (0x9A) to one of its motors in turn
    /// (`loop.health_rotation`, when the wire budget has room for it at the loop's rate:
    /// [`health_budget`](Self::health_budget) within the reply window).
    pub health_rotation: bool,
    joints: Range<usize>,
    /// On a `multi-torque` bus, its motors beyond the 0x280 frame's ids 1..=4 (each driven by
    /// an 0xA1 request of its own).
    beyond_frame: u32,
}

impl BusSpec {
    /// The joints on this bus (consecutive in description order).
    pub fn joints(&self) -> impl Iterator<Item = JointId> + Clone + use<> {
        self.joints.clone().map(JointId::from_index)
    }

    /// The joints on this bus as indices.
    pub fn joint_range(&self) -> Range<usize> {
        self.joints.clone()
    }

    /// Number of motors on the bus.
    pub fn motor_count(&self) -> usize {
        self.joints.len()
    }

    /// The request frames of one exchange: one 0x280 frame (`multi-torque`) and one per motor
    /// beyond its ids 1..=4, or one per motor.
    pub fn requests_per_exchange(&self) -> u32 {
        match self.exchange {
            ExchangeKind::MultiTorque => 1 + self.beyond_frame,
            // A motion-mode command is an 8-byte standard frame, as an 0xA1 request is.
            ExchangeKind::PerMotor | ExchangeKind::Motion => self.joints.len() as u32,
        }
    }

    /// Worst-case duration of one exchange on this bus (every request, every reply:
    /// [`wire::exchange_budget_of`]).
    pub fn exchange_budget(&self) -> Duration {
        wire::exchange_budget_of(
            self.requests_per_exchange(),
            self.joints.len() as u32,
            self.bitrate,
            self.turnaround,
        )
    }

    /// Worst-case duration of one exchange with the status request of the health rotation:
    /// one request and one reply more than [`exchange_budget`](Self::exchange_budget).
    pub fn health_budget(&self) -> Duration {
        wire::exchange_budget_of(
            self.requests_per_exchange() + 1,
            self.joints.len() as u32 + 1,
            self.bitrate,
            self.turnaround,
        )
    }

    /// Sets its exchange, decided once its motors' dialects are known (`exchange_of`), with
    /// what follows from it: the motors a `multi-torque` exchange drives beyond its 0x280
    /// frame. `joints` are this bus's joints.
    pub(super) fn set_exchange(&mut self, exchange: ExchangeKind, joints: &[JointSpec]) {
        self.exchange = exchange;
        self.beyond_frame = match exchange {
            ExchangeKind::MultiTorque => joints
                .iter()
                .filter(|j| j.slot() >= MAX_MOTORS_PER_BUS)
                .count() as u32,
            ExchangeKind::PerMotor | ExchangeKind::Motion => 0,
        };
    }
}

/// Bus `b`'s `[[bus]]` entry (at `key`, its first joint the robot's joint `first`), checked
/// alone; its exchange is decided with its motors (`BusSpec::set_exchange`).
pub(super) fn bus_spec(
    b: usize,
    bus: &BusConfig,
    key: &str,
    first: usize,
) -> Result<BusSpec, RobotError> {
    let interface = Interface::parse(&bus.interface).ok_or_else(|| {
        invalid(
            format!("{key}.interface"),
            "must not be empty: a SocketCAN interface (e.g. \"can0\") or \"sim\"",
        )
    })?;
    if !(10_000..=1_000_000).contains(&bus.bitrate) {
        return Err(invalid(
            format!("{key}.bitrate"),
            format!(
                "is {}, must be 10000..=1000000 bit/s (classic CAN)",
                bus.bitrate
            ),
        ));
    }
    let turnaround = Duration::from_micros(bus.turnaround_us);
    if turnaround > MAX_TURNAROUND {
        return Err(invalid(
            format!("{key}.turnaround_us"),
            format!(
                "is {} us, must be at most {} us (a motor's time from request to reply)",
                bus.turnaround_us,
                MAX_TURNAROUND.as_micros()
            ),
        ));
    }
    if bus.motors.is_empty() {
        return Err(invalid(
            format!("{key}.motor"),
            "a bus needs at least one motor",
        ));
    }
    let name = match &bus.name {
        Some(name) if name.trim().is_empty() => {
            return Err(invalid(format!("{key}.name"), "must not be empty"));
        }
        Some(name) => name.clone(),
        None => format!("bus{b}"),
    };
    let mut zero_torque_ids = Vec::new();
    for (i, &id) in bus.zero_torque_ids.iter().enumerate() {
        let ikey = format!("{key}.zero_torque_ids[{i}]");
        let motor = MotorId::new(id)
            .ok()
            .filter(|m| usize::from(m.get()) <= MAX_MOTORS_PER_BUS)
            .ok_or_else(|| invalid(&ikey, format!("is {id}, must be 1..=4")))?;
        if bus.motors.iter().any(|m| m.id == id) {
            return Err(invalid(
                ikey,
                format!("motor {id} is described on this bus: it cannot also be undriven"),
            ));
        }
        if !zero_torque_ids.contains(&motor) {
            zero_torque_ids.push(motor);
        }
    }
    Ok(BusSpec {
        name,
        interface,
        bitrate: bus.bitrate,
        turnaround,
        // Decided once its motors' dialects are known (`exchange_of`).
        exchange: ExchangeKind::MultiTorque,
        zero_torque_ids,
        // Decided once the exchange's budget is known (`health_fits`).
        health_rotation: false,
        joints: first..first + bus.motors.len(),
        beyond_frame: 0,
    })
}

#[cfg(test)]
mod tests {
    use crate::robot::test_fixtures::{LEG, expect_invalid};

    #[test]
    fn bad_bus_values_name_their_key() {
        expect_invalid(
            &LEG.replace("interface = \"can0\"", "interface = \" \""),
            "bus[0].interface",
        );
        expect_invalid(
            &LEG.replace(
                "interface = \"can0\"",
                "interface = \"can0\"\nturnaround_us = 18446744073709551615",
            ),
            "bus[0].turnaround_us",
        );
    }
}
