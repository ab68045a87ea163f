//! A thread's scheduler statistics, read from another thread: how long it ran on a CPU, how
//! long it waited for one while runnable, and its state now. The supervisor reads the loop
//! thread's to tell a stall the OS caused (the thread was not run) from a controller that
//! spins or blocks.
//!
//! Linux keeps them in `/proc/<pid>/task/<tid>/schedstat` (`sum_exec_runtime`, `run_delay`, in
//! nanoseconds; kernels with `CONFIG_SCHED_INFO`, which distribution kernels have) and the state
//! in `.../stat`. The thread opens its own (`/proc/thread-self/...`) once, before its first
//! tick; reading them again is a `pread` at offset 0 of the open file: no allocation, no
//! `unsafe`, nothing on the loop thread.

use core::time::Duration;
use std::fs::File;

/// What the scheduler says about a thread at one instant.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct SchedSample {
    /// Time it has run on a CPU, in all.
    pub ran: Duration,
    /// Time it has waited, runnable, for a CPU, in all.
    pub waited: Duration,
}

impl SchedSample {
    /// What happened between `earlier` and this sample.
    pub fn since(&self, earlier: &SchedSample) -> SchedSample {
        SchedSample {
            ran: self.ran.saturating_sub(earlier.ran),
            waited: self.waited.saturating_sub(earlier.waited),
        }
    }
}

/// A thread's state, from its `stat` file.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum ThreadState {
    /// Running or runnable (`R`).
    Runnable,
    /// Sleeping, interruptibly (`S`, `I`).
    Sleeping,
    /// In an uninterruptible wait, usually I/O in the kernel (`D`).
    Blocked,
    /// Stopped by a signal (`SIGSTOP`, `SIGTSTP`) or a debugger (`T`, `t`).
    Stopped,
    /// Anything else (exiting, dead).
    Other,
}

/// The scheduler statistics of one thread, opened by that thread ([`of_current_thread`]) and
/// readable from any thread.
///
/// [`of_current_thread`]: ThreadStats::of_current_thread
#[derive(Debug)]
pub struct ThreadStats {
    schedstat: File,
    stat: File,
}

impl ThreadStats {
    /// The calling thread's statistics, or `None` where the kernel does not give them (not
    /// Linux, no `/proc`, a kernel without `CONFIG_SCHED_INFO`).
    pub fn of_current_thread() -> Option<Self> {
        let stats = Self {
            schedstat: File::open("/proc/thread-self/schedstat").ok()?,
            stat: File::open("/proc/thread-self/stat").ok()?,
        };
        stats.sample().map(|_| stats)
    }

    /// The thread's CPU time and run-queue wait so far (`None` if it cannot be read, e.g. the
    /// thread has exited).
    pub fn sample(&self) -> Option<SchedSample> {
        let mut buf = [0u8; 96];
        let n = read_at_start(&self.schedstat, &mut buf)?;
        parse_schedstat(&buf[..n])
    }

    /// The thread's state now.
    pub fn state(&self) -> Option<ThreadState> {
        // `pid (comm) S ...`: the state follows the last `)` (a thread name may hold one).
        let mut buf = [0u8; 128];
        let n = read_at_start(&self.stat, &mut buf)?;
        let text = &buf[..n];
        let close = text.iter().rposition(|&b| b == b')')?;
        let state = *text.get(close + 2)?;
        Some(match state {
            b'R' => ThreadState::Runnable,
            b'S' | b'I' => ThreadState::Sleeping,
            b'D' => ThreadState::Blocked,
            b'T' | b't' => ThreadState::Stopped,
            _ => ThreadState::Other,
        })
    }
}

#[cfg(unix)]
fn read_at_start(file: &File, buf: &mut [u8]) -> Option<usize> {
    use std::os::unix::fs::FileExt;
    file.read_at(buf, 0).ok().filter(|&n| n > 0)
}

#[cfg(not(unix))]
fn read_at_start(_file: &File, _buf: &mut [u8]) -> Option<usize> {
    None
}

/// `"<ran ns> <waited ns> <timeslices>\n"`.
fn parse_schedstat(text: &[u8]) -> Option<SchedSample> {
    let text = core::str::from_utf8(text).ok()?;
    let mut fields = text.split_ascii_whitespace();
    let mut next = || fields.next()?.parse::<u64>().ok().map(Duration::from_nanos);
    Some(SchedSample {
        ran: next()?,
        waited: next()?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn schedstat_lines_parse_and_garbage_does_not() {
        assert_eq!(
            parse_schedstat(b"41765771 238606566 26\n"),
            Some(SchedSample {
                ran: Duration::from_nanos(41_765_771),
                waited: Duration::from_nanos(238_606_566),
            })
        );
        assert_eq!(parse_schedstat(b""), None);
        assert_eq!(parse_schedstat(b"12"), None);
        assert_eq!(parse_schedstat(b"x y z"), None);
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn another_thread_reads_a_threads_cpu_time_and_state() {
        use std::sync::mpsc;
        let (tx, rx) = mpsc::channel();
        let (go, wait) = mpsc::channel::<()>();
        let worker = std::thread::spawn(move || {
            tx.send(ThreadStats::of_current_thread().unwrap()).unwrap();
            // Sleeps until told, then spins for 30 ms of its own CPU time.
            wait.recv().unwrap();
            let stats = ThreadStats::of_current_thread().unwrap();
            let start = stats.sample().unwrap();
            while stats.sample().unwrap().since(&start).ran < Duration::from_millis(30) {}
            wait.recv().unwrap();
        });
        let stats = rx.recv().unwrap();
        std::thread::sleep(Duration::from_millis(20));
        assert_eq!(stats.state(), Some(ThreadState::Sleeping));
        let before = stats.sample().unwrap();
        go.send(()).unwrap();
        // Read from this thread while the worker spins (on a loaded machine it may take long).
        let spun = loop {
            let now = stats.sample().unwrap().since(&before);
            if now.ran >= Duration::from_millis(30) {
                break now;
            }
            std::thread::sleep(Duration::from_millis(5));
        };
        assert!(spun.ran >= Duration::from_millis(30), "{spun:?}");
        go.send(()).unwrap();
        worker.join().unwrap();
        // The thread is gone: nothing to read, nothing panics.
        assert_eq!(stats.sample(), None);
    }
}
