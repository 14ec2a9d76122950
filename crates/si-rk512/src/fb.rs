//! FB equivalents for RK 512 jobs in the style of the CP 341's P_SND_RK (SEND and FETCH
//! requests; [CP 341] §2.2.3), with the S7 call semantics of
//! [`si_core::fb`]: REQ is edge-triggered, R resets, DONE / ERROR / STATUS are valid for
//! exactly one call. The [`Station`] is a [`JobPort`] whose jobs are [`Rk512Job`]s; both FBs
//! run on si-core's [`JobRequest`], the core every job-starting FB shares.
//!
//! The manual's chapter 2 has no parameter list for P_SND_RK; the inputs here are the job's header
//! fields (address, coordination flag, length) and the outputs the usual DONE, ERROR, STATUS.
//!
//! - **R** cancels the running job at once ([`Station::cancel`]): the FB shows ERROR with
//!   1E0DH in that call, as every si-core FB does, the station forgets the job, and a REQ
//!   edge in a later call starts a new one (no 0502H while the old telegram's TRES runs).
//! - **Chained STATUS** ([CP 341 Diag]): a job whose command telegram the 3964(R)
//!   link could not send shows ERROR with the link's 07xxH in one call and ERROR with 051AH in
//!   the next, "the procedure-level error placed in STATUS just before".
//! - **S_RCV** over the station ([`si_core::fb::SRcv`]) shows the passive side's 06xxH (and
//!   the 07xxH before 0612H, and 08xxH receive errors) with ERROR, one per call.
//!
//! ```
//! use si_rk512::fb::{FetchFb, SendFb};
//! use si_rk512::frame::{Address, Coordination};
//! use si_rk512::passive::ServerConfig;
//! use si_rk512::{Config, Station};
//! use si_sim::Simulator;
//! use si_core::{Duration, SerialSettings};
//!
//! let line = SerialSettings::default();
//! let mut high = Config::default();
//! high.link.priority = si_3964r::Priority::High;
//! let mut memory = ServerConfig::default();
//! memory.memory.dbs.insert(5, 64);
//! let mut sim = Simulator::new(1);
//! let a = sim.add_station("A", line, Station::new(high.with_settings(line)).unwrap());
//! let b = sim.add_station("B", line, Station::serving(Config::default().with_settings(line), &memory).unwrap());
//! sim.connect(a, b);
//!
//! let (mut send, mut fetch) = (SendFb::default(), FetchFb::default());
//! let to = Address::Db { db: 5, dw: 2 };
//! let (mut sent, mut fetched) = (false, None);
//! for _cycle in 0..1000 {
//!     // One PLC cycle every 10 ms: REQ held TRUE; the FETCH starts once the SEND is DONE.
//!     let s = sim.with(a, |st, now| send.call(st, now, true, false, to, Coordination::NONE, b"ABCD"));
//!     assert!(!s.result.error);
//!     sent |= s.result.done;
//!     if sent {
//!         let f = sim.with(a, |st, now| fetch.call(st, now, true, false, to, Coordination::NONE, 4));
//!         if f.result.done { fetched = f.data; break; }
//!     }
//!     sim.run_for(Duration::from_millis(10));
//! }
//! assert_eq!(fetched.unwrap(), &b"ABCD"[..]);
//! ```

use crate::frame::{Address, Coordination};
use crate::station::{Event, JobId, RequestError, Station};
use bytes::Bytes;
use si_core::fb::{JobRequest, Pulse};
use si_core::job::{JobEnd, JobPort, NotStarted, Reception};
use si_core::{Instant, Status};

/// One RK 512 job as an FB starts it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Rk512Job {
    /// SEND `data` to `address` ([`Station::send`]).
    Send {
        /// Where the data go in the partner (DB or DX).
        address: Address,
        /// The coordination flag.
        coordination: Coordination,
        /// The data.
        data: Bytes,
    },
    /// FETCH `len` bytes from `address` ([`Station::fetch`]).
    Fetch {
        /// Where the data come from in the partner.
        address: Address,
        /// The coordination flag.
        coordination: Coordination,
        /// Bytes to fetch.
        len: usize,
    },
}

impl JobPort for Station {
    type Job = Rk512Job;
    /// The FETCH data (empty for a SEND).
    type Output = Bytes;

    /// A refusal shows at once: busy 0502H, length 1E41H, not a DB/DX 1E20H, flag bit 0515H,
    /// CPU number 0516H.
    fn start_job(&mut self, now: Instant, job: Rk512Job) -> Result<JobId, NotStarted> {
        match job {
            Rk512Job::Send {
                address,
                coordination,
                data,
            } => self.send(now, address, coordination, data),
            Rk512Job::Fetch {
                address,
                coordination,
                len,
            } => self.fetch(now, address, coordination, len),
        }
        .map_err(|e| NotStarted::Refused(e.status()))
    }

    fn job_outcome(&mut self, id: JobId) -> Option<Result<Bytes, Status>> {
        Station::job_outcome(self, id)
    }

    /// [`Station::cancel`]: the station forgets the job too (a telegram already handed to the
    /// 3964(R) link is still sent, [ET200S SI] §2.10, Table 2-13, and its late reaction is
    /// reported as 0A01H).
    fn cancel_job(&mut self, id: JobId) {
        self.cancel(id);
    }

    /// The passive side's next STATUS (06xxH, 07xxH before 0612H, 08xxH) as ERROR; never a
    /// frame, since the partner's SEND data land in memory.
    fn take_received(&mut self, _now: Instant, _dest: &mut [u8]) -> Option<Reception> {
        self.take_reception_error().map(Reception::Error)
    }

    /// R on S_RCV drops the STATUS codes not yet taken.
    fn stop_receiving(&mut self, reset: bool) -> bool {
        if reset {
            self.clear_reception_errors();
        }
        false
    }
}

/// The REQ / R core of both request FBs, with the second code of a chained STATUS: after an
/// outcome of 051AH the FB first shows the 3964(R) error and then 051AH in the next call.
#[derive(Debug, Default)]
struct Request {
    run: JobRequest,
    then: Pulse<Status>,
}

impl Request {
    fn call(
        &mut self,
        station: &mut Station,
        now: Instant,
        req: bool,
        r: bool,
        job: impl FnOnce() -> Rk512Job,
    ) -> Option<Result<Bytes, Status>> {
        if r {
            self.then.take();
        } else if let Some(status) = self.then.take() {
            return Some(Err(status));
        }
        let outcome = self.run.call(station, now, req, r, || Ok(job()));
        match (&outcome, station.last_cause()) {
            (Some(Err(status)), Some(cause)) if *status == crate::status::COMMAND_NOT_SENT => {
                self.then.fire(*status);
                Some(Err(cause))
            }
            _ => outcome,
        }
    }
}

/// What a request FB shows after one call: DONE / ERROR / STATUS, and FETCH's data with DONE.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct FbOutput {
    /// DONE / ERROR / STATUS for this call.
    pub result: si_core::fb::Done,
    /// FETCH only: the data, with DONE.
    pub data: Option<Bytes>,
}

impl From<Option<Result<Bytes, Status>>> for FbOutput {
    fn from(outcome: Option<Result<Bytes, Status>>) -> Self {
        let data = outcome.clone().and_then(Result::ok);
        FbOutput {
            result: outcome.into(),
            data,
        }
    }
}

/// SEND request (P_SND_RK with a SEND job): a rising edge on REQ sends `data` to `address`.
#[derive(Debug, Default)]
pub struct SendFb {
    inner: Request,
}

impl SendFb {
    /// One call of the FB (one PLC cycle). An edge while a job runs is ignored; R cancels the
    /// job and reports ERROR with 1E0D; refusals (busy 0502, length 1E41, not a DB/DX 1E20,
    /// flag bit 0515, CPU number 0516) show at once.
    #[allow(clippy::too_many_arguments)]
    pub fn call(
        &mut self,
        station: &mut Station,
        now: Instant,
        req: bool,
        r: bool,
        address: Address,
        coordination: Coordination,
        data: &[u8],
    ) -> FbOutput {
        let outcome = self.inner.call(station, now, req, r, || Rk512Job::Send {
            address,
            coordination,
            data: Bytes::copy_from_slice(data),
        });
        FbOutput {
            data: None,
            ..outcome.into()
        }
    }
}

/// FETCH request (P_SND_RK with a FETCH job): a rising edge on REQ fetches `len` bytes.
#[derive(Debug, Default)]
pub struct FetchFb {
    inner: Request,
}

impl FetchFb {
    /// One call of the FB; DONE comes with the data.
    #[allow(clippy::too_many_arguments)]
    pub fn call(
        &mut self,
        station: &mut Station,
        now: Instant,
        req: bool,
        r: bool,
        address: Address,
        coordination: Coordination,
        len: usize,
    ) -> FbOutput {
        self.inner
            .call(station, now, req, r, || Rk512Job::Fetch {
                address,
                coordination,
                len,
            })
            .into()
    }
}

/// A job ends with [`Event::Done`] (its FETCH data, empty for a SEND) or [`Event::Failed`]. A
/// busy station is [`NotStarted::Busy`] here (the async driver queues the job), where the FBs
/// show 0502H.
impl JobEnd for Station {
    type Job = Rk512Job;
    type Output = Bytes;
    type Refusal = RequestError;
    type Failure = Status;

    fn begin_job(
        &mut self,
        now: Instant,
        job: Rk512Job,
    ) -> Result<JobId, NotStarted<RequestError>> {
        match job {
            Rk512Job::Send {
                address,
                coordination,
                data,
            } => self.send(now, address, coordination, data),
            Rk512Job::Fetch {
                address,
                coordination,
                len,
            } => self.fetch(now, address, coordination, len),
        }
        .map_err(|e| match e {
            RequestError::Busy => NotStarted::Busy,
            e => NotStarted::Refused(e),
        })
    }

    fn job_end(event: &Event) -> Option<(JobId, Result<Bytes, Status>)> {
        match event {
            Event::Done { job, data } => Some((*job, Ok(data.clone()))),
            Event::Failed { job, status } => Some((*job, Err(*status))),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::passive::ServerConfig;
    use crate::Config;
    use si_core::status::common;
    use si_core::{Duration, SerialSettings};
    use si_sim::Simulator;

    fn setup() -> (
        Simulator,
        si_sim::StationId<Station>,
        si_sim::StationId<Station>,
    ) {
        let line = SerialSettings::default();
        let mut high = Config::default();
        high.link.priority = si_3964r::Priority::High;
        let mut memory = ServerConfig::default();
        memory.memory.dbs.insert(5, 64);
        let mut sim = Simulator::new(1);
        let a = sim.add_station("A", line, Station::new(high.with_settings(line)).unwrap());
        let b = sim.add_station(
            "B",
            line,
            Station::serving(Config::default().with_settings(line), &memory).unwrap(),
        );
        sim.connect(a, b);
        (sim, a, b)
    }

    #[test]
    fn done_and_error_last_one_call_and_refusals_show_at_once() {
        let (mut sim, a, _b) = setup();
        let mut fetch = FetchFb::default();
        let at = Address::Db { db: 5, dw: 0 };
        // An odd length for a DB: ERROR with 1E41 on the same call.
        let out = sim.with(a, |s, now| {
            fetch.call(s, now, true, false, at, Coordination::NONE, 3)
        });
        assert!(out.result.error);
        assert_eq!(out.result.status, common::INVALID_LEN);
        let out = sim.with(a, |s, now| {
            fetch.call(s, now, true, false, at, Coordination::NONE, 3)
        });
        assert!(
            !out.result.error,
            "ERROR lasts one call, and a held REQ starts nothing"
        );
        // A missing DB: ERROR with the partner's 0903, once.
        let missing = Address::Db { db: 6, dw: 0 };
        let mut seen = Vec::new();
        for cycle in 0..300 {
            let req = cycle > 0;
            let out = sim.with(a, |s, now| {
                fetch.call(s, now, req, false, missing, Coordination::NONE, 2)
            });
            if out.result.error || out.result.done {
                seen.push(out.result.status);
            }
            sim.run_for(Duration::from_millis(10));
        }
        assert_eq!(seen, vec![crate::status::PARTNER_NO_SUCH_DB]);
    }

    #[test]
    fn reset_reports_1e0d_for_the_running_job() {
        let (mut sim, a, _b) = setup();
        let mut send = SendFb::default();
        let at = Address::Db { db: 5, dw: 0 };
        let out = sim.with(a, |s, now| {
            send.call(s, now, true, false, at, Coordination::NONE, b"AB")
        });
        assert!(!out.result.done && !out.result.error);
        let out = sim.with(a, |s, now| {
            send.call(s, now, true, true, at, Coordination::NONE, b"AB")
        });
        assert!(out.result.error);
        assert_eq!(out.result.status, common::ABORTED_BY_RESET);
    }
}
