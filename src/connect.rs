//! Connecting a robot description to its motors: simulated motors that match the description
//! (in real or virtual time), or real SocketCAN interfaces; and stopping a run on Ctrl-C.
//!
//! Every example and most programs start the same way: decide where the motors are (a
//! [`Target`], usually from the command line: `--iface can0` or the simulator), [`open`] one bus
//! per bus of the [`RobotConfig`], build the [`RtLoop`](crate::RtLoop) on the connection's clock
//! and buses, and make Ctrl-C stop it safely ([`stop_on_ctrl_c`]).
//!
//! ```
//! use rmd_rt::connect::{self, SimTime, Target};
//! use rmd_rt::{BusConfig, Commands, Controller, Feedback, Flow, MotorConfig, RobotConfig};
//! use rmd_rt::{RtLoop, RunLimit, TickContext};
//!
//! struct Idle;
//! impl Controller for Idle {
//!     fn update(&mut self, _: &TickContext, _: &Feedback<'_>, _: &mut Commands<'_>) -> Flow {
//!         Flow::Continue
//!     }
//! }
//!
//! let robot = RobotConfig::new(1000.0)
//!     .with_bus(BusConfig::new("can0").with_motor(MotorConfig::new(1).gear_ratio(9.0)));
//! // `--iface can0` would be `Target::from_args(&["can0".into()], false)?`.
//! let target = Target::Simulator(SimTime::Virtual);
//! let sims = connect::sim_configs(&robot, 7);
//! let connection = connect::open(&target, &robot, sims)?;
//! let rt = RtLoop::new(robot, connection.clock, connection.buses, Idle)?;
//! let outcome = rt.run(RunLimit::Ticks(100));
//! assert_eq!(outcome.report.stats.ticks, 100);
//! assert!(outcome.report.safe_stop.all_off_confirmed());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! # Simulated motors that match the description
//!
//! [`sim_motor`] builds a simulated motor with the description's gear ratio, torque constant and
//! encoder width, and mounts its encoder so that the loop's joint angle is the simulated joint's
//! true angle. That holds, as on a real geared motor, only when the joint powers up inside its
//! [`power_up_window`]: the loop sees one motor turn of the single-turn encoder at start-up,
//! which is `360 / gear_ratio` degrees of joint (40 degrees with a 1:9 gearbox), starting at
//! `-zero_offset_deg`. A robot description sets each `zero_offset_deg` so that the joint's
//! power-up pose lies in that window (see `docs/getting-started.md`, "Homing a geared joint").

use core::fmt;
use std::sync::{Mutex, OnceLock, PoisonError};

use rmd_bus::{BusError, CanBus, Clock, MonotonicClock, Received, Timestamp, VirtualClock};
use rmd_loop::Stopper;
use rmd_loop::config::{BusConfig, Direction, MotorConfig, RobotConfig};
use rmd_protocol::CanFrame;
use rmd_sim::{SimBus, SimConfig, WireTiming};

/// Whether simulated motors run in real time or in virtual time.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum SimTime {
    /// Real time ([`MonotonicClock`]): a run takes as long as it would on real motors.
    Real,
    /// Virtual time ([`VirtualClock`]): deterministic and as fast as the CPU allows.
    Virtual,
}

/// Where the motors of a run are.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Target {
    /// Simulated motors, one simulated bus per bus of the robot description.
    Simulator(SimTime),
    /// Real CAN interfaces, one per bus of the robot description, in its order.
    SocketCan(Vec<String>),
}

impl Target {
    /// The target of the usual command-line options: `--iface NAME` (repeatable, or a
    /// comma-separated list) for real interfaces, none for the simulator; `--virtual-time` only
    /// with the simulator.
    ///
    /// ```
    /// use rmd_rt::connect::{SimTime, Target};
    /// assert_eq!(Target::from_args(&[], false)?, Target::Simulator(SimTime::Real));
    /// assert_eq!(Target::from_args(&[], true)?, Target::Simulator(SimTime::Virtual));
    /// let four = Target::from_args(&["can0,can1".into(), "can2".into(), "can3".into()], false)?;
    /// assert_eq!(four, Target::SocketCan(vec!["can0".into(), "can1".into(), "can2".into(), "can3".into()]));
    /// assert!(Target::from_args(&["can0".into()], true).is_err());
    /// # Ok::<(), rmd_rt::connect::ConnectError>(())
    /// ```
    pub fn from_args(ifaces: &[String], virtual_time: bool) -> Result<Self, ConnectError> {
        let names: Vec<String> = ifaces
            .iter()
            .flat_map(|arg| arg.split(','))
            .map(|name| name.trim().to_string())
            .collect();
        if names.is_empty() {
            return Ok(Target::Simulator(if virtual_time {
                SimTime::Virtual
            } else {
                SimTime::Real
            }));
        }
        if names.iter().any(String::is_empty) {
            return Err(ConnectError::EmptyInterfaceName);
        }
        if virtual_time {
            return Err(ConnectError::VirtualTimeOnRealBus);
        }
        Ok(Target::SocketCan(names))
    }

    /// Whether the motors are simulated.
    pub fn is_simulated(&self) -> bool {
        matches!(self, Target::Simulator(_))
    }

    /// Whether the run is in virtual time.
    pub fn is_virtual_time(&self) -> bool {
        *self == Target::Simulator(SimTime::Virtual)
    }
}

impl fmt::Display for Target {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Target::Simulator(SimTime::Real) => f.write_str("simulated motors, real time"),
            Target::Simulator(SimTime::Virtual) => f.write_str("simulated motors, virtual time"),
            Target::SocketCan(names) => write!(f, "SocketCAN {}", names.join(", ")),
        }
    }
}

/// Why a connection could not be made.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ConnectError {
    /// The number of interfaces does not match the robot description.
    #[error(
        "the robot has {expected} bus(es) but {given} CAN interface(s) were given: pass one \
         --iface per bus (e.g. --iface can0,can1)"
    )]
    InterfaceCount {
        /// Buses in the robot description.
        expected: usize,
        /// Interfaces given.
        given: usize,
    },
    /// An interface name in a list was empty.
    #[error("an empty CAN interface name was given (e.g. a trailing comma in --iface can0,)")]
    EmptyInterfaceName,
    /// Virtual time was asked for real motors.
    #[error("--virtual-time needs the simulator: real motors run in real time (drop --iface)")]
    VirtualTimeOnRealBus,
    /// The number of simulator configurations does not match the robot description.
    #[error(
        "the robot has {expected} bus(es) but {given} simulated bus configuration(s) were given"
    )]
    SimCount {
        /// Buses in the robot description.
        expected: usize,
        /// Simulated buses given.
        given: usize,
    },
    /// A simulated bus could not be built.
    #[error("simulated bus {bus}: {source}")]
    Sim {
        /// Bus index.
        bus: usize,
        /// What is wrong with its configuration.
        source: rmd_sim::ConfigError,
    },
    /// A CAN interface could not be opened.
    #[cfg(target_os = "linux")]
    #[error("bus {bus}: {source}")]
    Open {
        /// Bus index.
        bus: usize,
        /// Why (the message says how to fix it).
        source: rmd_bus::socketcan::OpenError,
    },
    /// SocketCAN is only available on Linux.
    #[error("real CAN interfaces need Linux SocketCAN; on this system only the simulator runs")]
    Unsupported,
    /// The Ctrl-C handler could not be installed.
    #[error("cannot install the Ctrl-C handler: {0}")]
    CtrlC(String),
}

/// The clock of a connection: virtual for simulated motors in virtual time, the system's
/// monotonic clock otherwise.
#[derive(Clone, Debug)]
pub enum AnyClock {
    /// Virtual time.
    Virtual(VirtualClock),
    /// Real time.
    Monotonic(MonotonicClock),
}

impl Clock for AnyClock {
    fn now(&self) -> Timestamp {
        match self {
            AnyClock::Virtual(c) => c.now(),
            AnyClock::Monotonic(c) => c.now(),
        }
    }

    fn sleep_until(&self, deadline: Timestamp) {
        match self {
            AnyClock::Virtual(c) => c.sleep_until(deadline),
            AnyClock::Monotonic(c) => c.sleep_until(deadline),
        }
    }

    fn spin_until(&self, deadline: Timestamp) {
        match self {
            AnyClock::Virtual(c) => c.spin_until(deadline),
            AnyClock::Monotonic(c) => c.spin_until(deadline),
        }
    }
}

/// One bus of a connection: simulated motors or a SocketCAN interface.
#[derive(Debug)]
pub enum AnyBus {
    /// Simulated motors.
    Sim(Box<SimBus<AnyClock>>),
    /// A real (or virtual) CAN interface.
    #[cfg(target_os = "linux")]
    SocketCan(Box<rmd_bus::socketcan::SocketCanBus>),
}

impl AnyBus {
    /// The simulated bus, if this is one (to look at the simulated motors).
    pub fn as_sim_mut(&mut self) -> Option<&mut SimBus<AnyClock>> {
        match self {
            AnyBus::Sim(bus) => Some(bus),
            #[cfg(target_os = "linux")]
            AnyBus::SocketCan(_) => None,
        }
    }
}

impl CanBus for AnyBus {
    fn send(&mut self, frame: &CanFrame) -> Result<(), BusError> {
        match self {
            AnyBus::Sim(bus) => bus.send(frame),
            #[cfg(target_os = "linux")]
            AnyBus::SocketCan(bus) => bus.send(frame),
        }
    }

    fn recv_until(&mut self, deadline: Timestamp) -> Result<Option<Received>, BusError> {
        match self {
            AnyBus::Sim(bus) => bus.recv_until(deadline),
            #[cfg(target_os = "linux")]
            AnyBus::SocketCan(bus) => bus.recv_until(deadline),
        }
    }
}

/// The buses of a robot and the clock they run on, ready for
/// [`RtLoop::new`](crate::RtLoop::new).
#[derive(Debug)]
pub struct Connection {
    /// The clock.
    pub clock: AnyClock,
    /// One bus per bus of the robot description, in its order.
    pub buses: Vec<AnyBus>,
}

/// Opens one bus per bus of `robot` on `target`: the simulated buses described by `sims` (one
/// per bus, usually from [`sim_configs`] plus the robot's loads), or the SocketCAN interfaces
/// the target names (then `sims` is not used).
pub fn open(
    target: &Target,
    robot: &RobotConfig,
    sims: Vec<SimConfig>,
) -> Result<Connection, ConnectError> {
    match target {
        Target::Simulator(time) => {
            let clock = match time {
                SimTime::Real => AnyClock::Monotonic(MonotonicClock),
                SimTime::Virtual => AnyClock::Virtual(VirtualClock::new()),
            };
            if sims.len() != robot.buses.len() {
                return Err(ConnectError::SimCount {
                    expected: robot.buses.len(),
                    given: sims.len(),
                });
            }
            let buses = sim_buses(&clock, sims)?
                .into_iter()
                .map(|bus| AnyBus::Sim(Box::new(bus)))
                .collect();
            Ok(Connection { clock, buses })
        }
        Target::SocketCan(names) => {
            if names.len() != robot.buses.len() {
                return Err(ConnectError::InterfaceCount {
                    expected: robot.buses.len(),
                    given: names.len(),
                });
            }
            open_socketcan(names)
        }
    }
}

#[cfg(target_os = "linux")]
fn open_socketcan(names: &[String]) -> Result<Connection, ConnectError> {
    use rmd_bus::socketcan::{SocketCanBus, SocketCanOptions};
    let options = SocketCanOptions::new();
    let buses = names
        .iter()
        .enumerate()
        .map(|(bus, name)| {
            SocketCanBus::open(name, &options)
                .map(|bus| AnyBus::SocketCan(Box::new(bus)))
                .map_err(|source| ConnectError::Open { bus, source })
        })
        .collect::<Result<_, _>>()?;
    Ok(Connection {
        clock: AnyClock::Monotonic(MonotonicClock),
        buses,
    })
}

#[cfg(not(target_os = "linux"))]
fn open_socketcan(_names: &[String]) -> Result<Connection, ConnectError> {
    Err(ConnectError::Unsupported)
}

/// Builds one simulated bus per configuration, all on `clock` (clones of one clock share one
/// time line). Tests use it to keep the buses and look at the simulated motors after a run.
pub fn sim_buses<C: Clock + Clone>(
    clock: &C,
    sims: Vec<SimConfig>,
) -> Result<Vec<SimBus<C>>, ConnectError> {
    sims.into_iter()
        .enumerate()
        .map(|(bus, config)| {
            SimBus::new(clock.clone(), config).map_err(|source| ConnectError::Sim { bus, source })
        })
        .collect()
}

/// Simulated buses matching every bus of `robot` ([`sim_config`]), seeded `seed`, `seed + 1`, ...
pub fn sim_configs(robot: &RobotConfig, seed: u64) -> Vec<SimConfig> {
    robot
        .buses
        .iter()
        .zip(seed..)
        .map(|(bus, seed)| sim_config(bus, seed))
        .collect()
}

/// A simulated bus matching `bus`: its bit rate, and a [`sim_motor`] for each of its motors,
/// with no load (add the robot's loads and power-up pose to the returned motors).
pub fn sim_config(bus: &BusConfig, seed: u64) -> SimConfig {
    let mut config = SimConfig::with_motors(0).seed(seed);
    config.bus.timing = WireTiming::Bitrate(bus.bitrate);
    config.motors = bus.motors.iter().map(sim_motor).collect();
    config
}

/// A simulated motor matching `motor` (RMD-X8-class defaults for everything the description
/// does not say): same id, gear ratio, encoder width and, when given, output torque constant;
/// its encoder mounted so that the loop reads the joint's true angle whenever the joint powers
/// up inside its [`power_up_window`]. The simulated output angle is
/// `direction * joint angle` (see [`sim_output_angle_deg`]).
///
/// ```
/// use rmd_rt::MotorConfig;
/// let knee = MotorConfig::new(3).gear_ratio(9.0).torque_constant(2.09).zero_offset_deg(110.0);
/// let sim = rmd_rt::connect::sim_motor(&knee);
/// assert_eq!(sim.id.get(), 3);
/// assert_eq!(sim.motor.gear_ratio, 9.0);
/// assert!((sim.motor.torque_constant_nm_per_a * 9.0 - 2.09).abs() < 1e-12);
/// ```
pub fn sim_motor(motor: &MotorConfig) -> rmd_sim::MotorConfig {
    let mut sim = rmd_sim::MotorConfig::new(motor.motor_id());
    sim.motor.gear_ratio = motor.gear_ratio;
    if let Some(kt) = motor.torque_constant_nm_per_amp {
        sim.motor.torque_constant_nm_per_a = kt / motor.gear_ratio;
    }
    sim.firmware.encoder_width = motor.encoder_width();
    // The loop reads joint = s * m / G - z from the first reading m in [0, 360) degrees of
    // motor; the simulated encoder reads (G * output + 360 * offset) mod 360. With
    // offset = s * z * G / 360 the two agree (joint = s * output) as long as the first reading
    // did not wrap, i.e. inside the power-up window.
    let turns = motor.direction.sign() * motor.zero_offset_deg * motor.gear_ratio / 360.0;
    sim.motor.encoder_mount_offset_turns = turns.rem_euclid(1.0);
    sim
}

/// The simulated output angle (degrees) at which a [`sim_motor`] of `motor` shows `joint_deg`
/// to the loop: `direction * joint_deg` (for a simulated motor's `initial_output_angle_deg`,
/// and for its gravity link's angle).
pub fn sim_output_angle_deg(motor: &MotorConfig, joint_deg: f64) -> f64 {
    motor.direction.sign() * joint_deg
}

/// The joint angles (degrees, `[low, high)`) in which a geared joint must be at power-up for the
/// loop to read its angle right: one motor turn of the single-turn encoder, starting where the
/// encoder reads zero, `-zero_offset_deg` (for a reversed joint the window extends below it).
///
/// ```
/// use rmd_rt::MotorConfig;
/// use rmd_rt::rt::config::Direction;
/// let hip = MotorConfig::new(2).gear_ratio(9.0).zero_offset_deg(-30.0);
/// assert_eq!(rmd_rt::connect::power_up_window(&hip), (30.0, 70.0));
/// let reversed = hip.clone().direction(Direction::Reversed);
/// assert_eq!(rmd_rt::connect::power_up_window(&reversed), (-10.0, 30.0));
/// ```
pub fn power_up_window(motor: &MotorConfig) -> (f64, f64) {
    let width = 360.0 / motor.gear_ratio;
    let start = -motor.zero_offset_deg;
    match motor.direction {
        Direction::Normal => (start, start + width),
        Direction::Reversed => (start - width, start),
    }
}

/// The `zero_offset_deg` that centres a joint's [`power_up_window`] on `joint_deg`, for a joint
/// whose encoder reads zero at `encoder_zero_joint_deg` (on a simulated motor made by
/// [`sim_motor`], the offset alone decides where the encoder reads zero, so any value works).
///
/// On a real motor, read the encoder (e.g. `rmd status ID`) with the joint at a known angle and
/// compute the offset from that: see `docs/getting-started.md`.
pub fn centred_zero_offset_deg(gear_ratio: f64, direction: Direction, joint_deg: f64) -> f64 {
    let half = 180.0 / gear_ratio;
    match direction {
        Direction::Normal => -(joint_deg - half),
        Direction::Reversed => -(joint_deg + half),
    }
}

/// The loop that Ctrl-C stops, and how many interrupts it has seen.
static CTRL_C: Mutex<CtrlCState> = Mutex::new(CtrlCState {
    stopper: None,
    interrupts: 0,
});
/// Whether the process-wide handler is installed (or why it could not be).
static HANDLER: OnceLock<Result<(), String>> = OnceLock::new();

#[derive(Debug)]
struct CtrlCState {
    stopper: Option<Stopper>,
    interrupts: u32,
}

/// Makes Ctrl-C (and SIGTERM, SIGHUP) stop the loop that `stopper` belongs to: the first
/// interrupt asks it to stop (it sends zero torque and motor-off to every motor, then reports),
/// the second is an emergency stop, the third exits the process at once (status 130).
///
/// The handler is installed once per process, the first time this is called; later calls make
/// it stop another loop (e.g. the next run of a program that runs several in turn) and reset the
/// count. Fails with [`ConnectError::CtrlC`] if another handler was installed by other means.
pub fn stop_on_ctrl_c(stopper: Stopper) -> Result<(), ConnectError> {
    {
        let mut state = CTRL_C.lock().unwrap_or_else(PoisonError::into_inner);
        state.stopper = Some(stopper);
        state.interrupts = 0;
    }
    HANDLER
        .get_or_init(|| ctrlc::set_handler(on_interrupt).map_err(|e| e.to_string()))
        .clone()
        .map_err(ConnectError::CtrlC)
}

/// Runs on the `ctrlc` crate's handler thread (an ordinary thread, not a signal context).
fn on_interrupt() {
    let mut state = CTRL_C.lock().unwrap_or_else(PoisonError::into_inner);
    state.interrupts += 1;
    match (state.interrupts, &state.stopper) {
        (1, Some(stopper)) => {
            eprintln!(
                "\ninterrupted: stopping (zero torque, then motor off); again for an emergency stop"
            );
            stopper.stop();
        }
        (2, Some(stopper)) => {
            eprintln!("\ninterrupted again: EMERGENCY STOP");
            stopper.emergency_stop();
        }
        _ => std::process::exit(130),
    }
}

/// How many interrupts (Ctrl-C, SIGTERM, SIGHUP) the loop registered by the last
/// [`stop_on_ctrl_c`] has seen.
pub fn interrupts() -> u32 {
    CTRL_C
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .interrupts
}

#[cfg(test)]
mod tests {
    use super::*;
    use rmd_loop::{Commands, Controller, Feedback, Flow, RtLoop, RunLimit, TickContext};
    use rmd_sim::ControlMode;

    /// Holds every joint at its start angle and remembers the first feedback.
    struct Hold {
        first: Vec<f64>,
    }

    impl Controller for Hold {
        fn start(&mut self, _: &TickContext, fb: &Feedback<'_>) {
            self.first = fb.iter().map(|m| m.joint_angle_deg).collect();
        }
        fn update(&mut self, _: &TickContext, fb: &Feedback<'_>, cmd: &mut Commands<'_>) -> Flow {
            for (i, m) in fb.iter().enumerate() {
                let _ = cmd.set_current(
                    i,
                    0.5 * (self.first[i] - m.joint_angle_deg) - 0.02 * m.joint_velocity_dps,
                );
            }
            Flow::Continue
        }
    }

    fn leg(directions: [Direction; 2]) -> RobotConfig {
        let mut bus = BusConfig::new("can0");
        for (i, d) in directions.into_iter().enumerate() {
            bus = bus.with_motor(
                MotorConfig::new(i as u8 + 1)
                    .gear_ratio(9.0)
                    .torque_constant(2.09)
                    .direction(d)
                    .zero_offset_deg(centred_zero_offset_deg(9.0, d, -75.0)),
            );
        }
        RobotConfig::new(1000.0).with_bus(bus)
    }

    #[test]
    fn targets_from_arguments() {
        assert_eq!(
            Target::from_args(&["can0".into()], false).unwrap(),
            Target::SocketCan(vec!["can0".into()])
        );
        assert!(matches!(
            Target::from_args(&["can0,".into()], false),
            Err(ConnectError::EmptyInterfaceName)
        ));
        assert!(Target::from_args(&[], true).unwrap().is_virtual_time());
        assert!(!Target::from_args(&[], false).unwrap().is_virtual_time());
        assert_eq!(
            Target::SocketCan(vec!["can0".into(), "can1".into()]).to_string(),
            "SocketCAN can0, can1"
        );
    }

    #[test]
    fn counts_must_match_the_description() {
        let robot = leg([Direction::Normal; 2]);
        let err = open(
            &Target::SocketCan(vec!["can0".into(), "can1".into()]),
            &robot,
            Vec::new(),
        )
        .unwrap_err();
        assert!(matches!(
            err,
            ConnectError::InterfaceCount {
                expected: 1,
                given: 2
            }
        ));
        assert!(err.to_string().contains("--iface"));
        let err = open(&Target::Simulator(SimTime::Virtual), &robot, Vec::new()).unwrap_err();
        assert!(matches!(
            err,
            ConnectError::SimCount {
                expected: 1,
                given: 0
            }
        ));
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn a_missing_interface_is_a_typed_error_naming_the_bus() {
        let robot = leg([Direction::Normal; 2]);
        let err = open(
            &Target::SocketCan(vec!["rmdnosuch0".into()]),
            &robot,
            Vec::new(),
        )
        .unwrap_err();
        assert!(matches!(err, ConnectError::Open { bus: 0, .. }), "{err}");
    }

    #[test]
    fn a_bad_simulated_motor_is_a_typed_error_naming_the_bus() {
        let robot = leg([Direction::Normal; 2]);
        let mut sims = sim_configs(&robot, 1);
        sims[0].motors[1].load.output_inertia_kg_m2 = -1.0;
        let err = open(&Target::Simulator(SimTime::Virtual), &robot, sims).unwrap_err();
        assert!(matches!(err, ConnectError::Sim { bus: 0, .. }), "{err}");
    }

    #[test]
    fn power_up_windows() {
        for d in [Direction::Normal, Direction::Reversed] {
            let m = MotorConfig::new(1)
                .gear_ratio(6.0)
                .direction(d)
                .zero_offset_deg(centred_zero_offset_deg(6.0, d, 12.0));
            let (low, high) = power_up_window(&m);
            assert!((high - low - 60.0).abs() < 1e-9);
            assert!(
                ((low + high) / 2.0 - 12.0).abs() < 1e-9,
                "{d:?}: {low}..{high}"
            );
        }
    }

    /// The loop reads the simulated joint's true angle when it powers up inside its window,
    /// for either direction, several motor turns away from the encoder's zero; outside it, it
    /// is off by whole motor turns (which is why geared joints are homed).
    #[test]
    fn simulated_joints_read_their_true_angle_inside_the_power_up_window() {
        for (start, inside) in [(-75.0, true), (-90.0, true), (-60.0, true), (-100.0, false)] {
            let robot = leg([Direction::Normal, Direction::Reversed]);
            let mut sims = sim_configs(&robot, 3);
            for (m, motor) in sims[0].motors.iter_mut().zip(&robot.buses[0].motors) {
                m.initial_output_angle_deg = sim_output_angle_deg(motor, start);
            }
            let clock = VirtualClock::new();
            let mut buses = sim_buses(&clock, sims).unwrap();
            let rt = RtLoop::new(
                robot,
                clock.clone(),
                buses.iter_mut().collect(),
                Hold { first: Vec::new() },
            )
            .unwrap();
            let out = rt.run(RunLimit::Ticks(200));
            assert!(out.report.normal_stop, "{}", out.report);
            for (i, read) in out.controller.first.iter().enumerate() {
                if inside {
                    assert!(
                        (read - start).abs() < 0.05,
                        "motor {i}: read {read}, true {start}"
                    );
                } else {
                    let turns = (read - start) / 40.0;
                    assert!(
                        (turns.round() - turns).abs() < 0.01 && turns.round() != 0.0,
                        "{read}"
                    );
                }
            }
            // Held where it started, and off at the end.
            for (i, motor) in robot_directions().iter().enumerate() {
                let id = rmd_protocol::MotorId::new(i as u8 + 1).unwrap();
                let snap = buses[0].snapshot(id).unwrap();
                assert_eq!(snap.mode, ControlMode::Off);
                assert!(
                    (snap.output_angle_deg - motor * start).abs() < 0.5,
                    "{snap:?}"
                );
            }
        }
    }

    fn robot_directions() -> [f64; 2] {
        [Direction::Normal.sign(), Direction::Reversed.sign()]
    }

    #[test]
    fn open_builds_working_simulated_buses_on_the_chosen_clock() {
        let robot = leg([Direction::Normal; 2]);
        for time in [SimTime::Virtual, SimTime::Real] {
            let target = Target::Simulator(time);
            let mut c = open(&target, &robot, sim_configs(&robot, 1)).unwrap();
            assert_eq!(c.buses.len(), 1);
            assert!(c.buses[0].as_sim_mut().is_some());
            assert_eq!(
                matches!(c.clock, AnyClock::Virtual(_)),
                time == SimTime::Virtual
            );
            let rt =
                RtLoop::new(robot.clone(), c.clock, c.buses, Hold { first: Vec::new() }).unwrap();
            let out = rt.run(RunLimit::Ticks(50));
            assert_eq!(out.report.stats.ticks, 50);
            assert!(out.report.safe_stop.all_off_confirmed());
        }
    }
}
