//! The quiet guard after a timeout (a host extension, off unless set with
//! [`Master::with_quiet_after_timeout`](crate::Master::with_quiet_after_timeout)): a late answer
//! is never taken for the answer to the next request.
//!
//! An RTU response carries no transaction id: it names only the slave and the function
//! ([Modbus serial] §2.5.1). A slave that answers after the response timeout would have its
//! answer taken for the next request's if that request went to the same slave with the same
//! function and length — wrong data handed to a client (a gateway serving many clients sees
//! this when one read is slow). The module itself has no such rule ([Modbus/USS] §3.4.3 ends the
//! job at the timeout); a master in front of other people's slaves needs one `[derived]`.
//!
//! So once a job has ended without an answer, the next request waits until the line has been
//! silent for the guard's `quiet` time, counted from the timeout or from the last character
//! received since, whichever is later; what arrives meanwhile is an unsolicited frame, discarded
//! and counted by the master as any other. The wait is bounded: a line that never goes quiet
//! (noise, a chattering slave) holds the request at most `quiet` + the longest response
//! ([`crate::MasterConfig::max_response_duration`]) after the timeout, and the request then
//! goes out as it would without the guard. A late answer that comes after the line was silent
//! for `quiet` cannot be told from an answer and is not guarded against; choose `quiet` at least
//! as long as a slow slave may be late.

use si_core::{Duration, Instant};

/// The guard: its quiet time and, while armed, the instant of the timeout that armed it.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct QuietGuard {
    /// Silence required before the next request; zero turns the guard off.
    quiet: Duration,
    /// The timeout that armed it, until a request goes out.
    armed: Option<Instant>,
}

impl QuietGuard {
    /// A guard asking `quiet` of silence after a timeout (zero: off).
    pub fn new(quiet: Duration) -> Self {
        QuietGuard { quiet, armed: None }
    }

    /// A job ended at `now` without an answer: guard the next request.
    pub fn arm(&mut self, now: Instant) {
        if self.quiet != Duration::ZERO {
            self.armed = Some(now);
        }
    }

    /// A request went out: the guard is spent.
    pub fn clear(&mut self) {
        self.armed = None;
    }

    /// The latest instant the guard may hold a request to: `quiet` + `longest` (the longest
    /// response) after the timeout. `None` when not armed.
    pub fn bound(&self, longest: Duration) -> Option<Instant> {
        self.armed.map(|t| t + self.quiet + longest)
    }

    /// The longest the guard can hold a request started at any instant: `quiet` + `longest`
    /// (the longest response) when it is set, zero when it is off. What
    /// [`Master::longest_job`](crate::master::Master::longest_job) adds to a job's own bound.
    pub fn longest_hold(&self, longest: Duration) -> Duration {
        if self.quiet == Duration::ZERO {
            Duration::ZERO
        } else {
            self.quiet + longest
        }
    }

    /// When the next request may go out, given the last character received (`last`) and the
    /// longest response: silence of `quiet` since the timeout or `last`, within
    /// [`bound`](Self::bound). `None` when not armed.
    pub fn until(&self, last: Option<Instant>, longest: Duration) -> Option<Instant> {
        let since = self.armed?;
        let from = last.map_or(since, |l| l.max(since));
        Some((from + self.quiet).min(since + self.quiet + longest))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ms(n: u64) -> Instant {
        Instant::from_micros(n * 1000)
    }

    #[test]
    fn off_and_unarmed_guards_hold_nothing() {
        let mut off = QuietGuard::new(Duration::ZERO);
        off.arm(ms(500));
        assert_eq!(off.until(None, Duration::from_millis(10)), None);
        let on = QuietGuard::new(Duration::from_millis(300));
        assert_eq!(on.until(Some(ms(5)), Duration::from_millis(10)), None);
    }

    #[test]
    fn silence_counts_from_the_timeout_or_the_last_byte_and_is_bounded() {
        let mut g = QuietGuard::new(Duration::from_millis(300));
        g.arm(ms(500));
        let longest = Duration::from_millis(100);
        assert_eq!(g.until(None, longest), Some(ms(800)));
        assert_eq!(
            g.until(Some(ms(400)), longest),
            Some(ms(800)),
            "bytes before the timeout"
        );
        assert_eq!(
            g.until(Some(ms(700)), longest),
            Some(ms(900)),
            "a late answer at 700 ms"
        );
        assert_eq!(g.until(Some(ms(5000)), longest), Some(ms(900)), "bounded");
        assert_eq!(g.bound(longest), Some(ms(900)));
        g.clear();
        assert_eq!(g.until(Some(ms(700)), longest), None);
    }
}
