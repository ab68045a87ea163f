//! The standard command-line flags of every program that runs the loop (the examples, `rmd
//! bench`, `rmd drill`, ...): one vocabulary, flattened into each program's own clap arguments.
//!
//! ```
//! use clap::Parser;
//! use rmd_rig::args::{LoopArgs, OutputArgs, RobotArgs};
//!
//! #[derive(Parser)]
//! struct Args {
//!     #[command(flatten)]
//!     robot: RobotArgs,
//!     #[command(flatten)]
//!     run: LoopArgs,
//!     #[command(flatten)]
//!     output: OutputArgs,
//! }
//! let args = Args::parse_from(["leg", "--iface", "can0", "--duration", "1500ms", "--fifo", "80", "--stall-bound", "200ms"]);
//! assert_eq!(args.robot.iface, ["can0"]);
//! assert_eq!(args.run.duration, Some(std::time::Duration::from_millis(1500)));
//! assert_eq!(args.run.stall_bound, Some(std::time::Duration::from_millis(200)));
//! assert_eq!(args.run.realtime.fifo, Some(80));
//! // Seconds without a unit, and the examples' older spelling, work too.
//! let args = Args::parse_from(["leg", "--seconds", "2.5", "--fifo-priority", "70", "--rate-hz", "500"]);
//! assert_eq!(args.run.duration, Some(std::time::Duration::from_millis(2500)));
//! assert_eq!(args.run.rate, Some(500.0));
//! ```

pub mod duration;
mod telemetry;
pub mod values;

pub use telemetry::{MAX_LIVE_CLIENTS, TelemetryArgs, live_addr, live_clients, live_rate};

use core::time::Duration;
use std::io::{BufRead, IsTerminal, Write};
use std::path::PathBuf;

use rmd_loop::os::{CpuLatencyRequest, RtRequest};
use rmd_loop::robot::{CpuLatencySetting, RobotConfig, read_config};
use rmd_loop::{RunLimit, robot::Robot};

use crate::error::RigError;
use crate::placement::{Overrides, Placement, PlacementDefault};
use crate::runner::progress::Display;

/// Where the robot is: its description and its buses.
#[derive(clap::Args, Debug, Clone, Default, PartialEq, Eq)]
pub struct RobotArgs {
    /// Robot description file (TOML), replacing the program's own (see examples/robots/).
    #[arg(long, value_name = "FILE")]
    pub robot: Option<PathBuf>,
    /// Simulated motors matching the description, on every bus.
    #[arg(long, conflicts_with = "iface")]
    pub sim: bool,
    /// CAN interface of each bus: in bus order (`can0,can1`) or by bus name (`front=can0`);
    /// repeatable. Without it: the description's interfaces (the examples: simulated motors).
    #[arg(long = "iface", value_name = "[BUS=]IFACE")]
    pub iface: Vec<String>,
    /// Run simulated motors in virtual time: deterministic, as fast as the CPU allows.
    #[arg(long)]
    pub virtual_time: bool,
    /// Seed of the simulated motors (turnaround jitter, faults).
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub seed: u64,
    /// Do not ask for confirmation before moving real motors.
    #[arg(long, short)]
    pub yes: bool,
}

impl RobotArgs {
    /// The robot description: `--robot FILE`, or `default_toml` (the program's own, usually
    /// `include_str!` of a file in examples/robots/). Parsed only: apply [`LoopArgs`] and
    /// build the [`Robot`] with `Robot::try_from`.
    pub fn description(&self, default_toml: &str) -> Result<RobotConfig, RigError> {
        Ok(match &self.robot {
            Some(path) => read_config(path)?,
            None => RobotConfig::from_toml(default_toml)?,
        })
    }

    /// What the flags say about where the motors are.
    pub fn overrides(&self) -> Overrides {
        Overrides {
            simulate: self.sim,
            interfaces: self.iface.clone(),
            virtual_time: self.virtual_time,
        }
    }

    /// Where every bus of `robot` is for this run.
    pub fn placement(
        &self,
        robot: &Robot,
        default: PlacementDefault,
    ) -> Result<Placement, RigError> {
        Placement::resolve(robot, &self.overrides(), default)
    }

    /// With real motors, says what is about to move and waits for Enter (unless `--yes`);
    /// returns whether to go on. With simulated motors, always goes on. Without a terminal to
    /// ask on, refuses (use `--yes`).
    pub fn confirm_motion(&self, placement: &Placement, what: &str) -> bool {
        if !placement.has_real_motors() || self.yes {
            return true;
        }
        let mut err = std::io::stderr();
        let _ = writeln!(err, "REAL MOTORS on {placement}: {what}");
        if !std::io::stdin().is_terminal() {
            let _ = writeln!(
                err,
                "no terminal to confirm on: add --yes to move real motors without asking"
            );
            return false;
        }
        let _ = writeln!(
            err,
            "Make sure nothing and nobody is in the way. Ctrl-C stops the motors at any time."
        );
        let _ = write!(err, "Press Enter to start (or Ctrl-C to quit): ");
        let _ = err.flush();
        let mut line = String::new();
        matches!(std::io::stdin().lock().read_line(&mut line), Ok(n) if n > 0)
    }
}

/// The real-time setup of the thread that runs: `--cpu`, `--fifo`, `--lock-memory`,
/// `--spin-us`, `--cpu-dma-latency`.
#[derive(clap::Args, Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RealtimeArgs {
    /// Pin the loop thread to this CPU (ideally an isolated one: see docs/realtime.md).
    #[arg(long, value_name = "CPU", value_parser = values::cpu)]
    pub cpu: Option<usize>,
    /// Run the loop thread under SCHED_FIFO at this priority (1..=99; needs the privilege), with
    /// the process's memory locked (mlockall, as `cyclictest -m`).
    #[arg(long, visible_alias = "fifo-priority", value_name = "PRIO", value_parser = values::fifo)]
    pub fifo: Option<u8>,
    /// Lock the process's memory (mlockall) when the loop starts (implied by --fifo).
    #[arg(long)]
    pub lock_memory: bool,
    /// Sleep until this many microseconds before each deadline, then busy-wait (0: sleep only).
    #[arg(long, value_name = "US", allow_hyphen_values = true, value_parser = values::spin_us)]
    pub spin_us: Option<u64>,
    /// Hold this CPU wake-up latency (/dev/cpu_dma_latency, microseconds) while the loop runs,
    /// or `off`. Default: 0 with --cpu or --fifo (as cyclictest), else the description's.
    #[arg(long, value_name = "US|off", value_parser = values::cpu_latency, allow_hyphen_values = true)]
    pub cpu_dma_latency: Option<CpuLatencySetting>,
}

impl RealtimeArgs {
    /// What to ask of the operating system for a thread that runs on its own (no loop): the
    /// CPU latency request as the loop would hold it (`--cpu-dma-latency`, else 0 us with
    /// `--cpu` or `--fifo`, else none).
    pub fn request(&self, prefault_stack_bytes: usize) -> RtRequest {
        let latency_us = match self.cpu_dma_latency.unwrap_or_default() {
            CpuLatencySetting::Us(us) => Some(us),
            CpuLatencySetting::Off => None,
            CpuLatencySetting::Auto => (self.cpu.is_some() || self.fifo.is_some()).then_some(0),
        };
        RtRequest {
            cpu: self.cpu,
            fifo_priority: self.fifo,
            lock_memory: self.lock_memory || self.fifo.is_some(),
            prefault_stack_bytes,
            cpu_latency: latency_us
                .map(|us| CpuLatencyRequest::new(Duration::from_micros(u64::from(us)))),
        }
    }

    /// The spin margin (zero when not given).
    pub fn spin(&self) -> Duration {
        Duration::from_micros(self.spin_us.unwrap_or(0))
    }

    /// Writes the flags that were given into a description's `[loop]` settings.
    pub fn apply(&self, config: &mut RobotConfig) {
        let l = &mut config.loop_config;
        if self.cpu.is_some() {
            l.cpu = self.cpu;
        }
        if self.fifo.is_some() {
            l.fifo_priority = self.fifo;
        }
        l.lock_memory |= self.lock_memory || self.fifo.is_some();
        if let Some(us) = self.spin_us {
            l.spin_margin_us = us;
        }
        if let Some(latency) = self.cpu_dma_latency {
            l.cpu_dma_latency_us = latency;
        }
    }
}

/// How the loop runs: rate, length, real-time settings.
#[derive(clap::Args, Debug, Clone, Default, PartialEq)]
pub struct LoopArgs {
    /// Loop rate, Hz (default: the description's).
    #[arg(long, visible_alias = "rate-hz", value_name = "HZ", value_parser = values::rate)]
    pub rate: Option<f64>,
    /// How long to run: seconds (`10`) or with units (`1500ms`, `2m`).
    #[arg(long, visible_alias = "seconds", value_name = "DURATION", value_parser = duration::run_length)]
    pub duration: Option<Duration>,
    /// End the run, every motor made safe, when a tick does not complete within this long
    /// (`200ms`; default: the description's loop.stall_bound_ms, else ten periods and at
    /// least 50 ms). On a busy machine without real-time priority the OS may not run the loop
    /// for longer than that: the report then says so (see docs/realtime.md).
    #[arg(long, value_name = "DURATION", value_parser = duration::stall_bound)]
    pub stall_bound: Option<Duration>,
    /// The real-time setup.
    #[command(flatten)]
    pub realtime: RealtimeArgs,
}

impl LoopArgs {
    /// Writes the flags that were given into a description's `[loop]` settings.
    pub fn apply(&self, config: &mut RobotConfig) {
        if let Some(rate) = self.rate {
            config.loop_config.rate_hz = rate;
        }
        if let Some(bound) = self.stall_bound {
            config.loop_config.stall_bound_ms = Some(bound.as_millis() as u64);
        }
        self.realtime.apply(config);
    }

    /// How long to run: `--duration`, else `default` (`None`: until stopped).
    pub fn limit(&self, default: Option<Duration>) -> RunLimit {
        match self.duration.or(default) {
            Some(d) => RunLimit::Duration(d),
            None => RunLimit::Forever,
        }
    }
}

/// What a run shows and writes: the display, the report's form, and the telemetry sinks
/// (`--csv`, `--mcap`, `--foxglove`).
#[derive(clap::Args, Debug, Clone, Default, PartialEq)]
pub struct OutputArgs {
    /// The telemetry sinks.
    #[command(flatten)]
    pub telemetry: TelemetryArgs,
    /// No live display: only the final report.
    #[arg(long, short)]
    pub quiet: bool,
    /// Print the final report as one JSON object (and no live display).
    #[arg(long)]
    pub json: bool,
}

impl OutputArgs {
    /// The live display: none with `--quiet` or `--json`, a bar updated in place on a terminal,
    /// a line per second otherwise (logs).
    pub fn display(&self) -> Display {
        if self.quiet || self.json {
            Display::Quiet
        } else if std::io::stderr().is_terminal() {
            Display::Terminal
        } else {
            Display::Lines
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn loop_flags_write_into_the_description() {
        let mut config = RobotConfig::new(1000.0);
        LoopArgs {
            rate: Some(500.0),
            duration: None,
            stall_bound: Some(Duration::from_millis(250)),
            realtime: RealtimeArgs {
                cpu: Some(1),
                fifo: Some(80),
                lock_memory: false,
                spin_us: Some(50),
                cpu_dma_latency: None,
            },
        }
        .apply(&mut config);
        let l = &config.loop_config;
        assert_eq!(
            (
                l.rate_hz,
                l.cpu,
                l.fifo_priority,
                l.lock_memory,
                l.spin_margin_us
            ),
            (500.0, Some(1), Some(80), true, 50)
        );
        assert_eq!(l.stall_bound_ms, Some(250));
        // Flags not given leave the description alone.
        let mut config = RobotConfig::new(250.0);
        config.loop_config.cpu = Some(3);
        LoopArgs::default().apply(&mut config);
        assert_eq!(
            (config.loop_config.rate_hz, config.loop_config.cpu),
            (250.0, Some(3))
        );
    }

    #[test]
    fn the_cpu_latency_flag_writes_into_the_description_and_the_request() {
        use clap::Parser;
        #[derive(Parser)]
        struct Args {
            #[command(flatten)]
            rt: RealtimeArgs,
        }
        let parse = |args: &[&str]| {
            Args::try_parse_from(std::iter::once("x").chain(args.iter().copied())).map(|a| a.rt)
        };
        let latency = |rt: &RealtimeArgs| {
            rt.request(0)
                .cpu_latency
                .map(|l| (l.max_latency, l.device.display().to_string()))
        };
        let zero = Some((Duration::ZERO, "/dev/cpu_dma_latency".to_string()));
        // Default: 0 us with --cpu or --fifo, none without.
        assert_eq!(latency(&parse(&[]).unwrap()), None);
        assert_eq!(latency(&parse(&["--cpu", "0"]).unwrap()), zero);
        assert_eq!(latency(&parse(&["--fifo", "80"]).unwrap()), zero);
        // Given: as given.
        let off = parse(&["--cpu", "0", "--cpu-dma-latency", "off"]).unwrap();
        assert_eq!(latency(&off), None);
        let ten = parse(&["--cpu-dma-latency", "10"]).unwrap();
        assert_eq!(
            latency(&ten).map(|(d, _)| d),
            Some(Duration::from_micros(10))
        );
        assert!(parse(&["--cpu-dma-latency", "soon"]).is_err());
        // Into the description's [loop], only when given.
        let mut config = RobotConfig::new(1000.0);
        off.apply(&mut config);
        assert_eq!(
            config.loop_config.cpu_dma_latency_us,
            CpuLatencySetting::Off
        );
        let mut config = RobotConfig::new(1000.0);
        parse(&["--cpu", "0"]).unwrap().apply(&mut config);
        assert_eq!(
            config.loop_config.cpu_dma_latency_us,
            CpuLatencySetting::Auto
        );
    }
}
