//! Local-echo suppression for ports that hear their own transmission, Sans-IO.
//!
//! A two-wire RS-485 adapter whose receiver stays enabled while it sends (many USB-RS485
//! converters, and any bus tap) hands every transmitted byte back to the host. The engines must
//! not take that for the partner's answer. [`EchoFilter`] remembers what was sent and, within
//! the transmit window (until the last byte has been on the wire and the port's delivery delay
//! has passed), drops received bytes that match it, in order. The first byte that does not
//! match ends suppression: it and everything after it is passed on (a collision or the partner
//! talking over us is something the engine must see). What is remembered is bounded
//! ([`ECHO_CAPACITY`]); beyond that the oldest expected bytes are forgotten, so at worst a long
//! transmission's echo start reaches the engine, which rejects it as it would any noise.

use crate::time::Instant;
use std::collections::VecDeque;

/// At most this many transmitted bytes are remembered for suppression: more than the longest
/// frame of any protocol here (a 3964(R) block of 1024 data bytes with every byte doubled, a
/// Modbus ADU of 256).
pub const ECHO_CAPACITY: usize = 4_096;

/// Drops the echo of our own transmission from the received stream (module docs).
#[derive(Debug, Clone, Default)]
pub struct EchoFilter {
    /// Transmitted bytes whose echo has not come back yet, oldest first.
    expected: VecDeque<u8>,
    /// The end of the transmit window: after it nothing more is expected.
    until: Option<Instant>,
}

impl EchoFilter {
    /// A filter expecting nothing.
    pub fn new() -> Self {
        Self::default()
    }

    /// We transmitted `bytes`; their echo may arrive until `until` (end of the bytes' wire time
    /// plus the port's delivery delay).
    pub fn sent(&mut self, bytes: &[u8], until: Instant) {
        let keep = bytes.len().min(ECHO_CAPACITY);
        let overflow = (self.expected.len() + keep).saturating_sub(ECHO_CAPACITY);
        self.expected.drain(..overflow.min(self.expected.len()));
        self.expected.extend(&bytes[bytes.len() - keep..]);
        self.until = Some(self.until.map_or(until, |u| u.max(until)));
    }

    /// Bytes are waiting to be heard back.
    pub fn is_expecting(&self) -> bool {
        !self.expected.is_empty()
    }

    /// The part of `rx`, received at `now`, that is not our echo: a suffix of `rx`.
    pub fn filter<'a>(&mut self, now: Instant, rx: &'a [u8]) -> &'a [u8] {
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

    /// Something other than our echo arrived (a line error, a mismatch): stop suppressing.
    pub fn stop(&mut self) {
        self.expected.clear();
        self.until = None;
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
    fn memory_is_bounded_to_the_newest_bytes() {
        let mut f = EchoFilter::new();
        let long: Vec<u8> = (0..ECHO_CAPACITY + 10).map(|i| i as u8).collect();
        f.sent(&long, at(1_000_000));
        f.sent(&[0xAA; 5], at(1_000_000));
        assert_eq!(f.expected.len(), ECHO_CAPACITY);
        assert_eq!(f.expected.back(), Some(&0xAA));
    }
}
