//! What a master's polls came to, per unit, as mbpoll users read it: answers, exception
//! responses, response timeouts and every other failure, each told by its STATUS.
//!
//! 0830H is the response timeout ([Modbus/USS] §3.4.3, Table 3-17), 0E61H–0E67H an
//! exception response (§3.3.6, Table 3-12); everything else on the line (0E57H CRC, 0831H
//! wrong slave, 0E5xH malformed responses, 08xxH receive errors) is another error.

use crate::status;
use si_core::Status;

/// What happened to the polls of one unit.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counters {
    /// Jobs that ended (one of the four below).
    pub polls: u64,
    /// Answered (a broadcast counts when sent).
    pub answers: u64,
    /// Exception responses (0E61H–0E67H).
    pub exceptions: u64,
    /// No response in time (0830H).
    pub timeouts: u64,
    /// Any other failure on the line.
    pub other_errors: u64,
}

/// How a failed job is counted.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// An exception response ([Modbus/USS] §3.3.6, Table 3-12).
    Exception,
    /// The response timeout ([Modbus/USS] §3.4.3, Table 3-17).
    Timeout,
    /// Anything else on the line.
    Other,
}

impl Kind {
    /// The kind of a failure with this STATUS.
    pub fn of(s: Status) -> Kind {
        if s == status::RESPONSE_TIMEOUT {
            Kind::Timeout
        } else if (status::EXCEPTION_ILLEGAL_FUNCTION.code()
            ..=status::EXCEPTION_NEGATIVE_ACKNOWLEDGE.code())
            .contains(&s.code())
        {
            Kind::Exception
        } else {
            Kind::Other
        }
    }

    /// Its name: `exception`, `timeout`, `error`.
    pub fn name(self) -> &'static str {
        match self {
            Kind::Exception => "exception",
            Kind::Timeout => "timeout",
            Kind::Other => "error",
        }
    }
}

impl Counters {
    /// Count one failure.
    pub fn failed(&mut self, kind: Kind) {
        self.polls += 1;
        match kind {
            Kind::Exception => self.exceptions += 1,
            Kind::Timeout => self.timeouts += 1,
            Kind::Other => self.other_errors += 1,
        }
    }

    /// Count one answer.
    pub fn answered(&mut self) {
        self.polls += 1;
        self.answers += 1;
    }
}
