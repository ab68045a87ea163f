//! Why a tick stalled: the operating system did not run the loop thread, or the thread spun, or
//! it was blocked; and in which stage of the tick.
//!
//! The supervisor judges a stall from the loop thread's own scheduler statistics over the stall
//! ([`crate::os::thread_stats`]): how long the thread ran on a CPU, how long it waited for one
//! while runnable, and the rest, when it slept or was blocked. A healthy tick needs at most a
//! period of CPU: a thread that ran more than two periods during the stall was busy
//! (a controller in an endless loop, say) whatever the load; otherwise the larger of waiting and
//! sleeping decides. When the supervisor itself was not run for most of the stall, the whole
//! process was not (stopped, or the machine starved it), and so neither was the loop thread.

use core::fmt;
use core::time::Duration;

/// Where the loop thread was in its tick.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
#[repr(u8)]
pub enum TickStage {
    /// Waiting for the tick's start (the timed wait).
    #[default]
    Waiting = 0,
    /// Sending the torque frames and collecting the replies (the bus I/O).
    Exchange = 1,
    /// In the controller's `update`.
    Controller = 2,
    /// After the controller: the limits, the frames of the next tick, telemetry, statistics.
    Bookkeeping = 3,
}

impl TickStage {
    pub(crate) fn from_u8(v: u8) -> Self {
        match v {
            0 => TickStage::Waiting,
            1 => TickStage::Exchange,
            2 => TickStage::Controller,
            _ => TickStage::Bookkeeping,
        }
    }
}

impl fmt::Display for TickStage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            TickStage::Waiting => "the wait for the tick",
            TickStage::Exchange => "the bus I/O",
            TickStage::Controller => "the controller's update",
            TickStage::Bookkeeping => "the loop's bookkeeping after the controller",
        })
    }
}

/// Why a tick did not complete within the stall bound.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum StallCause {
    /// The operating system did not run the loop thread: it waited for a CPU (other threads
    /// had them), or it was stopped, or the whole process was not run. Not the controller.
    NotRun {
        /// How long it waited for a CPU during the stall, when the statistics say.
        waited: Option<Duration>,
        /// The thread (or the process) was stopped (`SIGSTOP`, a debugger).
        stopped: bool,
    },
    /// The loop thread ran on a CPU through the stall: it was busy in `stage`.
    Busy {
        /// Where.
        stage: TickStage,
        /// How long it ran on a CPU during the stall.
        ran: Duration,
    },
    /// The loop thread slept or was blocked (a sleep, a lock, I/O) through the stall.
    Blocked {
        /// Where.
        stage: TickStage,
        /// How long it ran on a CPU during the stall.
        ran: Duration,
        /// In an uninterruptible wait in the kernel (I/O) when the stall was seen.
        in_kernel: bool,
    },
    /// Not known: no scheduler statistics of the loop thread (not Linux, no `/proc`), or a loop
    /// without a supervisor.
    Unknown {
        /// Where the loop thread was.
        stage: TickStage,
    },
}

/// What the supervisor measured over a stall.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) struct StallEvidence {
    /// The stall: from the loop thread's last sign of life to now.
    pub(crate) stalled: Duration,
    /// The part of it the statistics cover: from the supervisor's first look after the last
    /// sign of life to now.
    pub(crate) window: Duration,
    /// The loop thread's CPU time and run-queue wait over the window, if known.
    pub(crate) ran: Option<Duration>,
    pub(crate) waited: Option<Duration>,
    /// How long the supervisor itself was not run during the stall, beyond its own sleeps and
    /// its waits for a CPU: how long the whole process was not run.
    pub(crate) supervisor_late: Duration,
    /// The loop thread was stopped, runnable (waiting for a CPU now: a wait the statistics
    /// count only once it ends), or in the kernel (uninterruptible), when the stall was seen.
    pub(crate) stopped: bool,
    pub(crate) runnable: bool,
    pub(crate) in_kernel: bool,
    /// Where the loop thread was.
    pub(crate) stage: TickStage,
    /// The loop's period.
    pub(crate) period: Duration,
}

impl StallEvidence {
    /// The cause the evidence points at.
    pub(crate) fn cause(&self) -> StallCause {
        // The supervisor was not run for most of the stall either: the process was not.
        let process_not_run = self.supervisor_late * 2 >= self.stalled;
        let not_run = |waited| StallCause::NotRun {
            waited,
            stopped: self.stopped,
        };
        if self.stopped {
            return not_run(self.waited);
        }
        let covered = self.window * 2 >= self.stalled;
        let (Some(ran), Some(waited), true) = (self.ran, self.waited, covered) else {
            return if process_not_run || self.runnable {
                not_run(None)
            } else {
                StallCause::Unknown { stage: self.stage }
            };
        };
        // No healthy tick runs more than a period: more than two during the stall is a thread
        // that does not stop computing, however little of a CPU the load (or a frozen
        // supervisor) left it.
        if ran > self.period * 2 {
            return StallCause::Busy {
                stage: self.stage,
                ran,
            };
        }
        // Runnable and hardly run: waiting for a CPU, since when the statistics do not say
        // yet.
        if self.runnable {
            return not_run(None);
        }
        let asleep = self.window.saturating_sub(ran + waited);
        if waited >= asleep || process_not_run {
            // Waiting for a CPU; or neither running nor waiting while the whole process was
            // not run (stopped: a stopped thread is not runnable, so it does not wait either).
            not_run(Some(waited))
        } else {
            StallCause::Blocked {
                stage: self.stage,
                ran,
                in_kernel: self.in_kernel,
            }
        }
    }
}

/// Milliseconds with one decimal below 10, whole above.
struct Ms(Duration);

impl fmt::Display for Ms {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let ms = self.0.as_secs_f64() * 1e3;
        if ms < 10.0 {
            write!(f, "{ms:.1} ms")
        } else {
            write!(f, "{ms:.0} ms")
        }
    }
}

/// The words of a stall of `stalled` caused by `cause`, with what to do about it.
pub(crate) fn describe(
    f: &mut fmt::Formatter<'_>,
    stalled: Duration,
    cause: &StallCause,
) -> fmt::Result {
    let stalled = Ms(stalled);
    match cause {
        StallCause::NotRun { waited, stopped } => {
            write!(f, "the OS did not run the loop thread for {stalled}")?;
            match (stopped, waited) {
                (true, _) => write!(f, " (it was stopped: SIGSTOP, a debugger)")?,
                (false, Some(w)) if !w.is_zero() => write!(f, " (it waited {} for a CPU)", Ms(*w))?,
                _ => {}
            }
            write!(
                f,
                ": give it real-time priority, --fifo/--cpu, see docs/realtime.md (or allow \
                 longer stalls: --stall-bound, loop.stall_bound_ms)"
            )
        }
        StallCause::Busy { stage, ran } => write!(
            f,
            "the loop thread was busy in {stage} for {stalled} (it ran {} on a CPU): {}",
            Ms(*ran),
            match stage {
                TickStage::Controller => "a controller that does not return (an endless loop?)",
                _ => "the loop itself spun (please report it)",
            }
        ),
        StallCause::Blocked {
            stage,
            ran,
            in_kernel,
        } => write!(
            f,
            "the loop thread was blocked in {stage} for {stalled} (it ran {} on a CPU{}): {}",
            Ms(*ran),
            if *in_kernel {
                ", waiting in the kernel"
            } else {
                ""
            },
            match stage {
                TickStage::Controller => {
                    "a blocking call in the controller (a sleep, a lock, file or network I/O)"
                }
                TickStage::Exchange => {
                    "the bus I/O did not return (the CAN interface or its driver; a simulated \
                     bus: its lock)"
                }
                _ => "a blocking call in the loop (please report it)",
            }
        ),
        StallCause::Unknown { stage } => write!(
            f,
            "the loop thread was in {stage} for {stalled} (the controller or the bus I/O hung, or \
             the OS did not run it)"
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: Duration = Duration::from_millis(1);

    fn evidence(ran: u32, waited: u32) -> StallEvidence {
        StallEvidence {
            stalled: 61 * MS,
            window: 60 * MS,
            ran: Some(ran * MS),
            waited: Some(waited * MS),
            supervisor_late: Duration::ZERO,
            stopped: false,
            runnable: false,
            in_kernel: false,
            stage: TickStage::Controller,
            period: MS,
        }
    }

    #[test]
    fn the_evidence_decides_the_cause() {
        // Ran through the stall, even with a third of a CPU: busy.
        assert!(matches!(evidence(58, 1).cause(), StallCause::Busy { .. }));
        assert!(matches!(evidence(20, 39).cause(), StallCause::Busy { .. }));
        // Hardly ran, waited for a CPU: not run.
        assert!(matches!(
            evidence(1, 55).cause(),
            StallCause::NotRun { stopped: false, .. }
        ));
        // Hardly ran, did not wait: asleep or blocked...
        assert!(matches!(evidence(0, 2).cause(), StallCause::Blocked { .. }));
        // ... unless it is runnable now: waiting for a CPU (the statistics count a wait only
        // once it ends).
        let queued = StallEvidence {
            runnable: true,
            ..evidence(0, 2)
        };
        assert_eq!(
            queued.cause(),
            StallCause::NotRun {
                waited: None,
                stopped: false
            }
        );
        // The supervisor was not run either: the process was not (a stopped thread neither
        // runs nor waits)...
        let frozen = StallEvidence {
            supervisor_late: 55 * MS,
            ..evidence(0, 0)
        };
        assert!(matches!(frozen.cause(), StallCause::NotRun { .. }));
        // ... unless the loop thread ran through it.
        let spinning = StallEvidence {
            supervisor_late: 55 * MS,
            ..evidence(10, 40)
        };
        assert!(matches!(spinning.cause(), StallCause::Busy { .. }));
        // Without statistics the supervisor's own lateness still tells a frozen process.
        let frozen_blind = StallEvidence {
            ran: None,
            waited: None,
            ..frozen
        };
        assert!(matches!(
            frozen_blind.cause(),
            StallCause::NotRun { waited: None, .. }
        ));
        let stopped = StallEvidence {
            stopped: true,
            ..evidence(0, 0)
        };
        assert_eq!(
            stopped.cause(),
            StallCause::NotRun {
                waited: Some(Duration::ZERO),
                stopped: true
            }
        );
        // No statistics, or statistics over too little of the stall: unknown.
        let blind = StallEvidence {
            ran: None,
            waited: None,
            ..evidence(0, 0)
        };
        assert_eq!(
            blind.cause(),
            StallCause::Unknown {
                stage: TickStage::Controller
            }
        );
        let short = StallEvidence {
            window: 20 * MS,
            ..evidence(0, 0)
        };
        assert!(matches!(short.cause(), StallCause::Unknown { .. }));
    }
}
