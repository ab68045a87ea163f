//! Why a robot could not be opened or run. Every message says what to do; a `main` prints it
//! with `{}` (see [`crate::runner::exit_with_error`]).

/// Why a robot could not be opened or run.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RigError {
    /// The robot description is unusable.
    #[error(transparent)]
    Robot(#[from] rmd_loop::robot::RobotError),
    /// The number of interfaces given by order does not match the robot's buses.
    #[error(
        "the robot has {expected} bus(es) but {given} CAN interface(s) were given: pass one \
         --iface per bus in description order (e.g. --iface can0,can1) or name them \
         (--iface front=can0)"
    )]
    InterfaceCount {
        /// Buses in the description.
        expected: usize,
        /// Interfaces given.
        given: usize,
    },
    /// An interface name in a list was empty.
    #[error("an empty CAN interface name was given (e.g. a trailing comma in --iface can0,)")]
    EmptyInterfaceName,
    /// Both forms of `--iface` in one command line.
    #[error(
        "--iface takes either interfaces in bus order (can0,can1) or BUS=IFACE pairs, not both"
    )]
    MixedInterfaceForms,
    /// `--iface BUS=IFACE` named a bus the robot does not have.
    #[error("--iface names bus `{bus}`, but the robot's buses are: {known}")]
    UnknownBus {
        /// The name given.
        bus: String,
        /// The robot's bus names.
        known: String,
    },
    /// `--sim` together with `--iface`.
    #[error("--sim and --iface contradict each other: choose simulated motors or interfaces")]
    SimAndInterfaces,
    /// Two buses of the robot on one interface.
    #[error(
        "buses {first} and {second} are both on {interface}: one interface carries one bus \
         (its motor ids 1..=4 would collide); give each bus its own interface"
    )]
    SharedInterface {
        /// The interface.
        interface: String,
        /// The first bus on it.
        first: String,
        /// The second bus on it.
        second: String,
    },
    /// Virtual time was asked for real motors.
    #[error(
        "--virtual-time needs simulated motors, but bus {bus} is a real interface (add --sim or \
         drop --iface)"
    )]
    VirtualTimeOnRealBus {
        /// The first real bus.
        bus: String,
    },
    /// The number of simulator configurations does not match the robot description.
    #[error(
        "the robot has {expected} bus(es) but {given} simulated bus configuration(s) were given"
    )]
    SimCount {
        /// Buses in the description.
        expected: usize,
        /// Simulated buses given.
        given: usize,
    },
    /// A simulated bus could not be built.
    #[error("simulated bus {bus}: {source}")]
    Sim {
        /// The bus's name.
        bus: String,
        /// What is wrong with its configuration.
        source: rmd_sim::ConfigError,
    },
    /// A CAN interface could not be opened.
    #[cfg(target_os = "linux")]
    #[error("bus {bus}: {source}")]
    Open {
        /// The bus's name.
        bus: String,
        /// Why (the message says how to fix it).
        source: rmd_bus::socketcan::OpenError,
    },
    /// SocketCAN is only available on Linux.
    #[error("real CAN interfaces need Linux SocketCAN; on this system only the simulator runs")]
    Unsupported,
    /// The signal handler could not be installed.
    #[error("cannot install the Ctrl-C / SIGTERM handler: {0}")]
    Signals(String),
    /// The loop could not be built.
    #[error(transparent)]
    Build(#[from] rmd_loop::BuildError),
    /// The loop thread could not be started.
    #[error(transparent)]
    Spawn(#[from] rmd_loop::SpawnError),
    /// The loop thread died without a report.
    #[error(transparent)]
    ThreadDied(#[from] rmd_loop::LoopThreadDied),
    /// A telemetry file could not be written.
    #[error("cannot write {path}: {source}")]
    Output {
        /// The file.
        path: String,
        /// Why.
        source: std::io::Error,
    },
    /// The telemetry sinks could not start (a file, an address, a thread).
    #[error(transparent)]
    Telemetry(#[from] crate::telemetry::TelemetryError),
    /// A bad command-line value.
    #[error("{0}")]
    Usage(String),
    /// Moving real motors was not confirmed (no Enter, or no terminal and no `--yes`).
    #[error("not started: moving the real motors was not confirmed")]
    NotConfirmed,
}
