//! Where the loop's supervisor thread runs: off the loop's CPU and one `SCHED_FIFO` priority
//! above it. A loop thread that never gives its CPU away (a controller stuck in a busy loop at
//! real-time priority) must not be able to keep its own watchdog from running: a thread of the
//! same priority on the same CPU would only run once the loop thread blocks.
//!
//! The loop thread decides the placement when it sets itself up ([`SupervisorRequest::for_loop`],
//! from the CPUs it was allowed before pinning itself); the supervisor thread applies it to
//! itself first thing ([`place_supervisor`]), and the report's `real-time:` line says where it
//! ran ([`SupervisorPlacement`]).

use std::fmt;

use super::StepStatus;

/// Where the supervisor thread should run.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SupervisorRequest {
    /// The CPUs it may run on: every CPU the loop thread was allowed before it pinned itself,
    /// but the loop's. `None`: keep what it inherits from the loop thread.
    pub cpus: Option<Vec<usize>>,
    /// Its `SCHED_FIFO` priority: the loop's plus one (at most 99). `None`: keep what it
    /// inherits.
    pub fifo_priority: Option<u8>,
    /// The loop's CPU, when the supervisor has to share it (the loop was allowed no other).
    pub shares_loop_cpu: Option<usize>,
}

impl SupervisorRequest {
    /// The placement for the supervisor of a loop thread pinned to `loop_cpu` (if pinning was
    /// applied) at `loop_fifo` (if `SCHED_FIFO` was applied), which was allowed `allowed_cpus`
    /// before it pinned itself.
    ///
    /// ```
    /// use rmd_loop::os::SupervisorRequest;
    /// let r = SupervisorRequest::for_loop(Some(1), Some(80), &[0, 1, 2, 3]);
    /// assert_eq!(r.cpus, Some(vec![0, 2, 3]));
    /// assert_eq!(r.fifo_priority, Some(81));
    /// // The loop's only CPU: shared, and the priority above the loop's is what lets it run.
    /// let alone = SupervisorRequest::for_loop(Some(0), Some(99), &[0]);
    /// assert_eq!((alone.cpus, alone.fifo_priority, alone.shares_loop_cpu), (None, Some(99), Some(0)));
    /// ```
    pub fn for_loop(
        loop_cpu: Option<usize>,
        loop_fifo: Option<u8>,
        allowed_cpus: &[usize],
    ) -> Self {
        let (cpus, shares_loop_cpu) = match loop_cpu {
            None => (None, None),
            Some(cpu) => {
                let others: Vec<usize> =
                    allowed_cpus.iter().copied().filter(|&c| c != cpu).collect();
                if others.is_empty() {
                    (None, Some(cpu))
                } else {
                    (Some(others), None)
                }
            }
        };
        Self {
            cpus,
            fifo_priority: loop_fifo.map(|p| p.saturating_add(1).min(99)),
            shares_loop_cpu,
        }
    }
}

/// Where the supervisor thread ran (the report's `real-time:` line).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum SupervisorPlacement {
    /// No supervisor in this run (a loop without [`supervise`](crate::RtLoop::supervise)).
    #[default]
    NotRunning,
    /// It ran.
    Running {
        /// What it asked for.
        request: SupervisorRequest,
        /// Moving it off the loop's CPU.
        affinity: StepStatus,
        /// Its `SCHED_FIFO` priority.
        fifo: StepStatus,
    },
}

impl SupervisorPlacement {
    /// Why a requested step was not applied, and how to fix it.
    pub fn warnings(&self) -> impl Iterator<Item = &str> {
        let steps = match self {
            SupervisorPlacement::NotRunning => [None, None],
            SupervisorPlacement::Running { affinity, fifo, .. } => [Some(affinity), Some(fifo)],
        };
        steps.into_iter().flatten().filter_map(|s| match s {
            StepStatus::Failed(why) => Some(why.as_str()),
            _ => None,
        })
    }
}

impl fmt::Display for SupervisorPlacement {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let SupervisorPlacement::Running {
            request,
            affinity,
            fifo,
        } = self
        else {
            return write!(f, "supervisor: none");
        };
        write!(f, "supervisor: ")?;
        match (&request.cpus, request.shares_loop_cpu, affinity) {
            (_, _, StepStatus::Failed(_)) => write!(f, "off the loop's CPU FAILED")?,
            (Some(cpus), _, _) => {
                let list: Vec<String> = cpus.iter().map(ToString::to_string).collect();
                write!(f, "CPU {}", list.join(","))?
            }
            (None, Some(cpu), _) => write!(f, "on the loop's CPU {cpu} (no other allowed)")?,
            (None, None, _) => write!(f, "any CPU")?,
        }
        match (request.fifo_priority, fifo) {
            (Some(p), StepStatus::Applied) => write!(f, ", SCHED_FIFO {p}"),
            (Some(p), _) => write!(f, ", SCHED_FIFO {p} FAILED"),
            (None, _) => write!(f, ", normal scheduler"),
        }
    }
}

/// Applies `request` to the calling thread (the supervisor's, before its first look).
pub fn place_supervisor(request: &SupervisorRequest) -> SupervisorPlacement {
    let affinity = match &request.cpus {
        None => StepStatus::NotRequested,
        Some(cpus) => set_affinity(cpus),
    };
    let fifo = match request.fifo_priority {
        None => StepStatus::NotRequested,
        Some(p) => super::set_fifo("supervisor", p),
    };
    SupervisorPlacement::Running {
        request: request.clone(),
        affinity,
        fifo,
    }
}

/// The CPUs the calling thread may run on (`None`: unknown).
#[cfg(target_os = "linux")]
pub(crate) fn allowed_cpus() -> Option<Vec<usize>> {
    use nix::sched::{CpuSet, sched_getaffinity};
    use nix::unistd::Pid;
    let set = sched_getaffinity(Pid::from_raw(0)).ok()?;
    Some(
        (0..CpuSet::count())
            .filter(|&c| set.is_set(c).unwrap_or(false))
            .collect(),
    )
}

#[cfg(not(target_os = "linux"))]
pub(crate) fn allowed_cpus() -> Option<Vec<usize>> {
    None
}

#[cfg(target_os = "linux")]
fn set_affinity(cpus: &[usize]) -> StepStatus {
    use nix::sched::{CpuSet, sched_setaffinity};
    use nix::unistd::Pid;
    let mut set = CpuSet::new();
    for &cpu in cpus {
        if set.set(cpu).is_err() {
            return StepStatus::Failed(format!("CPU {cpu} is beyond what the kernel supports"));
        }
    }
    match sched_setaffinity(Pid::from_raw(0), &set) {
        Ok(()) => StepStatus::Applied,
        Err(errno) => StepStatus::Failed(format!(
            "could not move the supervisor thread off the loop's CPU ({errno}); it shares the \
             loop's CPU, where a controller that never yields can keep it from running. Fix: \
             allow the process more than one CPU"
        )),
    }
}

#[cfg(not(target_os = "linux"))]
fn set_affinity(_cpus: &[usize]) -> StepStatus {
    StepStatus::Failed("moving the supervisor thread is only supported on Linux".to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_unpinned_loop_leaves_the_supervisor_where_it_is() {
        let r = SupervisorRequest::for_loop(None, None, &[0, 1]);
        assert_eq!(r, SupervisorRequest::default());
        let p = std::thread::spawn(move || place_supervisor(&r))
            .join()
            .unwrap();
        assert_eq!(p.warnings().count(), 0);
        assert_eq!(p.to_string(), "supervisor: any CPU, normal scheduler");
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn the_supervisor_moves_off_the_loops_cpu() {
        let allowed = allowed_cpus().unwrap();
        if allowed.len() < 2 {
            eprintln!("skipped: one CPU allowed");
            return;
        }
        let loop_cpu = allowed[0];
        let r = SupervisorRequest::for_loop(Some(loop_cpu), None, &allowed);
        let (placement, after) = std::thread::spawn(move || {
            // Inherited from the loop thread, as the real supervisor's is.
            assert!(core_affinity::set_for_current(core_affinity::CoreId {
                id: loop_cpu
            }));
            (place_supervisor(&r), allowed_cpus().unwrap())
        })
        .join()
        .unwrap();
        assert!(!after.contains(&loop_cpu), "{after:?}");
        assert_eq!(after, allowed[1..]);
        assert_eq!(placement.warnings().count(), 0);
        assert!(
            placement.to_string().starts_with("supervisor: CPU "),
            "{placement}"
        );
    }

    #[test]
    fn a_priority_out_of_reach_is_reported() {
        let r = SupervisorRequest {
            fifo_priority: Some(0),
            ..SupervisorRequest::default()
        };
        let p = std::thread::spawn(move || place_supervisor(&r))
            .join()
            .unwrap();
        assert_eq!(p.warnings().count(), 1);
        assert!(p.to_string().ends_with("SCHED_FIFO 0 FAILED"), "{p}");
    }
}
