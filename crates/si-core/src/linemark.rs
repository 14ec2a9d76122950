//! Line errors from a marked byte stream: the POSIX `PARMRK` convention, decoded Sans-IO.
//!
//! A UART that finds a bad character (parity or stop bit wrong) or a BREAK tells the kernel; the
//! portable serial APIs drop that news (a bad character arrives as its garbled value or as 00H).
//! With `PARMRK` and `INPCK` set and `IGNPAR`, `IGNBRK`, `BRKINT` and `ISTRIP` clear, a Unix
//! terminal driver marks it in the received stream instead (termios(3), "PARMRK"; Linux
//! `n_tty_receive_parity_error` / `n_tty_receive_break`):
//!
//! | bytes read | meaning |
//! |---|---|
//! | `FF 00 x` | a character received with a parity or framing error; `x` is what arrived |
//! | `FF 00 00` | a BREAK |
//! | `FF FF` | a data byte FFH |
//!
//! [`MarkDecoder`] turns such a stream back into data runs and [`LineError`]s, in order, before
//! an engine sees the bytes (the tokio driver does this for ports opened by
//! `si_core::port::open`, which sets those flags on Linux). It keeps three states and no buffer,
//! so a mark split across two reads is carried over without storing anything, and any input is
//! valid: a stray `FF x` that no kernel writes passes through as the two data bytes it is.
//!
//! What the marks cannot say, and the reading chosen here:
//!
//! - **Parity or framing?** The kernel marks both the same way. The decoder reports what the
//!   caller names as the bad-character error: [`bad_char_error`] says `Parity` when the line has
//!   a checked parity bit (a single flipped bit, the usual disturbance, shows as a parity error
//!   first) and `Framing` when it has none (then a wrong stop bit is the only error the UART
//!   can see). Both map to the same STATUS in 3964(R) (080C, [ET200S SI] §2.13, Table 2-28);
//!   the ASCII driver and Modbus tell 0810 (parity) from 0811 (framing) and get this best
//!   guess.
//! - **A bad 00H character or a BREAK?** Both read `FF 00 00`; it is reported as
//!   [`LineError::Break`] (a BREAK is what a pulled cable produces, and what the kernel writes
//!   for it).
//! - **Overrun** is not marked: Linux counts it (the `TIOCGICOUNT` ioctl, for which no
//!   maintained crate offers a safe call) and logs "input overrun(s)" to the kernel log; the
//!   lost characters then show as a BCC/CRC or length error in the protocol.

use crate::sansio::LineError;
use crate::serial::{Parity, SerialSettings};

/// The byte that starts a mark.
const MARK: u8 = 0xFF;

/// One piece of a decoded stream: a run of data bytes, or a line error in their place.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Marked<'a> {
    /// Data bytes, in order (a borrowed slice of the input).
    Data(&'a [u8]),
    /// A line condition where a character would have been.
    Error(LineError),
}

/// Where the decoder stands between two reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
enum State {
    /// Plain data.
    #[default]
    Data,
    /// After an `FF`.
    Mark,
    /// After `FF 00`: the next byte is the bad character (or 00 for a BREAK).
    MarkNul,
}

/// Decodes a `PARMRK`-marked byte stream into data runs and line errors (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MarkDecoder {
    state: State,
    bad_char: LineError,
}

/// The line error a marked bad character is reported as on a line with these settings: parity
/// when a parity bit is checked, framing when none is (module docs, "Parity or framing?").
pub fn bad_char_error(settings: &SerialSettings) -> LineError {
    match settings.parity() {
        Parity::Even | Parity::Odd | Parity::Mark => LineError::Parity,
        // Space is the manuals' "any": sent, not checked (serial.rs), so only framing remains.
        Parity::None | Parity::Space => LineError::Framing,
    }
}

impl MarkDecoder {
    /// A decoder that reports a marked bad character as `bad_char` (see [`bad_char_error`]).
    pub const fn new(bad_char: LineError) -> Self {
        MarkDecoder {
            state: State::Data,
            bad_char,
        }
    }

    /// Decode the next read, handing each piece to `sink` in order. A mark cut off at the end
    /// of `input` is completed by the next call.
    pub fn feed<'a>(&mut self, input: &'a [u8], mut sink: impl FnMut(Marked<'a>)) {
        // Start of the data run not yet handed on.
        let mut run = 0;
        for (i, &byte) in input.iter().enumerate() {
            self.state = match self.state {
                State::Data if byte == MARK => {
                    if run < i {
                        sink(Marked::Data(&input[run..i]));
                    }
                    State::Mark
                }
                State::Data => continue,
                State::Mark if byte == MARK => {
                    // FF FF: one data FFH; the run restarts with this second FF.
                    run = i;
                    State::Data
                }
                State::Mark if byte == 0 => State::MarkNul,
                State::Mark => {
                    // Not a mark any kernel writes: the FF was data, and so is this byte.
                    sink(Marked::Data(&[MARK]));
                    run = i;
                    State::Data
                }
                State::MarkNul => {
                    sink(Marked::Error(if byte == 0 {
                        LineError::Break
                    } else {
                        self.bad_char
                    }));
                    run = i + 1;
                    State::Data
                }
            };
        }
        if self.state == State::Data && run < input.len() {
            sink(Marked::Data(&input[run..]));
        }
    }
}

/// What a receiver got in one character slot: the input a marking terminal driver encodes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Received {
    /// A good character.
    Byte(u8),
    /// A character with a parity or framing error, with the value that arrived.
    Bad(u8),
    /// A BREAK.
    Break,
}

/// Append `item` to `out` as a `PARMRK` terminal driver would write it (module docs): the other
/// side of [`MarkDecoder`], for tests and for simulated ports.
pub fn mark(item: Received, out: &mut Vec<u8>) {
    match item {
        Received::Byte(MARK) => out.extend_from_slice(&[MARK, MARK]),
        Received::Byte(b) => out.push(b),
        Received::Bad(b) => out.extend_from_slice(&[MARK, 0, b]),
        Received::Break => out.extend_from_slice(&[MARK, 0, 0]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// What the engine would see: data bytes as `Ok`, errors as `Err`, with runs flattened.
    fn decode_all(decoder: &mut MarkDecoder, reads: &[&[u8]]) -> Vec<Result<u8, LineError>> {
        let mut seen = Vec::new();
        for read in reads {
            decoder.feed(read, |piece| match piece {
                Marked::Data(run) => {
                    assert!(!run.is_empty(), "no empty data runs");
                    seen.extend(run.iter().map(|&b| Ok(b)));
                }
                Marked::Error(e) => seen.push(Err(e)),
            });
        }
        seen
    }

    #[test]
    fn marks_become_errors_and_doubled_ff_one_data_byte() {
        let mut d = MarkDecoder::new(LineError::Parity);
        let stream = [
            0x02, 0xFF, 0xFF, 0x41, 0xFF, 0x00, 0x37, 0x42, 0xFF, 0x00, 0x00, 0x03,
        ];
        assert_eq!(
            decode_all(&mut d, &[&stream]),
            vec![
                Ok(0x02),
                Ok(0xFF),
                Ok(0x41),
                Err(LineError::Parity),
                Ok(0x42),
                Err(LineError::Break),
                Ok(0x03)
            ]
        );
    }

    #[test]
    fn a_mark_split_across_reads_is_completed_by_the_next() {
        let mut d = MarkDecoder::new(LineError::Framing);
        let got = decode_all(
            &mut d,
            &[&[0x10, 0xFF], &[0x00], &[0x55, 0xFF], &[0xFF, 0x03]],
        );
        assert_eq!(
            got,
            vec![Ok(0x10), Err(LineError::Framing), Ok(0xFF), Ok(0x03)]
        );
    }

    #[test]
    fn runs_are_slices_of_the_input_between_marks() {
        let mut d = MarkDecoder::new(LineError::Parity);
        let mut pieces = Vec::new();
        d.feed(&[1, 2, 3, 0xFF, 0, 9, 4, 5], |p| pieces.push(p));
        assert_eq!(
            pieces,
            vec![
                Marked::Data(&[1, 2, 3]),
                Marked::Error(LineError::Parity),
                Marked::Data(&[4, 5])
            ]
        );
    }

    #[test]
    fn an_ff_no_kernel_writes_passes_as_data() {
        let mut d = MarkDecoder::new(LineError::Parity);
        assert_eq!(
            decode_all(&mut d, &[&[0xFF, 0x41, 0x42]]),
            vec![Ok(0xFF), Ok(0x41), Ok(0x42)]
        );
    }

    #[test]
    fn the_bad_character_error_follows_the_parity_setting() {
        let even = SerialSettings::default();
        assert_eq!(bad_char_error(&even), LineError::Parity);
        let none = SerialSettings::new(9_600, 8, Parity::None, 1).unwrap();
        assert_eq!(bad_char_error(&none), LineError::Framing);
    }

    fn received() -> impl Strategy<Value = Received> {
        prop_oneof![
            6 => any::<u8>().prop_map(Received::Byte),
            2 => Just(Received::Byte(0xFF)),
            1 => (1u8..=255).prop_map(Received::Bad),
            1 => Just(Received::Break),
        ]
    }

    proptest! {
        /// Whatever the receiver got, cut into reads anywhere, decodes back to itself.
        #[test]
        fn encode_then_decode_round_trips(
            items in proptest::collection::vec(received(), 0..64),
            cuts in proptest::collection::vec(any::<prop::sample::Index>(), 0..8),
        ) {
            let mut stream = Vec::new();
            for &item in &items {
                mark(item, &mut stream);
            }
            let mut at: Vec<usize> = cuts.iter().map(|c| c.index(stream.len() + 1)).collect();
            at.sort_unstable();
            let mut reads = Vec::new();
            let mut from = 0;
            for cut in at {
                reads.push(&stream[from..cut]);
                from = cut;
            }
            reads.push(&stream[from..]);
            let mut d = MarkDecoder::new(LineError::Parity);
            let expected: Vec<_> = items.iter().map(|i| match *i {
                Received::Byte(b) => Ok(b),
                Received::Bad(_) => Err(LineError::Parity),
                Received::Break => Err(LineError::Break),
            }).collect();
            prop_assert_eq!(decode_all(&mut d, &reads), expected);
        }

        /// Any bytes at all, cut into reads anywhere: no panic, never more data out than bytes
        /// in, and the same pieces as one read of the whole.
        #[test]
        fn any_input_decodes_the_same_however_it_is_cut(
            bytes in proptest::collection::vec(prop_oneof![any::<u8>(), Just(0xFF), Just(0)], 0..256),
            cut in any::<prop::sample::Index>(),
        ) {
            let whole = decode_all(&mut MarkDecoder::new(LineError::Framing), &[&bytes]);
            prop_assert!(whole.len() <= bytes.len());
            let (a, b) = bytes.split_at(cut.index(bytes.len() + 1));
            let cut = decode_all(&mut MarkDecoder::new(LineError::Framing), &[a, b]);
            prop_assert_eq!(whole, cut);
        }
    }
}
