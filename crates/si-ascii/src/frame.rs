//! The pure part of receive framing: deciding, byte by byte, where a frame ends by the
//! end-of-text or fixed-length criterion, and guarding the maximum length
//! ([ET200S SI] §2.8, [CP 341] §2.2.4, [CP 440], [CP 340]).
//!
//! Time-based decisions (the character delay time as terminator or as monitoring time) belong to
//! the [link](crate::link), which owns the clock; this module has no state beyond the frame in
//! progress, so it is easy to test exhaustively.
//!
//! The ASCII driver has no frame *encoding*: the user data are the frame ([ET200S SI] §2.8).
//! Surplus bytes after an end criterion start the next frame ([CP 341] §2.2.4: "merged with the
//! next frame").

use crate::config::EndCriterion;

/// What one more byte means for the frame in progress.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Cut {
    /// The frame goes on.
    Continue,
    /// This byte completes the frame (it belongs to it).
    Complete,
    /// This byte would make the frame longer than the cutter's maximum
    /// ([`Config::max_frame_len`](crate::Config::max_frame_len)).
    TooLong,
}

/// Tracks the frame in progress against an end criterion.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Cutter {
    end: EndCriterion,
    /// The longest frame; one byte more is [`Cut::TooLong`].
    max: usize,
    len: usize,
    /// The last byte was end-of-text character 1 (for a two-character sequence).
    after_first: bool,
}

impl Cutter {
    /// A cutter for `end` and frames of at most `max` bytes, with no frame in progress.
    pub const fn new(end: EndCriterion, max: usize) -> Self {
        Cutter {
            end,
            max,
            len: 0,
            after_first: false,
        }
    }

    /// Bytes of the frame in progress.
    pub const fn len(&self) -> usize {
        self.len
    }

    /// True when no frame is in progress.
    pub const fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Start a new frame.
    pub fn reset(&mut self) {
        self.len = 0;
        self.after_first = false;
    }

    /// Track the end-of-text sequence only (no length): true when `byte` ends it. Used while a
    /// broken frame is being skipped, to find where the next one starts.
    #[inline]
    pub fn ends_text(&mut self, byte: u8) -> bool {
        let EndCriterion::EndChars { first, second } = self.end else {
            return false;
        };
        if second == 0 {
            return byte == first;
        }
        let done = self.after_first && byte == second;
        self.after_first = !done && byte == first;
        done
    }

    /// Account for one more byte of the frame.
    #[inline]
    pub fn push(&mut self, byte: u8) -> Cut {
        self.len += 1;
        if self.len > self.max {
            return Cut::TooLong;
        }
        let complete = match self.end {
            EndCriterion::CharDelay => false,
            EndCriterion::EndChars { .. } => self.ends_text(byte),
            EndCriterion::FixedLength { len } => self.len >= usize::from(len),
        };
        if complete {
            Cut::Complete
        } else {
            Cut::Continue
        }
    }
}

/// Split `stream` into the frames the end-of-text or fixed-length criterion cuts when nothing
/// else (no timing) intervenes, frames longer than `max` bytes cut there as incomplete; the
/// unterminated rest comes last, if any. An allocation-free iterator over sub-slices, handy for
/// tests and for offline tools.
pub fn split(end: EndCriterion, max: usize, stream: &[u8]) -> Split<'_> {
    Split {
        cutter: Cutter::new(end, max),
        rest: stream,
    }
}

/// Iterator of [`split`]: `(frame, complete)`.
#[derive(Debug, Clone)]
pub struct Split<'a> {
    cutter: Cutter,
    rest: &'a [u8],
}

impl<'a> Iterator for Split<'a> {
    type Item = (&'a [u8], bool);
    fn next(&mut self) -> Option<Self::Item> {
        if self.rest.is_empty() {
            return None;
        }
        self.cutter.reset();
        for (i, &b) in self.rest.iter().enumerate() {
            match self.cutter.push(b) {
                Cut::Continue => {}
                Cut::Complete => {
                    let (frame, rest) = self.rest.split_at(i + 1);
                    self.rest = rest;
                    return Some((frame, true));
                }
                Cut::TooLong => {
                    let (frame, rest) = self.rest.split_at(i);
                    self.rest = rest;
                    return Some((frame, false));
                }
            }
        }
        let frame = core::mem::take(&mut self.rest);
        Some((frame, false))
    }
}

/// The flow-control parameter blocks 20H–22H a non-S7 DP master sends with job code 5
/// (`[ET200S SI]` §2.12, Tables 2-26 and 2-27): one codec for the link and the coordination
/// window, in si-core; [`Link::apply_param_block`](crate::Link::apply_param_block) applies one.
pub use si_core::param_block::{ParamBlock, ParamError};

/// The ASCII name of a control character (`CR`, `LF`, `NUL` … `US`, `DEL`), with DC1 and DC3
/// by their flow-control names `XON` and `XOFF` ([ET200S SI] §2.8, flow control: the
/// default XON/XOFF characters); `None` for a printable character or a byte above 7FH.
pub fn control_name(byte: u8) -> Option<&'static str> {
    const C0: [&str; 32] = [
        "NUL", "SOH", "STX", "ETX", "EOT", "ENQ", "ACK", "BEL", "BS", "HT", "LF", "VT", "FF", "CR",
        "SO", "SI", "DLE", "XON", "DC2", "XOFF", "DC4", "NAK", "SYN", "ETB", "CAN", "EM", "SUB",
        "ESC", "FS", "GS", "RS", "US",
    ];
    match byte {
        0x7F => Some("DEL"),
        _ => C0.get(usize::from(byte)).copied(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::MAX_FRAME_LEN;
    use proptest::prelude::*;

    fn frames(end: EndCriterion, s: &[u8]) -> Vec<(Vec<u8>, bool)> {
        split(end, MAX_FRAME_LEN, s)
            .map(|(f, c)| (f.to_vec(), c))
            .collect()
    }

    #[test]
    fn one_end_character_cuts_after_it() {
        let end = EndCriterion::DEFAULT_END_CHARS;
        assert_eq!(
            frames(end, b"ab\x03cd\x03e"),
            vec![
                (b"ab\x03".to_vec(), true),
                (b"cd\x03".to_vec(), true),
                (b"e".to_vec(), false)
            ]
        );
    }

    #[test]
    fn two_end_characters_are_a_sequence() {
        let end = EndCriterion::EndChars {
            first: 0x0D,
            second: 0x0A,
        };
        // A lone CR or LF does not end the frame; CR LF does.
        assert_eq!(
            frames(end, b"a\rb\nc\r\nd"),
            vec![(b"a\rb\nc\r\n".to_vec(), true), (b"d".to_vec(), false)]
        );
        // CR CR LF: the second CR restarts the sequence.
        assert_eq!(frames(end, b"\r\r\n"), vec![(b"\r\r\n".to_vec(), true)]);
    }

    #[test]
    fn fixed_length_surplus_starts_the_next_frame() {
        let end = EndCriterion::FixedLength { len: 3 };
        assert_eq!(
            frames(end, b"abcdefg"),
            vec![
                (b"abc".to_vec(), true),
                (b"def".to_vec(), true),
                (b"g".to_vec(), false)
            ]
        );
    }

    #[test]
    fn the_byte_after_the_maximum_is_too_long() {
        for max in [MAX_FRAME_LEN, 224, 1024] {
            let mut c = Cutter::new(EndCriterion::CharDelay, max);
            for _ in 0..max {
                assert_eq!(c.push(0), Cut::Continue);
            }
            assert_eq!(c.push(0), Cut::TooLong, "max {max}");
        }
    }

    proptest! {
        #[test]
        fn fixed_length_split_reassembles(len in 1u16..=200, stream in proptest::collection::vec(any::<u8>(), 0..1500)) {
            let end = EndCriterion::FixedLength { len };
            let parts: Vec<_> = split(end, MAX_FRAME_LEN, &stream).collect();
            let joined: Vec<u8> = parts.iter().flat_map(|(f, _)| f.iter().copied()).collect();
            prop_assert_eq!(&joined, &stream);
            for (f, complete) in &parts {
                if *complete { prop_assert_eq!(f.len(), usize::from(len)); }
            }
        }

        #[test]
        fn end_char_split_reassembles(first in 1u8.., second: u8, stream in proptest::collection::vec(any::<u8>(), 0..600)) {
            let end = EndCriterion::EndChars { first, second };
            let joined: Vec<u8> = split(end, MAX_FRAME_LEN, &stream).flat_map(|(f, _)| f.iter().copied()).collect();
            prop_assert_eq!(joined, stream);
        }
    }

    #[test]
    fn control_names_are_ascii_with_xon_and_xoff() {
        let names: Vec<_> = [0x48, 0x0D, 0x0A, 0x11, 0x13, 0x7F, 0x80]
            .into_iter()
            .map(control_name)
            .collect();
        assert_eq!(
            names,
            [
                None,
                Some("CR"),
                Some("LF"),
                Some("XON"),
                Some("XOFF"),
                Some("DEL"),
                None
            ]
        );
    }
}
