//! A sink's output, known readable up to a mark: every byte a file sink writes goes through
//! [`SealableOutput`], which remembers where the last complete unit (an MCAP chunk with its
//! index, a CSV row) ends. When a write fails (a full disk, a revoked device), the sink cuts the
//! output back to that mark and ends it properly ([`SealableOutput::seal`]): what it holds stays
//! readable, and the sink knows exactly which records that is.
//!
//! Invariants: `mark <= position`; bytes before `mark` are complete units; once sealed, nothing
//! more reaches the target (every write fails), so no buffered remainder lands after the seal.

use std::fs::File;
use std::io::{self, Seek, SeekFrom, Write};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};

/// Where the bytes go.
enum Target {
    /// A file: cut back by truncating it.
    File(File),
    /// A caller's writer: cut back by seeking and overwriting (what lay beyond stays).
    Writer(Box<dyn WriteSeek + Send>),
}

impl Target {
    fn writer(&mut self) -> &mut dyn WriteSeek {
        match self {
            Target::File(file) => file,
            Target::Writer(writer) => &mut **writer,
        }
    }
}

/// `Write + Seek` as one object type.
pub(crate) trait WriteSeek: Write + Seek {}
impl<T: Write + Seek + ?Sized> WriteSeek for T {}

/// How the mark moves.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) enum Units {
    /// Only where the sink says ([`SealableOutput::mark_here`]): after a flush that ended an MCAP chunk.
    Marked,
    /// After every line break that reached the target (a CSV file: one row per line).
    Lines,
}

struct State {
    target: Target,
    units: Units,
    /// Bytes that reached the target.
    position: u64,
    /// Where the last complete unit ends.
    mark: u64,
    /// Line breaks before `mark` ([`Units::Lines`]).
    lines: u64,
    /// I/O errors seen, and the first one's message.
    errors: u64,
    first_error: Option<String>,
    /// Cut back and ended: nothing more is written.
    sealed: bool,
}

/// The shared handle on an output: one for the writer that fills it (a `Write + Seek`), one for
/// the sink that marks and seals it.
#[derive(Clone)]
pub(crate) struct SealableOutput(Arc<Mutex<State>>);

impl SealableOutput {
    fn new(target: Target, units: Units) -> Self {
        Self(Arc::new(Mutex::new(State {
            target,
            units,
            position: 0,
            mark: 0,
            lines: 0,
            errors: 0,
            first_error: None,
            sealed: false,
        })))
    }

    /// An output to `file` (written from its start).
    pub(crate) fn file(file: File, units: Units) -> Self {
        Self::new(Target::File(file), units)
    }

    /// An output to a caller's writer (written from where it stands).
    pub(crate) fn writer(writer: Box<dyn WriteSeek + Send>, units: Units) -> Self {
        Self::new(Target::Writer(writer), units)
    }

    fn state(&self) -> MutexGuard<'_, State> {
        self.0.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// Everything written so far ends a complete unit.
    pub(crate) fn mark_here(&self) {
        let mut state = self.state();
        state.mark = state.position;
    }

    /// Line breaks in the complete part ([`Units::Lines`]).
    pub(crate) fn lines(&self) -> u64 {
        self.state().lines
    }

    /// I/O errors so far, and the first one's message.
    pub(crate) fn errors(&self) -> (u64, Option<String>) {
        let state = self.state();
        (state.errors, state.first_error.clone())
    }

    /// Cuts the output back to the mark, writes `tail` there (the end a reader expects, e.g. an
    /// MCAP footer; may be empty) and lets nothing more through. Returns the bytes kept.
    ///
    /// # Errors
    /// The I/O error of the cut or of the tail (the output then ends at the mark, or wherever
    /// the failed write left it).
    pub(crate) fn seal(&self, tail: &[u8]) -> io::Result<u64> {
        let mut state = self.state();
        state.sealed = true;
        let mark = state.mark;
        if let Target::File(file) = &mut state.target {
            file.set_len(mark)?;
        }
        let writer = state.target.writer();
        writer.seek(SeekFrom::Start(mark))?;
        writer.write_all(tail)?;
        writer.flush()?;
        let kept = mark + tail.len() as u64;
        state.position = kept;
        Ok(kept)
    }
}

impl State {
    fn note<T>(&mut self, result: io::Result<T>) -> io::Result<T> {
        if let Err(error) = &result {
            self.errors += 1;
            self.first_error.get_or_insert_with(|| error.to_string());
        }
        result
    }
}

/// Written after the seal: refused, so that nothing lands after the output's end.
fn sealed_error() -> io::Error {
    io::Error::other("the output was ended after an earlier write error")
}

impl Write for SealableOutput {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let mut state = self.state();
        if state.sealed {
            return Err(sealed_error());
        }
        let result = state.target.writer().write(buf);
        let written = state.note(result)?;
        let start = state.position;
        state.position += written as u64;
        if state.units == Units::Lines {
            let done = &buf[..written];
            if let Some(last) = done.iter().rposition(|&b| b == b'\n') {
                state.lines += done.iter().filter(|&&b| b == b'\n').count() as u64;
                state.mark = start + last as u64 + 1;
            }
        }
        Ok(written)
    }

    fn flush(&mut self) -> io::Result<()> {
        let mut state = self.state();
        if state.sealed {
            return Err(sealed_error());
        }
        let result = state.target.writer().flush();
        state.note(result)
    }
}

impl Seek for SealableOutput {
    fn seek(&mut self, pos: SeekFrom) -> io::Result<u64> {
        let mut state = self.state();
        if state.sealed {
            return Err(sealed_error());
        }
        let result = state.target.writer().seek(pos);
        let position = state.note(result)?;
        state.position = position;
        Ok(position)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Cursor;

    /// A writer with room for `room` bytes; a write beyond takes what fits, then fails.
    struct Room {
        data: Cursor<Vec<u8>>,
        room: usize,
    }

    impl Write for Room {
        fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
            let left = self.room.saturating_sub(self.data.position() as usize);
            if left == 0 {
                return Err(io::Error::from(io::ErrorKind::StorageFull));
            }
            self.data.write(&buf[..buf.len().min(left)])
        }
        fn flush(&mut self) -> io::Result<()> {
            Ok(())
        }
    }

    impl Seek for Room {
        fn seek(&mut self, pos: SeekFrom) -> io::Result<u64> {
            self.data.seek(pos)
        }
    }

    #[test]
    fn lines_mark_the_last_complete_row_and_the_seal_cuts_back_to_it() {
        let file = tempfile::tempfile().unwrap();
        let mut output = SealableOutput::file(file.try_clone().unwrap(), Units::Lines);
        output.write_all(b"a,b\n1,2\n3,").unwrap();
        assert_eq!(output.lines(), 2);
        output.seal(b"").unwrap();
        assert!(output.write_all(b"4\n").is_err(), "nothing after the seal");
        let mut text = String::new();
        let mut file = file;
        file.seek(SeekFrom::Start(0)).unwrap();
        std::io::Read::read_to_string(&mut file, &mut text).unwrap();
        assert_eq!(text, "a,b\n1,2\n");
    }

    #[test]
    fn a_failed_write_is_counted_and_the_seal_ends_at_the_mark_with_the_tail() {
        let room = Room {
            data: Cursor::new(Vec::new()),
            room: 10,
        };
        let mut output = SealableOutput::writer(Box::new(room), Units::Marked);
        output.write_all(b"head").unwrap();
        output.mark_here();
        assert!(output.write_all(b"0123456789").is_err());
        let (errors, first) = output.errors();
        assert_eq!(errors, 1);
        assert!(first.is_some());
        assert_eq!(output.seal(b"END").unwrap(), 7);
        assert!(output.write_all(b"more").is_err(), "nothing after the seal");
    }
}
