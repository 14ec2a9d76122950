//! RTU over TCP: raw RTU ADUs (address, PDU, CRC) cut out of a byte stream, Sans-IO.
//!
//! Serial device servers in "raw" or "transparent" mode forward the bytes of an RTU line over
//! a TCP connection unchanged: address, PDU and CRC low byte first ([Modbus serial] §2.5.1),
//! with no MBAP header. TCP keeps no gaps, so the 3.5-character silence that ends an RTU frame
//! on the wire ([Modbus serial] §2.5.1.1) is lost: a frame must end at the length its header
//! predicts (the same prediction as [`crate::config::FrameEnd::Length`], [`rx::request_len`] and
//! [`rx::response_len`]), and the CRC over that length decides whether it is a frame.
//!
//! # Readings chosen `[derived]`
//!
//! - **Predicted length, then the CRC.** A frame is cut the moment it holds its predicted
//!   length and the CRC over those bytes checks. A request also gets a prediction for the
//!   function codes of [Modbus AP] the module does not serve but a gateway passes through:
//!   11H report server ID (§6.13), 14H/15H file records (§6.14, §6.15, byte count at offset 2),
//!   16H mask write (§6.16), 17H read/write multiple registers (§6.17, byte count at offset 10),
//!   18H read FIFO queue (§6.18) and 2BH encapsulated interface transport with MEI type 0EH,
//!   read device identification (§6.21).
//! - **A bad CRC is reported once, then the stream hunts.** A frame whose CRC does not check
//!   at its predicted length is reported ([`Cut::BadCrc`]) so the caller can drop and count it.
//!   The codec then drops one byte at a time (counted in [`StreamCounters::skipped`], not
//!   reported again) until a frame of its predicted length checks, so a byte inserted or lost
//!   in the stream costs the one frame it hit, never the ones after it. Dropping one byte at a
//!   time never skips the start of a real frame.
//! - **An unpredictable frame ends where the next frame begins, or at a gap.** A frame whose
//!   length cannot be predicted (an unknown function code, or a corrupted one) ends where a
//!   predicted frame that checks begins; the bytes before it are a frame if their own CRC
//!   checks, else a bad frame ([`Cut::BadCrc`]). When nothing follows, it waits for
//!   [`RtuStream::gap`]: the caller calls it when the stream has been idle long enough (a
//!   device server sends a frame in one burst). The gap cuts the bytes held as one frame if
//!   they end in a valid CRC, searching forward from each start offset while hunting.
//! - **Bounded.** At most [`MAX_ADU`] bytes are held; an unpredictable frame that reaches that
//!   size is dropped ([`Cut::Overflow`]).
//!
//! ```
//! use si_modbus::frame::{Adu, Request};
//! use si_modbus::rtu_stream::{Cut, RtuStream};
//! use si_modbus::rx::Expect;
//! let adu = Adu::request(1, &Request::ReadHoldingRegisters { address: 0, quantity: 10 }).unwrap();
//! let mut stream = RtuStream::new(Expect::Request);
//! let mut input = adu.as_bytes();
//! match stream.push(&mut input) {
//!     Some(Cut::Frame(got)) => assert_eq!(got.as_bytes(), adu.as_bytes()),
//!     other => panic!("{other:?}"),
//! }
//! assert!(input.is_empty());
//! ```

use crate::frame::{crc16, crc_ok, Adu, MAX_ADU};
use crate::rx::{self, Expect, Prediction};

/// What the stream cut: a frame, or bytes it dropped and why.
///
/// A frame is held inline (no heap per frame), which makes this enum large; that is deliberate.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Cut {
    /// A whole ADU whose CRC checks.
    Frame(Adu),
    /// `len` bytes, the predicted length (or, for a frame without a prediction, the bytes
    /// before the next frame), whose last two bytes are not the CRC of the rest: dropped. `expected` is the CRC computed over the bytes, `found` the CRC they carry.
    BadCrc {
        /// Frame length, CRC included.
        len: usize,
        /// CRC-16 computed over the first `len - 2` bytes.
        expected: u16,
        /// CRC-16 carried in the last two bytes (low byte first).
        found: u16,
    },
    /// Bytes held at a [`RtuStream::gap`] that are no frame (too short, or no valid CRC).
    Fragment {
        /// Bytes dropped.
        len: usize,
    },
    /// An unpredictable frame reached [`MAX_ADU`] bytes without a gap: dropped.
    Overflow {
        /// Bytes dropped.
        len: usize,
    },
}

/// Counts of what the stream did, never reset (for metrics).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct StreamCounters {
    /// Frames cut with a valid CRC.
    pub frames: u64,
    /// Frames dropped for a bad CRC ([`Cut::BadCrc`]).
    pub crc_errors: u64,
    /// Bytes dropped one at a time while hunting for the next frame.
    pub skipped: u64,
    /// Fragments dropped at a gap ([`Cut::Fragment`]).
    pub fragments: u64,
    /// Unpredictable frames dropped at the size bound ([`Cut::Overflow`]).
    pub overflows: u64,
}

/// A streaming RTU-over-TCP decoder: takes bytes in any chunking, cuts ADUs at their
/// predicted length (see the module documentation).
#[derive(Clone)]
pub struct RtuStream {
    buf: [u8; MAX_ADU],
    have: usize,
    expect: Expect,
    /// After a bad CRC: drop one byte at a time until a frame checks.
    hunting: bool,
    /// The next hunt checks every complete frame held, not only those ending at the last byte.
    rescan: bool,
    counters: StreamCounters,
}

impl RtuStream {
    /// A stream that expects frames of kind `expect`: [`Expect::Request`] on a listener that
    /// serves clients, [`Expect::ResponseTo`] on a line to a device server, [`Expect::Nothing`]
    /// to cut only at gaps.
    pub const fn new(expect: Expect) -> Self {
        RtuStream {
            buf: [0; MAX_ADU],
            have: 0,
            expect,
            hunting: false,
            rescan: false,
            counters: StreamCounters {
                frames: 0,
                crc_errors: 0,
                skipped: 0,
                fragments: 0,
                overflows: 0,
            },
        }
    }

    /// Change what the next frame is expected to be (a master sets the request's function
    /// code before it sends).
    pub fn set_expect(&mut self, expect: Expect) {
        self.expect = expect;
    }

    /// Bytes held of an unfinished frame.
    pub fn pending(&self) -> usize {
        self.have
    }

    /// The counters so far.
    pub fn counters(&self) -> StreamCounters {
        self.counters
    }

    /// Take bytes from the front of `input` until something is cut or `input` is empty.
    ///
    /// Returns the cut (call again with the rest of `input` for the next), or `None` when all
    /// of `input` was taken and the frame held needs more bytes or a [`RtuStream::gap`].
    pub fn push(&mut self, input: &mut &[u8]) -> Option<Cut> {
        loop {
            if let Some(cut) = self.try_cut() {
                return Some(cut);
            }
            let (&byte, rest) = input.split_first()?;
            *input = rest;
            self.buf[self.have] = byte;
            self.have += 1;
        }
    }

    /// The stream has been idle long enough to end a frame: cut what is held. Call it until
    /// it returns `None`; the stream is then empty and in step again.
    ///
    /// The bytes held are searched for the earliest start offset where a predicted frame, or
    /// all the bytes to the end, check. Bytes before it are reported as a bad frame (while
    /// hunting: skipped silently), then the frame is cut. Bytes where nothing checks are a
    /// [`Cut::Fragment`].
    pub fn gap(&mut self) -> Option<Cut> {
        if self.have == 0 {
            self.hunting = false;
            return None;
        }
        let held = self.have;
        let found = (0..held).find_map(|at| match self.predict(at) {
            Prediction::Len(n) if at + n <= held && crc_ok(&self.buf[at..at + n]) => Some((at, n)),
            _ if held - at >= 4 && crc_ok(&self.buf[at..held]) => Some((at, held - at)),
            _ => None,
        });
        let Some((at, len)) = found else {
            self.have = 0;
            self.hunting = false;
            self.counters.fragments += 1;
            return Some(Cut::Fragment { len: held });
        };
        if at > 0 {
            if !self.hunting {
                return Some(self.drop_bad(at));
            }
            self.counters.skipped += at as u64;
        }
        self.consume(at);
        self.cut_frame(0, len)
    }

    /// Drop the first `len` bytes held, which are no frame: a bad CRC from 4 bytes on, else a
    /// fragment.
    fn drop_bad(&mut self, len: usize) -> Cut {
        let head = &self.buf[..len];
        let cut = if len < 4 {
            self.counters.fragments += 1;
            Cut::Fragment { len }
        } else {
            self.counters.crc_errors += 1;
            Cut::BadCrc {
                len,
                expected: crc16(&head[..len - 2]),
                found: u16::from_le_bytes([head[len - 2], head[len - 1]]),
            }
        };
        self.consume(len);
        cut
    }

    /// Cut a frame out of the bytes held if their prediction says it is complete.
    fn try_cut(&mut self) -> Option<Cut> {
        if self.hunting {
            return self.hunt();
        }
        let len = match self.predict(0) {
            Prediction::NeedMore(_) => return None,
            Prediction::Unknown if self.have >= MAX_ADU => {
                let len = self.have;
                self.have = 0;
                self.counters.overflows += 1;
                return Some(Cut::Overflow { len });
            }
            Prediction::Unknown => return self.cut_unknown(),
            Prediction::Len(len) => len,
        };
        if self.have < len {
            return None;
        }
        let frame = &self.buf[..len];
        if crc_ok(frame) {
            return self.cut_frame(0, len);
        }
        let expected = crc16(&frame[..len - 2]);
        let found = u16::from_le_bytes([frame[len - 2], frame[len - 1]]);
        self.counters.crc_errors += 1;
        self.hunting = true;
        self.rescan = true;
        // The reported frame's first byte goes with the report, not into `skipped`.
        self.consume(1);
        Some(Cut::BadCrc {
            len,
            expected,
            found,
        })
    }

    /// A frame without a prediction ends where a predicted frame that checks begins: the
    /// bytes before it are a frame if their own CRC checks, else a bad frame (reported like a
    /// bad CRC; under 4 bytes a fragment). Until such a frame follows, a [`RtuStream::gap`] or
    /// the size bound ends it. Only frames ending at the newest byte are checked.
    fn cut_unknown(&mut self) -> Option<Cut> {
        let at = (1..self.have).find(|&at| match self.predict(at) {
            Prediction::Len(n) => at + n == self.have && crc_ok(&self.buf[at..self.have]),
            _ => false,
        })?;
        if at >= 4 && crc_ok(&self.buf[..at]) {
            return self.cut_frame(0, at);
        }
        Some(self.drop_bad(at))
    }

    /// After a bad CRC: the earliest start offset whose predicted frame is complete and
    /// checks wins; leading bytes that can no longer start a frame are dropped one at a time.
    ///
    /// Only frames that end at the newest byte are checked (earlier ends were checked when
    /// their last byte came), except in the first scan after the bad CRC: one CRC per offset
    /// at most, so a hostile stream costs O(held) per byte.
    fn hunt(&mut self) -> Option<Cut> {
        let rescan = core::mem::take(&mut self.rescan);
        for at in 0..self.have {
            if let Prediction::Len(n) = self.predict(at) {
                let end = at + n;
                let due = if rescan {
                    end <= self.have
                } else {
                    end == self.have
                };
                if due && crc_ok(&self.buf[at..end]) {
                    self.counters.skipped += at as u64;
                    return self.cut_frame(at, n);
                }
            }
        }
        loop {
            match self.predict(0) {
                Prediction::NeedMore(_) => return None,
                Prediction::Len(n) if n > self.have => return None,
                _ => self.skip_one(),
            }
        }
    }

    /// Hand out the `len` bytes at `at` as a frame and drop everything up to their end.
    fn cut_frame(&mut self, at: usize, len: usize) -> Option<Cut> {
        let adu = Adu::from_slice(&self.buf[at..at + len])?;
        self.consume(at + len);
        self.hunting = false;
        self.counters.frames += 1;
        Some(Cut::Frame(adu))
    }

    /// The length the held bytes' header predicts, never over [`MAX_ADU`] and never under 4.
    fn predict(&self, at: usize) -> Prediction {
        let head = &self.buf[at..self.have];
        let p = match self.expect {
            Expect::Nothing => Prediction::Unknown,
            Expect::Request => request_len(head),
            Expect::ResponseTo(fc) => rx::response_len(fc, head),
        };
        match p {
            Prediction::Len(n) if !(4..=MAX_ADU).contains(&n) => Prediction::Unknown,
            other => other,
        }
    }

    fn skip_one(&mut self) {
        self.consume(1);
        self.counters.skipped += 1;
    }

    fn consume(&mut self, n: usize) {
        self.buf.copy_within(n..self.have, 0);
        self.have -= n;
    }
}

impl Default for RtuStream {
    fn default() -> Self {
        RtuStream::new(Expect::Request)
    }
}

impl core::fmt::Debug for RtuStream {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("RtuStream")
            .field("held", &si_core::hex::format(&self.buf[..self.have]))
            .field("expect", &self.expect)
            .field("hunting", &self.hunting)
            .field("counters", &self.counters)
            .finish()
    }
}

/// The length of a request as [`rx::request_len`] predicts it, extended by the function codes
/// a gateway passes through ([Modbus AP] §6.13–§6.18, §6.21; see the module documentation).
pub fn request_len(head: &[u8]) -> Prediction {
    match rx::request_len(head) {
        Prediction::Unknown => {}
        known => return known,
    }
    let counted = |at: usize, fixed: usize| match head.get(at) {
        Some(&count) => Prediction::Len(fixed + count as usize),
        None => Prediction::NeedMore(at + 1),
    };
    match head.get(1) {
        // Report server ID: address, function, CRC.
        Some(0x11) => Prediction::Len(4),
        // Read/write file record: byte count at offset 2, then the sub-requests.
        Some(0x14) | Some(0x15) => counted(2, 5),
        // Mask write register: reference, AND mask, OR mask.
        Some(0x16) => Prediction::Len(10),
        // Read/write multiple registers: four 16-bit fields, then the write byte count.
        Some(0x17) => counted(10, 13),
        // Read FIFO queue: the FIFO pointer address.
        Some(0x18) => Prediction::Len(6),
        // Encapsulated interface transport: MEI type 0EH (read device identification) carries
        // the read device id code and the object id.
        Some(0x2B) => match head.get(2) {
            Some(0x0E) => Prediction::Len(7),
            Some(_) => Prediction::Unknown,
            None => Prediction::NeedMore(3),
        },
        _ => Prediction::Unknown,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::{Request, Response};

    fn fc03(unit: u8, address: u16) -> Adu {
        Adu::request(
            unit,
            &Request::ReadHoldingRegisters {
                address,
                quantity: 10,
            },
        )
        .unwrap()
    }

    fn cut_all(stream: &mut RtuStream, mut input: &[u8]) -> Vec<Cut> {
        let mut cuts = Vec::new();
        while let Some(cut) = stream.push(&mut input) {
            cuts.push(cut);
        }
        cuts
    }

    fn with_crc(body: &[u8]) -> Vec<u8> {
        let mut v = body.to_vec();
        v.extend_from_slice(&crc16(body).to_le_bytes());
        v
    }

    #[test]
    fn back_to_back_requests_are_cut_at_their_length() {
        let (a, b) = (fc03(1, 0), fc03(2, 100));
        let bytes = [a.as_bytes(), b.as_bytes()].concat();
        let mut s = RtuStream::new(Expect::Request);
        assert_eq!(cut_all(&mut s, &bytes), vec![Cut::Frame(a), Cut::Frame(b)]);
        assert_eq!(s.pending(), 0);
        assert_eq!(s.counters().frames, 2);
    }

    #[test]
    fn a_bad_crc_is_reported_once_and_the_next_frame_is_found() {
        let mut bad = fc03(1, 0).as_bytes().to_vec();
        bad[7] ^= 0xFF;
        let good = fc03(3, 7);
        let bytes = [&bad[..], good.as_bytes()].concat();
        let mut s = RtuStream::new(Expect::Request);
        let cuts = cut_all(&mut s, &bytes);
        assert_eq!(cuts.len(), 2, "{cuts:?}");
        assert!(
            matches!(cuts[0], Cut::BadCrc { len: 8, found, expected } if found != expected),
            "{cuts:?}"
        );
        assert_eq!(cuts[1], Cut::Frame(good));
        let c = s.counters();
        assert_eq!((c.frames, c.crc_errors, c.skipped), (1, 1, 7));
    }

    #[test]
    fn a_stray_byte_costs_only_the_frame_it_hit() {
        let (a, b) = (fc03(1, 0), fc03(2, 1));
        let bytes = [&[0x55][..], a.as_bytes(), b.as_bytes()].concat();
        let mut s = RtuStream::new(Expect::Request);
        let cuts = cut_all(&mut s, &bytes);
        // 55 01 is read as a request to unit 55H with FC01: its CRC fails, then the hunt finds
        // unit 1's frame at the next offset.
        assert!(matches!(cuts[0], Cut::BadCrc { len: 8, .. }), "{cuts:?}");
        assert_eq!(&cuts[1..], [Cut::Frame(a), Cut::Frame(b)]);
    }

    #[test]
    fn an_unknown_function_waits_for_the_gap() {
        let odd = with_crc(&[1, 0x41, 1, 2, 3]);
        let mut s = RtuStream::new(Expect::Request);
        assert_eq!(cut_all(&mut s, &odd), vec![]);
        assert_eq!(s.pending(), odd.len());
        assert_eq!(s.gap(), Some(Cut::Frame(Adu::from_slice(&odd).unwrap())));
        assert_eq!(s.gap(), None);
        // A short fragment at a gap is dropped.
        assert_eq!(cut_all(&mut s, &[1, 0x41]), vec![]);
        assert_eq!(s.gap(), Some(Cut::Fragment { len: 2 }));
        assert_eq!(s.counters().fragments, 1);
    }

    #[test]
    fn an_unknown_frame_ends_where_the_next_frame_begins() {
        let odd = with_crc(&[1, 0x41, 1, 2, 3]);
        let mut garbled = odd.clone();
        garbled[2] ^= 0x10;
        let a = fc03(2, 0);
        let bytes = [&odd[..], a.as_bytes(), &garbled[..], a.as_bytes()].concat();
        let mut s = RtuStream::new(Expect::Request);
        let cuts = cut_all(&mut s, &bytes);
        assert_eq!(
            cuts[..2],
            [Cut::Frame(Adu::from_slice(&odd).unwrap()), Cut::Frame(a)]
        );
        assert!(matches!(cuts[2], Cut::BadCrc { len: 7, .. }), "{cuts:?}");
        assert_eq!(cuts[3..], [Cut::Frame(a)]);
    }

    #[test]
    fn an_endless_unknown_frame_overflows_at_the_bound() {
        let mut s = RtuStream::new(Expect::Request);
        let junk = [0x41u8; MAX_ADU + 10];
        let mut input = &junk[..];
        assert_eq!(s.push(&mut input), Some(Cut::Overflow { len: MAX_ADU }));
        assert_eq!(input.len(), 10);
        assert_eq!(s.counters().overflows, 1);
    }

    #[test]
    fn pass_through_requests_have_a_length() {
        // [Modbus AP] §6.21: read device identification, basic, object 0.
        let devid = with_crc(&[1, 0x2B, 0x0E, 0x01, 0x00]);
        let fc17 = with_crc(&[1, 0x17, 0, 1, 0, 2, 0, 3, 0, 1, 2, 0xAB, 0xCD]);
        let bytes = [&devid[..], &fc17[..]].concat();
        let mut s = RtuStream::new(Expect::Request);
        let cuts = cut_all(&mut s, &bytes);
        assert_eq!(
            cuts,
            vec![
                Cut::Frame(Adu::from_slice(&devid).unwrap()),
                Cut::Frame(Adu::from_slice(&fc17).unwrap())
            ]
        );
    }

    #[test]
    fn responses_are_cut_by_the_request_function() {
        let r = Adu::response(
            4,
            &Response::ReadHoldingRegisters(crate::frame::Registers::Words(&[1, 2, 3])),
        )
        .unwrap();
        let exc = with_crc(&[4, 0x83, 0x02]);
        let bytes = [r.as_bytes(), &exc[..]].concat();
        let mut s = RtuStream::new(Expect::ResponseTo(3));
        let cuts = cut_all(&mut s, &bytes);
        assert_eq!(
            cuts,
            vec![Cut::Frame(r), Cut::Frame(Adu::from_slice(&exc).unwrap())]
        );
    }

    #[test]
    fn a_gap_ends_the_hunt_and_an_unknown_frame_after_it_is_cut() {
        let odd = with_crc(&[9, 0x41, 7]);
        let mut bad = fc03(1, 0).as_bytes().to_vec();
        bad[6] ^= 1;
        let mut s = RtuStream::new(Expect::Request);
        let cuts = cut_all(&mut s, &bad);
        assert!(matches!(cuts[..], [Cut::BadCrc { .. }]), "{cuts:?}");
        // The device server's silence between the two bursts: whatever is left is dropped.
        assert!(matches!(s.gap(), None | Some(Cut::Fragment { .. })));
        assert_eq!(cut_all(&mut s, &odd), vec![]);
        assert_eq!(s.gap(), Some(Cut::Frame(Adu::from_slice(&odd).unwrap())));
    }

    #[test]
    fn a_false_prediction_does_not_hold_the_hunt() {
        // While hunting, FC10 with a byte count of 200 would wait for 209 bytes; the valid
        // frame held after it is cut as soon as its last byte comes.
        let good = fc03(5, 1);
        let mut s = RtuStream::new(Expect::Request);
        s.hunting = true;
        s.rescan = true;
        let bytes = [&[0x07, 0x10, 0, 0, 0, 1, 200][..], good.as_bytes()].concat();
        assert_eq!(cut_all(&mut s, &bytes), vec![Cut::Frame(good)]);
        assert_eq!(s.counters().skipped, 7);
        assert_eq!(s.pending(), 0);
    }
}
