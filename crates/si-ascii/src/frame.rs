//! The pure part of receive framing: deciding, byte by byte, where a frame ends by the
//! end-of-text or fixed-length criterion, and guarding the maximum length
//! (et200s-si-3964r-ascii.md §6.3, cp341-3964r-rk512-ascii.md §5.3, public-facts.md §4).
//!
//! Time-based decisions (the character delay time as terminator or as monitoring time) belong to
//! the [link](crate::link), which owns the clock; this module has no state beyond the frame in
//! progress, so it is easy to test exhaustively.
//!
//! The ASCII driver has no frame *encoding*: the user data are the frame (§6.1). Surplus bytes
//! after an end criterion start the next frame (cp341 §5.3: "merged with the next frame").

use crate::config::{AutoV24, EndCriterion, RtsCts, XonXoff};

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

/// A flow-control parameter block as a non-S7 DP master sends it with job code 5
/// (et200s-si-3964r-ascii.md §9.8, Table 2-26): block number, big-endian length of what
/// follows, then the parameters; times are big-endian counts of 10 ms (A-11).
///
/// ```
/// use si_ascii::frame::ParamBlock;
/// use si_ascii::XonXoff;
///
/// let block = ParamBlock::XonXoff(XonXoff::default());
/// assert_eq!(block.encode(), [0x20, 0x00, 0x04, 0x11, 0x13, 0x00, 0xC8]);
/// assert_eq!(ParamBlock::decode(&block.encode()), Ok(block));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ParamBlock {
    /// Block 20H: XON, XOFF, wait time for XON (S_XON).
    XonXoff(XonXoff),
    /// Block 21H: wait time for CTS = ON (S_RTS).
    RtsCts(RtsCts),
    /// Block 22H: RTS-off time, data output wait time (S_V24).
    AutoV24(AutoV24),
}

/// Why a parameter block could not be read.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum ParamBlockError {
    /// Fewer bytes than the block needs.
    #[error("parameter block too short: {0} bytes")]
    TooShort(usize),
    /// A block number other than 20H, 21H, 22H.
    #[error("unknown parameter block number {0:02X}H: 20H, 21H or 22H")]
    UnknownBlock(u8),
    /// The length field does not match the block (0004H, 0002H, 0004H).
    #[error("parameter block {block:02X}H has length {length:04X}H, expected {expected:04X}H")]
    Length {
        /// Block number.
        block: u8,
        /// Length found.
        length: u16,
        /// Length the block has.
        expected: u16,
    },
}

fn ms_to_count(ms: u32) -> [u8; 2] {
    u16::try_from(ms / 10).unwrap_or(u16::MAX).to_be_bytes()
}

fn count_to_ms(hi: u8, lo: u8) -> u32 {
    u32::from(u16::from_be_bytes([hi, lo])) * 10
}

impl ParamBlock {
    /// The block's bytes: 7 for 20H and 22H, 5 for 21H (returned as 7 with the valid length
    /// in [`ParamBlock::len`]; unused bytes are zero).
    pub fn encode(&self) -> [u8; 7] {
        match *self {
            ParamBlock::XonXoff(p) => {
                let [h, l] = ms_to_count(p.wait_for_xon_ms);
                [0x20, 0x00, 0x04, p.xon, p.xoff, h, l]
            }
            ParamBlock::RtsCts(p) => {
                let [h, l] = ms_to_count(p.wait_for_cts_ms);
                [0x21, 0x00, 0x02, h, l, 0, 0]
            }
            ParamBlock::AutoV24(p) => {
                let [a, b] = ms_to_count(p.time_rts_off_ms);
                let [c, d] = ms_to_count(p.data_wait_time_ms);
                [0x22, 0x00, 0x04, a, b, c, d]
            }
        }
    }

    /// Bytes of the encoded block (7 or 5).
    pub fn len(&self) -> usize {
        match self {
            ParamBlock::RtsCts(_) => 5,
            _ => 7,
        }
    }

    /// Never empty; here for clippy's `len` convention.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// Read a block from the start of `bytes` (trailing bytes, such as segment padding, are
    /// ignored). Ranges are checked where the block is applied ([`crate::Link::set_xon_xoff`]
    /// and friends), which reports 1E20H.
    pub fn decode(bytes: &[u8]) -> Result<ParamBlock, ParamBlockError> {
        let [block, lh, ll, ..] = *bytes else {
            return Err(ParamBlockError::TooShort(bytes.len()));
        };
        let length = u16::from_be_bytes([lh, ll]);
        let expected = match block {
            0x20 | 0x22 => 4,
            0x21 => 2,
            other => return Err(ParamBlockError::UnknownBlock(other)),
        };
        if length != expected {
            return Err(ParamBlockError::Length {
                block,
                length,
                expected,
            });
        }
        let body = bytes
            .get(3..3 + usize::from(expected))
            .ok_or(ParamBlockError::TooShort(bytes.len()))?;
        Ok(match (block, body) {
            (0x20, &[xon, xoff, h, l]) => ParamBlock::XonXoff(XonXoff {
                xon,
                xoff,
                wait_for_xon_ms: count_to_ms(h, l),
            }),
            (0x21, &[h, l]) => ParamBlock::RtsCts(RtsCts {
                wait_for_cts_ms: count_to_ms(h, l),
            }),
            (_, &[a, b, c, d]) => ParamBlock::AutoV24(AutoV24 {
                time_rts_off_ms: count_to_ms(a, b),
                data_wait_time_ms: count_to_ms(c, d),
            }),
            _ => return Err(ParamBlockError::TooShort(bytes.len())),
        })
    }
}

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
    fn table_2_27_xon_xoff_job_stream_decodes() {
        // The three 3-byte segments of Table 2-27: 20 00 04 | 0B 0D 00 | C8. The example prints
        // DC1/DC3 as 0BH/0DH (decimal 11/13, A-9); the block carries whatever bytes it holds.
        let stream = [0x20, 0x00, 0x04, 0x0B, 0x0D, 0x00, 0xC8, 0xEE, 0xEE];
        assert_eq!(
            ParamBlock::decode(&stream),
            Ok(ParamBlock::XonXoff(XonXoff {
                xon: 0x0B,
                xoff: 0x0D,
                wait_for_xon_ms: 2_000
            }))
        );
    }

    #[test]
    fn table_2_26_blocks_round_trip_with_defaults() {
        for block in [
            ParamBlock::XonXoff(XonXoff::default()),
            ParamBlock::RtsCts(RtsCts::default()),
            ParamBlock::AutoV24(AutoV24::default()),
        ] {
            let bytes = block.encode();
            assert_eq!(ParamBlock::decode(&bytes[..block.len()]), Ok(block));
        }
        assert_eq!(
            ParamBlock::RtsCts(RtsCts::default()).encode()[..5],
            [0x21, 0x00, 0x02, 0x00, 0xC8]
        );
        assert_eq!(
            ParamBlock::AutoV24(AutoV24::default()).encode(),
            [0x22, 0x00, 0x04, 0x00, 0x01, 0x00, 0x01]
        );
        assert_eq!(
            ParamBlock::decode(&[0x23, 0, 4]),
            Err(ParamBlockError::UnknownBlock(0x23))
        );
        assert_eq!(
            ParamBlock::decode(&[0x21, 0, 4, 0, 0, 0, 0]),
            Err(ParamBlockError::Length {
                block: 0x21,
                length: 4,
                expected: 2
            })
        );
        assert_eq!(
            ParamBlock::decode(&[0x20, 0, 4, 1]),
            Err(ParamBlockError::TooShort(4))
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
        fn param_block_decode_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..12)) {
            let _ = ParamBlock::decode(&bytes);
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
