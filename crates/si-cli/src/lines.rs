//! Line-oriented input with a cap on a line's length ("Bounded memory": `si dp-coord
//! module` once read a 200 MB stdin line whole and reached 1.09 GB).
//!
//! [`CappedLines`] reads at most `cap` bytes of a line and its `\r\n` end; a longer line
//! stops it with an error naming the line number and the cap, so memory stays bounded
//! whatever a pipe delivers. Lines are `\n`-terminated; a trailing `\r` is dropped, invalid
//! UTF-8 is an error as it is for [`std::io::BufRead::lines`].

use std::io::{self, BufRead, Read};

/// The longest stdin line a window reader takes: a window of at most 32 bytes is under 100
/// characters as hex with spaces (si_dp_coord::frame::WindowSize); 4 KiB leaves room for a
/// comment after it.
pub const MAX_WINDOW_LINE: usize = 4096;

/// An iterator over the lines of `reader`, each at most `cap` bytes (without its newline).
/// After an error it ends.
pub struct CappedLines<R> {
    reader: R,
    cap: usize,
    line: usize,
    done: bool,
    buf: Vec<u8>,
}

impl<R: BufRead> CappedLines<R> {
    /// Lines of `reader` of at most `cap` bytes.
    pub fn new(reader: R, cap: usize) -> Self {
        CappedLines {
            reader,
            cap,
            line: 0,
            done: false,
            buf: Vec::new(),
        }
    }

    fn next_line(&mut self) -> io::Result<Option<String>> {
        self.buf.clear();
        self.line += 1;
        // The cap, the line end `\r\n`, and nothing more.
        let limit = u64::try_from(self.cap)
            .unwrap_or(u64::MAX)
            .saturating_add(2);
        let n = (&mut self.reader)
            .take(limit)
            .read_until(b'\n', &mut self.buf)?;
        if n == 0 {
            return Ok(None);
        }
        if self.buf.last() == Some(&b'\n') {
            self.buf.pop();
        }
        if self.buf.last() == Some(&b'\r') {
            self.buf.pop();
        }
        if self.buf.len() > self.cap {
            return Err(io::Error::new(
                io::ErrorKind::InvalidData,
                format!(
                    "input line {} is longer than {} bytes; stopped reading it",
                    self.line, self.cap
                ),
            ));
        }
        String::from_utf8(std::mem::take(&mut self.buf))
            .map(Some)
            .map_err(|_| {
                io::Error::new(
                    io::ErrorKind::InvalidData,
                    format!("input line {} is not UTF-8 text", self.line),
                )
            })
    }
}

impl<R: BufRead> Iterator for CappedLines<R> {
    type Item = io::Result<String>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let item = self.next_line().transpose();
        if !matches!(item, Some(Ok(_))) {
            self.done = true;
        }
        item
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_up_to_the_cap_are_read_and_a_longer_one_is_refused_by_number() {
        // Five bytes fit (with or without `\r\n`), six do not.
        let text = b"01 02\r\n#c\n\nabcde\nabcdef\nnever read\n";
        let mut lines = CappedLines::new(&text[..], 5);
        for want in ["01 02", "#c", "", "abcde"] {
            assert_eq!(lines.next().unwrap().unwrap(), want);
        }
        let e = lines.next().unwrap().unwrap_err();
        assert_eq!(
            e.to_string(),
            "input line 5 is longer than 5 bytes; stopped reading it"
        );
        assert!(lines.next().is_none(), "ends after an error");
    }

    #[test]
    fn an_endless_line_is_refused_after_the_cap_not_read_whole() {
        // io::repeat never ends: reading it whole would never return.
        let endless = io::BufReader::new(io::repeat(b'7'));
        let mut lines = CappedLines::new(endless, MAX_WINDOW_LINE);
        let e = lines.next().unwrap().unwrap_err();
        assert!(
            e.to_string()
                .starts_with("input line 1 is longer than 4096"),
            "{e}"
        );
        assert!(lines.buf.capacity() <= 2 * (MAX_WINDOW_LINE + 2) + 64);
    }

    #[test]
    fn a_last_line_without_newline_and_bad_utf8() {
        let mut lines = CappedLines::new(&b"ab\ncd"[..], 5);
        assert_eq!(lines.next().unwrap().unwrap(), "ab");
        assert_eq!(lines.next().unwrap().unwrap(), "cd");
        assert!(lines.next().is_none());
        let mut lines = CappedLines::new(&b"\xFF\n"[..], 5);
        assert!(lines.next().unwrap().is_err());
    }
}
