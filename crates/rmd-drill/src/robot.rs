//! The drill's robot: `buses` x `motors` RMD-X8-class motors (1:9), each swinging a 1 kg arm
//! 0.2 m long, and the simulated motors' and buses' side of the faults.

use rmd_bus::Timestamp;
use rmd_loop::robot::Robot;
use rmd_loop::robot::{BusConfig, MotorConfig, RobotConfig};
use rmd_protocol::{MotorId, ProtocolFamily, WatchdogTimeout};
use rmd_sim::{BusFault, FaultRule, GravityLink, MotorSet, PhysicalFault, ReplyFault, SimConfig};

use crate::fault::DrillFault;
use crate::spec::DrillSpec;

/// The arm on every joint: at joint 0 (power-up) it points 30 degrees below horizontal, so
/// holding it takes about 0.8 A: every held motor is energised until the drill's fault.
const ARM: GravityLink = GravityLink {
    mass_kg: 1.0,
    length_m: 0.2,
    angle_offset_deg: 60.0,
};

/// Motor 1, where the physical faults strike.
const MOTOR_1: MotorId = match MotorId::new(1) {
    Ok(id) => id,
    Err(_) => panic!("1 is a motor id"),
};

/// The drill's robot description: 1 kHz, one bus per `spec.buses` with motors 1..=`motors`
/// (less an undescribed motor on bus 0).
pub(crate) fn robot(spec: &DrillSpec) -> Result<Robot, rmd_loop::robot::RobotError> {
    let mut config = RobotConfig::new(1000.0);
    for bus in 0..spec.buses {
        let mut bus_config = BusConfig::new("sim");
        bus_config.name = Some(format!("bus{bus}"));
        bus_config.exchange = spec.exchange;
        for id in 1..=spec.motors {
            if bus == 0 && undescribed(spec).is_some_and(|u| u.get() == id) {
                continue;
            }
            bus_config = bus_config.with_motor(motor(id, spec.family_of(id)));
        }
        config = config.with_bus(bus_config);
    }
    Robot::try_from(config)
}

fn motor(id: u8, firmware: ProtocolFamily) -> MotorConfig {
    let mut motor = match firmware {
        ProtocolFamily::LkV23x => MotorConfig::new(id).protocol("lk-v2.3x", Some("mg")),
        ProtocolFamily::MyActuatorV3 => MotorConfig::new(id).protocol("myactuator-v3", None),
        ProtocolFamily::V161 | ProtocolFamily::Unknown => MotorConfig::new(id),
    };
    motor.gear_ratio = Some(9.0);
    motor.encoder_bits = Some(14);
    motor.torque_constant_nm_per_amp = Some(2.09);
    motor.current_limit_amps = 3.0;
    motor.temperature_limit_celsius = Some(70.0);
    // Power-up window -20..20 degrees of joint, centred on the power-up pose (joint 0).
    motor.zero_offset_deg = 20.0;
    motor
}

/// The motor on bus 0 the description leaves out, if the drill has one.
fn undescribed(spec: &DrillSpec) -> Option<MotorId> {
    spec.faults.iter().find_map(|(fault, _)| match fault {
        DrillFault::UnknownMotor(id) => Some(*id),
        _ => None,
    })
}

/// The simulated buses: every described motor powered up at joint 0 under its arm, the
/// undescribed motor on bus 0, and the faults of bus 0 from `start + at`.
pub(crate) fn sims(robot: &Robot, spec: &DrillSpec, start: Timestamp) -> Vec<SimConfig> {
    let mut sims = rmd_rig::sim::sim_configs(robot, spec.seed);
    for sim in &mut sims {
        for motor in &mut sim.motors {
            motor.load.gravity = Some(ARM);
            motor.initial_output_angle_deg = 0.0;
        }
    }
    let first = robot.buses().first().and_then(|bus| bus.joints().next());
    if let (Some(id), Some(first), Some(bus0)) = (undescribed(spec), first, sims.first_mut()) {
        let mut motor = rmd_rig::sim::sim_motor(robot.spec(first));
        motor.id = id;
        motor.load.gravity = Some(ARM);
        bus0.motors.push(motor);
    }
    // The host falls silent on every bus at once, and each V3 motor has the watchdog in ROM.
    for &(fault, at) in &spec.faults {
        if let DrillFault::HostSilent(watchdog) = fault {
            let millis = u32::try_from(watchdog.as_millis()).unwrap_or(u32::MAX);
            for sim in &mut sims {
                for motor in &mut sim.motors {
                    motor.firmware.v3.watchdog = WatchdogTimeout::from_millis(millis);
                }
                sim.faults
                    .push(FaultRule::new(BusFault::HostSilent).first_after(start + at, 1));
            }
        }
    }
    if let Some(bus0) = sims.first_mut() {
        let ids: Vec<MotorId> = bus0.motors.iter().map(|m| m.id).collect();
        let threshold = bus0.motors.first().map_or((80.0, 36.0), |m| {
            (
                m.firmware.over_temperature_threshold_c,
                m.firmware.low_voltage_threshold_v,
            )
        });
        for &(fault, at) in &spec.faults {
            bus0.faults
                .extend(rules(fault, start + at, MotorSet::of(&ids), threshold));
        }
    }
    sims
}

/// The simulator's side of `fault` from `from` on, on a bus with `motors`; `thresholds` are the
/// firmware's over-temperature and low-voltage thresholds.
fn rules(
    fault: DrillFault,
    from: Timestamp,
    motors: MotorSet,
    (hot_c, low_v): (f64, f64),
) -> Vec<FaultRule> {
    let for_ever = Timestamp::from_nanos(u64::MAX);
    let replies = |kind, p: f64| {
        FaultRule::new(kind)
            .motors(motors)
            .during(from, for_ever)
            .with_probability(p)
    };
    match fault {
        DrillFault::BusOff(duration) => {
            vec![FaultRule::new(BusFault::BusOff { duration }).first_after(from, 1)]
        }
        DrillFault::TxStall(duration) => {
            vec![FaultRule::new(BusFault::TxStall { duration }).first_after(from, 1)]
        }
        DrillFault::SilentMotor(id) => vec![
            FaultRule::new(ReplyFault::DropReply)
                .motor(id)
                .during(from, for_ever),
        ],
        DrillFault::Drop(p) => vec![replies(ReplyFault::DropReply, p.get())],
        DrillFault::Late(p, delay) => vec![replies(ReplyFault::LateReply { delay }, p.get())],
        DrillFault::Corrupt(p) => vec![replies(ReplyFault::CorruptBytes { count: 2 }, p.get())],
        DrillFault::Duplicate(p) => vec![replies(ReplyFault::DuplicateReply, p.get())],
        DrillFault::WrongDlc(p) => vec![replies(ReplyFault::WrongDlc { dlc: 5 }, p.get())],
        DrillFault::OverTemperature => vec![
            FaultRule::new(PhysicalFault::OverTemperature {
                celsius: hot_c + 10.0,
            })
            .motor(MOTOR_1)
            .during(from, for_ever),
        ],
        DrillFault::LowVoltage => vec![
            FaultRule::new(PhysicalFault::LowVoltage {
                volts: (low_v - 6.0).max(0.0),
            })
            .motor(MOTOR_1)
            .during(from, for_ever),
        ],
        // Not bus 0's simulator: the controller's, the operator's, the description's
        // (`undescribed`) and every bus's (`sims`).
        DrillFault::ControllerHang(_)
        | DrillFault::ControllerPanic
        | DrillFault::NanCommand
        | DrillFault::SlowController(_)
        | DrillFault::Estop
        | DrillFault::Stop
        | DrillFault::UnknownMotor(_)
        | DrillFault::HostSilent(_) => Vec::new(),
    }
}
