//! The loop's settings (`[loop]`) and the safe stop's patience (`[safe_stop]`), checked.

use core::num::{NonZeroU32, NonZeroUsize};
use core::time::Duration;

use super::error::{RobotError, invalid};
use super::file::{
    CpuLatencySetting, LoopConfig, RejectedCommandPolicy, ReplyMode, SafeStopConfig,
};
use crate::schedule::{OverrunPolicy, Period};

/// The longest `loop.stall_bound_ms`.
pub const MAX_STALL_BOUND: Duration = Duration::from_secs(60);
/// The most `loop.startup_probes`.
pub const MAX_STARTUP_PROBES: u32 = 1000;
/// The largest `loop.telemetry_capacity`, in ticks (allocated up front).
pub const MAX_TELEMETRY_CAPACITY: usize = 65_536;
/// The CPUs `loop.cpu` may name (`0..MAX_CPUS`, the kernel's `CPU_SETSIZE`).
pub const MAX_CPUS: usize = 1024;

/// A `SCHED_FIFO` priority, 1..=99.
#[derive(Copy, Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct FifoPriority(u8);

impl FifoPriority {
    /// `priority` if it is in 1..=99.
    pub fn new(priority: u8) -> Option<Self> {
        (1..=99).contains(&priority).then_some(Self(priority))
    }

    /// The priority.
    pub fn get(self) -> u8 {
        self.0
    }
}

/// What the loop thread asks of the operating system.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct RealtimeSettings {
    /// Pin the loop thread to this CPU.
    pub cpu: Option<usize>,
    /// Run it under `SCHED_FIFO` at this priority.
    pub fifo_priority: Option<FifoPriority>,
    /// Lock the process's memory when the loop starts.
    pub lock_memory: bool,
    /// Hold this CPU wake-up latency (`/dev/cpu_dma_latency`) while the loop runs; `None`:
    /// leave the idle states alone. At most [`MAX_CPU_LATENCY`](crate::os::MAX_CPU_LATENCY).
    pub cpu_dma_latency: Option<Duration>,
}

/// The loop settings, checked.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct LoopSettings {
    /// The tick period.
    pub period: Period,
    /// Replies are collected until this long after a tick's scheduled start (within the period).
    pub reply_deadline: Duration,
    /// Same-tick or pipelined replies.
    pub reply_mode: ReplyMode,
    /// What to do when a tick overruns the next tick's start.
    pub overrun: OverrunPolicy,
    /// Busy-wait this long before each deadline (shorter than the period).
    pub spin_margin: Duration,
    /// CPU, priority, memory locking.
    pub realtime: RealtimeSettings,
    /// Consecutive ticks without fresh feedback from one motor that make a fault.
    pub missing_reply_fault_after: NonZeroU32,
    /// Start-up probe exchanges allowed for every motor to answer once.
    pub startup_probes: NonZeroU32,
    /// Capacity of the telemetry queue, in ticks.
    pub telemetry_capacity: NonZeroUsize,
    /// A period shorter than the worst-case exchange was accepted (benchmarks only).
    pub allow_over_budget: bool,
    /// What to do with a command that cannot be sent as given.
    pub rejected_command: RejectedCommandPolicy,
    /// A tick not complete after this long is ended by the supervisor (more than a period;
    /// default ten periods, at least 50 ms).
    pub stall_bound: Duration,
    /// Motor health in rotation was asked for (`loop.health_rotation`); each bus's
    /// [`BusSpec::health_rotation`](super::BusSpec::health_rotation) says whether it has room for it.
    pub health_rotation: bool,
}

/// The safe stop's patience, checked.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct SafeStopSettings {
    /// How long the safe stop keeps trying on each bus.
    pub deadline: Duration,
    /// How long a bus-off bus may take to restart (at most the deadline).
    pub bus_off_wait: Duration,
    /// How often motor-off is sent again to a motor that has not confirmed it.
    pub retry_every: Duration,
}

impl Default for SafeStopSettings {
    fn default() -> Self {
        let c = SafeStopConfig::default();
        Self {
            deadline: Duration::from_millis(c.deadline_ms),
            bus_off_wait: Duration::from_millis(c.bus_off_wait_ms),
            retry_every: Duration::from_millis(c.retry_ms),
        }
    }
}

/// The `[loop]` table, checked: each key's rule where the key is read (errors name
/// `loop.<key>`).
pub(super) fn loop_settings(l: &LoopConfig) -> Result<LoopSettings, RobotError> {
    let period = Period::from_hz(l.rate_hz).map_err(|e| invalid("loop.rate_hz", e.to_string()))?;
    let p = period.get();
    let fifo_priority =
        match l.fifo_priority {
            None => None,
            Some(prio) => Some(FifoPriority::new(prio).ok_or_else(|| {
                invalid("loop.fifo_priority", format!("is {prio}, must be 1..=99"))
            })?),
        };
    let cpu_dma_latency = match l.cpu_dma_latency_us {
        CpuLatencySetting::Off => None,
        CpuLatencySetting::Auto => {
            (l.cpu.is_some() || fifo_priority.is_some()).then_some(Duration::ZERO)
        }
        CpuLatencySetting::Us(us) => {
            let latency = Duration::from_micros(u64::from(us));
            if latency > crate::os::MAX_CPU_LATENCY {
                return Err(invalid(
                    "loop.cpu_dma_latency_us",
                    format!(
                        "is {us} us, must be at most {} us (or \"off\")",
                        crate::os::MAX_CPU_LATENCY.as_micros()
                    ),
                ));
            }
            Some(latency)
        }
    };
    let spin_margin = Duration::from_micros(l.spin_margin_us);
    if spin_margin >= p {
        return Err(invalid(
            "loop.spin_margin_us",
            format!(
                "is {} us, must be shorter than the period ({} us)",
                l.spin_margin_us,
                p.as_micros()
            ),
        ));
    }
    let reply_deadline = match l.reply_deadline_us {
        Some(us) => Duration::from_micros(us),
        None => default_reply_deadline(p),
    };
    if reply_deadline.is_zero() || reply_deadline > p {
        return Err(invalid(
            "loop.reply_deadline_us",
            format!(
                "is {} us, must be within the period (1..={} us)",
                reply_deadline.as_micros(),
                p.as_micros()
            ),
        ));
    }
    let count = |key: &str, v: u32, max: u32| {
        NonZeroU32::new(v)
            .filter(|n| n.get() <= max)
            .ok_or_else(|| invalid(key, format!("is {v}, must be 1..={max}")))
    };
    if let Some(cpu) = l.cpu
        && cpu >= MAX_CPUS
    {
        return Err(invalid(
            "loop.cpu",
            format!("is {cpu}, must be below {MAX_CPUS} (a CPU number as in /proc/cpuinfo)"),
        ));
    }
    let stall_bound = match l.stall_bound_ms {
        Some(ms) => Duration::from_millis(ms),
        None => (p * 10).max(Duration::from_millis(50)),
    };
    if stall_bound <= p || stall_bound > MAX_STALL_BOUND {
        return Err(invalid(
            "loop.stall_bound_ms",
            format!(
                "is {} ms, must be longer than the period ({} us) and at most {} ms",
                stall_bound.as_millis(),
                p.as_micros(),
                MAX_STALL_BOUND.as_millis()
            ),
        ));
    }
    if let OverrunPolicy::Fault { after: 0 } = l.overrun {
        return Err(invalid("loop.overrun.after", "must be at least 1"));
    }
    Ok(LoopSettings {
        period,
        reply_deadline,
        reply_mode: l.reply_mode,
        overrun: l.overrun,
        spin_margin,
        realtime: RealtimeSettings {
            cpu: l.cpu,
            fifo_priority,
            lock_memory: l.lock_memory,
            cpu_dma_latency,
        },
        // Any number of ticks (u32::MAX: never, for benchmarks).
        missing_reply_fault_after: count(
            "loop.missing_reply_fault_after",
            l.missing_reply_fault_after,
            u32::MAX,
        )?,
        startup_probes: count("loop.startup_probes", l.startup_probes, MAX_STARTUP_PROBES)?,
        telemetry_capacity: NonZeroUsize::new(l.telemetry_capacity)
            .filter(|n| n.get() <= MAX_TELEMETRY_CAPACITY)
            .ok_or_else(|| {
                invalid(
                    "loop.telemetry_capacity",
                    format!(
                        "is {}, must be 1..={MAX_TELEMETRY_CAPACITY} ticks",
                        l.telemetry_capacity
                    ),
                )
            })?,
        allow_over_budget: l.allow_over_budget,
        rejected_command: l.rejected_command,
        stall_bound,
        health_rotation: l.health_rotation,
    })
}

/// The `[safe_stop]` table, checked (errors name `safe_stop.<key>`).
pub(super) fn safe_stop_settings(c: &SafeStopConfig) -> Result<SafeStopSettings, RobotError> {
    if c.deadline_ms == 0 || c.deadline_ms > 60_000 {
        return Err(invalid(
            "safe_stop.deadline_ms",
            format!("is {}, must be 1..=60000 ms", c.deadline_ms),
        ));
    }
    if c.bus_off_wait_ms > c.deadline_ms {
        return Err(invalid(
            "safe_stop.bus_off_wait_ms",
            format!(
                "is {} ms, must be at most safe_stop.deadline_ms ({} ms)",
                c.bus_off_wait_ms, c.deadline_ms
            ),
        ));
    }
    if c.retry_ms == 0 || c.retry_ms > c.deadline_ms {
        return Err(invalid(
            "safe_stop.retry_ms",
            format!(
                "is {}, must be 1..=safe_stop.deadline_ms ({} ms)",
                c.retry_ms, c.deadline_ms
            ),
        ));
    }
    Ok(SafeStopSettings {
        deadline: Duration::from_millis(c.deadline_ms),
        bus_off_wait: Duration::from_millis(c.bus_off_wait_ms),
        retry_every: Duration::from_millis(c.retry_ms),
    })
}

/// The reply deadline of a period when the description gives none: the period minus 10% (at
/// least 50 us), but at least half the period.
pub(super) fn default_reply_deadline(p: Duration) -> Duration {
    p.saturating_sub((p / 10).max(Duration::from_micros(50)))
        .max(p / 2)
}

#[cfg(test)]
mod tests {
    use core::time::Duration;

    use crate::robot::test_fixtures::{LEG, expect_invalid};
    use crate::robot::{Robot, RobotError};

    #[test]
    fn bad_loop_values_name_their_key() {
        expect_invalid(
            &LEG.replace("rate_hz = 500.0", "rate_hz = 0.0"),
            "loop.rate_hz",
        );
        expect_invalid(
            &LEG.replace("spin_margin_us = 20", "spin_margin_us = 5000"),
            "loop.spin_margin_us",
        );
        expect_invalid(&LEG.replace("after = 5", "after = 0"), "loop.overrun.after");
        expect_invalid(
            &LEG.replace("cpu = 1", "cpu = 1\nfifo_priority = 100"),
            "loop.fifo_priority",
        );
        expect_invalid(
            &LEG.replace("cpu = 1", "cpu = 1\ncpu_dma_latency_us = 1000001"),
            "loop.cpu_dma_latency_us",
        );
    }

    #[test]
    fn physically_absurd_loop_values_are_refused_naming_their_key() {
        let on_loop = |line: &str| LEG.replace("[loop]", &format!("[loop]\n{line}"));
        for (line, key) in [
            (
                "stall_bound_ms = 18446744073709551615",
                "loop.stall_bound_ms",
            ),
            (
                "missing_reply_fault_after = 0",
                "loop.missing_reply_fault_after",
            ),
            ("startup_probes = 4294967295", "loop.startup_probes"),
            (
                "telemetry_capacity = 1000000000000",
                "loop.telemetry_capacity",
            ),
            (
                "reply_deadline_us = 18446744073709551615",
                "loop.reply_deadline_us",
            ),
        ] {
            expect_invalid(&on_loop(line), key);
        }
        expect_invalid(&LEG.replace("cpu = 1", "cpu = 4096"), "loop.cpu");
        expect_invalid(
            &LEG.replace("rate_hz = 500.0", "rate_hz = 1e308"),
            "loop.rate_hz",
        );
    }

    #[test]
    fn the_cpu_latency_request_parses_and_defaults_to_zero_with_real_time_settings() {
        let latency = |text: &str| {
            Robot::from_toml(text)
                .unwrap()
                .settings()
                .realtime
                .cpu_dma_latency
        };
        let us = Duration::from_micros;
        // Auto: 0 us when pinned or SCHED_FIFO, off otherwise.
        assert_eq!(latency(LEG), Some(us(0)));
        let plain = LEG.replace("cpu = 1\n", "");
        assert_eq!(latency(&plain), None);
        assert_eq!(
            latency(&plain.replace("rate_hz = 500.0", "rate_hz = 500.0\nfifo_priority = 80")),
            Some(us(0))
        );
        // Given: a number of microseconds, or off, whatever else is set.
        assert_eq!(
            latency(&LEG.replace("cpu = 1", "cpu = 1\ncpu_dma_latency_us = 25")),
            Some(us(25))
        );
        assert_eq!(
            latency(&plain.replace("rate_hz = 500.0", "rate_hz = 500.0\ncpu_dma_latency_us = 3")),
            Some(us(3))
        );
        assert_eq!(
            latency(&LEG.replace("cpu = 1", "cpu = 1\ncpu_dma_latency_us = \"off\"")),
            None
        );
        assert_eq!(
            latency(&LEG.replace("cpu = 1", "cpu = 1\ncpu_dma_latency_us = \"auto\"")),
            Some(us(0))
        );
        // Survives a round trip through TOML.
        let robot =
            Robot::from_toml(&LEG.replace("cpu = 1", "cpu = 1\ncpu_dma_latency_us = \"off\""))
                .unwrap();
        assert_eq!(Robot::from_toml(&robot.config().to_toml()).unwrap(), robot);
        // Anything else is a parse error that says what is expected.
        for bad in ["-1", "\"on\"", "1.5", "5000000000"] {
            let err = Robot::from_toml(
                &LEG.replace("cpu = 1", &format!("cpu = 1\ncpu_dma_latency_us = {bad}")),
            )
            .unwrap_err();
            assert!(
                matches!(&err, RobotError::Parse { message: m, .. } if m.contains("microseconds") && m.contains("off")),
                "{bad}: {err}"
            );
        }
    }
}
