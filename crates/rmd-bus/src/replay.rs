//! Playing a `candump -L` log back with its original timing, in real or virtual time.
//!
//! [`LogReader`] streams a log (`(seconds.fraction) interface ID#DATA [T|R]` lines, as
//! `candump -L` and [`record`](crate::record) write them) as [`LogRecord`]s, one line at a time
//! (at most [`MAX_LINE_BYTES`] held: a longer line is a [`BadLine`], skipped without being
//! read into memory), keeping the lines it cannot use as [`BadLine`]s instead of giving up;
//! [`read_log`] collects a whole log. [`ReplaySchedule`] maps each record's timestamp to the
//! instant it is due on a [`Clock`], at the original pace, scaled, or as fast as possible, with
//! pauses longer than a cap shortened to it ([`ReplaySchedule::max_gap`]).
//! [`ReplayBus`] is a [`CanBus`] that yields recorded frames at those instants (e.g. the
//! received frames of a session, to run a decoder or a controller against them offline); a
//! tool that plays a log onto an interface sends each record when it is due.
//!
//! ```
//! use core::time::Duration;
//! use rmd_bus::candump::FrameDirection;
//! use rmd_bus::replay::{read_log, Pace, ReplayBus};
//! use rmd_bus::{BusMessage, CanBus, Clock, VirtualClock};
//!
//! let log = "(1700000000.000000) can0 141#9C00000000000000 T\n\
//!            (1700000000.000400) can0 141#9C19000000000000 R\n\
//!            (1700000000.010000) can0 141#9C00000000000000 T\n\
//!            (1700000000.010450) can0 141#9C1A000000000000 R\n";
//! let parsed = read_log(log.as_bytes())?;
//! assert!(parsed.bad_lines.is_empty());
//! // The frames the motors sent, at their original times (virtual time: instant and exact).
//! let received = parsed.records.into_iter().filter(|r| r.direction == Some(FrameDirection::Rx));
//! let clock = VirtualClock::new();
//! let mut bus = ReplayBus::new(clock.clone(), received, Pace::Original);
//! let first = bus.recv_until(clock.now() + Duration::from_secs(1)).unwrap().unwrap();
//! assert_eq!(first.at.as_nanos(), 0); // the first replayed frame is due at once
//! let second = bus.recv_until(clock.now() + Duration::from_secs(1)).unwrap().unwrap();
//! assert_eq!(second.at.as_nanos(), 10_050_000); // 10.05 ms after the first
//! assert!(matches!(second.message, BusMessage::Frame(f) if f.data()[1] == 0x1A));
//! # Ok::<(), std::io::Error>(())
//! ```

use core::time::Duration;
use std::collections::VecDeque;
use std::io::{self, BufRead};

/// The longest log line read, in bytes (line break excluded). A `candump -L` line of a classic
/// CAN frame is under 60 bytes, of a CAN FD frame under 200; a longer line is not a frame.
pub const MAX_LINE_BYTES: usize = 1024;

use crate::candump::{CandumpError, FrameDirection, parse_line};
use crate::{BusError, BusMessage, CanBus, CanFrame, Clock, Received, Timestamp};

/// One frame of a log.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LogRecord {
    /// Line number in the log (1-based).
    pub line: usize,
    /// The line's timestamp (time since the Unix epoch for `candump -L`).
    pub timestamp: Duration,
    /// The interface the line names.
    pub interface: String,
    /// candump's direction marker, if the line has one.
    pub direction: Option<FrameDirection>,
    /// The frame.
    pub frame: CanFrame,
}

/// Why a line of a log was not used.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum LineProblem {
    /// The line is not a valid candump line.
    #[error(transparent)]
    Candump(#[from] CandumpError),
    /// The line has no `(seconds.fraction)` timestamp, so it cannot be replayed in time.
    #[error("no (seconds.fraction) timestamp: replay needs candump -L lines")]
    MissingTimestamp,
    /// The line has no interface name.
    #[error("no interface name: replay needs candump -L lines `(time) interface ID#DATA`")]
    MissingInterface,
    /// The line is not valid UTF-8.
    #[error("not valid UTF-8 text")]
    NotText,
    /// The line is longer than [`MAX_LINE_BYTES`]: no candump line is; it was skipped unread.
    #[error("longer than {limit} bytes ({bytes} bytes): not a candump line, not read")]
    TooLong {
        /// The line's length, bytes.
        bytes: u64,
        /// [`MAX_LINE_BYTES`].
        limit: usize,
    },
}

/// A line of a log that was not used, and why.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("line {line}: {problem}")]
pub struct BadLine {
    /// Line number (1-based).
    pub line: usize,
    /// What is wrong with it.
    pub problem: LineProblem,
}

/// A log read by [`read_log`]: the usable records in file order, and the lines skipped.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ParsedLog {
    /// The records.
    pub records: Vec<LogRecord>,
    /// The lines that could not be used (blank lines are neither).
    pub bad_lines: Vec<BadLine>,
}

/// Reads a whole `candump -L` log into memory (see [`LogReader`] to stream one). Every usable
/// line becomes a [`LogRecord`]; every other non-blank line a [`BadLine`] (the rest is still
/// read). Fails only on an I/O error.
pub fn read_log<R: BufRead>(reader: R) -> io::Result<ParsedLog> {
    let mut parsed = ParsedLog::default();
    for item in LogReader::new(reader) {
        match item? {
            Ok(record) => parsed.records.push(record),
            Err(bad) => parsed.bad_lines.push(bad),
        }
    }
    Ok(parsed)
}

/// A `candump -L` log, line by line: each non-blank line is `Ok(record)` or `Err(bad line)`;
/// the iterator's own `Err` is an I/O error (it ends there). At most [`MAX_LINE_BYTES`] of a
/// line are held in memory: a longer line is skipped up to its line break, unread, and is a
/// [`LineProblem::TooLong`].
///
/// ```
/// use rmd_bus::replay::{LineProblem, LogReader, MAX_LINE_BYTES};
/// let log = format!("(1.0) can0 141#00\n{}\n(2.0) can0 141#01\n", "x".repeat(5000));
/// let lines: Vec<_> = LogReader::new(log.as_bytes()).collect::<Result<_, _>>()?;
/// assert_eq!(lines.len(), 3);
/// assert_eq!(lines[2].as_ref().unwrap().line, 3);
/// let bad = lines[1].as_ref().unwrap_err();
/// assert_eq!(bad.problem, LineProblem::TooLong { bytes: 5000, limit: MAX_LINE_BYTES });
/// # Ok::<(), std::io::Error>(())
/// ```
#[derive(Debug)]
pub struct LogReader<R> {
    reader: R,
    line: usize,
    buffer: Vec<u8>,
    done: bool,
}

impl<R: BufRead> LogReader<R> {
    /// Reads `reader` from where it stands.
    pub fn new(reader: R) -> Self {
        Self {
            reader,
            line: 0,
            buffer: Vec::with_capacity(128),
            done: false,
        }
    }

    /// The next line into `self.buffer` (without its line break), or its length if it is too
    /// long to hold; `None` at the end.
    fn next_line(&mut self) -> io::Result<Option<Result<(), u64>>> {
        self.buffer.clear();
        let mut length = 0u64;
        let mut any = false;
        loop {
            let chunk = match self.reader.fill_buf() {
                Ok(chunk) => chunk,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(e),
            };
            if chunk.is_empty() {
                return Ok(any.then(|| held(length)));
            }
            any = true;
            let (part, end) = match chunk.iter().position(|&b| b == b'\n') {
                Some(at) => (&chunk[..at], Some(at + 1)),
                None => (chunk, None),
            };
            length += part.len() as u64;
            if length <= MAX_LINE_BYTES as u64 {
                self.buffer.extend_from_slice(part);
            }
            let used = end.unwrap_or(chunk.len());
            self.reader.consume(used);
            if end.is_some() {
                return Ok(Some(held(length)));
            }
        }
    }
}

/// `Ok` for a line that fits the limit, its length otherwise.
fn held(length: u64) -> Result<(), u64> {
    if length <= MAX_LINE_BYTES as u64 {
        Ok(())
    } else {
        Err(length)
    }
}

impl<R: BufRead> Iterator for LogReader<R> {
    type Item = io::Result<Result<LogRecord, BadLine>>;

    fn next(&mut self) -> Option<Self::Item> {
        while !self.done {
            let read = match self.next_line() {
                Ok(Some(read)) => read,
                Ok(None) => {
                    self.done = true;
                    return None;
                }
                Err(e) => {
                    self.done = true;
                    return Some(Err(e));
                }
            };
            self.line += 1;
            let line = self.line;
            let bad = |problem| Some(Ok(Err(BadLine { line, problem })));
            if let Err(bytes) = read {
                return bad(LineProblem::TooLong {
                    bytes,
                    limit: MAX_LINE_BYTES,
                });
            }
            let Ok(text) = std::str::from_utf8(&self.buffer) else {
                return bad(LineProblem::NotText);
            };
            if text.trim().is_empty() {
                continue;
            }
            return Some(Ok(
                record_of(line, text).map_err(|problem| BadLine { line, problem })
            ));
        }
        None
    }
}

fn record_of(line: usize, text: &str) -> Result<LogRecord, LineProblem> {
    let parsed = parse_line(text)?;
    Ok(LogRecord {
        line,
        timestamp: parsed.timestamp.ok_or(LineProblem::MissingTimestamp)?,
        interface: parsed.interface.ok_or(LineProblem::MissingInterface)?,
        direction: parsed.direction,
        frame: parsed.frame,
    })
}

/// How fast a log is played back.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum Pace {
    /// With the original spacing between frames.
    Original,
    /// `speed` times faster than the original (2.0: twice as fast; 0.5: half speed). Must be
    /// finite and above zero (see [`Pace::scaled`]).
    Scaled(f64),
    /// Every frame due at once, in file order.
    AsFastAsPossible,
}

/// A playback speed that is not a finite number above zero.
#[derive(Copy, Clone, Debug, PartialEq, thiserror::Error)]
#[error("replay speed {0} is not a finite number above 0 (1 is the original pace)")]
pub struct InvalidSpeed(pub f64);

impl Pace {
    /// The pace `speed` times the original: [`Pace::Original`] for 1.
    ///
    /// ```
    /// use rmd_bus::replay::Pace;
    /// assert_eq!(Pace::scaled(1.0), Ok(Pace::Original));
    /// assert_eq!(Pace::scaled(4.0), Ok(Pace::Scaled(4.0)));
    /// assert!(Pace::scaled(0.0).is_err() && Pace::scaled(f64::NAN).is_err());
    /// ```
    pub fn scaled(speed: f64) -> Result<Self, InvalidSpeed> {
        if !(speed.is_finite() && speed > 0.0) {
            Err(InvalidSpeed(speed))
        } else if speed == 1.0 {
            Ok(Pace::Original)
        } else {
            Ok(Pace::Scaled(speed))
        }
    }
}

/// When each record of a log is due on a clock, taken in log order: the first record at
/// `start`, each next one after the one before by their timestamp difference (scaled by the
/// pace). A timestamp earlier than one before it is due at once (never before the previous
/// record). With [`max_gap`](Self::max_gap), a pause longer than the cap is played as the cap
/// (and [`Due::shortened`] says so): a log with a gap of years still plays.
///
/// ```
/// use core::time::Duration;
/// use rmd_bus::Timestamp;
/// use rmd_bus::replay::{Pace, ReplaySchedule};
/// let first = Duration::from_secs(1_700_000_000);
/// let start = Timestamp::from_nanos(5_000);
/// let mut schedule = ReplaySchedule::new(first, start, Pace::Scaled(2.0))
///     .max_gap(Duration::from_secs(10));
/// assert_eq!(schedule.next(first).at, start);
/// assert_eq!(schedule.next(first + Duration::from_millis(10)).at, start + Duration::from_millis(5));
/// // Eight years later in the log: played 10 s later.
/// let due = schedule.next(first + Duration::from_secs(8 * 365 * 86_400));
/// assert_eq!(due.at, start + Duration::from_millis(5) + Duration::from_secs(10));
/// assert!(due.shortened.unwrap() > Duration::from_secs(4 * 365 * 86_400 - 1)); // at 2x
/// ```
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ReplaySchedule {
    pace: Pace,
    max_gap: Option<Duration>,
    /// The latest timestamp taken so far (the first record's before any).
    latest: Duration,
    /// When the record of `latest` was due.
    at: Timestamp,
}

/// When a record is due, and whether the pause before it was shortened.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct Due {
    /// The instant it is due.
    pub at: Timestamp,
    /// The pause before it as the log has it (scaled by the pace), when longer than the cap
    /// and played as the cap instead.
    pub shortened: Option<Duration>,
}

impl ReplaySchedule {
    /// A schedule whose record stamped `first` is due at `start`, without a cap on pauses.
    pub fn new(first: Duration, start: Timestamp, pace: Pace) -> Self {
        Self {
            pace,
            max_gap: None,
            latest: first,
            at: start,
        }
    }

    /// Plays any pause longer than `gap` (after the pace's scaling) as `gap`.
    pub fn max_gap(mut self, gap: Duration) -> Self {
        self.max_gap = Some(gap);
        self
    }

    /// When the next record, stamped `timestamp`, is due (records are taken in log order).
    pub fn next(&mut self, timestamp: Duration) -> Due {
        let recorded = timestamp.saturating_sub(self.latest);
        self.latest = self.latest.max(timestamp);
        let played = match self.pace {
            Pace::Original => recorded,
            Pace::Scaled(speed) => {
                Duration::try_from_secs_f64(recorded.as_secs_f64() / speed).unwrap_or(Duration::MAX)
            }
            Pace::AsFastAsPossible => Duration::ZERO,
        };
        let (pause, shortened) = match self.max_gap {
            Some(cap) if played > cap => (cap, Some(played)),
            _ => (played, None),
        };
        self.at += pause;
        Due {
            at: self.at,
            shortened,
        }
    }
}

/// A [`CanBus`] that receives the frames of a log at their scheduled times (on its clock, from
/// the time it is created) and accepts every frame sent to it (counted, not checked).
///
/// `recv_until` waits on the clock like a real bus: for the next frame if it is due by the
/// deadline (it is returned stamped with its due time), else until the deadline. In virtual
/// time this is exact and instant; in real time it sleeps.
#[derive(Debug)]
pub struct ReplayBus<C> {
    clock: C,
    frames: VecDeque<(Timestamp, CanFrame)>,
    sent: u64,
}

impl<C: Clock> ReplayBus<C> {
    /// A bus that will receive `records` (in their order) at the times `pace` gives them,
    /// starting now on `clock`. Timestamps that go backwards are played at once (never
    /// before the previous frame).
    pub fn new(clock: C, records: impl IntoIterator<Item = LogRecord>, pace: Pace) -> Self {
        let records: Vec<LogRecord> = records.into_iter().collect();
        let start = clock.now();
        let mut frames = VecDeque::with_capacity(records.len());
        if let Some(first) = records.first() {
            let mut schedule = ReplaySchedule::new(first.timestamp, start, pace);
            for record in records {
                frames.push_back((schedule.next(record.timestamp).at, record.frame));
            }
        }
        Self {
            clock,
            frames,
            sent: 0,
        }
    }

    /// Frames not yet received.
    pub fn remaining(&self) -> usize {
        self.frames.len()
    }

    /// Frames sent to the bus so far.
    pub fn sent(&self) -> u64 {
        self.sent
    }

    /// The clock.
    pub fn clock(&self) -> &C {
        &self.clock
    }
}

impl<C: Clock> CanBus for ReplayBus<C> {
    fn send(&mut self, _frame: &CanFrame) -> Result<(), BusError> {
        self.sent += 1;
        Ok(())
    }

    fn recv_until(&mut self, deadline: Timestamp) -> Result<Option<Received>, BusError> {
        match self.frames.front() {
            Some(&(due, frame)) if due <= deadline => {
                self.clock.sleep_until(due);
                self.frames.pop_front();
                Ok(Some(Received {
                    at: due,
                    message: BusMessage::Frame(frame),
                }))
            }
            _ => {
                self.clock.sleep_until(deadline);
                Ok(None)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::VirtualClock;

    const LOG: &str = "\
(1700000000.000000) can0 280#6400000000000000 T
(1700000000.000300) can0 141#A119000000000000 R

(1700000000.001000) can0 280#6400000000000000 T
this is not a frame
141#9C00000000000000
(1700000000.001310) can0 141#A11A000000000000 R
(1700000000.001200) can0 142#A11A000000000000 R
";

    #[test]
    fn reading_keeps_good_lines_and_names_the_bad_ones() {
        let parsed = read_log(LOG.as_bytes()).unwrap();
        let lines: Vec<_> = parsed.records.iter().map(|r| r.line).collect();
        assert_eq!(lines, [1, 2, 4, 7, 8]);
        assert_eq!(parsed.records[1].direction, Some(FrameDirection::Rx));
        assert_eq!(parsed.records[1].interface, "can0");
        assert_eq!(
            parsed.bad_lines,
            [
                BadLine {
                    line: 5,
                    problem: LineProblem::Candump(CandumpError::Unrecognized)
                },
                BadLine {
                    line: 6,
                    problem: LineProblem::MissingTimestamp
                }
            ]
        );
        assert_eq!(
            parsed.bad_lines[1].to_string(),
            "line 6: no (seconds.fraction) timestamp: replay needs candump -L lines"
        );
    }

    #[test]
    fn an_over_long_line_is_skipped_unread_and_the_rest_is_read() {
        let long = "1".repeat(3 * MAX_LINE_BYTES);
        let log = format!("(1.0) can0 141#00\n(2.0) can0 141#{long}\n(3.0) can0 141#01");
        // A small buffer: the long line spans many reads, none of which is kept.
        let reader = io::BufReader::with_capacity(64, log.as_bytes());
        let parsed = read_log(reader).unwrap();
        assert_eq!(
            parsed.records.iter().map(|r| r.line).collect::<Vec<_>>(),
            [1, 3]
        );
        assert_eq!(
            parsed.bad_lines,
            [BadLine {
                line: 2,
                problem: LineProblem::TooLong {
                    bytes: (3 * MAX_LINE_BYTES + 15) as u64,
                    limit: MAX_LINE_BYTES
                }
            }]
        );
        // A line of exactly the limit is read.
        let exact = format!("(1.0) can0 141#00{}", " ".repeat(MAX_LINE_BYTES - 17));
        assert_eq!(exact.len(), MAX_LINE_BYTES);
        assert_eq!(read_log(exact.as_bytes()).unwrap().records.len(), 1);
    }

    #[test]
    fn a_gap_longer_than_the_cap_is_played_as_the_cap() {
        let second = Duration::from_secs(1);
        let mut schedule =
            ReplaySchedule::new(second, Timestamp::ZERO, Pace::Original).max_gap(second * 2);
        let times: Vec<(u64, Option<u64>)> = [1, 2, 1000, 1001, 1000, 1003]
            .into_iter()
            .map(|s| {
                let due = schedule.next(second * s);
                (
                    due.at.as_nanos() / 1_000_000_000,
                    due.shortened.map(|d| d.as_secs()),
                )
            })
            .collect();
        // 998 s cut to 2; a step back plays at once; then on from the latest timestamp.
        assert_eq!(
            times,
            [
                (0, None),
                (1, None),
                (3, Some(998)),
                (4, None),
                (4, None),
                (6, None)
            ]
        );
        // Even a gap of centuries, at the slowest pace, stays representable.
        let mut slow = ReplaySchedule::new(Duration::ZERO, Timestamp::ZERO, Pace::Scaled(0.001))
            .max_gap(second * 10);
        slow.next(Duration::ZERO);
        let due = slow.next(Duration::from_secs(u64::MAX / 2));
        assert_eq!(due.at, Timestamp::ZERO + second * 10);
        assert_eq!(due.shortened, Some(Duration::MAX));
    }

    #[test]
    fn invalid_utf8_is_a_bad_line_not_an_error() {
        let bytes = b"(1.0) can0 141#00\n\xff\xfe\n(2.0) can0 141#01\n";
        let parsed = read_log(&bytes[..]).unwrap();
        assert_eq!(parsed.records.len(), 2);
        assert_eq!(parsed.bad_lines[0].problem, LineProblem::NotText);
    }

    fn received_times(pace: Pace) -> Vec<u64> {
        let parsed = read_log(LOG.as_bytes()).unwrap();
        let clock = VirtualClock::starting_at(Timestamp::from_nanos(1_000_000_000));
        let mut bus = ReplayBus::new(clock.clone(), parsed.records, pace);
        let mut times = Vec::new();
        while let Some(rx) = bus
            .recv_until(clock.now() + Duration::from_secs(10))
            .unwrap()
        {
            // The bus waited for the frame on the clock: time is the frame's due time.
            assert_eq!(clock.now(), rx.at);
            times.push(rx.at.as_nanos() - 1_000_000_000);
        }
        times
    }

    #[test]
    fn frames_come_at_their_original_times_in_virtual_time() {
        // The last line is earlier than the one before it: played right after it, not before.
        assert_eq!(
            received_times(Pace::Original),
            [0, 300_000, 1_000_000, 1_310_000, 1_310_000]
        );
        assert_eq!(
            received_times(Pace::Scaled(2.0)),
            [0, 150_000, 500_000, 655_000, 655_000]
        );
        assert_eq!(received_times(Pace::AsFastAsPossible), [0; 5]);
    }

    #[test]
    fn a_deadline_before_the_next_frame_returns_nothing_at_the_deadline() {
        let parsed = read_log(LOG.as_bytes()).unwrap();
        let clock = VirtualClock::new();
        let mut bus = ReplayBus::new(clock.clone(), parsed.records, Pace::Original);
        assert!(bus.recv_until(Timestamp::ZERO).unwrap().is_some());
        let deadline = Timestamp::from_nanos(100_000);
        assert!(bus.recv_until(deadline).unwrap().is_none());
        assert_eq!(clock.now(), deadline);
        assert_eq!(bus.remaining(), 4);
        bus.send(&CanFrame::with_data(0x141, [0x9C, 0, 0, 0, 0, 0, 0, 0]).unwrap())
            .unwrap();
        assert_eq!(bus.sent(), 1);
        // Past the end: nothing, for ever.
        while bus
            .recv_until(clock.now() + Duration::from_secs(1))
            .unwrap()
            .is_some()
        {}
        assert_eq!(bus.remaining(), 0);
        let later = clock.now() + Duration::from_secs(1);
        assert!(bus.recv_until(later).unwrap().is_none());
        assert_eq!(clock.now(), later);
    }

    #[test]
    fn an_empty_log_replays_nothing() {
        let clock = VirtualClock::new();
        let mut bus = ReplayBus::new(clock.clone(), Vec::new(), Pace::Original);
        assert!(bus.recv_until(Timestamp::from_nanos(5)).unwrap().is_none());
    }
}
