//! The 3964 / 3964(R) block on the wire: DLE doubling, the closing `DLE ETX`, and the block check
//! character (pure functions and a byte-by-byte decoder, no timing, no state beyond one block).
//!
//! What this module calls a *block* is everything the sender puts on the line after the
//! partner's `DLE` answered its `STX`: the user data with every `DLE` doubled, then `DLE ETX`,
//! then (3964(R) only) the BCC ([ET200S SI] §2.7, Fig. 2-12, [CP 341]
//! [CP 341] §2.2.2, [CP 440], [Public 3964R]).
//!
//! ```
//! use si_3964r::frame::{decode, encode, Mode};
//!
//! // The worked example of [ET200S SI] §2.7, Fig. 2-12: BCC = 53H.
//! let block = encode(&[0x41, 0x42, 0x10, 0x43], Mode::BlockCheck);
//! assert_eq!(block, [0x41, 0x42, 0x10, 0x10, 0x43, 0x10, 0x03, 0x53]);
//! assert_eq!(decode(&block, Mode::BlockCheck, 200).unwrap(), [0x41, 0x42, 0x10, 0x43]);
//! ```
//!
//! # BCC coverage (the texts disagree; our reading)
//!
//! [ET200S SI] §2.7, Fig. 2-12 and [CP 341] §2.2.2 say the BCC is the XOR of
//! every byte sent after `STX`, *both* DLEs of a doubled pair and the closing `DLE ETX` included;
//! [ET200S SI 2005] §2.7.1 only says "XOR of all data bytes" (`[derived]`). We follow the
//! two explicit manuals and [CP 440], [Public 3964R] (which agree): the wire form, doubled DLEs
//! twice (they cancel), `DLE ETX` included, the BCC byte itself never doubled even when it equals
//! `DLE`.

use serde::{Deserialize, Serialize};

/// Start of text: the connection request (02H, [CP 440], [Public 3964R]; the manuals give no value,
/// `[derived]`).
pub const STX: u8 = 0x02;
/// End of text, second half of the closing `DLE ETX` (03H).
pub const ETX: u8 = 0x03;
/// Data link escape: positive acknowledgement and first half of `DLE ETX` (10H).
pub const DLE: u8 = 0x10;
/// Negative acknowledgement (15H; [CP 341] `[derived]`: the figure's "10H" is a slip).
pub const NAK: u8 = 0x15;

/// Protocol mode of Table 2-11: plain 3964 or 3964(R) with block check.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Mode {
    /// 3964(R): the block ends `DLE ETX BCC` (the manual's default, "Block check").
    #[default]
    BlockCheck,
    /// Plain 3964: the block ends `DLE ETX`, no BCC ("No block check").
    NoBlockCheck,
}

impl Mode {
    /// True for 3964(R).
    pub const fn has_bcc(self) -> bool {
        matches!(self, Mode::BlockCheck)
    }
}

/// What is wrong with a received block, as precisely as the bytes tell.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum FrameError {
    /// A `DLE` was followed by something other than `DLE` or `ETX`: the partner did not double a
    /// data DLE (STATUS 0805, [ET200S SI] §2.13, Table 2-28).
    #[error("odd DLE: DLE followed by {after:02X}H at block byte {at} (expected DLE or ETX)")]
    OddDle {
        /// The byte after the lone DLE.
        after: u8,
        /// Its position in the block (0 = first byte after the partner's DLE).
        at: usize,
    },
    /// The bytes ended before `DLE ETX`.
    #[error("missing DLE ETX: the block ends after {len} bytes without its end sequence")]
    MissingEtx {
        /// How many bytes there were.
        len: usize,
    },
    /// 3964(R): the bytes ended after `DLE ETX` without the BCC.
    #[error("missing BCC after DLE ETX")]
    MissingBcc,
    /// 3964(R): the received BCC differs from the XOR of the block (STATUS 0808).
    #[error("BCC error: expected {expected:02X}H, found {found:02X}H")]
    Bcc {
        /// What the XOR of the received bytes gives.
        expected: u8,
        /// What the partner sent.
        found: u8,
    },
    /// More user data than the configured maximum (STATUS 0850).
    #[error("block longer than the maximum of {max} bytes")]
    TooLong {
        /// The maximum.
        max: usize,
    },
    /// Bytes after the end of the block (only from [`decode`], which is given a whole block).
    #[error("{count} bytes after the end of the block")]
    Trailing {
        /// How many.
        count: usize,
    },
}

/// XOR of `bytes`: the block check character of 3964(R) when `bytes` is the block as sent after
/// `STX`, doubled DLEs and `DLE ETX` included ([ET200S SI] §2.7, Fig. 2-12).
pub fn bcc(bytes: &[u8]) -> u8 {
    bytes.iter().fold(0, |acc, b| acc ^ b)
}

/// Appends the block for `payload` to `out`: data with DLEs doubled, `DLE ETX`, and for
/// 3964(R) the BCC. `out` is reused by the engine, so a steady state allocates nothing.
///
/// Runs between DLEs are copied whole rather than byte by byte (BENCHMARKS.md: the block
/// encode runs at memory speed, well above 1 GiB/s).
pub fn encode_into(payload: &[u8], mode: Mode, out: &mut Vec<u8>) {
    let start = out.len();
    out.reserve(payload.len() + 4);
    let mut rest = payload;
    while let Some(i) = find_dle(rest) {
        out.extend_from_slice(&rest[..=i]);
        out.push(DLE);
        rest = &rest[i + 1..];
    }
    out.extend_from_slice(rest);
    out.extend_from_slice(&[DLE, ETX]);
    if mode.has_bcc() {
        let check = bcc(&out[start..]);
        out.push(check);
    }
}

/// Index of the first DLE in `bytes`. Tests 32 bytes at a time without an early exit, which
/// the compiler turns into vector compares: the codec's hot loop (BENCHMARKS.md).
fn find_dle(bytes: &[u8]) -> Option<usize> {
    let mut base = 0;
    for chunk in bytes.chunks(32) {
        if chunk.iter().fold(false, |found, &b| found | (b == DLE)) {
            return chunk.iter().position(|&b| b == DLE).map(|i| base + i);
        }
        base += chunk.len();
    }
    None
}

/// The block for `payload` (see [`encode_into`]).
pub fn encode(payload: &[u8], mode: Mode) -> Vec<u8> {
    let mut out = Vec::with_capacity(payload.len() + 4);
    encode_into(payload, mode, &mut out);
    out
}

/// Decodes one whole block (what follows the receiver's `DLE`) into its user data.
///
/// Returns the *first* error found, as the manual's receiver reports the first error
/// ([ET200S SI] §2.7, `[derived]`).
pub fn decode(block: &[u8], mode: Mode, max_len: usize) -> Result<Vec<u8>, FrameError> {
    let mut decoder = Decoder::new(mode, max_len);
    match decoder.push_slice(block) {
        (used, Some(result)) => {
            result?;
            let count = block.len() - used;
            if count > 0 {
                return Err(FrameError::Trailing { count });
            }
            Ok(decoder.payload().to_vec())
        }
        (_, None) => Err(decoder.incomplete_error()),
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum DecodeState {
    Data,
    AfterDle,
    WaitBcc,
    Finished,
}

/// A receiver of one block, fed one character at a time.
///
/// Like the manual's receiver ([ET200S SI] §2.7, receiving: cleardown and errors during reception,
/// §2.7 `[derived]`) it does not stop at the first error: it keeps reading to the end sequence,
/// remembers the first error, and reports the outcome once, when the block is complete. The payload
/// buffer never grows beyond the maximum length.
#[derive(Debug, Clone)]
pub struct Decoder {
    mode: Mode,
    max_len: usize,
    state: DecodeState,
    payload: Vec<u8>,
    bcc: u8,
    received: usize,
    error: Option<FrameError>,
    /// More user data arrived than the maximum: the receive buffer cannot hold the block.
    overlong: bool,
}

impl Decoder {
    /// A decoder for blocks of at most `max_len` user-data bytes.
    pub fn new(mode: Mode, max_len: usize) -> Self {
        Decoder {
            mode,
            max_len,
            state: DecodeState::Data,
            payload: Vec::with_capacity(max_len.min(4096)),
            bcc: 0,
            received: 0,
            error: None,
            overlong: false,
        }
    }

    /// Start a new block (after the receiver's `DLE`), keeping the buffer's capacity.
    pub fn reset(&mut self) {
        self.state = DecodeState::Data;
        self.payload.clear();
        self.bcc = 0;
        self.received = 0;
        self.error = None;
        self.overlong = false;
    }

    /// Feed one received character. `Some` once the block is complete (after `DLE ETX`, or the
    /// BCC for 3964(R)): `Ok(())` if it is good, or the first error found in it. Characters fed
    /// after completion are ignored (`None`) until [`reset`](Self::reset).
    pub fn push(&mut self, byte: u8) -> Option<Result<(), FrameError>> {
        let at = self.received;
        self.received = self.received.saturating_add(1);
        match self.state {
            DecodeState::Finished => return None,
            DecodeState::WaitBcc => {
                self.state = DecodeState::Finished;
                if self.bcc != byte {
                    self.note(FrameError::Bcc {
                        expected: self.bcc,
                        found: byte,
                    });
                }
                return Some(self.outcome());
            }
            DecodeState::Data => {
                self.bcc ^= byte;
                if byte == DLE {
                    self.state = DecodeState::AfterDle;
                } else {
                    self.store(byte);
                }
            }
            DecodeState::AfterDle => {
                self.bcc ^= byte;
                match byte {
                    DLE => {
                        self.state = DecodeState::Data;
                        self.store(DLE);
                    }
                    ETX => {
                        if self.mode.has_bcc() {
                            self.state = DecodeState::WaitBcc;
                        } else {
                            self.state = DecodeState::Finished;
                            return Some(self.outcome());
                        }
                    }
                    after => {
                        self.state = DecodeState::Data;
                        self.note(FrameError::OddDle { after, at });
                    }
                }
            }
        }
        None
    }

    /// Feed several characters, exactly as if each went through [`push`](Self::push), but
    /// copying runs of ordinary data characters in one go. Returns how many characters were
    /// consumed and, when the block completed with the last of them, its outcome: the
    /// characters after the end of the block are left unconsumed.
    pub fn push_slice(&mut self, bytes: &[u8]) -> (usize, Option<Result<(), FrameError>>) {
        let mut i = 0;
        while i < bytes.len() {
            if self.state == DecodeState::Data {
                let rest = &bytes[i..];
                let run = find_dle(rest).unwrap_or(rest.len());
                if run > 0 {
                    let chunk = &rest[..run];
                    self.bcc ^= bcc(chunk);
                    let room = self.max_len.saturating_sub(self.payload.len());
                    let take = run.min(room);
                    self.payload.extend_from_slice(&chunk[..take]);
                    if take < run {
                        self.overflow();
                    }
                    self.received = self.received.saturating_add(run);
                    i += run;
                    continue;
                }
            }
            let result = self.push(bytes[i]);
            i += 1;
            if result.is_some() {
                return (i, result);
            }
        }
        (i, None)
    }

    /// True once the end sequence (and BCC) has been read.
    pub fn is_complete(&self) -> bool {
        self.state == DecodeState::Finished
    }

    /// True while the last character was a lone `DLE` (the next decides between doubled data
    /// and the end sequence).
    pub fn after_dle(&self) -> bool {
        self.state == DecodeState::AfterDle
    }

    /// True when the end sequence has been read and only the BCC is missing (3964(R)).
    pub fn awaiting_bcc(&self) -> bool {
        self.state == DecodeState::WaitBcc
    }

    /// Characters fed since the last reset.
    pub fn received(&self) -> usize {
        self.received
    }

    /// The user data stored so far (at most the maximum length).
    pub fn payload(&self) -> &[u8] {
        &self.payload
    }

    /// True once more user data arrived than the maximum length, whatever the first error was:
    /// the block cannot be stored, and a receiver may end it here instead of reading a partner
    /// that never sends the end sequence for ever (see `Link`, "Bounds").
    pub fn is_overlong(&self) -> bool {
        self.overlong
    }

    /// The first error seen so far, if any.
    pub fn error(&self) -> Option<FrameError> {
        self.error
    }

    /// What is missing if the input stops now.
    pub fn incomplete_error(&self) -> FrameError {
        match self.state {
            DecodeState::WaitBcc => FrameError::MissingBcc,
            _ => FrameError::MissingEtx { len: self.received },
        }
    }

    fn store(&mut self, byte: u8) {
        if self.payload.len() < self.max_len {
            self.payload.push(byte);
        } else {
            self.overflow();
        }
    }

    fn overflow(&mut self) {
        self.overlong = true;
        self.note(FrameError::TooLong { max: self.max_len });
    }

    fn note(&mut self, e: FrameError) {
        self.error.get_or_insert(e);
    }

    fn outcome(&self) -> Result<(), FrameError> {
        self.error.map_or(Ok(()), Err)
    }
}

/// The name of a control character sent alone ([`STX`], [`DLE`], [`NAK`]), as a trace or a
/// sequence diagram labels it; `None` for any other byte ([ET200S SI] §2.7, control
/// characters).
pub const fn control_name(byte: u8) -> Option<&'static str> {
    match byte {
        STX => Some("STX"),
        DLE => Some("DLE"),
        NAK => Some("NAK"),
        _ => None,
    }
}

/// The name of each byte of one transmission, `None` for data: a control character sent alone
/// ([`control_name`]), or a block's closing `DLE ETX` and the `BCC` after it. A byte is named by
/// its place, not its value: a doubled `DLE` in the data and a data byte 02H are data
/// ([ET200S SI] §2.7; Fig. 2-12).
///
/// ```
/// use si_3964r::frame::byte_names;
/// let names: Vec<_> = byte_names(&[0x41, 0x10, 0x10, 0x10, 0x03, 0x41]).collect();
/// assert_eq!(names, [None, None, None, Some("DLE"), Some("ETX"), Some("BCC")]);
/// ```
pub fn byte_names(transmission: &[u8]) -> impl Iterator<Item = Option<&'static str>> + '_ {
    let alone = match transmission {
        [b] => control_name(*b),
        _ => None,
    };
    // The closing DLE ETX: the first DLE followed by ETX once doubled DLEs are skipped.
    let mut end = None;
    let mut i = 0;
    while transmission.len() > 1 && i + 1 < transmission.len() {
        match (transmission[i], transmission[i + 1]) {
            (DLE, DLE) => i += 2,
            (DLE, ETX) => {
                end = Some(i);
                break;
            }
            _ => i += 1,
        }
    }
    (0..transmission.len()).map(move |k| match end {
        _ if transmission.len() == 1 => alone,
        Some(e) if k == e => Some("DLE"),
        Some(e) if k == e + 1 => Some("ETX"),
        Some(e) if k == e + 2 => Some("BCC"),
        _ => None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn worked_example_of_5_2_bcc_is_53h() {
        let block = encode(&[0x41, 0x42, 0x10, 0x43], Mode::BlockCheck);
        assert_eq!(block, [0x41, 0x42, 0x10, 0x10, 0x43, 0x10, 0x03, 0x53]);
        assert_eq!(bcc(&block[..7]), 0x53);
    }

    #[test]
    fn plain_3964_has_no_bcc() {
        assert_eq!(
            encode(&[0x10], Mode::NoBlockCheck),
            [0x10, 0x10, 0x10, 0x03]
        );
        assert_eq!(
            decode(&[0x10, 0x10, 0x10, 0x03], Mode::NoBlockCheck, 200),
            Ok(vec![0x10])
        );
    }

    #[test]
    fn bcc_equal_to_dle_is_not_doubled() {
        // 0x03 ^ 0x10 ^ 0x03 = 0x10: data 03 gives BCC 10H, sent once ([CP 440], [Public 3964R]).
        let block = encode(&[0x03], Mode::BlockCheck);
        assert_eq!(block, [0x03, 0x10, 0x03, 0x10]);
        assert_eq!(decode(&block, Mode::BlockCheck, 200), Ok(vec![0x03]));
    }

    #[test]
    fn decoder_names_each_error() {
        let m = Mode::BlockCheck;
        assert_eq!(
            decode(&[0x41, 0x10, 0x03, 0x00], m, 200),
            Err(FrameError::Bcc {
                expected: 0x52,
                found: 0x00
            })
        );
        assert_eq!(
            decode(&[0x41, 0x10, 0x41, 0x10, 0x03, 0x41], m, 200),
            Err(FrameError::OddDle { after: 0x41, at: 2 })
        );
        assert_eq!(
            decode(&[0x41, 0x42], m, 200),
            Err(FrameError::MissingEtx { len: 2 })
        );
        assert_eq!(
            decode(&[0x41, 0x10, 0x03], m, 200),
            Err(FrameError::MissingBcc)
        );
        assert_eq!(
            decode(&encode(&[1, 2, 3], m), m, 2),
            Err(FrameError::TooLong { max: 2 })
        );
        let mut long = encode(&[1], m);
        long.push(7);
        assert_eq!(
            decode(&long, m, 200),
            Err(FrameError::Trailing { count: 1 })
        );
    }

    /// Bytes where DLE, ETX and STX are frequent, so runs, doubled DLEs and odd DLEs all occur.
    fn dle_heavy() -> impl proptest::strategy::Strategy<Value = Vec<u8>> {
        use proptest::prelude::*;
        prop::collection::vec(
            prop_oneof![Just(DLE), Just(ETX), Just(STX), any::<u8>()],
            0..400,
        )
    }

    proptest::proptest! {
        /// The run-copying fast path of `push_slice` is exactly `push` byte by byte: same
        /// outcome at the same place, same payload, error and state afterwards.
        #[test]
        fn push_slice_is_push_byte_by_byte(bytes in dle_heavy(), max in 0usize..300, bcc_mode: bool) {
            let mode = if bcc_mode { Mode::BlockCheck } else { Mode::NoBlockCheck };
            let mut slow = Decoder::new(mode, max);
            let mut slow_end = (bytes.len(), None);
            for (i, &b) in bytes.iter().enumerate() {
                if let Some(r) = slow.push(b) {
                    slow_end = (i + 1, Some(r));
                    break;
                }
            }
            let mut fast = Decoder::new(mode, max);
            proptest::prop_assert_eq!(fast.push_slice(&bytes), slow_end);
            proptest::prop_assert_eq!(fast.payload(), slow.payload());
            proptest::prop_assert_eq!(fast.error(), slow.error());
            proptest::prop_assert_eq!(fast.received(), slow.received());
            proptest::prop_assert_eq!(fast.state, slow.state);
        }

        /// The run-copying encoder is the byte-by-byte definition of [ET200S SI] §2.7, Fig. 2-12.
        #[test]
        fn encode_is_the_bytewise_definition(payload in dle_heavy(), bcc_mode: bool) {
            let mode = if bcc_mode { Mode::BlockCheck } else { Mode::NoBlockCheck };
            let mut expected = Vec::new();
            for &b in &payload {
                expected.push(b);
                if b == DLE {
                    expected.push(DLE);
                }
            }
            expected.extend_from_slice(&[DLE, ETX]);
            if mode.has_bcc() {
                expected.push(bcc(&expected));
            }
            proptest::prop_assert_eq!(encode(&payload, mode), expected);
        }
    }

    #[test]
    fn zero_length_block_decodes_to_nothing() {
        assert_eq!(
            decode(&[0x10, 0x03, 0x13], Mode::BlockCheck, 200),
            Ok(vec![])
        );
    }

    #[test]
    fn a_block_names_dle_etx_and_bcc_and_leaves_its_data_unnamed() {
        let names: Vec<_> = byte_names(&[0x02, 0x10, 0x10, 0x41, 0x10, 0x03, 0x55]).collect();
        let want = [
            None,
            None,
            None,
            None,
            Some("DLE"),
            Some("ETX"),
            Some("BCC"),
        ];
        assert_eq!(names, want);
        assert_eq!(byte_names(&[NAK]).collect::<Vec<_>>(), [Some("NAK")]);
        assert_eq!(byte_names(&[0x41]).collect::<Vec<_>>(), [None]);
        assert_eq!(byte_names(&[]).count(), 0);
        let plain: Vec<_> = byte_names(&[0x41, DLE, ETX]).collect();
        assert_eq!(plain, [None, Some("DLE"), Some("ETX")]);
    }
}
