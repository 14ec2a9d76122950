//! Local-echo suppression for ports that hear their own transmission, Sans-IO: the one RS-485
//! echo filter of every engine and of the driver.
//!
//! A two-wire RS-485 adapter whose receiver stays enabled while it sends (many USB-RS485
//! converters, and any bus tap) hands every transmitted byte back to the host. The engines must
//! not take that for the partner's answer. [`EchoFilter`] drops it, in one of three modes
//! ([`EchoMode`]):
//!
//! - **match** ([`EchoFilter::new`], the driver's `--local-echo`): remembers what was sent and,
//!   within the transmit window (until the last byte has been on the wire and the port's
//!   delivery delay has passed), drops received bytes that match it, in order. The first byte
//!   that does not match ends suppression: it and everything after it is passed on (a
//!   collision or the partner talking over us is something the engine must see). What is
//!   remembered is bounded ([`ECHO_CAPACITY`]); beyond that the oldest expected bytes are
//!   forgotten, so at worst a long transmission's echo start reaches the engine, which rejects
//!   it as it would any noise.
//! - **count** ([`EchoFilter::counting`], Modbus and USS with `local_echo`): the engine knows
//!   its line echoes; it drops as many received characters as it sent, whatever they are.
//! - **while sending** ([`EchoFilter::while_sending`], the ASCII driver on RS-485, which works
//!   half duplex only, [CP 341] §2.2.4): everything received from the first
//!   byte sent until the engine learns the transmission has left the line is its own.
//!
//! Every mode is bounded: a counter, a flag, or at most [`ECHO_CAPACITY`] bytes.

use crate::time::Instant;
use std::collections::VecDeque;

/// At most this many transmitted bytes are remembered for suppression: more than the longest
/// frame of any protocol here (a 3964(R) block of 1024 data bytes with every byte doubled, a
/// Modbus ADU of 256).
pub const ECHO_CAPACITY: usize = 4_096;

/// How an [`EchoFilter`] recognises the echo (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EchoMode {
    /// Drops received bytes equal to the ones sent, in order, within the transmit window.
    Match,
    /// Drops as many received characters as were sent.
    Count,
    /// Drops everything received while a transmission is on the line.
    WhileSending,
}

/// Drops the echo of our own transmission from the received stream (module docs).
#[derive(Debug, Clone)]
pub struct EchoFilter {
    mode: EchoMode,
    /// Match: transmitted bytes whose echo has not come back yet, oldest first.
    expected: VecDeque<u8>,
    /// Match: the end of the transmit window: after it nothing more is expected.
    until: Option<Instant>,
    /// Count: characters still to be dropped. While sending: nonzero while on the line.
    left: usize,
}

impl Default for EchoFilter {
    fn default() -> Self {
        Self::with_mode(EchoMode::Match)
    }
}

impl EchoFilter {
    /// A filter in match mode expecting nothing.
    pub fn new() -> Self {
        Self::default()
    }

    /// A filter in count mode expecting nothing.
    pub fn counting() -> Self {
        Self::with_mode(EchoMode::Count)
    }

    /// A filter in while-sending mode, not sending.
    pub fn while_sending() -> Self {
        Self::with_mode(EchoMode::WhileSending)
    }

    /// A filter in `mode` expecting nothing.
    pub fn with_mode(mode: EchoMode) -> Self {
        EchoFilter {
            mode,
            expected: VecDeque::new(),
            until: None,
            left: 0,
        }
    }

    /// The mode the filter was made with.
    pub fn mode(&self) -> EchoMode {
        self.mode
    }

    /// We transmitted `bytes`; their echo may arrive until `until` (end of the bytes' wire time
    /// plus the port's delivery delay). Count and while-sending mode use only the length (see
    /// [`sent_len`](Self::sent_len)).
    pub fn sent(&mut self, bytes: &[u8], until: Instant) {
        if self.mode != EchoMode::Match {
            self.sent_len(bytes.len());
            return;
        }
        let keep = bytes.len().min(ECHO_CAPACITY);
        let overflow = (self.expected.len() + keep).saturating_sub(ECHO_CAPACITY);
        self.expected.drain(..overflow.min(self.expected.len()));
        self.expected.extend(&bytes[bytes.len() - keep..]);
        self.until = Some(self.until.map_or(until, |u| u.max(until)));
    }

    /// We transmitted `n` bytes: count mode drops `n` more received characters; while-sending
    /// mode starts dropping (a zero-length transmission too: the line is ours until
    /// [`transmitted`](Self::transmitted)). Match mode needs the bytes ([`sent`](Self::sent))
    /// and ignores this.
    pub fn sent_len(&mut self, n: usize) {
        match self.mode {
            EchoMode::Match => {}
            EchoMode::Count => self.left = self.left.saturating_add(n),
            EchoMode::WhileSending => self.left = 1,
        }
    }

    /// The transmission has left the line: while-sending mode stops dropping. The other modes
    /// keep what they expect (the echo arrives after the bytes left).
    pub fn transmitted(&mut self) {
        if self.mode == EchoMode::WhileSending {
            self.left = 0;
        }
    }

    /// Bytes are waiting to be heard back (while sending: a transmission is on the line).
    pub fn is_expecting(&self) -> bool {
        match self.mode {
            EchoMode::Match => !self.expected.is_empty(),
            EchoMode::Count | EchoMode::WhileSending => self.left > 0,
        }
    }

    /// The part of `rx`, received at `now`, that is not our echo: a suffix of `rx`.
    pub fn filter<'a>(&mut self, now: Instant, rx: &'a [u8]) -> &'a [u8] {
        match self.mode {
            EchoMode::Match => self.filter_matching(now, rx),
            EchoMode::Count => {
                let skip = self.left.min(rx.len());
                self.left -= skip;
                &rx[skip..]
            }
            EchoMode::WhileSending if self.left > 0 => &[],
            EchoMode::WhileSending => rx,
        }
    }

    /// One received character, at `now`, for engines that take bytes one at a time: `true`
    /// when it is our echo (and is dropped).
    pub fn drops(&mut self, now: Instant, byte: u8) -> bool {
        self.filter(now, &[byte]).is_empty()
    }

    /// A line error (framing, parity, overrun, break) in place of a character: `true` when it
    /// is taken for a garbled character of our echo. Count mode counts it as one of the echoed
    /// characters, while-sending mode drops it while sending; in match mode it is not our echo
    /// and ends suppression.
    pub fn drops_line_error(&mut self) -> bool {
        match self.mode {
            EchoMode::Match => {
                self.stop();
                false
            }
            EchoMode::Count | EchoMode::WhileSending if self.left > 0 => {
                if self.mode == EchoMode::Count {
                    self.left -= 1;
                }
                true
            }
            EchoMode::Count | EchoMode::WhileSending => false,
        }
    }

    /// Something other than our echo arrived (a line error, a mismatch, a timeout): stop
    /// suppressing.
    pub fn stop(&mut self) {
        self.expected.clear();
        self.until = None;
        self.left = 0;
    }

    fn filter_matching<'a>(&mut self, now: Instant, rx: &'a [u8]) -> &'a [u8] {
        if self.until.is_some_and(|u| now > u) {
            self.stop();
        }
        let mut taken = 0;
        while let (Some(&want), Some(&got)) = (self.expected.front(), rx.get(taken)) {
            if want != got {
                self.stop();
                break;
            }
            self.expected.pop_front();
            taken += 1;
        }
        &rx[taken..]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(us: u64) -> Instant {
        Instant::from_micros(us)
    }

    #[test]
    fn the_echo_is_dropped_and_the_answer_passed_on() {
        let mut f = EchoFilter::new();
        f.sent(&[1, 3, 0, 0], at(10_000));
        assert_eq!(f.filter(at(1_000), &[1, 3]), &[] as &[u8]);
        assert_eq!(f.filter(at(2_000), &[0, 0, 1, 3, 2]), &[1, 3, 2]);
        assert!(!f.is_expecting());
    }

    #[test]
    fn a_mismatch_ends_suppression_and_is_passed_on() {
        let mut f = EchoFilter::new();
        f.sent(&[1, 3, 0, 0], at(10_000));
        assert_eq!(f.filter(at(1_000), &[1, 9, 0, 0]), &[9, 0, 0]);
        assert!(!f.is_expecting());
        assert_eq!(f.filter(at(1_500), &[0]), &[0]);
    }

    #[test]
    fn after_the_window_nothing_is_dropped() {
        let mut f = EchoFilter::new();
        f.sent(&[7, 7], at(10_000));
        assert_eq!(f.filter(at(10_001), &[7, 7]), &[7, 7]);
    }

    #[test]
    fn counting_drops_as_many_characters_as_were_sent_whatever_they_are() {
        let mut f = EchoFilter::counting();
        f.sent_len(3);
        f.sent(&[0; 2], at(0));
        assert!(f.is_expecting());
        assert_eq!(f.filter(at(1), &[9, 8]), &[] as &[u8]);
        assert!(f.drops(at(2), 7));
        assert!(f.drops_line_error());
        assert_eq!(f.filter(at(3), &[6, 5, 4]), &[5, 4]);
        assert!(!f.is_expecting());
        assert!(!f.drops(at(4), 1));
        assert!(!f.drops_line_error());
    }

    #[test]
    fn counting_stops_on_request() {
        let mut f = EchoFilter::counting();
        f.sent_len(usize::MAX);
        f.sent_len(5);
        f.stop();
        assert_eq!(f.filter(at(1), &[1]), &[1]);
    }

    #[test]
    fn while_sending_drops_everything_until_the_transmission_left() {
        let mut f = EchoFilter::while_sending();
        assert_eq!(f.filter(at(0), &[1]), &[1]);
        f.sent_len(0);
        assert!(f.is_expecting());
        assert_eq!(f.filter(at(1), &[1, 2, 3, 4]), &[] as &[u8]);
        assert!(f.drops(at(2), 5));
        assert!(f.drops_line_error());
        assert!(f.drops_line_error());
        f.transmitted();
        assert!(!f.is_expecting());
        assert_eq!(f.filter(at(3), &[1, 2]), &[1, 2]);
        assert!(!f.drops_line_error());
    }

    #[test]
    fn a_line_error_ends_matching() {
        let mut f = EchoFilter::new();
        f.sent(&[1, 2], at(10_000));
        assert!(!f.drops_line_error());
        assert_eq!(f.filter(at(1), &[1, 2]), &[1, 2]);
        assert_eq!(f.mode(), EchoMode::Match);
    }

    #[test]
    fn memory_is_bounded_to_the_newest_bytes() {
        let mut f = EchoFilter::new();
        let long: Vec<u8> = (0..ECHO_CAPACITY + 10).map(|i| i as u8).collect();
        f.sent(&long, at(1_000_000));
        f.sent(&[0xAA; 5], at(1_000_000));
        assert_eq!(f.expected.len(), ECHO_CAPACITY);
        assert_eq!(f.expected.back(), Some(&0xAA));
    }
}
