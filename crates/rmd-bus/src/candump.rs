//! candump's text formats: parse a line of any of them, write `candump -L` log lines.
//!
//! Three formats are read, each with or without a leading `(seconds.fraction)` timestamp and with
//! or without candump's direction marker (`-x`):
//!
//! | format | example |
//! |---|---|
//! | compact (`cansend` syntax) | `141#9C00000000000000` |
//! | log file (`candump -L` / `-l`) | `(1700000000.123456) can0 141#9C00000000000000` (`-x` appends ` T` or ` R`) |
//! | default text | `can0  141   [8]  9C 00 00 00 00 00 00 00` (`-x`: `can0  TX - -  141   [8]  ...`) |
//!
//! Data bytes in the compact forms may be separated by `.` (candump's `-S` off / `cansend`
//! style), hex is case-insensitive, and the default text may end with candump's `-a` ASCII column
//! (`'........'`), which is ignored. The RMD protocol only uses classic CAN data frames with
//! standard (11-bit) IDs, so extended IDs, remote frames and CAN FD frames are typed errors.
//!
//! ```
//! use rmd_bus::candump::{parse_line, FrameDirection, LogLine};
//! use core::time::Duration;
//!
//! let line = parse_line("(1700000000.123456) can0 141#9C00000000000000 R").unwrap();
//! assert_eq!(line.timestamp, Some(Duration::new(1_700_000_000, 123_456_000)));
//! assert_eq!(line.interface.as_deref(), Some("can0"));
//! assert_eq!(line.direction, Some(FrameDirection::Rx));
//! assert_eq!(line.frame.to_string(), "141#9C00000000000000");
//!
//! let default = parse_line("  can0  TX - -  141   [8]  A1 00 00 00 64 00 00 00").unwrap();
//! assert_eq!(default.direction, Some(FrameDirection::Tx));
//! assert_eq!(default.frame.data()[4], 0x64);
//!
//! let log = LogLine::new(Duration::new(12, 500_000_000), "can0", default.frame);
//! assert_eq!(log.to_string(), "(0000000012.500000) can0 141#A100000064000000");
//! ```

use core::fmt;
use core::str::FromStr;
use core::time::Duration;

use rmd_protocol::CanFrame;

/// Which way a frame went, as seen by the host that recorded the log (candump `-x`).
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum FrameDirection {
    /// Sent by the logging host (`TX`, or ` T` in log files).
    Tx,
    /// Received by the logging host (`RX`, or ` R` in log files).
    Rx,
}

impl fmt::Display for FrameDirection {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            FrameDirection::Tx => "TX",
            FrameDirection::Rx => "RX",
        })
    }
}

/// One parsed candump line: the frame and whatever context the format carried.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CandumpLine {
    /// The `(seconds.fraction)` timestamp, as a duration since the log's epoch (the Unix epoch
    /// for `-L` and `-t a`; the first or previous frame for `-t z` / `-t d`).
    pub timestamp: Option<Duration>,
    /// The CAN interface name (`can0`), absent in the compact form.
    pub interface: Option<String>,
    /// candump's direction marker, if the line has one.
    pub direction: Option<FrameDirection>,
    /// The frame.
    pub frame: CanFrame,
}

impl CandumpLine {
    /// The line as a `candump -L` log line, if it has a timestamp and an interface.
    pub fn log_line(&self) -> Option<LogLine<'_>> {
        Some(LogLine {
            timestamp: self.timestamp?,
            interface: self.interface.as_deref()?,
            direction: self.direction,
            frame: self.frame,
        })
    }
}

impl FromStr for CandumpLine {
    type Err = CandumpError;
    fn from_str(s: &str) -> Result<Self, CandumpError> {
        parse_line(s)
    }
}

/// What is wrong with a candump line.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum CandumpError {
    /// The line is empty (or only whitespace).
    #[error("empty line")]
    Empty,
    /// A `(` without its closing `)`.
    #[error("timestamp `{0}` has no closing `)`")]
    UnterminatedTimestamp(String),
    /// The timestamp is not `seconds.fraction`.
    #[error("bad timestamp `({0})`: expected (seconds.fraction), e.g. (1700000000.123456)")]
    BadTimestamp(String),
    /// Nothing after the timestamp and interface.
    #[error("missing frame")]
    MissingFrame,
    /// The CAN ID is not hexadecimal or has the wrong number of digits.
    #[error("bad CAN ID `{0}`: expected 3 hex digits (standard ID)")]
    BadCanId(String),
    /// A standard ID above 0x7FF.
    #[error("CAN ID 0x{0:X} is above 0x7FF, the largest standard ID")]
    CanIdTooLarge(u32),
    /// An extended (29-bit) ID: the RMD protocol uses standard IDs only.
    #[error("extended CAN ID {0:08X} is not supported: the RMD protocol uses standard 11-bit IDs")]
    ExtendedId(u32),
    /// A remote (RTR) frame.
    #[error("remote frame (RTR) on CAN ID {0}: the RMD protocol uses data frames only")]
    RemoteFrame(String),
    /// A CAN FD frame (`ID##...`).
    #[error("CAN FD frame on CAN ID {0}: the RMD protocol uses classic CAN frames")]
    CanFd(String),
    /// The data is not hex byte pairs.
    #[error("bad data `{0}`: expected hex byte pairs, e.g. 9C00000000000000")]
    BadData(String),
    /// More than 8 data bytes.
    #[error("{0} data bytes: a classic CAN frame has at most 8")]
    TooManyBytes(usize),
    /// The `[N]` length field is malformed.
    #[error("bad length `{0}`: expected [0]..[8]")]
    BadLength(String),
    /// The `[N]` length does not match the number of data bytes.
    #[error("length [{len}] but {bytes} data bytes")]
    LengthMismatch {
        /// The length field.
        len: usize,
        /// The number of data bytes on the line.
        bytes: usize,
    },
    /// The line has none of candump's layouts.
    #[error(
        "not a candump line: expected `ID#DATA`, `(time) interface ID#DATA` or `interface ID [N] DATA`"
    )]
    Unrecognized,
    /// Something follows the frame that candump does not write there.
    #[error("unexpected `{0}` after the frame")]
    Trailing(String),
}

/// Parses one line in any of candump's text formats (see the module docs).
///
/// Leading and trailing whitespace (including a line break) is ignored.
pub fn parse_line(line: &str) -> Result<CandumpLine, CandumpError> {
    let mut rest = line.trim();
    if rest.is_empty() {
        return Err(CandumpError::Empty);
    }
    let mut timestamp = None;
    if let Some(after) = rest.strip_prefix('(') {
        let close = after
            .find(')')
            .ok_or_else(|| CandumpError::UnterminatedTimestamp(rest.to_string()))?;
        timestamp = Some(parse_timestamp(&after[..close])?);
        rest = &after[close + 1..];
    }
    let tokens: Vec<&str> = rest.split_whitespace().collect();
    let Some(&first) = tokens.first() else {
        return Err(CandumpError::MissingFrame);
    };

    // Compact form, alone or after an interface name: `[if] ID#DATA [T|R]`.
    let compact_at = if first.contains('#') {
        Some(0)
    } else if tokens.get(1).is_some_and(|t| t.contains('#')) {
        Some(1)
    } else {
        None
    };
    if let Some(at) = compact_at {
        let frame = parse_compact_frame(tokens[at])?;
        let direction = match &tokens[at + 1..] {
            [] => None,
            ["T"] => Some(FrameDirection::Tx),
            ["R"] => Some(FrameDirection::Rx),
            more => return Err(CandumpError::Trailing(more.join(" "))),
        };
        return Ok(CandumpLine {
            timestamp,
            interface: (at == 1).then(|| first.to_string()),
            direction,
            frame,
        });
    }

    // Default text: `if [TX|RX flag flag] ID [N] BYTES... ['ascii']`.
    let interface = first.to_string();
    let mut i = 1;
    let direction = match tokens.get(i) {
        Some(&"TX") => Some(FrameDirection::Tx),
        Some(&"RX") => Some(FrameDirection::Rx),
        _ => None,
    };
    if direction.is_some() {
        // candump -x writes two flag columns after the direction: BRS (`B`/`-`), ESI (`E`/`-`).
        i += 3;
    }
    // Without an `ID [N]` pair this is no candump line at all; say so rather than blame a token.
    let (Some(id_text), Some(len_text)) = (tokens.get(i), tokens.get(i + 1)) else {
        return Err(CandumpError::Unrecognized);
    };
    if !len_text.starts_with('[') {
        return Err(CandumpError::Unrecognized);
    }
    let id = parse_id(id_text)?;
    let len = parse_length(len_text)?;
    let after_len = &tokens[i + 2..];
    if after_len.first() == Some(&"remote") {
        return Err(CandumpError::RemoteFrame(id_text.to_string()));
    }
    let byte_tokens: Vec<&str> = after_len
        .iter()
        .copied()
        .take_while(|t| !t.starts_with('\''))
        .collect();
    let ascii = &after_len[byte_tokens.len()..];
    let is_ascii_column = |t: &[&str]| {
        t.first().is_some_and(|f| f.starts_with('\''))
            && t.last().is_some_and(|l| l.ends_with('\''))
    };
    if !ascii.is_empty() && !is_ascii_column(ascii) {
        return Err(CandumpError::Trailing(ascii.join(" ")));
    }
    if byte_tokens.len() > 8 {
        return Err(CandumpError::TooManyBytes(byte_tokens.len()));
    }
    let mut data = Vec::with_capacity(byte_tokens.len());
    for t in &byte_tokens {
        if t.len() != 2 {
            return Err(CandumpError::BadData(t.to_string()));
        }
        data.push(u8::from_str_radix(t, 16).map_err(|_| CandumpError::BadData(t.to_string()))?);
    }
    if data.len() != len {
        return Err(CandumpError::LengthMismatch {
            len,
            bytes: data.len(),
        });
    }
    Ok(CandumpLine {
        timestamp,
        interface: Some(interface),
        direction,
        frame: make_frame(id, &data)?,
    })
}

/// Parses a frame in the compact form `ID#DATA` (`141#9C00000000000000`, `141#9C.00.00`).
///
/// ```
/// use rmd_bus::candump::parse_compact_frame;
/// let frame = parse_compact_frame("141#9c.00.00.00.00.00.00.00").unwrap();
/// assert_eq!(frame.to_string(), "141#9C00000000000000");
/// assert!(parse_compact_frame("141#R").is_err());
/// ```
pub fn parse_compact_frame(text: &str) -> Result<CanFrame, CandumpError> {
    let (id_text, data_text) = text
        .split_once('#')
        .ok_or_else(|| CandumpError::BadData(text.to_string()))?;
    let id = parse_id(id_text)?;
    if data_text.starts_with('#') {
        return Err(CandumpError::CanFd(id_text.to_string()));
    }
    if data_text.starts_with(['R', 'r']) {
        return Err(CandumpError::RemoteFrame(id_text.to_string()));
    }
    let digits: String = data_text.chars().filter(|&c| c != '.').collect();
    if !digits.len().is_multiple_of(2) || !digits.chars().all(|c| c.is_ascii_hexdigit()) {
        return Err(CandumpError::BadData(data_text.to_string()));
    }
    if digits.len() > 16 {
        return Err(CandumpError::TooManyBytes(digits.len() / 2));
    }
    let data: Vec<u8> = (0..digits.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&digits[i..i + 2], 16))
        .collect::<Result<_, _>>()
        .map_err(|_| CandumpError::BadData(data_text.to_string()))?;
    make_frame(id, &data)
}

fn make_frame(id: u16, data: &[u8]) -> Result<CanFrame, CandumpError> {
    // parse_id guarantees id <= 0x7FF and callers at most 8 bytes, so this cannot fail; map the
    // error anyway rather than panic.
    CanFrame::new(id, data).map_err(|_| CandumpError::CanIdTooLarge(u32::from(id)))
}

/// A standard ID: 1..=3 hex digits, at most 0x7FF. Eight digits is an extended ID.
fn parse_id(text: &str) -> Result<u16, CandumpError> {
    if text.is_empty() || !text.chars().all(|c| c.is_ascii_hexdigit()) {
        return Err(CandumpError::BadCanId(text.to_string()));
    }
    match text.len() {
        1..=3 => {
            let id = u32::from_str_radix(text, 16)
                .map_err(|_| CandumpError::BadCanId(text.to_string()))?;
            if id > 0x7FF {
                Err(CandumpError::CanIdTooLarge(id))
            } else {
                Ok(id as u16)
            }
        }
        8 => Err(CandumpError::ExtendedId(
            u32::from_str_radix(text, 16).map_err(|_| CandumpError::BadCanId(text.to_string()))?,
        )),
        _ => Err(CandumpError::BadCanId(text.to_string())),
    }
}

/// `[N]` (candump also writes `[08]` in some versions).
fn parse_length(text: &str) -> Result<usize, CandumpError> {
    let inner = text
        .strip_prefix('[')
        .and_then(|t| t.strip_suffix(']'))
        .ok_or_else(|| CandumpError::BadLength(text.to_string()))?;
    match inner.parse::<usize>() {
        Ok(n) if n <= 8 && !inner.is_empty() && inner.len() <= 2 => Ok(n),
        _ => Err(CandumpError::BadLength(text.to_string())),
    }
}

/// `seconds[.fraction]` with at most 9 fraction digits.
fn parse_timestamp(text: &str) -> Result<Duration, CandumpError> {
    let bad = || CandumpError::BadTimestamp(text.to_string());
    let (secs, frac) = text.split_once('.').unwrap_or((text, ""));
    let all_digits = |s: &str| s.chars().all(|c| c.is_ascii_digit());
    if secs.is_empty() || !all_digits(secs) || !all_digits(frac) || frac.len() > 9 {
        return Err(bad());
    }
    let secs: u64 = secs.parse().map_err(|_| bad())?;
    let mut nanos: u32 = if frac.is_empty() {
        0
    } else {
        frac.parse().map_err(|_| bad())?
    };
    for _ in frac.len()..9 {
        nanos *= 10;
    }
    Ok(Duration::new(secs, nanos))
}

/// A `candump -L` log line, `(seconds.micros) interface ID#DATA` (with ` T` / ` R` appended when
/// the direction is known, as candump `-L -x` writes it). Formatting allocates nothing.
///
/// ```
/// use core::time::Duration;
/// use rmd_bus::candump::{parse_line, FrameDirection, LogLine};
/// use rmd_bus::CanFrame;
/// let frame = CanFrame::new(0x280, &[0x64, 0, 0x9C, 0xFF, 0, 0, 0, 0]).unwrap();
/// let line = LogLine::new(Duration::new(1_700_000_000, 123_456_789), "can0", frame)
///     .with_direction(FrameDirection::Tx);
/// assert_eq!(line.to_string(), "(1700000000.123456) can0 280#64009CFF00000000 T");
/// assert_eq!(parse_line(&line.to_string()).unwrap().frame, frame);
/// ```
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct LogLine<'a> {
    /// Time since the Unix epoch (written with microsecond resolution, truncated, like candump).
    pub timestamp: Duration,
    /// Interface name.
    pub interface: &'a str,
    /// Direction marker, written as ` T` / ` R` when present.
    pub direction: Option<FrameDirection>,
    /// The frame.
    pub frame: CanFrame,
}

impl<'a> LogLine<'a> {
    /// A log line without direction marker.
    pub fn new(timestamp: Duration, interface: &'a str, frame: CanFrame) -> Self {
        Self {
            timestamp,
            interface,
            direction: None,
            frame,
        }
    }

    /// The same line with a direction marker.
    pub fn with_direction(self, direction: FrameDirection) -> Self {
        Self {
            direction: Some(direction),
            ..self
        }
    }
}

impl fmt::Display for LogLine<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "({:010}.{:06}) {} {}",
            self.timestamp.as_secs(),
            self.timestamp.subsec_micros(),
            self.interface,
            self.frame
        )?;
        match self.direction {
            Some(FrameDirection::Tx) => f.write_str(" T"),
            Some(FrameDirection::Rx) => f.write_str(" R"),
            None => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(id: u16, data: &[u8]) -> CanFrame {
        CanFrame::new(id, data).unwrap()
    }

    const STATUS2: [u8; 8] = [0x9C, 0, 0, 0, 0, 0, 0, 0];

    #[test]
    fn compact_form() {
        let l = parse_line("141#9C00000000000000").unwrap();
        assert_eq!(
            l,
            CandumpLine {
                timestamp: None,
                interface: None,
                direction: None,
                frame: frame(0x141, &STATUS2)
            }
        );
        assert_eq!(
            parse_line("  141#9c.00.00.00.00.00.00.00 \n")
                .unwrap()
                .frame,
            frame(0x141, &STATUS2)
        );
        assert_eq!(parse_line("7FF#").unwrap().frame, frame(0x7FF, &[]));
        assert_eq!(parse_line("1#01").unwrap().frame, frame(0x001, &[1]));
    }

    #[test]
    fn log_form_with_and_without_direction() {
        let l = parse_line("(1700000000.123456) can0 141#9C00000000000000").unwrap();
        assert_eq!(l.timestamp, Some(Duration::new(1_700_000_000, 123_456_000)));
        assert_eq!(l.interface.as_deref(), Some("can0"));
        assert_eq!(l.direction, None);
        assert_eq!(l.frame, frame(0x141, &STATUS2));
        let l = parse_line("(1700000000.123456) vcan12 141#9C00000000000000 T").unwrap();
        assert_eq!(l.direction, Some(FrameDirection::Tx));
        assert_eq!(l.interface.as_deref(), Some("vcan12"));
        // Round trip through the formatter.
        assert_eq!(
            l.log_line().unwrap().to_string(),
            "(1700000000.123456) vcan12 141#9C00000000000000 T"
        );
    }

    #[test]
    fn default_text_form() {
        let l = parse_line("  can0  141   [8]  9C 00 00 00 00 00 00 00").unwrap();
        assert_eq!(l.interface.as_deref(), Some("can0"));
        assert_eq!((l.timestamp, l.direction), (None, None));
        assert_eq!(l.frame, frame(0x141, &STATUS2));
        let l = parse_line("  can0  RX - -  142   [8]  A1 19 00 08 FF FF FF 3F").unwrap();
        assert_eq!(l.direction, Some(FrameDirection::Rx));
        assert_eq!(
            l.frame,
            frame(0x142, &[0xA1, 0x19, 0x00, 0x08, 0xFF, 0xFF, 0xFF, 0x3F])
        );
        let l =
            parse_line(" (1700000000.000001)  can1  TX B E  280   [08]  64 00 9C FF 00 00 D0 07")
                .unwrap();
        assert_eq!(l.timestamp, Some(Duration::new(1_700_000_000, 1_000)));
        assert_eq!(l.direction, Some(FrameDirection::Tx));
        assert_eq!(l.frame.id(), 0x280);
        // -t d / -t z style timestamps and candump -a ASCII column.
        let l = parse_line("(000.000250)  can0  141   [2]  9C 41   '.A'").unwrap();
        assert_eq!(l.timestamp, Some(Duration::from_micros(250)));
        assert_eq!(l.frame, frame(0x141, &[0x9C, 0x41]));
        let l = parse_line("can0  141   [0]").unwrap();
        assert_eq!(l.frame.dlc(), 0);
    }

    #[test]
    fn errors_say_what_is_wrong() {
        let cases: &[(&str, CandumpError)] = &[
            ("", CandumpError::Empty),
            ("   ", CandumpError::Empty),
            (
                "(1700000000.1 can0 141#00",
                CandumpError::UnterminatedTimestamp("(1700000000.1 can0 141#00".into()),
            ),
            (
                "(17x.1) can0 141#00",
                CandumpError::BadTimestamp("17x.1".into()),
            ),
            (
                "(1.1234567890) can0 141#00",
                CandumpError::BadTimestamp("1.1234567890".into()),
            ),
            (
                "(2021-05-10 15:02:46.148635) can0 141#00",
                CandumpError::BadTimestamp("2021-05-10 15:02:46.148635".into()),
            ),
            ("(1.0)", CandumpError::MissingFrame),
            ("14G#00", CandumpError::BadCanId("14G".into())),
            ("1412#00", CandumpError::BadCanId("1412".into())),
            ("800#00", CandumpError::CanIdTooLarge(0x800)),
            ("12345678#00", CandumpError::ExtendedId(0x1234_5678)),
            ("141#R", CandumpError::RemoteFrame("141".into())),
            ("141##0112233", CandumpError::CanFd("141".into())),
            ("141#9C0", CandumpError::BadData("9C0".into())),
            ("141#9CZZ", CandumpError::BadData("9CZZ".into())),
            ("141#000000000000000000", CandumpError::TooManyBytes(9)),
            ("141#00 X", CandumpError::Trailing("X".into())),
            ("can0 141#00 T R", CandumpError::Trailing("T R".into())),
            ("can0  141   [9]  00", CandumpError::BadLength("[9]".into())),
            ("can0  141   8  00", CandumpError::Unrecognized),
            ("can0  141", CandumpError::Unrecognized),
            ("this is not a frame", CandumpError::Unrecognized),
            ("can0  14X   [1]  00", CandumpError::BadCanId("14X".into())),
            ("can0  141   [x]  00", CandumpError::BadLength("[x]".into())),
            (
                "can0  141   [8]  9C 00",
                CandumpError::LengthMismatch { len: 8, bytes: 2 },
            ),
            ("can0  141   [2]  9C 0", CandumpError::BadData("0".into())),
            ("can0  141   [2]  9C XY", CandumpError::BadData("XY".into())),
            (
                "can0  141   [1]  remote request",
                CandumpError::RemoteFrame("141".into()),
            ),
            (
                "can0  141   [1]  00 'x' trailing",
                CandumpError::Trailing("'x' trailing".into()),
            ),
            ("can0", CandumpError::Unrecognized),
        ];
        for (line, err) in cases {
            assert_eq!(parse_line(line).as_ref(), Err(err), "line {line:?}");
        }
    }

    #[test]
    fn log_line_formatting() {
        let f = frame(0x141, &STATUS2);
        assert_eq!(
            LogLine::new(Duration::new(0, 999_999_999), "can0", f).to_string(),
            "(0000000000.999999) can0 141#9C00000000000000"
        );
        assert_eq!(
            LogLine::new(Duration::new(1, 0), "can0", f)
                .with_direction(FrameDirection::Rx)
                .to_string(),
            "(0000000001.000000) can0 141#9C00000000000000 R"
        );
        let no_ts = parse_line("can0 141#00").unwrap();
        assert!(no_ts.log_line().is_none());
    }
}
