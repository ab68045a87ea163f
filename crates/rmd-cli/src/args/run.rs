//! The run flags, one vocabulary for `rmd` and the examples: how long (`--duration`, alias
//! `--seconds`), how fast (`--rate`, alias `--rate-hz`) and the real-time setup of the thread
//! that runs (`--cpu`, `--fifo` alias `--fifo-priority`, `--spin-us`), with their value parsers.
//!
//! Every value is checked when the command line is parsed, so that a bad value is a usage error
//! (exit 2, one line on stderr) before anything runs.

use core::time::Duration;

use clap::Args;
use rmd_loop::config::LoopConfig;
use rmd_loop::os::RtRequest;

use super::duration::{self, Bounds};

/// Longest run accepted (one day).
pub(crate) const MAX_RUN: Duration = Duration::from_secs(86_400);
/// Stack pre-faulted by the measuring thread (as the loop does).
pub(crate) const PREFAULT_STACK_BYTES: usize = 512 * 1024;

/// Real-time setup of the measuring thread: `--cpu`, `--fifo`, `--spin-us`.
#[derive(Args, Debug, Clone, Copy, Default)]
pub(crate) struct RtFlags {
    /// Pin the loop thread to this CPU (an index as in /proc/cpuinfo).
    #[arg(long, value_parser = cpu)]
    pub(crate) cpu: Option<usize>,
    /// Run the loop thread under SCHED_FIFO at this priority (1..=99), with its memory locked
    /// (mlockall, as `cyclictest -m`).
    #[arg(long, visible_alias = "fifo-priority", value_name = "PRIO", value_parser = fifo)]
    pub(crate) fifo: Option<u8>,
    /// Sleep until this many microseconds before each deadline, then busy-wait (0: sleep only).
    #[arg(long, value_name = "US", default_value_t = 0)]
    pub(crate) spin_us: u64,
}

impl RtFlags {
    /// What to ask of the operating system.
    pub(crate) fn request(&self) -> RtRequest {
        RtRequest {
            cpu: self.cpu,
            fifo_priority: self.fifo,
            lock_memory: self.fifo.is_some(),
            prefault_stack_bytes: PREFAULT_STACK_BYTES,
        }
    }

    /// Writes these settings into a loop's configuration (the loop applies them to its thread).
    pub(crate) fn configure(&self, config: &mut LoopConfig) {
        let request = self.request();
        config.cpu = request.cpu;
        config.fifo_priority = request.fifo_priority;
        config.lock_memory = request.lock_memory;
        config.spin_margin_us = self.spin_us;
    }

    /// The spin margin.
    pub(crate) fn spin(&self) -> Duration {
        Duration::from_micros(self.spin_us)
    }
}

/// `--duration` (alias `--seconds`) of a run: a positive duration of at most a day, with units
/// (`500ms`, `2m`) or a bare number of seconds.
pub(crate) fn run_length(text: &str) -> Result<Duration, String> {
    duration::parse(text, Bounds::positive_up_to(MAX_RUN))
}

/// `--rate` (alias `--rate-hz`) of a loop: a positive, finite rate in Hz within the loop's range.
pub(crate) fn rate(text: &str) -> Result<f64, String> {
    let hz: f64 = text
        .trim()
        .parse()
        .map_err(|_| format!("`{text}` is not a rate in Hz"))?;
    if !(hz.is_finite() && hz > 0.0) {
        return Err(format!("{text} Hz: must be a positive number"));
    }
    rmd_loop::schedule::Period::from_hz(hz).map_err(|e| e.to_string())?;
    Ok(hz)
}

/// `--cpu`: a CPU this process may run on.
pub(crate) fn cpu(text: &str) -> Result<usize, String> {
    let cpu: usize = text
        .trim()
        .parse()
        .map_err(|_| format!("`{text}` is not a CPU index"))?;
    let ids = core_affinity::get_core_ids().unwrap_or_default();
    if ids.iter().any(|c| c.id == cpu) {
        Ok(cpu)
    } else {
        let list: Vec<String> = ids.iter().map(|c| c.id.to_string()).collect();
        Err(format!(
            "CPU {cpu} is not available to this process (available: {})",
            if list.is_empty() {
                "unknown".to_string()
            } else {
                list.join(", ")
            }
        ))
    }
}

/// `--fifo`: a SCHED_FIFO priority, 1..=99.
pub(crate) fn fifo(text: &str) -> Result<u8, String> {
    let p: u8 = text
        .trim()
        .parse()
        .map_err(|_| format!("`{text}` is not a priority (1..=99)"))?;
    if !(1..=99).contains(&p) {
        return Err(format!("priority {p}: must be 1..=99"));
    }
    Ok(p)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_are_checked() {
        assert_eq!(run_length("0.5").unwrap(), Duration::from_millis(500));
        assert_eq!(run_length("250ms").unwrap(), Duration::from_millis(250));
        assert_eq!(run_length("2m").unwrap(), Duration::from_secs(120));
        for bad in ["0", "-1", "nan", "inf", "x", "100000", "2days"] {
            assert!(run_length(bad).is_err(), "{bad}");
        }
        assert_eq!(rate("1000").unwrap(), 1000.0);
        for bad in ["0", "-5", "nan", "1e9", "0.001"] {
            assert!(rate(bad).is_err(), "{bad}");
        }
        assert_eq!(fifo("99").unwrap(), 99);
        assert!(fifo("0").is_err());
        assert!(fifo("100").is_err());
        assert_eq!(cpu("0").unwrap(), 0);
        assert!(cpu("100000").unwrap_err().contains("not available"));
    }
}
