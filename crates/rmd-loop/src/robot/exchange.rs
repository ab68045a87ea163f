//! A bus's exchange, checked against its motors and the loop: its kind (`multi-torque`,
//! `per-motor`, `motion`) and what each allows, and whether the wire carries it, and the health
//! rotation, at the loop's rate.

use core::time::Duration;

use super::bus::{BusSpec, MAX_MOTORS_PER_BUS};
use super::error::{RobotError, Shown, invalid};
use super::file::{BusConfig, ExchangeKind, ReplyMode};
use super::joint::JointSpec;
use super::settings::{LoopSettings, default_reply_deadline};

/// The bus's exchange: as written, or `per-motor` when a motor speaks MyActuator V3 (whose
/// 0x280 frame is one command for every motor: `multi-torque` is refused there), else
/// `multi-torque`.
pub(super) fn exchange_of(
    bus: &BusConfig,
    joints: &[JointSpec],
    key: &str,
) -> Result<ExchangeKind, RobotError> {
    let v3 = joints
        .iter()
        .find(|j| !j.dialect.multi_torque_is_per_motor_torque());
    match (bus.exchange, v3) {
        (Some(ExchangeKind::MultiTorque), Some(j)) => Err(invalid(
            format!("{key}.exchange"),
            format!(
                "is \"multi-torque\", but joint `{}` (motor {}) speaks {}, to which a 0x280 frame \
                 is one command for every motor, not torque: use exchange = \"per-motor\" (the \
                 default on such a bus)",
                j.name,
                j.motor.get(),
                j.dialect.name()
            ),
        )),
        (Some(ExchangeKind::Motion), _) => {
            check_motion_joints(joints, key)?;
            Ok(ExchangeKind::Motion)
        }
        (Some(kind), _) => Ok(kind),
        (None, Some(_)) => Ok(ExchangeKind::PerMotor),
        // The 0x280 frame for ids 1..=4 (and 0xA1 requests for the ids beyond), unless no motor
        // has one of those ids.
        (None, None) if joints.iter().any(|j| j.slot() < MAX_MOTORS_PER_BUS) => {
            Ok(ExchangeKind::MultiTorque)
        }
        (None, None) => Ok(ExchangeKind::PerMotor),
    }
}

/// Every joint of a `motion` bus speaks MyActuator V3 (the only family with a motion mode)
/// and has a torque constant (its replies report torque in N*m, from which the loop reports
/// the current, and its current commands become feed-forward torque).
fn check_motion_joints(joints: &[JointSpec], key: &str) -> Result<(), RobotError> {
    for j in joints {
        if j.dialect.v3_firmware().is_none() {
            return Err(invalid(
                format!("{key}.exchange"),
                format!(
                    "is \"motion\", but joint `{}` (motor {}) speaks {}, which has no motion \
                     mode (MyActuator V3 only): use exchange = \"per-motor\" or \
                     \"multi-torque\", or put the V3 motors on a bus of their own",
                    j.name,
                    j.motor.get(),
                    j.dialect.name()
                ),
            ));
        }
        if j.torque_constant_nm_per_amp.is_none() {
            return Err(invalid(
                format!("{key}.exchange"),
                format!(
                    "is \"motion\", but joint `{}` (motor {}) has no torque constant: motion \
                     mode reports torque in N*m and takes currents as feed-forward torque; set \
                     torque_constant_nm_per_amp (or a model that gives it)",
                    j.name,
                    j.motor.get()
                ),
            ));
        }
    }
    Ok(())
}

/// A `motion` bus's replies carry no temperature: its joints' temperature limits are watched
/// through the health rotation's status replies, so a temperature limit there needs the
/// rotation on.
pub(super) fn check_motion_temperature(
    bus: &BusSpec,
    joints: &[JointSpec],
    settings: &LoopSettings,
    key: &str,
) -> Result<(), RobotError> {
    if bus.exchange != ExchangeKind::Motion || bus.health_rotation {
        return Ok(());
    }
    let Some(j) = joints
        .iter()
        .find(|j| j.temperature_limit_celsius.is_some())
    else {
        return Ok(());
    };
    let why = if settings.health_rotation {
        format!(
            "this bus has no room for it at {} Hz (its exchange with a status request and \
             reply needs up to {} us): lower loop.rate_hz or put fewer motors on the bus",
            settings.period.hz(),
            bus.health_budget().as_micros()
        )
    } else {
        "loop.health_rotation is off: turn it on".to_string()
    };
    Err(invalid(
        format!("{key}.exchange"),
        format!(
            "is \"motion\" and joint `{}` has temperature_limit_celsius, but motion-mode replies \
             carry no temperature: the limit is watched through the health rotation's status \
             replies, and {why}; or remove the limit, or use exchange = \"per-motor\"",
            j.name
        ),
    ))
}

/// What the bus's exchange allows: a `multi-torque` bus drives ids 1..=4 with its 0x280 frame
/// (and acknowledges undescribed ones among them) and any higher id with 0xA1 requests of its
/// own; a `per-motor` or `motion` bus commands only its described motors.
pub(super) fn check_bus_layout(spec: &BusSpec, key: &str) -> Result<(), RobotError> {
    match spec.exchange {
        ExchangeKind::MultiTorque => {}
        ExchangeKind::PerMotor | ExchangeKind::Motion => {
            if !spec.zero_torque_ids.is_empty() {
                return Err(invalid(
                    format!("{key}.zero_torque_ids"),
                    "a per-motor bus commands only its described motors: an undescribed motor \
                     there is never sent torque; remove zero_torque_ids",
                ));
            }
        }
    }
    Ok(())
}

/// The bus must carry one exchange per tick (same tick: before the reply deadline). A rate it
/// cannot carry is refused, naming the highest rate it can carry and what to change.
pub(super) fn check_budget(
    bus: &BusSpec,
    s: &LoopSettings,
    explicit_deadline: bool,
    key: &str,
) -> Result<(), RobotError> {
    let budget = bus.exchange_budget();
    let (window, window_name) = match s.reply_mode {
        ReplyMode::SameTick => (s.reply_deadline, "reply deadline"),
        ReplyMode::Pipelined => (s.period.get(), "period"),
    };
    if budget <= window || s.allow_over_budget {
        return Ok(());
    }
    let shortest = shortest_period(budget, s.reply_mode, explicit_deadline);
    let highest = highest_rate_hz(shortest);
    let deadline_hint = if explicit_deadline && s.reply_mode == ReplyMode::SameTick {
        format!(
            ", or raise loop.reply_deadline_us to at least {} us",
            budget.as_micros().max(1)
        )
    } else {
        String::new()
    };
    Err(invalid(
        key,
        format!(
            "cannot carry one exchange per tick at {} Hz: {} motors ({} exchange, {} request \
             frame(s)) at {} bit/s with {} us turnaround need up to {} us (worst-case bit \
             stuffing), but the {window_name} is {} us. The highest rate this bus can carry is \
             {highest} Hz. Lower loop.rate_hz to at most {highest}, put fewer motors on this \
             bus (spread them over more buses), raise the bit rate{}{deadline_hint}",
            Shown(1e9 / s.period.get().as_nanos() as f64),
            bus.motor_count(),
            bus.exchange,
            bus.requests_per_exchange(),
            bus.bitrate,
            bus.turnaround.as_micros(),
            budget.as_micros(),
            window.as_micros(),
            match s.reply_mode {
                ReplyMode::SameTick => ", or use reply_mode = \"pipelined\"",
                ReplyMode::Pipelined => "",
            },
        ),
    ))
}

/// Whether the bus carries the health rotation's status request and reply every tick within
/// its reply window (same tick: the reply deadline; pipelined: the period). Never with
/// `allow_over_budget`'s leave: a bus beyond its budget runs without it.
pub(super) fn health_fits(bus: &BusSpec, s: &LoopSettings) -> bool {
    let window = match s.reply_mode {
        ReplyMode::SameTick => s.reply_deadline,
        ReplyMode::Pipelined => s.period.get(),
    };
    bus.health_budget() <= window
}

/// The shortest period whose window (same tick: the default reply deadline, or the explicit
/// one, which must fit in the period; pipelined: the period) holds an exchange of `budget`.
fn shortest_period(budget: Duration, mode: ReplyMode, explicit_deadline: bool) -> Duration {
    if mode == ReplyMode::Pipelined || explicit_deadline {
        return budget;
    }
    // The default deadline grows with the period: the least period whose deadline holds the
    // budget, to the nanosecond (at most twice the budget).
    let (mut low, mut high) = (budget.as_nanos() as u64, 2 * budget.as_nanos() as u64 + 1);
    while low < high {
        let mid = low + (high - low) / 2;
        if default_reply_deadline(Duration::from_nanos(mid)) >= budget {
            high = mid;
        } else {
            low = mid + 1;
        }
    }
    Duration::from_nanos(low)
}

/// The highest whole rate (Hz) whose period is at least `period`.
fn highest_rate_hz(period: Duration) -> u64 {
    let ns = period.as_nanos().max(1);
    let mut hz = (1_000_000_000 / ns) as u64;
    // `Period::from_hz` rounds the period to the nanosecond: step down until it is long enough.
    while hz > 1 && (1e9 / hz as f64).round() < ns as f64 {
        hz -= 1;
    }
    hz
}

#[cfg(test)]
mod tests {
    use core::time::Duration;

    use crate::robot::test_fixtures::v3_bus;
    use crate::robot::{
        BusConfig, ExchangeKind, MotorConfig, ReplyMode, Robot, RobotConfig, RobotError,
    };

    #[test]
    fn a_period_the_bus_cannot_carry_is_refused() {
        // 4 motors at 1 Mbit/s need up to 875 us: 2 kHz (500 us period) cannot work.
        let mut bus = BusConfig::new("can0");
        for id in 1..=4 {
            bus = bus.with_motor(MotorConfig::new(id));
        }
        let err = Robot::try_from(RobotConfig::new(2000.0).with_bus(bus.clone())).unwrap_err();
        assert!(err.to_string().contains("875 us"), "{err}");
        // 1 kHz fits with the default 900 us reply deadline.
        Robot::try_from(RobotConfig::new(1000.0).with_bus(bus.clone())).unwrap();
        // Pipelined mode only needs the exchange to fit in the period.
        let mut pipelined = RobotConfig::new(1100.0).with_bus(bus.clone());
        pipelined.loop_config.reply_mode = ReplyMode::Pipelined;
        Robot::try_from(pipelined).unwrap();
        // A lower bit rate needs a lower rate.
        assert!(Robot::try_from(RobotConfig::new(1000.0).with_bus(bus.bitrate(500_000))).is_err());
    }

    #[test]
    fn ids_beyond_four_get_requests_of_their_own() {
        let mut bus = BusConfig::new("can0");
        for id in [1, 2, 3, 4, 5] {
            bus = bus.with_motor(MotorConfig::new(id));
        }
        // The 0x280 frame for ids 1..=4, an 0xA1 request for id 5.
        let robot = Robot::try_from(RobotConfig::new(100.0).with_bus(bus.clone())).unwrap();
        assert_eq!(robot.buses()[0].exchange, ExchangeKind::MultiTorque);
        assert_eq!(robot.buses()[0].requests_per_exchange(), 2);
        // A per-motor bus: one request each (ids up to 32), when the rate leaves the wire time.
        let per_motor = bus
            .exchange(ExchangeKind::PerMotor)
            .with_motor(MotorConfig::new(32));
        let robot = Robot::try_from(RobotConfig::new(100.0).with_bus(per_motor)).unwrap();
        assert_eq!(robot.buses()[0].exchange, ExchangeKind::PerMotor);
        assert_eq!(robot.buses()[0].requests_per_exchange(), 6);
        assert_eq!(robot.joints()[5].motor.get(), 32);
        // Without an id of 1..=4 there is nothing for a 0x280 frame to do: per-motor.
        let high = BusConfig::new("can0").with_motor(MotorConfig::new(5));
        let robot = Robot::try_from(RobotConfig::new(100.0).with_bus(high)).unwrap();
        assert_eq!(robot.buses()[0].exchange, ExchangeKind::PerMotor);
        // Thirty-two motors on one bus take their wire time: refused at 1 kHz, naming the rate.
        let mut full = BusConfig::new("can0");
        for id in 1..=32 {
            full = full.with_motor(MotorConfig::new(id));
        }
        let err = Robot::try_from(RobotConfig::new(1000.0).with_bus(full)).unwrap_err();
        assert!(
            err.to_string().contains("highest rate this bus can carry"),
            "{err}"
        );
    }

    #[test]
    fn a_v3_bus_exchanges_per_motor_and_refuses_multi_torque() {
        let robot = Robot::try_from(RobotConfig::new(1000.0).with_bus(v3_bus(3))).unwrap();
        let bus = &robot.buses()[0];
        assert_eq!(bus.exchange, ExchangeKind::PerMotor);
        // Three requests outlast the first motor's turnaround: 6 frames of 135 us.
        assert_eq!(bus.exchange_budget(), Duration::from_micros(810));
        let multi = v3_bus(3).exchange(ExchangeKind::MultiTorque);
        match Robot::try_from(RobotConfig::new(1000.0).with_bus(multi)) {
            Err(RobotError::Invalid { key, problem, .. }) => {
                assert_eq!(key, "bus[0].exchange");
                assert!(problem.contains("per-motor"), "{problem}");
            }
            other => panic!("{other:?}"),
        }
        // A bus mixing a v1.61 motor with a V3 one is per-motor too.
        let mixed = BusConfig::new("can0")
            .with_motor(MotorConfig::new(1))
            .with_motor(MotorConfig::new(2).protocol("myactuator-v3", None));
        let robot = Robot::try_from(RobotConfig::new(1000.0).with_bus(mixed)).unwrap();
        assert_eq!(robot.buses()[0].exchange, ExchangeKind::PerMotor);
    }

    #[test]
    fn a_rate_beyond_the_wire_budget_is_refused_naming_the_highest_it_can_carry() {
        // Four V3 motors per-motor at 1 Mbit/s: 4 * 135 + 4 * 135 = 1080 us; the default reply
        // deadline (90% of the period) holds it from 1200 us: 833 Hz.
        let err = Robot::try_from(RobotConfig::new(1000.0).with_bus(v3_bus(4))).unwrap_err();
        let RobotError::Invalid { key, problem, .. } = err else {
            panic!("{err:?}")
        };
        assert_eq!(key, "bus[0]");
        assert!(
            problem.contains("highest rate this bus can carry is 833 Hz"),
            "{problem}"
        );
        assert!(problem.contains("fewer motors"), "{problem}");
        Robot::try_from(RobotConfig::new(833.0).with_bus(v3_bus(4))).unwrap();
        assert!(Robot::try_from(RobotConfig::new(834.0).with_bus(v3_bus(4))).is_err());
        // Pipelined: the period must hold it: 1 / 1080 us = 925.9 Hz.
        let mut pipelined = RobotConfig::new(1000.0).with_bus(v3_bus(4));
        pipelined.loop_config.reply_mode = ReplyMode::Pipelined;
        let err = Robot::try_from(pipelined.clone()).unwrap_err();
        assert!(err.to_string().contains("is 925 Hz"), "{err}");
        pipelined.loop_config.rate_hz = 925.0;
        Robot::try_from(pipelined).unwrap();
        // The highest rate named is always one the check accepts, for every layout.
        for motors in 1..=8u8 {
            for bitrate in [125_000, 500_000, 1_000_000] {
                let bus = v3_bus(motors).bitrate(bitrate);
                let Err(RobotError::Invalid { problem, .. }) =
                    Robot::try_from(RobotConfig::new(5000.0).with_bus(bus.clone()))
                else {
                    panic!("5 kHz accepted");
                };
                let hz: f64 = problem
                    .split("can carry is ")
                    .nth(1)
                    .and_then(|rest| rest.split(' ').next())
                    .and_then(|n| n.parse().ok())
                    .unwrap_or_else(|| panic!("{problem}"));
                Robot::try_from(RobotConfig::new(hz).with_bus(bus.clone())).unwrap();
                assert!(Robot::try_from(RobotConfig::new(hz + 1.0).with_bus(bus)).is_err());
            }
        }
    }
}
