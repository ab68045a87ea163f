//! The small operating-system layer of the loop thread: CPU pinning, `SCHED_FIFO` priority,
//! memory locking, stack pre-faulting and the timer slack. The only place in rmd-rt with `unsafe` code.
//!
//! Each step is best effort: when a privilege is missing (no `CAP_SYS_NICE` / rtprio limit for
//! `SCHED_FIFO`, no `CAP_IPC_LOCK` / memlock limit for `mlockall`) the loop runs anyway and the
//! [`RtStatus`] says what was not applied and how to fix it.
#![allow(unsafe_code)]

use std::fmt;

/// What to ask of the operating system for the real-time thread.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RtRequest {
    /// Pin the thread to this CPU (index as in `/proc/cpuinfo`).
    pub cpu: Option<usize>,
    /// Run under `SCHED_FIFO` at this priority (1..=99).
    pub fifo_priority: Option<u8>,
    /// Lock all current and future memory (`mlockall(MCL_CURRENT | MCL_FUTURE)`) so that no page
    /// fault can stall the loop.
    pub lock_memory: bool,
    /// Touch this many bytes of the thread's stack up front so that its pages are resident.
    pub prefault_stack_bytes: usize,
}

/// The outcome of one setup step.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum StepStatus {
    /// Not requested.
    NotRequested,
    /// Applied.
    Applied,
    /// Requested but not applied: why, and how to fix it.
    Failed(String),
}

impl StepStatus {
    /// Whether the step was requested and failed.
    pub fn failed(&self) -> bool {
        matches!(self, StepStatus::Failed(_))
    }
}

/// What the operating system granted the real-time thread.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RtStatus {
    /// CPU pinning.
    pub affinity: StepStatus,
    /// `SCHED_FIFO` scheduling.
    pub fifo: StepStatus,
    /// `mlockall`.
    pub memory_lock: StepStatus,
    /// Bytes of stack pre-faulted.
    pub prefaulted_stack_bytes: usize,
    /// The thread's timer slack after setup, in nanoseconds, when the OS reports one. Without
    /// `SCHED_FIFO`, Linux may wake a sleeping thread up to its timer slack late (50 us by
    /// default) to batch wake-ups; the loop thread always sets its own to 1 ns (no privilege
    /// needed). Real-time threads ignore it.
    pub timer_slack_ns: Option<u64>,
}

impl RtStatus {
    /// Human-readable warnings, one per step that was requested and not applied.
    pub fn warnings(&self) -> impl Iterator<Item = &str> {
        [&self.affinity, &self.fifo, &self.memory_lock]
            .into_iter()
            .filter_map(|s| match s {
                StepStatus::Failed(why) => Some(why.as_str()),
                _ => None,
            })
    }

    /// Whether every requested step was applied.
    pub fn fully_applied(&self) -> bool {
        self.warnings().next().is_none()
    }
}

impl fmt::Display for RtStatus {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fn show(s: &StepStatus) -> &str {
            match s {
                StepStatus::NotRequested => "not requested",
                StepStatus::Applied => "applied",
                StepStatus::Failed(_) => "FAILED",
            }
        }
        write!(
            f,
            "cpu pinning: {}, SCHED_FIFO: {}, mlockall: {}, stack pre-faulted: {} KiB",
            show(&self.affinity),
            show(&self.fifo),
            show(&self.memory_lock),
            self.prefaulted_stack_bytes / 1024
        )?;
        if let Some(ns) = self.timer_slack_ns {
            write!(f, ", timer slack: {ns} ns")?;
        }
        Ok(())
    }
}

/// Applies `request` to the calling thread and reports what was granted. Never fails: a step
/// that cannot be applied is reported in the returned status.
pub fn apply_to_current_thread(request: &RtRequest) -> RtStatus {
    let affinity = match request.cpu {
        None => StepStatus::NotRequested,
        Some(cpu) => pin_to_cpu(cpu),
    };
    let fifo = match request.fifo_priority {
        None => StepStatus::NotRequested,
        Some(prio) => set_fifo(prio),
    };
    let memory_lock = if request.lock_memory {
        lock_memory()
    } else {
        StepStatus::NotRequested
    };
    prefault_stack(request.prefault_stack_bytes);
    RtStatus {
        affinity,
        fifo,
        memory_lock,
        prefaulted_stack_bytes: request.prefault_stack_bytes.min(MAX_PREFAULT),
        timer_slack_ns: minimise_timer_slack(),
    }
}

/// Sets the calling thread's timer slack to its minimum (1 ns) and returns the value in effect.
#[cfg(target_os = "linux")]
fn minimise_timer_slack() -> Option<u64> {
    use nix::sys::prctl;
    // Best effort: the call needs no privilege; if it fails, the value read back says so.
    let _ = prctl::set_timerslack(1);
    prctl::get_timerslack().ok().map(|ns| ns as u64)
}

#[cfg(not(target_os = "linux"))]
fn minimise_timer_slack() -> Option<u64> {
    None
}

fn pin_to_cpu(cpu: usize) -> StepStatus {
    let Some(ids) = core_affinity::get_core_ids() else {
        return StepStatus::Failed(format!(
            "could not pin the loop thread to CPU {cpu}: the list of CPUs is unavailable"
        ));
    };
    match ids.into_iter().find(|c| c.id == cpu) {
        None => StepStatus::Failed(format!(
            "could not pin the loop thread to CPU {cpu}: no such CPU in this process's affinity \
             mask (choose one of 0..{})",
            std::thread::available_parallelism()
                .map(|n| n.get())
                .unwrap_or(1)
        )),
        Some(id) => {
            if core_affinity::set_for_current(id) {
                StepStatus::Applied
            } else {
                StepStatus::Failed(format!(
                    "could not pin the loop thread to CPU {cpu}: sched_setaffinity refused"
                ))
            }
        }
    }
}

#[cfg(target_os = "linux")]
fn set_fifo(priority: u8) -> StepStatus {
    if !(1..=99).contains(&priority) {
        return StepStatus::Failed(format!(
            "SCHED_FIFO priority {priority} is out of range: use 1..=99"
        ));
    }
    let param = libc::sched_param {
        sched_priority: i32::from(priority),
    };
    // SAFETY: pthread_self() is always a valid handle for the calling thread, and `param` is a
    // fully initialised sched_param that lives across the call; the call only reads it.
    let rc = unsafe { libc::pthread_setschedparam(libc::pthread_self(), libc::SCHED_FIFO, &param) };
    if rc == 0 {
        StepStatus::Applied
    } else {
        let err = std::io::Error::from_raw_os_error(rc);
        StepStatus::Failed(format!(
            "could not switch the loop thread to SCHED_FIFO priority {priority} ({err}); the loop \
             runs under the normal scheduler. Fix: run as root, or grant CAP_SYS_NICE \
             (`setcap cap_sys_nice+ep <binary>`), or raise the rtprio limit \
             (`@realtime - rtprio 99` in /etc/security/limits.d/)"
        ))
    }
}

#[cfg(not(target_os = "linux"))]
fn set_fifo(priority: u8) -> StepStatus {
    StepStatus::Failed(format!(
        "SCHED_FIFO priority {priority} requested, but real-time scheduling is only supported on Linux"
    ))
}

#[cfg(target_os = "linux")]
fn lock_memory() -> StepStatus {
    use nix::sys::mman::{MlockAllFlags, mlockall};
    match mlockall(MlockAllFlags::MCL_CURRENT | MlockAllFlags::MCL_FUTURE) {
        Ok(()) => StepStatus::Applied,
        Err(errno) => StepStatus::Failed(format!(
            "could not lock memory with mlockall ({errno}); page faults may stall the loop. Fix: \
             run as root, or grant CAP_IPC_LOCK, or raise the memlock limit (`ulimit -l unlimited`, \
             `@realtime - memlock unlimited` in /etc/security/limits.d/)"
        )),
    }
}

#[cfg(not(target_os = "linux"))]
fn lock_memory() -> StepStatus {
    StepStatus::Failed("memory locking is only supported on Linux".to_string())
}

/// Largest stack pre-fault we perform (the loop thread is spawned with a larger stack).
pub const MAX_PREFAULT: usize = 1024 * 1024;

/// Writes `bytes` of stack so that its pages are mapped before the first tick.
fn prefault_stack(bytes: usize) {
    const CHUNK: usize = 64 * 1024;
    #[inline(never)]
    fn touch(remaining: usize) {
        let mut page = [0u8; CHUNK];
        // Write one byte per 4 KiB page; black_box stops the compiler from removing it.
        for i in (0..CHUNK).step_by(4096) {
            page[i] = 1;
        }
        std::hint::black_box(&mut page);
        if remaining > CHUNK {
            touch(remaining - CHUNK);
        }
    }
    if bytes > 0 {
        touch(bytes.min(MAX_PREFAULT));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nothing_requested_is_fully_applied() {
        let status = apply_to_current_thread(&RtRequest::default());
        assert_eq!(status.affinity, StepStatus::NotRequested);
        assert_eq!(status.fifo, StepStatus::NotRequested);
        assert_eq!(status.memory_lock, StepStatus::NotRequested);
        assert!(status.fully_applied());
    }

    #[test]
    fn an_impossible_cpu_or_priority_is_reported_not_fatal() {
        let status = std::thread::spawn(|| {
            apply_to_current_thread(&RtRequest {
                cpu: Some(100_000),
                fifo_priority: Some(0),
                lock_memory: false,
                prefault_stack_bytes: 128 * 1024,
            })
        })
        .join()
        .unwrap();
        assert!(status.affinity.failed());
        assert!(status.fifo.failed());
        assert_eq!(status.warnings().count(), 2);
        assert!(status.warnings().any(|w| w.contains("1..=99")));
        assert_eq!(status.prefaulted_stack_bytes, 128 * 1024);
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn the_timer_slack_is_minimised_and_reported() {
        let (status, slack_in_thread) = std::thread::spawn(|| {
            let status = apply_to_current_thread(&RtRequest::default());
            (status, nix::sys::prctl::get_timerslack().unwrap())
        })
        .join()
        .unwrap();
        assert_eq!(slack_in_thread, 1);
        assert_eq!(status.timer_slack_ns, Some(1));
        assert!(status.to_string().ends_with("timer slack: 1 ns"));
    }

    #[test]
    fn pinning_to_an_existing_cpu_is_applied() {
        let status = std::thread::spawn(|| {
            apply_to_current_thread(&RtRequest {
                cpu: Some(0),
                ..RtRequest::default()
            })
        })
        .join()
        .unwrap();
        assert_eq!(status.affinity, StepStatus::Applied);
    }
}
