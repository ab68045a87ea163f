//! Writing to stdout and stderr without ever panicking (`println!` and `eprintln!` panic when
//! the other end of a pipe is gone, e.g. `rmd status --sim 1-4 | head -2`).
//!
//! - stdout ([`outln!`](crate::output::outln), [`write_all`]): a write that fails because the
//!   reader closed the pipe returns [`WriteError::Closed`], which a command turns into
//!   [`CliError::OutputClosed`](crate::output::report::CliError::OutputClosed): it stops
//!   writing and ends quietly (a command that moved motors still turns them off first). Any
//!   other write error is a failure (exit 1).
//! - stderr ([`errln!`](crate::output::errln)): messages for the user, written if anyone
//!   listens; a closed stderr is ignored, so that the command still finishes its job.

use std::fmt;
use std::io::{self, Write};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// Set once a write to stdout found the pipe closed: later writes fail at once.
static STDOUT_CLOSED: AtomicBool = AtomicBool::new(false);

/// Why a write to stdout failed.
#[derive(Debug, thiserror::Error)]
pub(crate) enum WriteError {
    /// The reader went away (a closed pipe): nobody reads the output any more.
    #[error("standard output was closed")]
    Closed,
    /// Anything else (a full disk, a revoked terminal).
    #[error("cannot write the output: {0}")]
    Failed(#[source] io::Error),
}

impl WriteError {
    /// Sorts an I/O error: a broken pipe is [`Closed`](Self::Closed).
    pub(crate) fn from_io(error: io::Error) -> Self {
        if error.kind() == io::ErrorKind::BrokenPipe {
            WriteError::Closed
        } else {
            WriteError::Failed(error)
        }
    }
}

/// Writes `args` and a newline to stdout, and flushes.
pub(crate) fn out_line(args: fmt::Arguments<'_>) -> Result<(), WriteError> {
    write_stdout(|out| {
        out.write_fmt(args)?;
        out.write_all(b"\n")
    })
}

/// Writes `args` to stdout as it is (no newline added), and flushes.
pub(crate) fn out_text(args: fmt::Arguments<'_>) -> Result<(), WriteError> {
    write_stdout(|out| out.write_fmt(args))
}

/// Writes `bytes` to stdout, and flushes.
pub(crate) fn write_all(bytes: &[u8]) -> Result<(), WriteError> {
    write_stdout(|out| out.write_all(bytes))
}

fn write_stdout(
    write: impl FnOnce(&mut io::StdoutLock<'static>) -> io::Result<()>,
) -> Result<(), WriteError> {
    if STDOUT_CLOSED.load(Ordering::Relaxed) {
        return Err(WriteError::Closed);
    }
    let mut out = io::stdout().lock();
    write(&mut out).and_then(|()| out.flush()).map_err(|error| {
        let error = WriteError::from_io(error);
        if matches!(error, WriteError::Closed) {
            STDOUT_CLOSED.store(true, Ordering::Relaxed);
        }
        error
    })
}

/// Writes `args` and a newline to stderr, if it can (errors are ignored).
pub(crate) fn err_line(args: fmt::Arguments<'_>) {
    let mut err = io::stderr().lock();
    let _ = err.write_fmt(args).and_then(|()| err.write_all(b"\n"));
}

/// A sink that notes when its reader goes away, for writers on other threads (the recorder of
/// `rmd log -`): [`closed`](Self::closed) tells the command to stop.
#[derive(Debug)]
pub(crate) struct WatchedSink<W> {
    inner: W,
    closed: Arc<AtomicBool>,
}

impl<W: Write> WatchedSink<W> {
    /// Wraps `inner`; the returned flag turns true when a write finds the pipe closed.
    pub(crate) fn new(inner: W) -> (Self, Arc<AtomicBool>) {
        let closed = Arc::new(AtomicBool::new(false));
        (
            WatchedSink {
                inner,
                closed: Arc::clone(&closed),
            },
            closed,
        )
    }

    fn note<T>(&self, result: io::Result<T>) -> io::Result<T> {
        if let Err(error) = &result
            && error.kind() == io::ErrorKind::BrokenPipe
        {
            self.closed.store(true, Ordering::Relaxed);
        }
        result
    }
}

impl<W: Write> Write for WatchedSink<W> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let result = self.inner.write(buf);
        self.note(result)
    }

    fn flush(&mut self) -> io::Result<()> {
        let result = self.inner.flush();
        self.note(result)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::report::CliError;

    /// A writer whose reader has gone.
    struct Broken;

    impl Write for Broken {
        fn write(&mut self, _: &[u8]) -> io::Result<usize> {
            Err(io::Error::from(io::ErrorKind::BrokenPipe))
        }
        fn flush(&mut self) -> io::Result<()> {
            Ok(())
        }
    }

    #[test]
    fn a_broken_pipe_is_a_quiet_end_other_errors_are_failures() {
        assert!(matches!(
            CliError::from(WriteError::Failed(io::Error::from(
                io::ErrorKind::StorageFull
            ))),
            CliError::Failed(message) if message.starts_with("cannot write the output")
        ));
        assert!(matches!(
            CliError::from(WriteError::from_io(io::Error::from(
                io::ErrorKind::BrokenPipe
            ))),
            CliError::OutputClosed
        ));
    }

    #[test]
    fn a_watched_sink_raises_its_flag_on_a_broken_pipe_only() {
        let (mut sink, closed) = WatchedSink::new(Vec::new());
        sink.write_all(b"fine").unwrap();
        assert!(!closed.load(Ordering::Relaxed));
        let (mut sink, closed) = WatchedSink::new(Broken);
        assert!(sink.write_all(b"gone").is_err());
        assert!(closed.load(Ordering::Relaxed));
    }
}
