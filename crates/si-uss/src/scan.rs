//! Finding which nodes answer on a USS bus: the parameter job a scan may send to any node, how
//! its outcome reads, and how long one cycle over the nodes may take at most.
//!
//! The probe reads parameter 0, index 0 (PKW task ID 1, [SINAMICS V20] p. 107; [Modbus/USS]
//! §3.7.7): a read changes nothing
//! in a drive, and a drive without a parameter 0 still answers, with response ID 7 and an error
//! number, which proves it is there. One telegram per node (no PKW repetition): a scan must stay
//! short and polite on a live bus.

use crate::config::{MasterConfig, PollEntry};
use crate::master::ParamRequest;
use crate::status;
use si_core::{Duration, Status};

/// The job a scan gives each node: read parameter 0, index 0.
pub fn probe() -> ParamRequest {
    ParamRequest::read(0, 0)
}

/// What one probe found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Answer {
    /// The node answered: the value, or a PKW error (response ID 7 or 8), is an answer.
    Present,
    /// The node answered with telegrams that never matched the job, or was rejected: a
    /// device may be there at other settings or with another net-data structure.
    Garbled(Status),
    /// No answer within the response timeout.
    Absent,
}

impl Answer {
    /// How a probe's outcome reads: done, or failed with response ID 7 (`PKW_ERROR`) or 8
    /// (`PKW_INTERFACE_ERROR` with an error number) is a node that answered; `NO_ANSWER` none;
    /// anything else garbled.
    pub fn of(outcome: Result<(), (Status, Option<u16>)>) -> Answer {
        match outcome {
            Ok(()) => Answer::Present,
            Err((s, _)) if s == status::NO_ANSWER => Answer::Absent,
            Err((s, _)) if s == status::PKW_ERROR => Answer::Present,
            Err((_, Some(_))) => Answer::Present,
            Err((s, None)) => Answer::Garbled(s),
        }
    }
}

/// The longest one telegram exchange with `entry` takes with `config`: the start interval
/// (2 character times) before the request, the request, the response timeout, the response
/// within its residual run time (1.5 × its characters, [USS spec] §5.2.1.2), plus `slack` for
/// what the host adds. A scan that polls `n` nodes `c` times takes at most `n × c` times this.
pub fn telegram_bound(config: &MasterConfig, entry: &PollEntry, slack: Duration) -> Duration {
    // STX, LGE, ADR, the net data, BCC.
    let chars = 4 + entry.net_len() as u64;
    let s = config.settings;
    s.chars_time(2 + chars + (3 * chars).div_ceil(2)) + config.response_timeout + slack
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::PkwWords;

    #[test]
    fn a_drive_that_refuses_parameter_0_is_still_there() {
        assert_eq!(Answer::of(Ok(())), Answer::Present);
        assert_eq!(
            Answer::of(Err((status::PKW_ERROR, Some(0)))),
            Answer::Present
        );
        assert_eq!(Answer::of(Err((status::NO_ANSWER, None))), Answer::Absent);
        assert_eq!(
            Answer::of(Err((status::PKW_INTERFACE_ERROR, None))),
            Answer::Garbled(status::PKW_INTERFACE_ERROR)
        );
    }

    #[test]
    fn a_telegram_takes_at_least_the_response_timeout() {
        let entry = PollEntry::new(1, PkwWords::Four, 2);
        let c = MasterConfig::new(vec![entry]);
        let bound = telegram_bound(&c, &entry, Duration::ZERO);
        assert!(bound > c.response_timeout + c.settings.chars_time(16));
    }
}
