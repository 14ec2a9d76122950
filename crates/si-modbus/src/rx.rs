//! Frame detection by silence (et200s-si-modbus-uss.md §3.5, §3.7, Table 3-11).
//!
//! A Modbus RTU receiver does not predict frame lengths: a frame ends when the line has been
//! silent for the gap tZVZ = tZVZ_TAB × fMUL ([`LineConfig::gap`]). The engines then check the
//! frame (CRC, address, lengths). Garbage and short frames are discarded and counted, and the
//! receiver is in step again at the next gap. A gap inside a frame ends it early: both pieces
//! fail their checks and are counted.
//!
//! The gap is measured the way a UART lets a receiver measure it: from the moment one
//! character has been received to the moment the next one has (its end), as the module's
//! character delay time tZVZ is defined "between two characters" (§7.3, 0806H). The silence
//! on the wire is therefore one character time shorter than the time measured.
//!
//! Operating mode (§3.7): in **Normal** mode a frame carrying a UART error or BREAK is handed
//! up as faulty so the engine reports it. In **interference suppression** mode such frames are
//! dropped silently, leading bytes before a correctly received slave address are skipped, and
//! errors after a complete frame (valid CRC) are ignored.

use crate::config::{LineConfig, Mode};
use crate::frame::{crc_ok, Adu, MAX_ADU};
use si_core::{Duration, Instant, LineError};

/// Receive statistics, for diagnostics and tests.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counters {
    /// Frames of at least 4 bytes handed to the engine.
    pub frames: u64,
    /// Frames discarded: too short here, or refused by the engine (CRC, garbage, unsolicited).
    pub discarded: u64,
    /// Bytes skipped before a slave address (interference suppression).
    pub skipped_bytes: u64,
    /// Parity, framing, overrun errors and BREAKs seen.
    pub line_errors: u64,
    /// Frames longer than [`MAX_ADU`].
    pub overflows: u64,
    /// Frames dropped silently in interference suppression mode.
    pub suppressed: u64,
}

/// Why a frame cannot be used as it stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fault {
    /// A UART error or BREAK during the frame (or between frames, with no bytes).
    Line(LineError),
    /// More than [`MAX_ADU`] bytes before the gap.
    Overflow,
}

/// A frame ended by silence.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Received {
    /// The bytes (the first [`MAX_ADU`] on overflow).
    pub adu: Adu,
    /// Set if the frame is faulty (Normal mode only; suppression mode drops such frames).
    pub fault: Option<Fault>,
}

/// The silence-based frame assembler the master and slave share.
#[derive(Debug, Clone)]
pub struct Receiver {
    buf: [u8; MAX_ADU],
    len: usize,
    last: Option<Instant>,
    fault: Option<Fault>,
    gap: Duration,
    mode: Mode,
    echo_pending: usize,
    counters: Counters,
}

impl Receiver {
    /// A receiver for this line.
    pub fn new(line: &LineConfig) -> Self {
        Receiver {
            buf: [0; MAX_ADU],
            len: 0,
            last: None,
            fault: None,
            gap: line.gap(),
            mode: line.mode,
            echo_pending: 0,
            counters: Counters::default(),
        }
    }

    /// The end-of-frame gap in use.
    pub fn gap(&self) -> Duration {
        self.gap
    }

    /// Statistics so far.
    pub fn counters(&self) -> Counters {
        self.counters
    }

    /// Count a frame the engine threw away after looking at it.
    pub fn count_discarded(&mut self) {
        self.counters.discarded += 1;
    }

    /// We transmitted `n` bytes on a line that echoes them: drop the next `n` received bytes.
    pub fn expect_echo(&mut self, n: usize) {
        self.echo_pending = self.echo_pending.saturating_add(n);
    }

    /// True while a frame is being received (bytes or an error since the last gap).
    pub fn is_receiving(&self) -> bool {
        self.last.is_some()
    }

    /// When the current frame ends if nothing more arrives.
    pub fn deadline(&self) -> Option<Instant> {
        self.last.map(|t| t + self.gap)
    }

    /// The frame that ended by `now`, if the gap has passed since its last character.
    pub fn poll(&mut self, now: Instant) -> Option<Received> {
        let last = self.last?;
        if now < last + self.gap {
            return None;
        }
        self.last = None;
        let bytes = &self.buf[..self.len];
        let fault = self.fault.take();
        let len = core::mem::take(&mut self.len);
        let mut adu = Adu::from_slice(bytes).unwrap_or_default();
        match (self.mode, fault) {
            (Mode::InterferenceSuppression, Some(_)) => {
                self.counters.suppressed += 1;
                return None;
            }
            (_, Some(f)) => {
                return Some(Received {
                    adu,
                    fault: Some(f),
                })
            }
            _ => {}
        }
        if len < 4 {
            self.counters.discarded += 1;
            return None;
        }
        if self.mode == Mode::InterferenceSuppression && !crc_ok(adu.as_bytes()) {
            // The start is a correctly received address: try the later ones.
            let first = self.buf[0];
            let restart = (1..len.saturating_sub(3))
                .find(|&k| self.buf[k] == first && crc_ok(&self.buf[k..len]));
            if let Some(k) = restart {
                self.counters.skipped_bytes += k as u64;
                adu = Adu::from_slice(&self.buf[k..len]).unwrap_or_default();
            }
        }
        self.counters.frames += 1;
        Some(Received { adu, fault: None })
    }

    /// Bytes from the line at `now`. Call [`poll`](Self::poll) first: a gap before these bytes
    /// ends the previous frame. In interference suppression mode, bytes before the first one
    /// `is_start` accepts (the expected slave address) are skipped.
    pub fn push(&mut self, now: Instant, bytes: &[u8], is_start: impl Fn(u8) -> bool) {
        let skip = self.echo_pending.min(bytes.len());
        self.echo_pending -= skip;
        let mut bytes = &bytes[skip..];
        if bytes.is_empty() {
            return;
        }
        if self.len == 0 && self.fault.is_none() && self.mode == Mode::InterferenceSuppression {
            let start = bytes
                .iter()
                .position(|&b| is_start(b))
                .unwrap_or(bytes.len());
            self.counters.skipped_bytes += start as u64;
            bytes = &bytes[start..];
            if bytes.is_empty() {
                return;
            }
        }
        self.last = Some(now);
        let room = MAX_ADU - self.len;
        let n = bytes.len().min(room);
        self.buf[self.len..self.len + n].copy_from_slice(&bytes[..n]);
        self.len += n;
        if n < bytes.len() && self.fault.is_none() {
            self.counters.overflows += 1;
            self.fault = Some(Fault::Overflow);
        }
    }

    /// A UART error or BREAK at `now`.
    pub fn line_error(&mut self, now: Instant, error: LineError) {
        self.counters.line_errors += 1;
        if self.mode == Mode::InterferenceSuppression
            && self.len >= 4
            && crc_ok(&self.buf[..self.len])
        {
            // §3.7: errors after the end of a message (after the CRC) are ignored.
            return;
        }
        self.last = Some(now);
        if self.fault.is_none() {
            self.fault = Some(Fault::Line(error));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(us: u64) -> Instant {
        Instant::from_micros(us)
    }

    #[test]
    fn frame_ends_after_the_gap_not_before() {
        let mut rx = Receiver::new(&LineConfig::default());
        rx.push(at(0), &[1, 3, 0, 0, 0, 0x0A, 0xC5, 0xCD], |_| true);
        assert_eq!(rx.poll(at(3_999)), None);
        assert_eq!(rx.deadline(), Some(at(4_000)));
        let f = rx.poll(at(4_000)).unwrap();
        assert_eq!(f.adu.as_bytes(), &[1, 3, 0, 0, 0, 0x0A, 0xC5, 0xCD]);
        assert_eq!(rx.counters().frames, 1);
    }

    #[test]
    fn short_frames_are_counted_and_dropped() {
        let mut rx = Receiver::new(&LineConfig::default());
        rx.push(at(0), &[1, 2], |_| true);
        assert_eq!(rx.poll(at(10_000)), None);
        assert_eq!(rx.counters().discarded, 1);
    }

    #[test]
    fn suppression_skips_leading_garbage_and_faulty_frames() {
        let line = LineConfig {
            mode: Mode::InterferenceSuppression,
            ..LineConfig::default()
        };
        let mut rx = Receiver::new(&line);
        rx.push(at(0), &[0x55, 0xAA, 1, 3, 0, 0, 0, 0x0A, 0xC5, 0xCD], |b| {
            b == 1
        });
        let f = rx.poll(at(10_000)).unwrap();
        assert_eq!(f.adu.as_bytes()[0], 1);
        assert_eq!(rx.counters().skipped_bytes, 2);
        rx.line_error(at(20_000), LineError::Break);
        rx.push(at(20_100), &[1, 3, 0, 0, 0, 0x0A, 0xC5, 0xCD], |b| b == 1);
        assert_eq!(rx.poll(at(30_000)), None);
        assert_eq!(rx.counters().suppressed, 1);
    }

    #[test]
    fn overflow_is_a_fault() {
        let mut rx = Receiver::new(&LineConfig::default());
        rx.push(at(0), &[0u8; 300], |_| true);
        assert_eq!(rx.poll(at(10_000)).unwrap().fault, Some(Fault::Overflow));
    }
}
