//! The job layer: one [`JobId`], and the [`JobPort`] trait through which an FB equivalent starts
//! a job, takes its outcome and takes a received frame (ARCHITECTURE.md "FB equivalents";
//! [ET200S SI] §2.10, Table 2-14 `[derived]`; [ET200S SI 2005] §2.10).
//!
//! Every engine with send/receive jobs implements [`JobPort`]: the 3964(R) link, the ASCII link,
//! the RK 512 station, the Modbus master (for the S_SEND/S_RCV layouts of
//! [Modbus/USS] §3.4.2, §3.4.5–§3.4.16) and the window host of si-dp-coord. S_SEND and S_RCV are
//! written once, in [`crate::fb`], generic over it, so one user program drives an engine on the
//! host's own port or a module through the DP window (see [`Channel`](crate::fb::Channel)).

use crate::{Instant, Status};
use bytes::Bytes;
use core::fmt;
use serde::{Deserialize, Serialize};

/// Identifies one job of one engine, so its outcome can be matched to the caller that started
/// it. Each engine counts its own jobs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub struct JobId(pub u64);

impl fmt::Display for JobId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "job {}", self.0)
    }
}

/// Why [`JobPort::start_job`] (refusal `R` = the STATUS the FB shows) or
/// [`JobEnd::begin_job`] (refusal `R` = the engine's own refusal, which names the bad
/// argument) did not start a job.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NotStarted<R = Status> {
    /// The port runs another caller's job and takes this one once it is free: the FB keeps the
    /// job and offers it again on its next call (the ASCII link's reading of S_SEND); the
    /// async driver keeps it and offers it again after the engine's next event.
    Busy,
    /// Refused: for an FB the STATUS it shows at once (1E41H for a bad LEN, 0502H, 0E4xH, …).
    Refused(R),
}

impl From<Status> for NotStarted {
    fn from(status: Status) -> Self {
        NotStarted::Refused(status)
    }
}

/// What [`JobPort::take_received`] hands S_RCV in one call.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reception {
    /// A frame of `len` bytes was copied into the destination area: NDR with LEN. `status` is
    /// S_RCV's STATUS with it: 0B01H while the receive buffer is more than 2/3 full, else 0000H
    /// (each engine says whether it counts the frame just taken, see its impl).
    Frame {
        /// The frame's length (LEN).
        len: usize,
        /// 0B01H or 0000H.
        status: Status,
    },
    /// A reception failed (ERROR with STATUS), or the waiting frame does not fit the
    /// destination area (1E20H).
    Error(Status),
}

/// An engine an FB equivalent runs jobs on. See the [module docs](self).
///
/// The FB calls it from the user program's cycle; the engine itself is driven from outside as
/// every [`Engine`](crate::Engine). A job started with [`start_job`](JobPort::start_job) ends in
/// exactly one outcome, which [`job_outcome`](JobPort::job_outcome) hands to the FB that asks
/// for it by id.
pub trait JobPort {
    /// What one job asks for: the frame of S_SEND ([`Bytes`]) for the line links, the Modbus
    /// master (the S_SEND source area of [Modbus/USS] §3.4.5–§3.4.16) and the window host (whose
    /// job type also has the V.24 and parameter jobs); a SEND or FETCH request for the RK 512
    /// station.
    type Job;
    /// What a job gives back with DONE: `()` for a send, the fetched bytes for an RK 512 FETCH,
    /// the window's job outcome.
    type Output;

    /// Starts `job` at `now`.
    fn start_job(&mut self, now: Instant, job: Self::Job) -> Result<JobId, NotStarted>;

    /// The outcome of job `id` once it has ended; `None` while it runs (or if `id` is unknown).
    /// An engine may keep an outcome until its next job ends, so an FB takes it once and then
    /// forgets the id.
    fn job_outcome(&mut self, id: JobId) -> Option<Result<Self::Output, Status>>;

    /// The FB's R input for job `id`: the FB reports 1E0DH and forgets the job. An engine whose
    /// protocol can abort (the window) aborts it; a line link keeps sending a block it already
    /// has ([ET200S SI] §2.10, Table 2-13: "data the module has already received is still
    /// sent"), and the outcome is then nobody's.
    fn cancel_job(&mut self, id: JobId);

    /// S_RCV with EN_R = 1: at most one received frame (copied into `dest`) or one receive
    /// error per call; `None` when there is nothing. An engine without a receive buffer (the
    /// RK 512 station, whose partner's SEND jobs land in its memory) keeps this default.
    fn take_received(&mut self, now: Instant, dest: &mut [u8]) -> Option<Reception> {
        let _ = (now, dest);
        None
    }

    /// S_RCV's STATUS in a call with neither NDR nor ERROR: 0B01H while the receive buffer is
    /// more than 2/3 full (a warning with ERROR = 0, [ET200S SI] §2.10, Table 2-14, `[derived]`),
    /// else 0000H.
    fn receive_warning(&self) -> Status {
        Status::OK
    }

    /// S_RCV called with EN_R = 0 (`reset` false) or R = 1 (`reset` true). True if a transfer
    /// of a frame to the caller was in flight and is now aborted (S_RCV then shows ERROR with
    /// 1E0DH); only the window has such transfers, the line links hand a frame over within one
    /// call.
    fn stop_receiving(&mut self, reset: bool) -> bool {
        let _ = reset;
        false
    }
}

/// An engine whose events say when its jobs end: the one place where a job's end is
/// recognised, so that every async handle runs a job the same way (the tokio driver's
/// `Caller::run_job`, written once for all protocols) instead of matching events itself.
///
/// Implemented by each engine beside its [`JobPort`] impl (the 3964(R) link, the ASCII link,
/// the RK 512 station), and by the USS master, whose parameter jobs have no FB. The start is
/// its own method rather than [`JobPort::start_job`] because the two callers read "busy"
/// differently: S_SEND on a 3964(R) link shows 0502H at once, while the driver queues a job
/// that finds the engine busy and offers it again after the engine's next event.
pub trait JobEnd: crate::Engine {
    /// What one job asks for. Cloned for every start attempt, so cheap to clone ([`Bytes`],
    /// an address and a length).
    type Job: Clone;
    /// What a job gives back when it ends well: `()` for a sent frame, the fetched bytes, the
    /// USS response's PKW area.
    type Output;
    /// Why a job was not started: the engine's refusal, naming the argument it refused.
    type Refusal;
    /// What a job that ended badly carries: its STATUS, and whatever else the protocol
    /// reports with it (the USS error number).
    type Failure;

    /// Starts `job` at `now`: its id, [`NotStarted::Busy`] while another job runs (the caller
    /// offers it again later), or the refusal.
    fn begin_job(
        &mut self,
        now: Instant,
        job: Self::Job,
    ) -> Result<JobId, NotStarted<Self::Refusal>>;

    /// The job `event` ends, with its outcome; `None` for an event that ends no job.
    fn job_end(event: &Self::Event) -> Option<JobEnded<Self>>;
}

/// What [`JobEnd::job_end`] recognises: the job that ended and its outcome.
pub type JobEnded<E> = (JobId, Result<<E as JobEnd>::Output, <E as JobEnd>::Failure>);

/// A [`JobPort`] whose jobs include sending a frame: what S_SEND needs (every port but the
/// RK 512 station, whose jobs carry an address). Implemented for every such port; a user
/// program names it as its one bound.
pub trait FramePort: JobPort<Job: From<Bytes>> {}

impl<P: JobPort<Job: From<Bytes>>> FramePort for P {}

/// The job bookkeeping of an engine that runs one job at a time: it hands out the ids and keeps
/// the last outcome for [`JobPort::job_outcome`] until the next job ends.
#[derive(Debug, Clone)]
pub struct JobSlot<T> {
    next: u64,
    running: Option<JobId>,
    last: Option<(JobId, Result<T, Status>)>,
}

impl<T> Default for JobSlot<T> {
    fn default() -> Self {
        JobSlot {
            next: 1,
            running: None,
            last: None,
        }
    }
}

impl<T: Clone> JobSlot<T> {
    /// A new job starts: its id.
    pub fn start(&mut self) -> JobId {
        let id = JobId(self.next);
        self.next = self.next.wrapping_add(1);
        self.running = Some(id);
        id
    }

    /// The running job: the one a completion belongs to.
    pub fn running(&self) -> Option<JobId> {
        self.running
    }

    /// The running job ended with `result`; its id, or `None` if no job was tracked.
    pub fn finish(&mut self, result: Result<T, Status>) -> Option<JobId> {
        let id = self.running.take()?;
        self.last = Some((id, result));
        Some(id)
    }

    /// Forget the running job (its caller reset it): its outcome will be nobody's.
    pub fn forget(&mut self, id: JobId) {
        if self.running == Some(id) {
            self.running = None;
        }
    }

    /// The outcome of `id` if it was the last job to end.
    pub fn outcome(&self, id: JobId) -> Option<Result<T, Status>> {
        self.last
            .as_ref()
            .filter(|(j, _)| *j == id)
            .map(|(_, r)| r.clone())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slot_keeps_the_last_outcome_for_its_own_id_only() {
        let mut slot = JobSlot::<()>::default();
        let a = slot.start();
        assert_eq!(a, JobId(1));
        assert_eq!(slot.outcome(a), None);
        assert_eq!(slot.finish(Err(Status::from_code(0x0703))), Some(a));
        assert_eq!(slot.outcome(a), Some(Err(Status::from_code(0x0703))));
        let b = slot.start();
        slot.forget(b);
        assert_eq!(
            slot.finish(Ok(())),
            None,
            "a forgotten job's outcome is nobody's"
        );
        assert_eq!(slot.outcome(b), None);
        assert_eq!(slot.outcome(a), Some(Err(Status::from_code(0x0703))));
    }
}
