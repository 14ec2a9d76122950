//! Finding which units answer on a line, and at which line settings: the request a scan may
//! send to any unit, how an outcome reads, and how long one probe may take at most.
//!
//! The probe is FC03, one holding register at address 0 (a master job of [Modbus/USS]
//! §3.4.5–§3.4.16): a read changes
//! nothing in a slave, every Modbus device class implements FC03, and a unit without register 0
//! still answers, with exception 02 (illegal data address), which proves it is there. One try
//! per unit, no retry: a scan must stay short and polite on a live bus.

use crate::frame::Request;
use crate::master::Master;
use crate::status;
use si_core::{Duration, Status};

/// The request a scan sends to each unit: FC03, one register at address 0.
pub const PROBE: Request<'static> = Request::ReadHoldingRegisters {
    address: 0,
    quantity: 1,
};

/// What one probe found: si-core's, shared by every bus scan ([`answer`] says how a Modbus
/// outcome reads).
pub use si_core::sweep::Answer;

/// How a probe's outcome reads: `Ok` or an exception response is a unit that answered,
/// the response timeout (0830H, [Modbus/USS] §3.6) none, any other STATUS a garbled one
/// (not a valid response: CRC, length, another address).
pub fn answer(outcome: Result<(), Status>) -> Answer {
    match outcome {
        Ok(()) => Answer::Present,
        Err(s) if s == status::RESPONSE_TIMEOUT => Answer::Absent,
        // 0E61H … 0E6FH: the slave's exception response, a valid frame from it.
        Err(s) if (0x0E61..=0x0E6F).contains(&s.code()) => Answer::Present,
        Err(s) => Answer::Garbled(s),
    }
}

/// The longest one probe takes on `master` (built with the scan's config, retries 0: one try),
/// from its start to its end whatever the line does, plus `slack` for what the host adds
/// (scheduling): the engine's own bound, [`Master::longest_job`], not a formula of the scan's.
/// It counts what a noisy line can make a probe last: the hold for silence before the request,
/// the quiet guard after a timeout where one is set, the response time plus a port's latency,
/// and a garbled answer up to the longest frame, not just the 7 characters of a valid answer
/// to [`PROBE`]. A scan of `n` probes takes at most `n` times this.
pub fn probe_bound(master: &Master, slack: Duration) -> Duration {
    master.longest_job() + slack
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_exception_is_a_unit_that_answered_and_a_timeout_none() {
        assert_eq!(answer(Ok(())), Answer::Present);
        assert_eq!(
            answer(Err(status::EXCEPTION_ILLEGAL_DATA_ADDRESS)),
            Answer::Present
        );
        assert_eq!(answer(Err(status::RESPONSE_TIMEOUT)), Answer::Absent);
        assert_eq!(
            answer(Err(status::WRONG_SLAVE_ADDRESS)),
            Answer::Garbled(status::WRONG_SLAVE_ADDRESS)
        );
    }

    #[test]
    fn a_probe_is_bounded_by_the_engines_own_bound() {
        let c = crate::MasterConfig {
            retries: 0,
            ..Default::default()
        };
        let master = Master::new(c).unwrap();
        let bound = probe_bound(&master, Duration::ZERO);
        assert_eq!(bound, c.job_bound());
        assert!(bound > c.response_timeout + c.max_response_duration());
        let guarded = Master::new(c)
            .unwrap()
            .with_quiet_after_timeout(Duration::from_millis(300));
        assert_eq!(
            probe_bound(&guarded, Duration::from_millis(5)),
            c.job_bound() + Duration::from_millis(305) + c.max_response_duration()
        );
    }
}
