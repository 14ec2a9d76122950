//! Pure encode/decode of the window contents: window sizes, segments, the payload streams,
//! the V.24 signal word, the flow-control parameter blocks and the idle receive status.
//!
//! Everything here is stateless; the state machines live in [`host`](crate::host) and
//! [`module`](crate::module).

use crate::coord::CoordByte;
use core::fmt;
use serde::{Deserialize, Serialize};

/// The configured window size ([ET200S SI 2005] §2.12.1, Fig. 2-23): 4, 8 or 32 bytes in each
/// direction, chosen with the hardware-catalogue variant of the module.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
pub enum WindowSize {
    /// 4-byte window: 3 data bytes per segment.
    Four,
    /// 8-byte window: 7 data bytes per segment (the one of every manual example but Table 2-28).
    #[default]
    Eight,
    /// 32-byte window: 31 data bytes per segment. No example exists (`[derived]`).
    ThirtyTwo,
}

impl WindowSize {
    /// All sizes, smallest first.
    pub const ALL: [WindowSize; 3] = [WindowSize::Four, WindowSize::Eight, WindowSize::ThirtyTwo];

    /// Window length in bytes, coordination byte included.
    pub const fn bytes(self) -> usize {
        match self {
            WindowSize::Four => 4,
            WindowSize::Eight => 8,
            WindowSize::ThirtyTwo => 32,
        }
    }

    /// Data bytes per segment, n = 3, 7 or 31.
    pub const fn payload(self) -> usize {
        self.bytes() - 1
    }

    /// The size whose window is `len` bytes long.
    pub const fn from_len(len: usize) -> Option<WindowSize> {
        match len {
            4 => Some(WindowSize::Four),
            8 => Some(WindowSize::Eight),
            32 => Some(WindowSize::ThirtyTwo),
            _ => None,
        }
    }

    /// Number of segments a payload stream of `stream_len` bytes needs (at least 1).
    ///
    /// For a send of LEN bytes the stream is LEN + 2 (the length word), so LEN = 22 in the 8-byte
    /// window needs 4 segments (5 + 7 + 7 + 3) and LEN = 6 needs 2 (5 + 1), [ET200S SI 2005]
    /// §2.12.2–§2.12.6 `[derived]`.
    pub const fn segments(self, stream_len: usize) -> usize {
        let n = self.payload();
        if stream_len == 0 {
            1
        } else {
            stream_len.div_ceil(n)
        }
    }
}

impl fmt::Display for WindowSize {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}-byte window", self.bytes())
    }
}

/// One window image: the coordination byte and the data bytes, `size.bytes()` bytes in all.
///
/// Both directions use it: the host's *output* window (host → module) and the module's *input*
/// window (module → host). The buffer is fixed, so building a window never allocates.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct Window {
    size: WindowSize,
    bytes: [u8; 32],
}

impl Window {
    /// An all-zero window (idle, status 0000H).
    pub const fn new(size: WindowSize) -> Window {
        Window {
            size,
            bytes: [0; 32],
        }
    }

    /// A window from raw bytes: `None` unless `bytes` is exactly 4, 8 or 32 bytes long.
    pub fn from_bytes(bytes: &[u8]) -> Option<Window> {
        let size = WindowSize::from_len(bytes.len())?;
        let mut w = Window::new(size);
        w.bytes[..bytes.len()].copy_from_slice(bytes);
        Some(w)
    }

    /// The window size.
    pub const fn size(&self) -> WindowSize {
        self.size
    }

    /// The bytes as they go on the DP bus.
    pub fn as_bytes(&self) -> &[u8] {
        &self.bytes[..self.size.bytes()]
    }

    /// The decoded coordination byte.
    pub const fn coord(&self) -> CoordByte {
        CoordByte::decode(self.bytes[0])
    }

    /// Sets the coordination byte.
    pub fn set_coord(&mut self, coord: CoordByte) {
        self.bytes[0] = coord.encode();
    }

    /// Data bytes 1..n.
    pub fn data(&self) -> &[u8] {
        &self.bytes[1..self.size.bytes()]
    }

    /// The 16-bit word in bytes 1–2, MSB first (status word, length word; [ET200S SI 2005]
    /// §2.12.1).
    pub const fn word(&self) -> u16 {
        u16::from_be_bytes([self.bytes[1], self.bytes[2]])
    }

    /// Writes `coord` and a 16-bit word into bytes 0–2 and clears the rest (status answers).
    pub fn set_coord_word(&mut self, coord: CoordByte, word: u16) {
        self.clear();
        self.bytes[0] = coord.encode();
        self.bytes[1..3].copy_from_slice(&word.to_be_bytes());
    }

    /// Writes `coord` and segment `k` (1-based) of `stream` into the window; bytes after the end
    /// of the stream are 00H (the manual's "xx", `[derived]`: the receiver relies on the length).
    pub fn set_segment(&mut self, coord: CoordByte, stream: &[u8], k: usize) {
        self.clear();
        self.bytes[0] = coord.encode();
        let n = self.size.payload();
        let start = k.saturating_sub(1).saturating_mul(n).min(stream.len());
        let end = start.saturating_add(n).min(stream.len());
        let chunk = &stream[start..end];
        self.bytes[1..1 + chunk.len()].copy_from_slice(chunk);
    }

    /// All bytes to 00H.
    pub fn clear(&mut self) {
        self.bytes = [0; 32];
    }

    /// Mutable access to the data bytes 1..n.
    pub fn data_mut(&mut self) -> &mut [u8] {
        let len = self.size.bytes();
        &mut self.bytes[1..len]
    }
}

impl fmt::Debug for Window {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("Window[")?;
        for (i, b) in self.as_bytes().iter().enumerate() {
            if i > 0 {
                f.write_str(" ")?;
            }
            write!(f, "{b:02X}")?;
        }
        f.write_str("]")
    }
}

/// The payload stream of a send job: `[LEN_hi][LEN_lo][data …]` ([ET200S SI 2005] §2.12.2–§2.12.6
/// `[derived]`, the most likely reading of [ET200S SI] §2.12, Tables 2-22 to 2-25 `[derived]`,
/// confirmed by the 2005 manual's Table 2-23 with `11 00 16 'a'…`). Writes into `out` (cleared
/// first) so the caller can reuse its buffer.
pub fn send_stream(data: &[u8], out: &mut Vec<u8>) {
    out.clear();
    let len = u16::try_from(data.len()).unwrap_or(u16::MAX);
    out.extend_from_slice(&len.to_be_bytes());
    out.extend_from_slice(&data[..usize::from(len)]);
}

/// The V.24 signal states of the read/write V.24 jobs ([ET200S SI 2005] §2.12.2–§2.12.6
/// `[derived]`, Tables 2-25/2-26): a 16-bit word, high byte 00H, low byte
/// `0 0 0 DCD CTS RTS DSR DTR`.
///
/// The printed table has nine label cells over eight bits (`[derived]`); we read the leading "00"
/// as the high byte of the MSB-first word, so the bit field is in window byte 2. The byte position
/// is configurable ([`V24Layout`]) should a module put it in byte 1.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct V24Signals {
    /// Data carrier detect (input), bit 4.
    pub dcd: bool,
    /// Clear to send (input), bit 3.
    pub cts: bool,
    /// Request to send (output), bit 2.
    pub rts: bool,
    /// Data set ready (input), bit 1.
    pub dsr: bool,
    /// Data terminal ready (output), bit 0.
    pub dtr: bool,
}

impl V24Signals {
    /// The bit field (bits 7–5 are 0).
    pub const fn bits(self) -> u8 {
        (self.dcd as u8) << 4
            | (self.cts as u8) << 3
            | (self.rts as u8) << 2
            | (self.dsr as u8) << 1
            | self.dtr as u8
    }

    /// Decodes the bit field; bits 7–5 are ignored.
    pub const fn from_bits(bits: u8) -> V24Signals {
        V24Signals {
            dcd: bits & 0x10 != 0,
            cts: bits & 0x08 != 0,
            rts: bits & 0x04 != 0,
            dsr: bits & 0x02 != 0,
            dtr: bits & 0x01 != 0,
        }
    }

    /// Only the outputs a write V.24 job can set: RTS (bit 2) and DTR (bit 0) ([ET200S SI 2005]
    /// §2.12.2–§2.12.6, derived from §2.10.5/§2.8.5; the other bits are inputs of the module and
    /// have no effect).
    pub const fn outputs(self) -> V24Signals {
        V24Signals {
            dcd: false,
            cts: false,
            rts: self.rts,
            dsr: false,
            dtr: self.dtr,
        }
    }
}

impl From<V24Signals> for si_core::ModemSignals {
    /// The signal word as S_VSTAT shows it.
    fn from(s: V24Signals) -> si_core::ModemSignals {
        si_core::ModemSignals {
            dtr: s.dtr,
            dsr: s.dsr,
            rts: s.rts,
            cts: s.cts,
            dcd: s.dcd,
        }
    }
}

impl From<si_core::ModemSignals> for V24Signals {
    fn from(s: si_core::ModemSignals) -> V24Signals {
        V24Signals {
            dcd: s.dcd,
            cts: s.cts,
            rts: s.rts,
            dsr: s.dsr,
            dtr: s.dtr,
        }
    }
}

/// Where the V.24 bit field sits in the 16-bit signal word (`[derived]`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum V24Layout {
    /// Byte 1 = 00H, byte 2 = bit field (our reading: the word is MSB first and its high byte is
    /// the printed "00").
    #[default]
    LowByte,
    /// Byte 1 = bit field, byte 2 = 00H.
    HighByte,
}

impl V24Layout {
    /// The signal word as window bytes 1–2.
    pub const fn encode(self, signals: V24Signals) -> [u8; 2] {
        match self {
            V24Layout::LowByte => [0, signals.bits()],
            V24Layout::HighByte => [signals.bits(), 0],
        }
    }

    /// The signals from window bytes 1–2.
    pub const fn decode(self, bytes: [u8; 2]) -> V24Signals {
        match self {
            V24Layout::LowByte => V24Signals::from_bits(bytes[1]),
            V24Layout::HighByte => V24Signals::from_bits(bytes[0]),
        }
    }
}

/// The flow-control parameter blocks of the parameter job (`[ET200S SI 2005]` §2.12.6, Table
/// 2-28): one codec for the window and the ASCII link, in si-core. Times are raw counts of
/// 10 ms, exactly as they cross the window: 200 = 2 s.
pub use si_core::param_block::{ParamBlock, ParamError};

/// The receive status the module publishes in bytes 1–2 while idle ([ET200S SI 2005] §2.12.1), plus
/// 0101H, the answer to a receive job when nothing is there ([ET200S SI 2005] §2.12.7,
/// `[derived]`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum RxStatus {
    /// 0000H: no received frame.
    Empty,
    /// 0001H: a received frame is waiting.
    FramePresent,
    /// 0B01H: the receive buffer is more than 2/3 full (a frame is waiting).
    TwoThirdsFull,
    /// 0101H: "no message available" (answer to a receive job; not an error).
    NothingAvailable,
    /// Any other word (an error code, or a module this crate does not know).
    Other(u16),
}

impl RxStatus {
    /// The status from the 16-bit word.
    pub const fn from_word(word: u16) -> RxStatus {
        match word {
            0x0000 => RxStatus::Empty,
            0x0001 => RxStatus::FramePresent,
            0x0B01 => RxStatus::TwoThirdsFull,
            0x0101 => RxStatus::NothingAvailable,
            w => RxStatus::Other(w),
        }
    }

    /// The 16-bit word.
    pub const fn word(self) -> u16 {
        match self {
            RxStatus::Empty => 0x0000,
            RxStatus::FramePresent => 0x0001,
            RxStatus::TwoThirdsFull => 0x0B01,
            RxStatus::NothingAvailable => 0x0101,
            RxStatus::Other(w) => w,
        }
    }

    /// True when a receive job would find a frame (0001H or 0B01H).
    pub const fn frame_waiting(self) -> bool {
        matches!(self, RxStatus::FramePresent | RxStatus::TwoThirdsFull)
    }
}

/// Which way a window travels, for [`describe`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Direction {
    /// The host's output window (host → module).
    HostToModule,
    /// The module's input window (module → host).
    ModuleToHost,
}

/// A one-line reading of a window for people (`si frame decode`, traces): the coordination byte
/// and what bytes 1..n mean for it. A segment's data is shown as hex; whether an exec 1 segment
/// starts with the length word depends on the job's history, which a single window does not have.
pub fn describe(window: &Window, dir: Direction, v24: V24Layout) -> String {
    use crate::coord::JobCode;
    use core::fmt::Write;
    let c = window.coord();
    let word = window.word();
    let d = window.data();
    let status = |w: u16| crate::status::lookup(w).to_string();
    let mut s = c.to_string();
    let hex = |bytes: &[u8]| si_core::hex::format(bytes);
    let _ = match (c.job, c.exec, c.error, dir) {
        (_, _, true, _) => write!(s, ": segment out of order, last valid {}", c.exec),
        (JobCode::Idle, _, _, Direction::ModuleToHost) => {
            let rx = RxStatus::from_word(word);
            write!(s, ": receive status {word:04X}H ({rx:?})")
        }
        (JobCode::Idle, _, _, Direction::HostToModule) => Ok(()),
        (JobCode::WriteV24, 0, _, Direction::HostToModule) => {
            let sig = v24.decode([d[0], d[1]]);
            write!(s, ": set RTS={} DTR={}", sig.rts as u8, sig.dtr as u8)
        }
        (JobCode::ReadV24, 1, _, Direction::ModuleToHost) => {
            let g = v24.decode([d[0], d[1]]);
            write!(
                s,
                ": DCD={} CTS={} RTS={} DSR={} DTR={}",
                g.dcd as u8, g.cts as u8, g.rts as u8, g.dsr as u8, g.dtr as u8
            )
        }
        (JobCode::EndOfJob, _, _, Direction::ModuleToHost)
        | (JobCode::WriteV24 | JobCode::Receive, 0, _, Direction::ModuleToHost) => {
            write!(s, ": STATUS {}", status(word))
        }
        (_, 0, _, Direction::HostToModule) => write!(s, ": job request"),
        (JobCode::Send | JobCode::Parameters, 0, _, Direction::ModuleToHost) => {
            write!(s, ": job accepted")
        }
        (JobCode::Send | JobCode::Parameters, _, _, Direction::ModuleToHost)
        | (JobCode::Receive | JobCode::ReadV24, _, _, Direction::HostToModule) => {
            write!(s, ": acknowledges segment {}", c.exec)
        }
        _ => write!(s, ": data {}", hex(d)),
    };
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::coord::JobCode;

    #[test]
    fn segment_counts_of_section_2_6() {
        assert_eq!(WindowSize::Eight.segments(22 + 2), 4);
        assert_eq!(WindowSize::Eight.segments(6 + 2), 2);
        assert_eq!(WindowSize::Four.segments(224 + 2), 76);
        assert_eq!(WindowSize::Eight.segments(224 + 2), 33);
        assert_eq!(WindowSize::ThirtyTwo.segments(224 + 2), 8);
        assert_eq!(WindowSize::Four.segments(7), 3); // XON/XOFF block, Table 2-28
    }

    #[test]
    fn segments_of_table_2_23() {
        let mut stream = Vec::new();
        send_stream(b"abcdefghijklmnopqrstuv", &mut stream);
        let mut w = Window::new(WindowSize::Eight);
        w.set_segment(CoordByte::new(JobCode::Send, 1), &stream, 1);
        assert_eq!(
            w.as_bytes(),
            [0x11, 0x00, 0x16, b'a', b'b', b'c', b'd', b'e']
        );
        w.set_segment(CoordByte::new(JobCode::Send, 4), &stream, 4);
        assert_eq!(w.as_bytes(), [0x14, b't', b'u', b'v', 0, 0, 0, 0]);
        // Past the end: an empty, zero-filled segment rather than a panic.
        w.set_segment(CoordByte::new(JobCode::Send, 5), &stream, 99);
        assert_eq!(w.as_bytes(), [0x15, 0, 0, 0, 0, 0, 0, 0]);
    }

    #[test]
    fn v24_word_of_tables_2_25_and_2_26() {
        let s = V24Signals {
            dcd: true,
            cts: false,
            rts: true,
            dsr: false,
            dtr: true,
        };
        assert_eq!(s.bits(), 0b1_0101);
        assert_eq!(V24Layout::LowByte.encode(s), [0x00, 0x15]);
        assert_eq!(V24Layout::HighByte.encode(s), [0x15, 0x00]);
        for bits in 0..=0x1F {
            let s = V24Signals::from_bits(bits);
            assert_eq!(s.bits(), bits);
            for layout in [V24Layout::LowByte, V24Layout::HighByte] {
                assert_eq!(layout.decode(layout.encode(s)), s);
            }
        }
        assert_eq!(s.outputs().bits(), 0b0_0101);
    }

    #[test]
    fn idle_receive_status_words() {
        for (w, s) in [
            (0x0000, RxStatus::Empty),
            (0x0001, RxStatus::FramePresent),
            (0x0B01, RxStatus::TwoThirdsFull),
            (0x0101, RxStatus::NothingAvailable),
            (0x0850, RxStatus::Other(0x0850)),
        ] {
            assert_eq!(RxStatus::from_word(w), s);
            assert_eq!(s.word(), w);
        }
        assert!(RxStatus::TwoThirdsFull.frame_waiting());
        assert!(!RxStatus::NothingAvailable.frame_waiting());
    }

    #[test]
    fn describe_reads_the_manual_examples() {
        let w = |b: &[u8]| Window::from_bytes(b).unwrap();
        let l = V24Layout::LowByte;
        let (h, m) = (Direction::HostToModule, Direction::ModuleToHost);
        assert_eq!(
            describe(&w(&[0x00, 0x00, 0x01, 0]), m, l),
            "00H (idle, exec 0): receive status 0001H (FramePresent)"
        );
        assert_eq!(
            describe(&w(&[0x10, 0, 0, 0]), h, l),
            "10H (send, exec 0): job request"
        );
        assert_eq!(
            describe(&w(&[0x11, 0x00, 0x16, 0x61]), h, l),
            "11H (send, exec 1): data 00 16 61"
        );
        assert_eq!(
            describe(&w(&[0x74, 0x00, 0x00, 0]), m, l),
            "74H (end of job, exec 4): STATUS 16#0000 no error"
        );
        assert_eq!(
            describe(&w(&[0x20, 0x01, 0x01, 0]), m, l),
            "20H (receive, exec 0): STATUS 16#0101 receive job issued but no received frame is available (not an error)"
        );
        assert_eq!(
            describe(&w(&[0x31, 0x00, 0x1B, 0]), m, l),
            "31H (read V.24, exec 1): DCD=1 CTS=1 RTS=0 DSR=1 DTR=1"
        );
        assert_eq!(
            describe(&w(&[0x40, 0x00, 0x05, 0]), h, l),
            "40H (write V.24, exec 0): set RTS=1 DTR=1"
        );
        assert_eq!(
            describe(&w(&[0x19, 0, 0, 0]), m, l),
            "19H (send, error, last valid 1): segment out of order, last valid 1"
        );
        assert_eq!(
            describe(&w(&[0x12, 0, 0, 0]), m, l),
            "12H (send, exec 2): acknowledges segment 2"
        );
    }

    #[test]
    fn window_from_bytes_checks_the_size() {
        assert!(Window::from_bytes(&[0; 5]).is_none());
        let w = Window::from_bytes(&[0x00, 0x0B, 0x01, 0]).unwrap();
        assert_eq!(w.size(), WindowSize::Four);
        assert_eq!(w.word(), 0x0B01);
    }
}
