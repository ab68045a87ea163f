//! Reading input line by line in bounded memory: a line longer than [`MAX_LINE`] bytes is that
//! line's error, and the reader skips to the next newline without keeping what it skips.
//!
//! `BufRead::split` and `read_until` on the whole input keep a line however long it is, so a
//! stream without newlines (`rmd decode </dev/zero`) grows without bound. Here every read goes
//! through a `take` of at most one byte more than the limit, and the rest of an overlong line is
//! read into the same buffer and dropped, chunk by chunk.

use std::io::{self, BufRead, Read};

/// The longest line accepted, in bytes (without the newline). candump lines of classic CAN
/// frames are under 100 bytes; CAN FD `-L` lines under 200.
pub(crate) const MAX_LINE: usize = 4096;

/// One line of input.
#[derive(Debug, PartialEq, Eq)]
pub(crate) enum Line<'a> {
    /// The line's bytes, without the newline (and without a carriage return before it).
    Text(&'a [u8]),
    /// A line longer than the limit: its bytes were skipped up to the next newline.
    TooLong,
}

/// Reads lines of at most `limit` bytes from `input`.
pub(crate) struct Lines<R> {
    input: R,
    limit: usize,
    buffer: Vec<u8>,
}

impl<R: BufRead> Lines<R> {
    /// Lines of `input`, each at most `limit` bytes.
    pub(crate) fn new(input: R, limit: usize) -> Self {
        Self {
            input,
            limit,
            buffer: Vec::with_capacity(limit.saturating_add(1).min(MAX_LINE + 1)),
        }
    }

    /// The next line, `None` at the end of the input. An overlong line is reported as
    /// [`Line::TooLong`] as soon as the limit is passed; the rest of it is skipped before the
    /// next line is read (so an endless line, such as `/dev/zero`, is reported at once and then
    /// skipped in bounded memory until the input ends).
    pub(crate) fn next_line(&mut self) -> io::Result<Option<Line<'_>>> {
        self.buffer.clear();
        let bound = self.limit as u64 + 1;
        let read = (&mut self.input)
            .take(bound)
            .read_until(b'\n', &mut self.buffer)?;
        if read == 0 {
            return Ok(None);
        }
        if self.buffer.last() == Some(&b'\n') {
            self.buffer.pop();
            if self.buffer.last() == Some(&b'\r') {
                self.buffer.pop();
            }
            return Ok(Some(Line::Text(&self.buffer)));
        }
        if self.buffer.len() <= self.limit {
            // The last line, without a newline.
            return Ok(Some(Line::Text(&self.buffer)));
        }
        self.skip_rest()?;
        Ok(Some(Line::TooLong))
    }

    /// Skips to just after the next newline (or the end of the input), keeping at most `limit`
    /// bytes at a time.
    fn skip_rest(&mut self) -> io::Result<()> {
        loop {
            self.buffer.clear();
            let bound = self.limit as u64 + 1;
            let read = (&mut self.input)
                .take(bound)
                .read_until(b'\n', &mut self.buffer)?;
            if read == 0 || self.buffer.last() == Some(&b'\n') {
                self.buffer.clear();
                return Ok(());
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn all(input: &[u8], limit: usize) -> Vec<Result<Vec<u8>, ()>> {
        let mut lines = Lines::new(input, limit);
        let mut out = Vec::new();
        while let Some(line) = lines.next_line().unwrap() {
            out.push(match line {
                Line::Text(t) => Ok(t.to_vec()),
                Line::TooLong => Err(()),
            });
        }
        out
    }

    #[test]
    fn lines_up_to_the_limit_pass_and_longer_ones_are_skipped_whole() {
        let input = b"abcd\nabcde\nabc\r\n\nabcdefghijklmnop\nxy";
        assert_eq!(
            all(input, 4),
            [
                Ok(b"abcd".to_vec()),
                Err(()),
                Ok(b"abc".to_vec()),
                Ok(Vec::new()),
                Err(()),
                Ok(b"xy".to_vec()),
            ]
        );
        // An overlong last line without a newline.
        assert_eq!(all(b"ok\n0123456789", 4), [Ok(b"ok".to_vec()), Err(())]);
        assert!(all(b"", 4).is_empty());
    }

    #[test]
    fn the_buffer_never_grows_past_the_limit() {
        let long = vec![b'0'; 1 << 20];
        let mut input = long.clone();
        input.push(b'\n');
        input.extend_from_slice(b"next\n");
        let mut lines = Lines::new(&input[..], 64);
        assert_eq!(lines.next_line().unwrap(), Some(Line::TooLong));
        assert!(
            lines.buffer.capacity() <= 128,
            "{}",
            lines.buffer.capacity()
        );
        assert_eq!(lines.next_line().unwrap(), Some(Line::Text(b"next")));
        assert_eq!(lines.next_line().unwrap(), None);
    }
}
