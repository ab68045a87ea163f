//! `rmd`: the command-line tool of rmd-rt.
//!
//! `main` only parses the command line and dispatches; each subcommand group lives in its own
//! module (`encode`, `decode`, ...) with its clap `Args` and a `run` function returning the exit
//! code. To add a subcommand: a module, a variant in [`Command`], a line in `main`.
//!
//! Shared by the live-bus commands: [`connect`] (`--iface`/`--sim` to a bus, `--log`),
//! [`exchange`] (one request, one reply: timeout, retries, typed errors), [`interrupt`]
//! (Ctrl-C), [`safe_stop`] (motors off when a motion ends), [`confirm`] (ROM writes).

mod accel;
mod bench;
mod confirm;
mod connect;
mod decode;
mod drive;
mod encode;
mod encoder_cmd;
mod exchange;
mod ids;
mod interrupt;
mod json;
mod log;
mod monitor;
mod move_cmd;
mod pairing;
mod parse;
mod pid;
mod power;
mod readings;
mod replay;
mod report;
mod safe_stop;
mod scan;
mod sim;
mod status;
mod traj;
mod zero;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// Tools for GYEMS / MyActuator RMD servo motors on CAN.
///
/// Commands that talk to motors take `--iface IFACE` (a SocketCAN interface such as can0) or
/// `--sim` (simulated motors in this process). Commands that move a motor turn it off when
/// they end and on Ctrl-C.
#[derive(Parser, Debug)]
#[command(name = "rmd", version, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
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
    Encoder(encoder_cmd::EncoderArgs),
    /// Write the present position to ROM as the zero (asks first; needs a power cycle).
    Zero(zero::ZeroArgs),
    /// Motor off (0x80): output off, mode forgotten.
    Off(power::PowerArgs),
    /// Motor stop (0x81): output off, mode kept for `rmd run`.
    Stop(power::PowerArgs),
    /// Motor run (0x88): resume after `rmd stop`.
    Run(power::PowerArgs),
    /// Move to an angle (position modes 1..=4), within limits; waits until there.
    Move(move_cmd::MoveArgs),
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
    /// Trajectory generator tools: `rmd traj check FILE` runs a test-vector file.
    Traj(traj::TrajArgs),
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(err) => return report::clap_error(err),
    };
    match cli.command {
        Command::Encode(args) => encode::run(args),
        Command::Decode(args) => decode::run(args),
        Command::Sim(args) => sim::run(args),
        Command::Scan(args) => scan::run(args),
        Command::Status(args) => status::run(args),
        Command::Pid(args) => pid::run(args),
        Command::Accel(args) => accel::run(args),
        Command::Encoder(args) => encoder_cmd::run(args),
        Command::Zero(args) => zero::run(args),
        Command::Off(args) => power::run(power::Action::Off, args),
        Command::Stop(args) => power::run(power::Action::Stop, args),
        Command::Run(args) => power::run(power::Action::Run, args),
        Command::Move(args) => move_cmd::run(args),
        Command::Torque(args) => drive::run_torque(args),
        Command::Speed(args) => drive::run_speed(args),
        Command::Monitor(args) => monitor::run(args),
        Command::Log(args) => log::run(args),
        Command::Replay(args) => replay::run(args),
        Command::Bench(args) => bench::run(args),
        Command::Traj(args) => traj::run(args),
    }
}
