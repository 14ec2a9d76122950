//! S_SEND (FB3) and S_RCV (FB2) over a [`Link`], with the S7 call semantics
//! (et200s-si-3964r-ascii.md §8.1–§8.3, §8.9): the user program calls them once per "cycle";
//! REQ is edge-triggered, R resets, EN_R is a level, and DONE / NDR / ERROR / STATUS / LEN are
//! valid for exactly one call.
//!
//! ```
//! use si_3964r::fb::{SRcv, SSend};
//! use si_3964r::{Config, Link, Priority};
//! use si_core::sim::Simulator;
//! use si_core::{Duration, SerialSettings};
//!
//! let line = SerialSettings::default();
//! let mut sim = Simulator::new(1);
//! let high = Config { priority: Priority::High, ..Config::default() };
//! let a = sim.add_station("A", line, Link::new(high, line).unwrap());
//! let b = sim.add_station("B", line, Link::new(Config::default(), line).unwrap());
//! sim.connect(a, b);
//! let (mut s_send, mut s_rcv) = (SSend::default(), SRcv::default());
//!
//! let mut cycles = 0;
//! let (mut sent, mut got) = (false, None);
//! while !(sent && got.is_some()) && cycles < 1000 {
//!     // One PLC cycle every 10 ms: REQ held TRUE, EN_R statically TRUE.
//!     let out = sim.with(a, |link, now| s_send.call(link, now, true, false, b"temp=21"));
//!     sent |= out.done;
//!     let rcv = sim.with(b, |link, now| s_rcv.call(link, now, true, false));
//!     if rcv.ndr { got = rcv.data; }
//!     sim.run_for(Duration::from_millis(10));
//!     cycles += 1;
//! }
//! assert_eq!(got.unwrap(), &b"temp=21"[..]);
//! ```

use crate::link::{JobId, Link};
use bytes::Bytes;
use si_core::fb::{Pulse, RisingEdge};
use si_core::status::common;
use si_core::{Instant, Status};

/// What S_SEND shows after one call.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SSendOutput {
    /// The job finished without error (this call only).
    pub done: bool,
    /// The job finished with an error (this call only); STATUS says which.
    pub error: bool,
    /// 0000 with DONE, the error with ERROR, else 0000.
    pub status: Status,
}

/// FB3 S_SEND: a rising edge on REQ sends `data` as one block; DONE or ERROR/STATUS follow for
/// one call when the partner acknowledged it or the procedure gave up.
#[derive(Debug, Default)]
pub struct SSend {
    req: RisingEdge,
    job: Option<JobId>,
    result: Pulse<Result<(), Status>>,
}

impl SSend {
    /// One call of the FB (one PLC cycle).
    ///
    /// - `req`: a FALSE → TRUE edge starts a job (a held TRUE does not repeat it; an edge while a
    ///   job runs is ignored, as on the PLC);
    /// - `r`: reset. The FB forgets its job and reports ERROR with 1E0D for it; the block already
    ///   handed to the link is still sent (§8.2 "data the module has already received is still
    ///   sent"). While R is TRUE no job starts.
    /// - `data`: the block (S_SEND's DB_NO/DBB_NO/LEN), 1 … the configured maximum bytes;
    ///   other lengths end at once with ERROR and 1E41.
    pub fn call(
        &mut self,
        link: &mut Link,
        now: Instant,
        req: bool,
        r: bool,
        data: &[u8],
    ) -> SSendOutput {
        let edge = self.req.update(req);
        if r {
            if self.job.take().is_some() {
                self.result.fire(Err(common::ABORTED_BY_RESET));
            }
            self.req.reset();
            return self.outputs();
        }
        if let Some(job) = self.job {
            if let Some(outcome) = link.job_outcome(job) {
                self.job = None;
                self.result.fire(outcome);
            }
        } else if edge {
            match link.send(now, Bytes::copy_from_slice(data)) {
                Ok(job) => self.job = Some(job),
                Err(e) => self.result.fire(Err(e.status())),
            }
        }
        self.outputs()
    }

    /// True while a job started by this FB runs.
    pub fn busy(&self) -> bool {
        self.job.is_some()
    }

    fn outputs(&mut self) -> SSendOutput {
        match self.result.take() {
            Some(Ok(())) => SSendOutput {
                done: true,
                error: false,
                status: Status::OK,
            },
            Some(Err(status)) => SSendOutput {
                done: false,
                error: true,
                status,
            },
            None => SSendOutput {
                done: false,
                error: false,
                status: Status::OK,
            },
        }
    }
}

/// What S_RCV shows after one call.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SRcvOutput {
    /// New data received (this call only); `data` and `len` hold it.
    pub ndr: bool,
    /// A reception failed (this call only); STATUS says why.
    pub error: bool,
    /// Length of the block delivered with NDR, else 0.
    pub len: usize,
    /// The error with ERROR; otherwise 0B01 while the receive buffer is more than 2/3 full
    /// (a warning with ERROR = 0, §8.3, A-41), else 0000.
    pub status: Status,
    /// The block delivered with NDR (the FB's destination DB).
    pub data: Option<Bytes>,
}

/// FB2 S_RCV: with EN_R statically TRUE, each call delivers at most one received block (NDR,
/// LEN) or one receive error (ERROR, STATUS).
#[derive(Debug, Default)]
pub struct SRcv {
    ndr: Pulse<Bytes>,
    error: Pulse<Status>,
}

impl SRcv {
    /// One call of the FB (one PLC cycle).
    ///
    /// - `en_r`: enable receiving (a level). FALSE leaves blocks in the link's receive buffer,
    ///   which then fills up and makes the link answer the partner's STX with the 400 ms buffer
    ///   wait and NAK (§5.4 point 4).
    /// - `r`: reset; nothing is taken while it is TRUE, and NDR/ERROR/LEN are 0 (A-24).
    ///
    /// The manual's "EN_R = 0 aborts an active transfer" concerns the module-to-CPU copy of a
    /// block over the backplane; here a block moves from the link to the caller within one
    /// call, so there is never a transfer in flight to abort.
    pub fn call(&mut self, link: &mut Link, now: Instant, en_r: bool, r: bool) -> SRcvOutput {
        if r || !en_r {
            return SRcvOutput {
                ndr: false,
                error: false,
                len: 0,
                status: Status::OK,
                data: None,
            };
        }
        let warning = link.buffer_two_thirds_full();
        if let Some(status) = link.take_receive_error() {
            self.error.fire(status);
        } else if let Some(block) = link.take_block(now) {
            self.ndr.fire(block);
        }
        if let Some(status) = self.error.take() {
            return SRcvOutput {
                ndr: false,
                error: true,
                len: 0,
                status,
                data: None,
            };
        }
        let data = self.ndr.take();
        SRcvOutput {
            ndr: data.is_some(),
            error: false,
            len: data.as_ref().map_or(0, Bytes::len),
            status: if warning {
                common::BUFFER_TWO_THIRDS_FULL
            } else {
                Status::OK
            },
            data,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{Config, Priority};
    use crate::status;
    use si_core::sim::Simulator;
    use si_core::{Duration, SerialSettings};

    fn setup(
        b_config: Config,
    ) -> (
        Simulator,
        si_core::sim::StationId<Link>,
        si_core::sim::StationId<Link>,
    ) {
        let line = SerialSettings::default();
        let mut sim = Simulator::new(1);
        let high = Config {
            priority: Priority::High,
            ..Config::default()
        };
        let a = sim.add_station("A", line, Link::new(high, line).unwrap());
        let b = sim.add_station("B", line, Link::new(b_config, line).unwrap());
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
        let a = sim.add_station("A", line, Link::new(Config::default(), line).unwrap());
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
        // EN_R = 0: nothing is taken.
        let out = sim.with(b, |l, now| fb.call(l, now, false, false));
        assert!(!out.ndr);
        let out = sim.with(b, |l, now| fb.call(l, now, true, false));
        assert_eq!(
            (out.ndr, out.len, out.status),
            (true, 3, common::BUFFER_TWO_THIRDS_FULL)
        );
        let out = sim.with(b, |l, now| fb.call(l, now, true, false));
        assert_eq!((out.ndr, out.len, out.status), (true, 3, Status::OK));
        let out = sim.with(b, |l, now| fb.call(l, now, true, false));
        assert_eq!((out.ndr, out.len), (true, 5));
        assert_eq!(out.data.unwrap(), &b"three"[..]);
        let out = sim.with(b, |l, now| fb.call(l, now, true, false));
        assert!(!out.ndr && !out.error && out.len == 0);
    }

    #[test]
    fn s_rcv_reports_a_receive_error_once() {
        let (mut sim, a, b) = setup(Config::default());
        sim.transmit(a, b"garbage");
        sim.run_for(Duration::from_secs(1));
        let mut fb = SRcv::default();
        let out = sim.with(b, |l, now| fb.call(l, now, true, false));
        assert_eq!((out.error, out.status), (true, status::IDLE_GARBAGE));
        let out = sim.with(b, |l, now| fb.call(l, now, true, false));
        assert!(!out.error);
    }
}
