//! The small operating-system layer of the loop thread: CPU pinning, `SCHED_FIFO` priority,
//! memory locking, stack pre-faulting, the timer slack, and the CPU wake-up latency request
//! (`/dev/cpu_dma_latency`); where the loop's supervisor thread runs ([`place_supervisor`]);
//! and the loop thread's scheduler statistics, read by the supervisor ([`thread_stats`]).
//! The only place in rmd-loop with `unsafe` code.
//!
//! Each step is best effort: when a privilege is missing (no `CAP_SYS_NICE` / rtprio limit for
//! `SCHED_FIFO`, no `CAP_IPC_LOCK` / memlock limit for `mlockall`, no write access to
//! `/dev/cpu_dma_latency`) the loop runs anyway and the [`RtStatus`] says what was not applied
//! and how to fix it.
#![allow(unsafe_code)]

use core::time::Duration;
use std::fmt;
use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};

mod supervisor_thread;
pub mod thread_stats;

pub use supervisor_thread::{SupervisorPlacement, SupervisorRequest, place_supervisor};

/// The kernel's CPU latency request device (PM QoS): while a process holds it open with a value
/// written, no CPU enters an idle state whose exit latency exceeds that value.
pub const CPU_DMA_LATENCY_DEVICE: &str = "/dev/cpu_dma_latency";

/// Longest latency request the loop writes (the kernel's own default, "no constraint", is
/// 2000 s; anything above a second is no constraint in practice).
pub const MAX_CPU_LATENCY: Duration = Duration::from_secs(1);

/// A CPU wake-up latency request: what to write into which device.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CpuLatencyRequest {
    /// The largest acceptable CPU wake-up latency, whole microseconds (0: keep every CPU in
    /// its shallowest idle state, as `cyclictest` does while it measures). At most
    /// [`MAX_CPU_LATENCY`].
    pub max_latency: Duration,
    /// The device: [`CPU_DMA_LATENCY_DEVICE`] (tests give another path).
    pub device: PathBuf,
}

impl CpuLatencyRequest {
    /// A request of `max_latency` on [`CPU_DMA_LATENCY_DEVICE`].
    pub fn new(max_latency: Duration) -> Self {
        Self {
            max_latency,
            device: PathBuf::from(CPU_DMA_LATENCY_DEVICE),
        }
    }
}

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
    /// Hold a CPU wake-up latency request while the returned [`RtSetup`] lives.
    pub cpu_latency: Option<CpuLatencyRequest>,
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

/// What became of the CPU wake-up latency request.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum CpuLatencyStatus {
    /// Not requested (`cpu_dma_latency_us = "off"`, or no real-time setting asked for).
    NotRequested,
    /// Written and held open: no CPU enters an idle state slower to leave than this.
    Held {
        /// The latency written, microseconds.
        us: u32,
    },
    /// Requested but not held.
    Failed {
        /// The latency asked for, microseconds.
        us: u32,
        /// Why, in a few words (for the report's `real-time:` line).
        why: String,
        /// Why, and how to fix it (the report's warning).
        warning: String,
    },
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
    /// The CPU wake-up latency request (`/dev/cpu_dma_latency`).
    pub cpu_latency: CpuLatencyStatus,
    /// Bytes of stack pre-faulted.
    pub prefaulted_stack_bytes: usize,
    /// The thread's timer slack after setup, in nanoseconds, when the OS reports one. Without
    /// `SCHED_FIFO`, Linux may wake a sleeping thread up to its timer slack late (50 us by
    /// default) to batch wake-ups; the loop thread always sets its own to 1 ns (no privilege
    /// needed). Real-time threads ignore it.
    pub timer_slack_ns: Option<u64>,
    /// Where the loop's supervisor thread ran (set when it starts).
    pub supervisor: SupervisorPlacement,
}

impl RtStatus {
    /// Human-readable warnings, one per step that was requested and not applied.
    pub fn warnings(&self) -> impl Iterator<Item = &str> {
        let latency = match &self.cpu_latency {
            CpuLatencyStatus::Failed { warning, .. } => Some(warning.as_str()),
            _ => None,
        };
        [&self.affinity, &self.fifo, &self.memory_lock]
            .into_iter()
            .filter_map(|s| match s {
                StepStatus::Failed(why) => Some(why.as_str()),
                _ => None,
            })
            .chain(latency)
            .chain(self.supervisor.warnings())
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
            "cpu pinning: {}, SCHED_FIFO: {}, mlockall: {}, ",
            show(&self.affinity),
            show(&self.fifo),
            show(&self.memory_lock),
        )?;
        match &self.cpu_latency {
            CpuLatencyStatus::NotRequested => write!(f, "cpu_dma_latency: not requested")?,
            CpuLatencyStatus::Held { us } => write!(f, "cpu_dma_latency: {us} us held")?,
            CpuLatencyStatus::Failed { us, why, .. } => {
                write!(f, "cpu_dma_latency: {us} us FAILED ({why})")?
            }
        }
        write!(
            f,
            ", stack pre-faulted: {} KiB",
            self.prefaulted_stack_bytes / 1024
        )?;
        if let Some(ns) = self.timer_slack_ns {
            write!(f, ", timer slack: {ns} ns")?;
        }
        if self.supervisor != SupervisorPlacement::NotRunning {
            write!(f, ", {}", self.supervisor)?;
        }
        Ok(())
    }
}

/// A CPU wake-up latency request held open: the kernel honours it until this is dropped (the
/// device file is then closed and the request withdrawn).
#[derive(Debug)]
pub struct CpuLatencyHold {
    /// Kept open: closing it withdraws the request.
    _device: File,
    us: u32,
}

impl CpuLatencyHold {
    /// The latency held, microseconds.
    pub fn us(&self) -> u32 {
        self.us
    }
}

/// Why a CPU wake-up latency request could not be held.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum CpuLatencyError {
    /// The device file does not exist (a kernel without PM QoS, or a container without `/dev`).
    #[error(
        "could not hold the CPU latency request: {device} does not exist (a kernel without \
         CONFIG_CPU_IDLE / PM QoS, or a container without the device); deep CPU idle states may \
         add tens of microseconds to wake-ups. Fix: expose the device, or limit idle states on the \
         kernel command line (`processor.max_cstate=1 intel_idle.max_cstate=1`)"
    )]
    Missing {
        /// The device.
        device: String,
    },
    /// Opening it for writing was refused.
    #[error(
        "could not hold the CPU latency request: permission denied on {device}; deep CPU idle \
         states may add tens of microseconds to wake-ups. Fix: run as root, or give the user \
         write access to {device} (a udev rule such as `KERNEL==\"cpu_dma_latency\", \
         GROUP=\"realtime\", MODE=\"0660\"`)"
    )]
    PermissionDenied {
        /// The device.
        device: String,
    },
    /// The latency does not fit the device's 32-bit microsecond value.
    #[error(
        "could not hold the CPU latency request: {us} us is more than the {max} us allowed; use \
         a smaller cpu_dma_latency_us"
    )]
    OutOfRange {
        /// The latency asked for, microseconds.
        us: u128,
        /// The largest allowed, microseconds.
        max: u128,
    },
    /// Any other failure to open or write it.
    #[error("could not hold the CPU latency request: {action} {device} failed ({error})")]
    Io {
        /// The device.
        device: String,
        /// What was being done.
        action: &'static str,
        /// The operating system's error.
        error: String,
    },
}

impl CpuLatencyError {
    /// The reason in a few words.
    pub fn reason(&self) -> String {
        match self {
            CpuLatencyError::Missing { device } => format!("{device} does not exist"),
            CpuLatencyError::PermissionDenied { device } => {
                format!("permission denied on {device}")
            }
            CpuLatencyError::OutOfRange { us, .. } => format!("{us} us is out of range"),
            CpuLatencyError::Io {
                device,
                action,
                error,
            } => format!("{action} {device}: {error}"),
        }
    }
}

/// Writes `request.max_latency` (whole microseconds, as the native-endian 32-bit integer the
/// device expects) into `request.device` and keeps it open. Not real-time: call it before the
/// loop's first tick.
///
/// ```no_run
/// use core::time::Duration;
/// use rmd_loop::os::{CpuLatencyRequest, hold_cpu_latency};
/// let hold = hold_cpu_latency(&CpuLatencyRequest::new(Duration::ZERO))?;
/// // ... while `hold` lives, the CPUs stay out of deep idle states ...
/// drop(hold); // withdrawn
/// # Ok::<(), rmd_loop::os::CpuLatencyError>(())
/// ```
pub fn hold_cpu_latency(request: &CpuLatencyRequest) -> Result<CpuLatencyHold, CpuLatencyError> {
    let us = request.max_latency.as_micros();
    if request.max_latency > MAX_CPU_LATENCY {
        return Err(CpuLatencyError::OutOfRange {
            us,
            max: MAX_CPU_LATENCY.as_micros(),
        });
    }
    let us = us as u32; // at most 1_000_000
    let device = &request.device;
    let mut file = std::fs::OpenOptions::new()
        .write(true)
        .open(device)
        .map_err(|error| latency_io_error(device, "opening", &error))?;
    file.write_all(&(us as i32).to_ne_bytes())
        .map_err(|error| latency_io_error(device, "writing to", &error))?;
    Ok(CpuLatencyHold { _device: file, us })
}

fn latency_io_error(
    device: &Path,
    action: &'static str,
    error: &std::io::Error,
) -> CpuLatencyError {
    let device = device.display().to_string();
    match error.kind() {
        std::io::ErrorKind::NotFound => CpuLatencyError::Missing { device },
        std::io::ErrorKind::PermissionDenied => CpuLatencyError::PermissionDenied { device },
        _ => CpuLatencyError::Io {
            device,
            action,
            error: error.to_string(),
        },
    }
}

/// What [`apply_to_current_thread`] set up: the status, and the CPU latency request, held while
/// this lives.
#[derive(Debug)]
pub struct RtSetup {
    /// What was granted.
    pub status: RtStatus,
    /// The CPU latency request, if it was asked for and granted: drop it to withdraw it.
    pub cpu_latency: Option<CpuLatencyHold>,
    /// Where a supervisor of this thread should run: off its CPU, above its priority.
    pub supervisor: SupervisorRequest,
    /// This thread's scheduler statistics, for its supervisor (`None` where the kernel has
    /// none).
    pub thread_stats: Option<thread_stats::ThreadStats>,
}

/// Applies `request` to the calling thread and reports what was granted. Never fails: a step
/// that cannot be applied is reported in the returned status. The CPU latency request is held
/// until the returned [`RtSetup`] (its `cpu_latency`) is dropped.
pub fn apply_to_current_thread(request: &RtRequest) -> RtSetup {
    // Before pinning: the CPUs a supervisor may use instead of this thread's.
    let allowed = supervisor_thread::allowed_cpus().unwrap_or_default();
    let affinity = match request.cpu {
        None => StepStatus::NotRequested,
        Some(cpu) => pin_to_cpu(cpu),
    };
    let fifo = match request.fifo_priority {
        None => StepStatus::NotRequested,
        Some(prio) => set_fifo("loop", prio),
    };
    let supervisor = SupervisorRequest::for_loop(
        request.cpu.filter(|_| affinity == StepStatus::Applied),
        request
            .fifo_priority
            .filter(|_| fifo == StepStatus::Applied),
        &allowed,
    );
    let memory_lock = if request.lock_memory {
        lock_memory()
    } else {
        StepStatus::NotRequested
    };
    let (cpu_latency, hold) = match &request.cpu_latency {
        None => (CpuLatencyStatus::NotRequested, None),
        Some(latency) => match hold_cpu_latency(latency) {
            Ok(hold) => (CpuLatencyStatus::Held { us: hold.us() }, Some(hold)),
            Err(error) => (
                CpuLatencyStatus::Failed {
                    us: latency.max_latency.as_micros().min(u128::from(u32::MAX)) as u32,
                    why: error.reason(),
                    warning: error.to_string(),
                },
                None,
            ),
        },
    };
    prefault_stack(request.prefault_stack_bytes);
    RtSetup {
        status: RtStatus {
            affinity,
            fifo,
            memory_lock,
            cpu_latency,
            prefaulted_stack_bytes: request.prefault_stack_bytes.min(MAX_PREFAULT),
            timer_slack_ns: minimise_timer_slack(),
            supervisor: SupervisorPlacement::NotRunning,
        },
        cpu_latency: hold,
        supervisor,
        thread_stats: thread_stats::ThreadStats::of_current_thread(),
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

/// Switches the calling thread (the `who` thread, for the messages) to `SCHED_FIFO`.
#[cfg(target_os = "linux")]
fn set_fifo(who: &str, priority: u8) -> StepStatus {
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
            "could not switch the {who} thread to SCHED_FIFO priority {priority} ({err}); it \
             runs under the normal scheduler. Fix: run as root, or grant CAP_SYS_NICE \
             (`setcap cap_sys_nice+ep <binary>`), or raise the rtprio limit \
             (`@realtime - rtprio 99` in /etc/security/limits.d/)"
        ))
    }
}

#[cfg(not(target_os = "linux"))]
fn set_fifo(_who: &str, priority: u8) -> StepStatus {
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

    fn apply_on_new_thread(request: RtRequest) -> RtStatus {
        std::thread::spawn(move || apply_to_current_thread(&request).status)
            .join()
            .unwrap()
    }

    #[test]
    fn nothing_requested_is_fully_applied() {
        let setup = apply_to_current_thread(&RtRequest::default());
        let status = &setup.status;
        assert_eq!(status.affinity, StepStatus::NotRequested);
        assert_eq!(status.fifo, StepStatus::NotRequested);
        assert_eq!(status.memory_lock, StepStatus::NotRequested);
        assert_eq!(status.cpu_latency, CpuLatencyStatus::NotRequested);
        assert!(setup.cpu_latency.is_none());
        assert!(status.fully_applied());
        assert!(
            status
                .to_string()
                .contains("cpu_dma_latency: not requested")
        );
    }

    #[test]
    fn an_impossible_cpu_or_priority_is_reported_not_fatal() {
        let status = apply_on_new_thread(RtRequest {
            cpu: Some(100_000),
            fifo_priority: Some(0),
            prefault_stack_bytes: 128 * 1024,
            ..RtRequest::default()
        });
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
            let setup = apply_to_current_thread(&RtRequest::default());
            (setup.status, nix::sys::prctl::get_timerslack().unwrap())
        })
        .join()
        .unwrap();
        assert_eq!(slack_in_thread, 1);
        assert_eq!(status.timer_slack_ns, Some(1));
        assert!(status.to_string().ends_with("timer slack: 1 ns"));
    }

    #[test]
    fn pinning_to_an_existing_cpu_is_applied() {
        let status = apply_on_new_thread(RtRequest {
            cpu: Some(0),
            ..RtRequest::default()
        });
        assert_eq!(status.affinity, StepStatus::Applied);
    }

    /// A fresh directory for one test's files.
    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!(
            "rmd-loop-os-{name}-{}-{:?}",
            std::process::id(),
            std::thread::current().id()
        ));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// Whether this process has `path` open (a link in /proc/self/fd points at it).
    #[cfg(target_os = "linux")]
    fn is_open(path: &Path) -> bool {
        std::fs::read_dir("/proc/self/fd")
            .unwrap()
            .filter_map(|e| std::fs::read_link(e.ok()?.path()).ok())
            .any(|target| target == path)
    }

    #[test]
    fn a_missing_device_is_reported_with_its_reason_and_the_loop_goes_on() {
        let device = scratch("missing").join("cpu_dma_latency");
        let status = apply_on_new_thread(RtRequest {
            cpu_latency: Some(CpuLatencyRequest {
                max_latency: Duration::ZERO,
                device: device.clone(),
            }),
            ..RtRequest::default()
        });
        let CpuLatencyStatus::Failed { us, why, warning } = &status.cpu_latency else {
            panic!("{status:?}");
        };
        assert_eq!(*us, 0);
        assert!(why.contains("does not exist"), "{why}");
        assert!(warning.contains(&device.display().to_string()), "{warning}");
        assert!(warning.contains("Fix:"), "{warning}");
        // The real-time line says it failed and why; the warnings carry the fix.
        let line = status.to_string();
        assert!(
            line.contains(&format!(
                "cpu_dma_latency: 0 us FAILED ({} does not exist)",
                device.display()
            )),
            "{line}"
        );
        assert_eq!(status.warnings().collect::<Vec<_>>(), [warning.as_str()]);
        assert!(!status.fully_applied());
    }

    #[test]
    fn other_failures_say_what_was_done() {
        // A directory cannot be opened for writing.
        let device = scratch("dir");
        let error = hold_cpu_latency(&CpuLatencyRequest {
            max_latency: Duration::from_micros(5),
            device: device.clone(),
        })
        .unwrap_err();
        assert!(
            matches!(
                error,
                CpuLatencyError::Io {
                    action: "opening",
                    ..
                }
            ),
            "{error:?}"
        );
        assert!(error.to_string().contains(&device.display().to_string()));
        let too_long = CpuLatencyRequest {
            max_latency: MAX_CPU_LATENCY + Duration::from_micros(1),
            device: device.join("x"),
        };
        assert!(matches!(
            hold_cpu_latency(&too_long),
            Err(CpuLatencyError::OutOfRange { us: 1_000_001, .. })
        ));
        // Permission errors name the fix.
        let denied = latency_io_error(
            Path::new("/dev/cpu_dma_latency"),
            "opening",
            &std::io::Error::from_raw_os_error(13),
        );
        assert!(matches!(denied, CpuLatencyError::PermissionDenied { .. }));
        assert!(denied.to_string().contains("run as root"), "{denied}");
        assert_eq!(denied.reason(), "permission denied on /dev/cpu_dma_latency");
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn the_request_is_written_held_while_the_setup_lives_and_released_after() {
        let device = scratch("held").join("cpu_dma_latency");
        std::fs::write(&device, []).unwrap();
        let request = RtRequest {
            cpu_latency: Some(CpuLatencyRequest {
                max_latency: Duration::from_micros(7),
                device: device.clone(),
            }),
            ..RtRequest::default()
        };
        let setup = apply_to_current_thread(&request);
        assert_eq!(setup.status.cpu_latency, CpuLatencyStatus::Held { us: 7 });
        assert!(
            setup
                .status
                .to_string()
                .contains("cpu_dma_latency: 7 us held")
        );
        assert_eq!(setup.cpu_latency.as_ref().map(CpuLatencyHold::us), Some(7));
        // The device's format: one native-endian 32-bit integer, microseconds.
        assert_eq!(std::fs::read(&device).unwrap(), 7i32.to_ne_bytes());
        assert!(is_open(&device));
        drop(setup);
        assert!(!is_open(&device));
    }
}
