//! The 3964(R) link as a [`JobPort`], so si-core's S_SEND (FB3) and S_RCV (FB2) run on it with
//! the S7 call semantics ([ET200S SI] §2.10, Table 2-14 `[derived]`): the user program calls them
//! once per "cycle"; REQ is edge-triggered, R resets, EN_R is a level, and DONE / NDR / ERROR /
//! STATUS / LEN are valid for exactly one call.
//!
//! ```
//! use si_3964r::fb::{SRcv, SSend};
//! use si_3964r::{Config, Link, Priority};
//! use si_sim::Simulator;
//! use si_core::{Duration, SerialSettings};
//!
//! let line = SerialSettings::default();
//! let mut sim = Simulator::new(1);
//! let high = Config { priority: Priority::High, ..Config::default() };
//! let a = sim.add_station("A", line, Link::new(high.with_settings(line)).unwrap());
//! let b = sim.add_station("B", line, Link::new(Config::default().with_settings(line)).unwrap());
//! sim.connect(a, b);
//! let (mut s_send, mut s_rcv) = (SSend::default(), SRcv::default());
//! let mut db = [0u8; 256];
//!
//! let mut cycles = 0;
//! let (mut sent, mut got) = (false, None);
//! while !(sent && got.is_some()) && cycles < 1000 {
//!     // One PLC cycle every 10 ms: REQ held TRUE, EN_R statically TRUE.
//!     let out = sim.with(a, |link, now| s_send.call(link, now, true, false, b"temp=21"));
//!     sent |= out.done;
//!     let rcv = sim.with(b, |link, now| s_rcv.call(link, now, true, false, &mut db));
//!     if rcv.ndr { got = Some(db[..rcv.len].to_vec()); }
//!     sim.run_for(Duration::from_millis(10));
//!     cycles += 1;
//! }
//! assert_eq!(got.unwrap(), b"temp=21");
//! ```
//!
//! Readings: R on S_SEND forgets the job and reports ERROR with 1E0DH; the block already handed
//! to the link is still sent ([ET200S SI] §2.10, Table 2-13 "data the module has already received
//! is still sent"). The manual's "EN_R = 0 aborts an active transfer" concerns the module-to-CPU
//! copy of a block over the backplane; here a block moves from the link to the caller within one
//! call, so there is never a transfer in flight to abort. A block longer than the destination area
//! is taken from the receive buffer and reported with ERROR and 1E20H ([ET200S SI] §2.10, Table
//! 2-14 "destination area too short", as the window module does; the ASCII driver leaves it in its
//! buffer instead).

use crate::link::{Event, Link, SendError};
use bytes::Bytes;
use si_core::job::{JobEnd, JobId, JobPort, NotStarted, Reception};
use si_core::status::common;
use si_core::{Instant, Status};

pub use si_core::fb::{Done, Received, SRcv, SSend};

impl JobPort for Link {
    type Job = Bytes;
    type Output = ();

    /// [`Link::send`]; a refusal shows its STATUS (1E41H, 0502H while a job runs).
    fn start_job(&mut self, now: Instant, frame: Bytes) -> Result<JobId, NotStarted> {
        self.send(now, frame)
            .map_err(|e| NotStarted::Refused(e.status()))
    }

    fn job_outcome(&mut self, id: JobId) -> Option<Result<(), Status>> {
        Link::job_outcome(self, id)
    }

    /// The block is still sent ([ET200S SI] §2.10, Table 2-13); nothing to do.
    fn cancel_job(&mut self, _id: JobId) {}

    /// The oldest receive error first (one per call, [`Link::take_receive_error`]), else the
    /// oldest block. The 0B01H warning with NDR counts the block just taken (the buffer as it
    /// was when S_RCV was called).
    fn take_received(&mut self, now: Instant, dest: &mut [u8]) -> Option<Reception> {
        let warning = JobPort::receive_warning(self);
        if let Some(status) = self.take_receive_error() {
            return Some(Reception::Error(status));
        }
        let block = self.take_block(now)?;
        let Some(slot) = dest.get_mut(..block.len()) else {
            return Some(Reception::Error(common::PARAMETER_OUT_OF_RANGE));
        };
        slot.copy_from_slice(&block);
        Some(Reception::Frame {
            len: block.len(),
            status: warning,
        })
    }

    fn receive_warning(&self) -> Status {
        if self.buffer_two_thirds_full() {
            common::BUFFER_TWO_THIRDS_FULL
        } else {
            Status::OK
        }
    }
}

/// A send job ends with [`Event::Sent`] (the partner's DLE) or [`Event::SendFailed`]. A busy
/// link is [`NotStarted::Busy`] here (the async driver queues the job), where S_SEND shows 0502H.
impl JobEnd for Link {
    type Job = Bytes;
    type Output = ();
    type Refusal = SendError;
    type Failure = Status;

    fn begin_job(&mut self, now: Instant, frame: Bytes) -> Result<JobId, NotStarted<SendError>> {
        self.send(now, frame).map_err(|e| match e {
            SendError::Busy => NotStarted::Busy,
            e => NotStarted::Refused(e),
        })
    }

    fn job_end(event: &Event) -> Option<(JobId, Result<(), Status>)> {
        match *event {
            Event::Sent { job } => Some((job, Ok(()))),
            Event::SendFailed { job, status } => Some((job, Err(status))),
            Event::Received { .. } | Event::ReceiveError(_) => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{Config, Priority};
    use crate::status;
    use si_core::{Duration, SerialSettings};
    use si_sim::Simulator;

    fn setup(b_config: Config) -> (Simulator, si_sim::StationId<Link>, si_sim::StationId<Link>) {
        let line = SerialSettings::default();
        let mut sim = Simulator::new(1);
        let high = Config {
            priority: Priority::High,
            ..Config::default()
        };
        let a = sim.add_station("A", line, Link::new(high.with_settings(line)).unwrap());
        let b = sim.add_station("B", line, Link::new(b_config.with_settings(line)).unwrap());
        sim.connect(a, b);
        (sim, a, b)
    }

    #[test]
    fn s_send_done_is_one_call_and_req_is_edge_triggered() {
        let (mut sim, a, _b) = setup(Config::default());
        let mut fb = SSend::default();
        let mut dones = 0;
        for _ in 0..200 {
            let out = sim.with(a, |l, now| fb.call(l, now, true, false, b"x"));
            if out.done {
                dones += 1;
                assert_eq!(out.status, Status::OK);
            }
            assert!(!out.error);
            sim.run_for(Duration::from_millis(10));
        }
        // REQ held TRUE for 2 s: one job, one DONE.
        assert_eq!(dones, 1);
        assert_eq!(sim.engine(a).counters().blocks_sent, 1);
    }

    #[test]
    fn s_send_error_carries_the_status_for_one_call() {
        let line = SerialSettings::default();
        let mut sim = Simulator::new(1);
        let a = sim.add_station(
            "A",
            line,
            Link::new(Config::default().with_settings(line)).unwrap(),
        );
        let mut fb = SSend::default();
        let mut errors = Vec::new();
        for i in 0..2000 {
            let out = sim.with(a, |l, now| fb.call(l, now, i == 0, false, b"x"));
            if out.error {
                errors.push(out.status);
            }
            sim.run_for(Duration::from_millis(10));
        }
        // Nobody answers: six STX, QVZ each, then 0703 once.
        assert_eq!(errors, vec![status::SETUP_TIMEOUT]);
    }

    #[test]
    fn s_send_len_out_of_range_is_1e41_and_r_reports_1e0d() {
        let (mut sim, a, _b) = setup(Config::default());
        let mut fb = SSend::default();
        let out = sim.with(a, |l, now| fb.call(l, now, true, false, b""));
        assert_eq!((out.error, out.status), (true, common::INVALID_LEN));
        let out = sim.with(a, |l, now| fb.call(l, now, false, false, b""));
        assert!(!out.error);
        sim.with(a, |l, now| fb.call(l, now, true, false, b"abc"));
        assert!(fb.busy());
        let out = sim.with(a, |l, now| fb.call(l, now, true, true, b"abc"));
        assert_eq!((out.error, out.status), (true, common::ABORTED_BY_RESET));
        assert!(!fb.busy());
    }

    #[test]
    fn s_rcv_ndr_len_and_two_thirds_warning() {
        let (mut sim, a, b) = setup(Config {
            receive_buffer_blocks: 3,
            ..Config::default()
        });
        for text in [&b"one"[..], b"two", b"three"] {
            sim.with(a, |l, now| l.send(now, text).unwrap());
            sim.run_for(Duration::from_millis(200));
        }
        let mut fb = SRcv::default();
        let mut db = [0u8; 16];
        // EN_R = 0: nothing is taken.
        let out = sim.with(b, |l, now| fb.call(l, now, false, false, &mut db));
        assert!(!out.ndr);
        let out = sim.with(b, |l, now| fb.call(l, now, true, false, &mut db));
        assert_eq!(
            (out.ndr, out.len, out.status),
            (true, 3, common::BUFFER_TWO_THIRDS_FULL)
        );
        let out = sim.with(b, |l, now| fb.call(l, now, true, false, &mut db));
        assert_eq!((out.ndr, out.len, out.status), (true, 3, Status::OK));
        let out = sim.with(b, |l, now| fb.call(l, now, true, false, &mut db));
        assert_eq!((out.ndr, out.len), (true, 5));
        assert_eq!(&db[..out.len], b"three");
        let out = sim.with(b, |l, now| fb.call(l, now, true, false, &mut db));
        assert!(!out.ndr && !out.error && out.len == 0);
    }

    #[test]
    fn s_rcv_reports_a_receive_error_once() {
        let (mut sim, a, b) = setup(Config::default());
        sim.transmit(a, b"garbage");
        sim.run_for(Duration::from_secs(1));
        let mut fb = SRcv::default();
        let mut db = [0u8; 16];
        let out = sim.with(b, |l, now| fb.call(l, now, true, false, &mut db));
        assert_eq!((out.error, out.status), (true, status::IDLE_GARBAGE));
        let out = sim.with(b, |l, now| fb.call(l, now, true, false, &mut db));
        assert!(!out.error);
    }

    #[test]
    fn receive_errors_wait_oldest_first_and_the_oldest_is_dropped_beyond_the_bound() {
        use crate::link::RECEIVE_ERRORS;
        use si_core::{Engine, Instant, LineError};
        let line = SerialSettings::default();
        let mut link = Link::new(Config::default().with_settings(line)).unwrap();
        // A corrupted character in idle is reported at once as 080CH; a BREAK as 080DH.
        let mut raise = |parity_errors: usize| {
            link.handle_line_error(Instant::ZERO, LineError::Break);
            for _ in 0..parity_errors {
                link.handle_line_error(Instant::ZERO, LineError::Parity);
            }
            std::iter::from_fn(|| link.take_receive_error()).collect::<Vec<_>>()
        };
        let mut full = vec![status::BREAK];
        full.extend([status::TRANSMISSION_ERROR; RECEIVE_ERRORS - 1]);
        assert_eq!(raise(RECEIVE_ERRORS - 1), full, "oldest first");
        assert_eq!(
            raise(RECEIVE_ERRORS),
            vec![status::TRANSMISSION_ERROR; RECEIVE_ERRORS],
            "the oldest (080DH) dropped"
        );
    }

    #[test]
    fn s_rcv_block_longer_than_dest_is_1e20h_once() {
        let (mut sim, a, b) = setup(Config::default());
        let (mut fa, mut fb) = (SSend::default(), SRcv::default());
        let mut dest = [0u8; 4];
        let mut got = Vec::new();
        for _ in 0..200 {
            sim.with(a, |l, now| fa.call(l, now, true, false, b"too long"));
            let r = sim.with(b, |l, now| fb.call(l, now, true, false, &mut dest));
            if r.ndr || r.error {
                got.push(r);
            }
            sim.run_for(Duration::from_millis(5));
        }
        assert_eq!(got.len(), 1, "{got:?}");
        assert!(got[0].error && !got[0].ndr);
        assert_eq!(got[0].status, common::PARAMETER_OUT_OF_RANGE);
    }
}
