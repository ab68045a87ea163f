//! The subcommands of `rmd`, one module (or folder) each, with its clap `Args` and a `run`
//! function returning the exit code. To add a subcommand: a module here, a variant in
//! [`CliCommand`], a line in [`CliCommand::run`].

mod accel;
mod bench;
mod completions;
pub(crate) mod decode;
mod drill;
mod drive;
mod encode;
mod encoder;
pub(crate) mod examples;
mod log;
mod monitor;
mod motion;
mod pid;
mod power;
mod replay;
mod ros2;
mod scan;
mod sim;
mod status;
mod traj;
mod watchdog;
mod zero;

use std::process::ExitCode;

use clap::Subcommand;

/// The subcommands.
#[derive(Subcommand, Debug)]
pub(crate) enum CliCommand {
    /// Encode one command as a CAN frame, printed as candump's compact `ID#DATA`.
    Encode(encode::EncodeArgs),
    /// Decode frames (candump compact, -L log or default text) into JSON lines.
    Decode(decode::DecodeArgs),
    /// Run simulated motors on a CAN interface (e.g. vcan0), answering as firmware would.
    Sim(sim::SimArgs),
    /// List the motor ids that answer (1..=32), with their status 1.
    Scan(scan::ScanArgs),
    /// Read everything a motor reports: status 1/2/3, encoder, angles.
    Status(status::StatusArgs),
    /// Read or change the PID gains (RAM; --rom asks first).
    Pid(pid::PidArgs),
    /// Read or change the acceleration limit (RAM).
    Accel(accel::AccelArgs),
    /// Read the encoder, or write its offset.
    Encoder(encoder::EncoderArgs),
    /// Write the present position to ROM as the zero (asks first; needs a power cycle).
    Zero(zero::ZeroArgs),
    /// Motor off (0x80): output off, mode forgotten.
    Off(power::PowerArgs),
    /// Motor stop (0x81): output off, mode kept for `rmd run`.
    Stop(power::PowerArgs),
    /// Motor run (0x88): resume after `rmd stop`.
    Run(power::PowerArgs),
    /// A MyActuator V3 motor's communication watchdog (0xB3, ROM; asks first): output off and
    /// brake locked when no frame comes for TIME.
    Watchdog(watchdog::WatchdogArgs),
    /// Move to an angle (position modes 1..=4), within limits; waits until there.
    Move(motion::MoveArgs),
    /// Drive a torque current for a duration, then turn the motor off.
    Torque(drive::TorqueArgs),
    /// Drive a speed for a duration, then turn the motor off.
    Speed(drive::SpeedArgs),
    /// Live table of every motor's temperature, voltage, current, speed and angle.
    Monitor(monitor::MonitorArgs),
    /// Record a CAN interface to a candump -L file.
    Log(log::LogArgs),
    /// Play a candump -L log back in time: printed, or onto an interface or the simulator.
    Replay(replay::ReplayArgs),
    /// Benchmarks: the loop on simulated motors, timer jitter, the bus-limited rate.
    Bench(bench::BenchArgs),
    /// Fault drills on simulated motors, judged by the simulated firmware: is every motor safe?
    Drill(drill::DrillArgs),
    /// A robot as a ROS 2 node over DDS: joint states and diagnostics out, commands, trajectories and estop in.
    Ros2(ros2::Ros2Args),
    /// Trajectory generator tools: `rmd traj check FILE` runs a test-vector file.
    Traj(traj::TrajArgs),
    /// Print the shell completion script (bash, zsh, fish, elvish, powershell).
    Completions(completions::CompletionsArgs),
}

impl CliCommand {
    /// Runs the subcommand.
    pub(crate) fn run(self) -> ExitCode {
        match self {
            CliCommand::Encode(args) => encode::run(args),
            CliCommand::Drill(args) => drill::run(args),
            CliCommand::Decode(args) => decode::run(args),
            CliCommand::Sim(args) => sim::run(args),
            CliCommand::Scan(args) => scan::run(args),
            CliCommand::Status(args) => status::run(args),
            CliCommand::Pid(args) => pid::run(args),
            CliCommand::Accel(args) => accel::run(args),
            CliCommand::Encoder(args) => encoder::run(args),
            CliCommand::Zero(args) => zero::run(args),
            CliCommand::Off(args) => power::run(power::Action::Off, args),
            CliCommand::Stop(args) => power::run(power::Action::Stop, args),
            CliCommand::Run(args) => power::run(power::Action::Run, args),
            CliCommand::Watchdog(args) => watchdog::run(args),
            CliCommand::Move(args) => motion::run(args),
            CliCommand::Torque(args) => drive::run_torque(args),
            CliCommand::Speed(args) => drive::run_speed(args),
            CliCommand::Monitor(args) => monitor::run(args),
            CliCommand::Log(args) => log::run(args),
            CliCommand::Replay(args) => replay::run(args),
            CliCommand::Bench(args) => bench::run(args),
            CliCommand::Ros2(args) => ros2::run(args),
            CliCommand::Traj(args) => traj::run(args),
            CliCommand::Completions(args) => completions::run(args),
        }
    }
}
