//! Recording a bus to a candump -L file (`--log FILE`, `rmd log FILE|-`, `rmd sim --log`) so that
//! the file's reader can never hold the program: a pipe or FIFO whose reader stops reading does
//! not block the end of a command, nor its signals.
//!
//! The recorder ([`rmd_bus::record`]) never blocks the bus: its writer thread writes the queued
//! frames. A plain write to a full pipe would block that thread forever, and joining it at the
//! end would hang the program. So the writer writes through a [`LogSink`]: to a pipe, FIFO,
//! socket or terminal it writes only what the reader has room for, waiting in short polls. While
//! the command runs it waits as long as the reader needs (frames that do not fit in the
//! recorder's queue are dropped and counted). When the command ends, [`Recording::finish`] gives
//! the writer [`FINISH_LIMIT`] to write the rest; a signal (Ctrl-C, SIGTERM) ends that wait at
//! once. What was not written is counted and reported, and the command fails (exit 1, or 130
//! after a signal). Regular files are written directly.

use std::fs::File;
use std::io::{self, Write};
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};
use std::time::{Duration, Instant};

use rmd_bus::record::{LogWriter, RecordError, RecordOptions, Recorder, record};
use rmd_bus::{CanBus, Clock};
use rmd_rig::signals::{self, Signals};

use crate::output::errln;
use crate::output::report::CliError;

/// How long a command waits, once it is done, for a stalled reader of its log.
pub(crate) const FINISH_LIMIT: Duration = Duration::from_secs(5);

/// How long one wait for room in a pipe lasts before the writer looks at the limit again.
const POLL_SLICE: Duration = Duration::from_millis(20);

/// Bytes written to a pipe at a time: PIPE_BUF on Linux. A pipe that polls writable has room
/// for at least this much, so such a write never blocks, even on a descriptor shared with other
/// processes (stdout) that cannot be made non-blocking.
const PIPE_CHUNK: usize = 4096;

/// Why a writer stopped waiting for its reader.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) enum Stalled {
    /// [`FINISH_LIMIT`] went by after the command ended.
    Deadline(Duration),
    /// A signal came while the command waited.
    Signal,
}

/// When the writer of a recording stops waiting for a reader that does not read: shared by the
/// writer thread (through its [`LogSink`]) and the command that finishes the recording.
#[derive(Debug)]
pub(crate) struct GiveUp {
    /// What the log is, for messages (`/tmp/bus.log`, `stdout`).
    name: String,
    armed: OnceLock<Armed>,
    gave_up: OnceLock<Stalled>,
    waiting_said: AtomicBool,
}

#[derive(Debug)]
struct Armed {
    deadline: Instant,
    limit: Duration,
    /// The signal handler and the signals counted when the wait began.
    signals: Option<(Signals, u32)>,
}

impl GiveUp {
    fn new(name: String) -> Arc<Self> {
        Arc::new(Self {
            name,
            armed: OnceLock::new(),
            gave_up: OnceLock::new(),
            waiting_said: AtomicBool::new(false),
        })
    }

    /// Starts the final wait: from now the writer gives up after `limit`, or at the next
    /// signal. (Installs the signal policy's handler if the command had not, so that the
    /// signal is seen rather than ending the process half-way.) Only the first call counts.
    pub(crate) fn arm(&self, limit: Duration) {
        let signals = signals::install().ok().map(|s| (s, s.count()));
        let _ = self.armed.set(Armed {
            deadline: Instant::now() + limit,
            limit,
            signals,
        });
    }

    /// Why the writer gave up, if it did.
    pub(crate) fn gave_up(&self) -> Option<Stalled> {
        self.gave_up.get().copied()
    }

    /// Whether it is time to give up (and from now on, that it was).
    fn due(&self) -> Option<Stalled> {
        if let Some(reason) = self.gave_up() {
            return Some(reason);
        }
        let armed = self.armed.get()?;
        let reason = if armed
            .signals
            .is_some_and(|(signals, before)| signals.count() > before)
        {
            Stalled::Signal
        } else if Instant::now() >= armed.deadline {
            Stalled::Deadline(armed.limit)
        } else {
            return None;
        };
        Some(*self.gave_up.get_or_init(|| reason))
    }

    /// Says once, when the final wait finds the reader stalled, that the program waits for it.
    fn say_waiting(&self) {
        if let Some(armed) = self.armed.get()
            && !self.waiting_said.swap(true, Ordering::Relaxed)
        {
            errln!(
                "the reader of {} is not reading: waiting at most {} s for it (Ctrl-C gives up)",
                self.name,
                armed.limit.as_secs()
            );
        }
    }
}

/// The error a [`LogSink`] returns once it gave up on its reader.
fn stalled_error(reason: Stalled) -> io::Error {
    let text = match reason {
        Stalled::Deadline(limit) => format!(
            "the log's reader stopped reading; gave up {} s after the end",
            limit.as_secs()
        ),
        Stalled::Signal => "the log's reader stopped reading; interrupted while waiting".into(),
    };
    io::Error::new(io::ErrorKind::TimedOut, text)
}

/// Where a recording writes: a file, FIFO or stdout. Writes to a pipe, FIFO, socket or terminal
/// wait for room in short polls and give up as its [`GiveUp`] says; writes to a regular file
/// are plain writes.
#[derive(Debug)]
pub(crate) struct LogSink {
    file: File,
    /// A pipe, FIFO, socket or terminal (a reader can stall it).
    stream: bool,
    give_up: Arc<GiveUp>,
}

impl LogSink {
    /// Creates (or truncates) `path`. Opening a FIFO waits for its reader, as a shell
    /// redirection does.
    pub(crate) fn create(path: &Path) -> Result<Self, String> {
        let file =
            File::create(path).map_err(|e| format!("cannot create {}: {e}", path.display()))?;
        let stream = is_stream(&file);
        if stream {
            // Our own open file description: non-blocking affects no other process.
            set_nonblocking(&file)
                .map_err(|e| format!("cannot set up {} for writing: {e}", path.display()))?;
        }
        Ok(Self {
            file,
            stream,
            give_up: GiveUp::new(path.display().to_string()),
        })
    }

    /// Standard output (`rmd log -`). It stays blocking (its file description may be shared
    /// with the shell); writes to a pipe are kept to what the pipe has room for instead.
    pub(crate) fn stdout() -> Result<Self, String> {
        use std::os::fd::AsFd;
        let fd = io::stdout()
            .as_fd()
            .try_clone_to_owned()
            .map_err(|e| format!("cannot write to stdout: {e}"))?;
        let file = File::from(fd);
        Ok(Self {
            stream: is_stream(&file),
            file,
            give_up: GiveUp::new("stdout".to_owned()),
        })
    }

    /// When the writer gives up (shared with the writer thread).
    pub(crate) fn give_up(&self) -> Arc<GiveUp> {
        Arc::clone(&self.give_up)
    }
}

impl Write for LogSink {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        if !self.stream {
            return self.file.write(buf);
        }
        let chunk = &buf[..buf.len().min(PIPE_CHUNK)];
        loop {
            // Once given up, nothing more is written: what was not is counted as dropped.
            if let Some(reason) = self.give_up.gave_up() {
                return Err(stalled_error(reason));
            }
            if writable(&self.file, POLL_SLICE)? {
                match self.file.write(chunk) {
                    Err(error) if error.kind() == io::ErrorKind::WouldBlock => {}
                    Err(error) if error.kind() == io::ErrorKind::Interrupted => continue,
                    other => return other,
                }
            }
            if let Some(reason) = self.give_up.due() {
                return Err(stalled_error(reason));
            }
            self.give_up.say_waiting();
        }
    }

    fn flush(&mut self) -> io::Result<()> {
        self.file.flush()
    }
}

/// A pipe, FIFO, socket or terminal: something a reader drains (and can stop draining).
#[cfg(unix)]
fn is_stream(file: &File) -> bool {
    use std::os::unix::fs::FileTypeExt;
    file.metadata().is_ok_and(|m| {
        let kind = m.file_type();
        kind.is_fifo() || kind.is_socket() || kind.is_char_device()
    })
}

/// Not on this system: every file is written plainly.
#[cfg(not(unix))]
fn is_stream(_: &File) -> bool {
    false
}

/// Makes writes to `file` return `WouldBlock` instead of waiting.
#[cfg(target_os = "linux")]
fn set_nonblocking(file: &File) -> io::Result<()> {
    use nix::fcntl::{FcntlArg, OFlag, fcntl};
    let flags = OFlag::from_bits_truncate(fcntl(file, FcntlArg::F_GETFL)?);
    fcntl(file, FcntlArg::F_SETFL(flags | OFlag::O_NONBLOCK))?;
    Ok(())
}

/// Not on this system: writes block.
#[cfg(not(target_os = "linux"))]
fn set_nonblocking(_: &File) -> io::Result<()> {
    Ok(())
}

/// Waits at most `slice` for room to write in `file`; true if there is (or the reader is gone,
/// which the write then reports).
#[cfg(target_os = "linux")]
fn writable(file: &File, slice: Duration) -> io::Result<bool> {
    use nix::errno::Errno;
    use nix::poll::{PollFd, PollFlags, PollTimeout, poll};
    use std::os::fd::AsFd;
    let millis = u16::try_from(slice.as_millis()).unwrap_or(u16::MAX);
    let mut fds = [PollFd::new(file.as_fd(), PollFlags::POLLOUT)];
    match poll(&mut fds, PollTimeout::from(millis)) {
        Ok(0) | Err(Errno::EINTR) => Ok(false),
        Ok(_) => Ok(true),
        Err(errno) => Err(errno.into()),
    }
}

/// Not on this system: always writable (the write itself waits).
#[cfg(not(target_os = "linux"))]
fn writable(_: &File, _: Duration) -> io::Result<bool> {
    Ok(true)
}

/// A recording in progress: the recorder's writer thread and what finishing it needs. Finishing
/// (or dropping) it is bounded by [`FINISH_LIMIT`] and ends at a signal.
pub(crate) struct Recording {
    name: String,
    writer: Option<LogWriter<Box<dyn Write + Send>>>,
    give_up: Arc<GiveUp>,
}

impl Recording {
    /// Records `bus` (on `clock`) to `sink`; `wrap` may wrap the sink (e.g. to notice a closed
    /// stdout). Returns the recording bus to use in place of `bus`.
    pub(crate) fn start<B: CanBus, C: Clock>(
        bus: B,
        clock: C,
        sink: LogSink,
        wrap: impl FnOnce(LogSink) -> Box<dyn Write + Send>,
        options: RecordOptions,
    ) -> Result<(Recorder<B, C>, Self), String> {
        let give_up = sink.give_up();
        let name = give_up.name.clone();
        let (bus, writer) = record(bus, clock, wrap(sink), options).map_err(|e| e.to_string())?;
        Ok((
            bus,
            Self {
                name,
                writer: Some(writer),
                give_up,
            },
        ))
    }

    /// Ends the recording (stop using its bus first): writes what is queued, within
    /// [`FINISH_LIMIT`] if the reader stalls, and says on stderr what was written. The error
    /// says how many frames were not written (exit 130 if a signal ended the wait).
    pub(crate) fn finish(mut self) -> Result<(), CliError> {
        let Some(writer) = self.writer.take() else {
            return Ok(());
        };
        self.give_up.arm(FINISH_LIMIT);
        match writer.finish() {
            Ok(stats) => {
                errln!(
                    "recorded {} frames to {}{}",
                    stats.written,
                    self.name,
                    if stats.dropped > 0 {
                        format!(
                            " ({} dropped: the disk could not keep up; record to a faster disk \
                             or tmpfs)",
                            stats.dropped
                        )
                    } else {
                        String::new()
                    }
                );
                Ok(())
            }
            Err(RecordError::Write { stats, .. }) if self.give_up.gave_up().is_some() => {
                let lost = format!(
                    "{} frame(s) were not written to {} ({} written): its reader stopped reading",
                    stats.dropped, self.name, stats.written
                );
                Err(match self.give_up.gave_up() {
                    Some(Stalled::Signal) => {
                        CliError::Interrupted(format!("{lost}; stopped waiting for it"))
                    }
                    _ => CliError::Failed(format!(
                        "{lost}; gave up {} s after the end (read the log as it is written, or \
                         record to a file)",
                        FINISH_LIMIT.as_secs()
                    )),
                })
            }
            Err(error) => Err(CliError::Failed(format!("{}: {error}", self.name))),
        }
    }
}

/// A command's result once its recording finished: the command's own error first; a problem
/// with the log too is then printed on stderr rather than lost.
pub(crate) fn after(
    outcome: Result<(), CliError>,
    finished: Result<(), CliError>,
) -> Result<(), CliError> {
    match (outcome, finished) {
        (Ok(()), finished) => finished,
        (Err(error), Ok(())) => Err(error),
        (Err(error), Err(CliError::Failed(log) | CliError::Interrupted(log))) => {
            errln!("error: {log}");
            Err(error)
        }
        (Err(error), Err(_)) => Err(error),
    }
}

impl Drop for Recording {
    /// A recording dropped unfinished (an error ended the command) is still flushed, within the
    /// same bound.
    fn drop(&mut self) {
        if let Some(writer) = self.writer.take() {
            self.give_up.arm(FINISH_LIMIT);
            drop(writer);
        }
    }
}

#[cfg(all(test, target_os = "linux"))]
mod tests {
    use super::*;
    use std::io::Read;
    use std::os::fd::OwnedFd;

    /// A pipe's ends as files.
    fn pipe() -> (File, File) {
        let (read, write): (OwnedFd, OwnedFd) = nix::unistd::pipe().unwrap();
        (File::from(read), File::from(write))
    }

    fn sink_on(file: File) -> LogSink {
        set_nonblocking(&file).unwrap();
        LogSink {
            stream: is_stream(&file),
            file,
            give_up: GiveUp::new("test pipe".into()),
        }
    }

    #[test]
    fn a_pipe_is_written_as_its_reader_reads() {
        let (mut reader, writer) = pipe();
        let mut sink = sink_on(writer);
        assert!(sink.stream);
        let data = vec![b'x'; 200_000];
        let reading = std::thread::spawn(move || {
            let mut all = Vec::new();
            reader.read_to_end(&mut all).unwrap();
            all.len()
        });
        sink.write_all(&data).unwrap();
        drop(sink);
        assert_eq!(reading.join().unwrap(), data.len());
    }

    #[test]
    fn a_stalled_pipe_waits_until_the_limit_once_armed_then_refuses_more() {
        let (_reader, writer) = pipe();
        let mut sink = sink_on(writer);
        let give_up = sink.give_up();
        // Fill the pipe: nobody reads it.
        let chunk = [b'y'; PIPE_CHUNK];
        let filled = std::thread::spawn(move || {
            loop {
                if let Err(error) = sink.write_all(&chunk) {
                    return (sink, error);
                }
            }
        });
        // Not armed: the writer keeps waiting (it has not returned).
        std::thread::sleep(POLL_SLICE * 5);
        assert!(!filled.is_finished());
        give_up.arm(Duration::ZERO);
        let (mut sink, error) = filled.join().unwrap();
        assert_eq!(error.kind(), io::ErrorKind::TimedOut);
        assert_eq!(give_up.gave_up(), Some(Stalled::Deadline(Duration::ZERO)));
        assert!(sink.write(b"z").is_err());
    }

    #[test]
    fn a_regular_file_is_not_a_stream() {
        let path = std::env::temp_dir().join(format!("rmd-recording-{}", std::process::id()));
        let mut sink = LogSink::create(&path).unwrap();
        assert!(!sink.stream);
        sink.write_all(b"line\n").unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "line\n");
        let _ = std::fs::remove_file(path);
    }
}
