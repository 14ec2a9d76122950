//! Helpers that give the FB equivalents the S7 call semantics ([ET200S SI] §2.10,
//! [ET200S SI] §2.10 `[derived]`): REQ is edge-triggered, R resets, EN_R is a level, and DONE / NDR
//! / ERROR / STATUS are valid for exactly one call.
//!
//! ```
//! use si_core::fb::{Pulse, RisingEdge};
//!
//! let mut req = RisingEdge::default();
//! assert!(req.update(true));   // FALSE → TRUE: start a job
//! assert!(!req.update(true));  // still TRUE: nothing new
//! assert!(!req.update(false));
//! assert!(req.update(true));   // a new edge
//!
//! let mut done = Pulse::default();
//! done.fire(0x0000u16);
//! assert_eq!(done.take(), Some(0x0000)); // the call that sees it
//! assert_eq!(done.take(), None);         // the next call does not
//! ```
//!
//! [`SSend`] and [`SRcv`] are written here once, generic over [`JobPort`]; [`JobRequest`] is the
//! REQ/R/job core of every other job-starting FB.

use crate::job::{FramePort, JobId, JobPort, NotStarted, Reception};
use crate::status::common;
use crate::{FramePool, Instant, Status};
use bytes::Bytes;

/// R_TRIG: true on the call where the input goes from FALSE to TRUE.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RisingEdge {
    last: bool,
}

impl RisingEdge {
    /// Feed this call's input level; true on a rising edge.
    pub fn update(&mut self, input: bool) -> bool {
        let edge = input && !self.last;
        self.last = input;
        edge
    }

    /// Forget the last level (after R): the next TRUE counts as an edge.
    pub fn reset(&mut self) {
        self.last = false;
    }
}

/// An output that is set by one event and visible to exactly one FB call.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Pulse<T> {
    pending: Option<T>,
}

impl<T> Default for Pulse<T> {
    fn default() -> Self {
        Pulse { pending: None }
    }
}

impl<T> Pulse<T> {
    /// Arm the pulse for the next call. A second `fire` before that call replaces the first,
    /// as a PLC output would be overwritten.
    pub fn fire(&mut self, value: T) {
        self.pending = Some(value);
    }

    /// The value for this call, if any; afterwards the pulse is clear.
    pub fn take(&mut self) -> Option<T> {
        self.pending.take()
    }

    /// True if the next `take` returns a value.
    pub fn is_armed(&self) -> bool {
        self.pending.is_some()
    }
}

/// DONE / ERROR / STATUS of an FB without data outputs (S_VSET, S_XON, S_RTS, S_V24, and
/// S_SEND through the window), valid for the one call that returns it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Done {
    /// The job completed without error (this call only).
    pub done: bool,
    /// The job completed with an error (this call only).
    pub error: bool,
    /// 0000H, or the error.
    pub status: crate::Status,
}

impl Default for Done {
    /// Nothing completed in this call: DONE and ERROR false, STATUS 0000H.
    fn default() -> Self {
        Done {
            done: false,
            error: false,
            status: crate::Status::OK,
        }
    }
}

impl Done {
    /// DONE for this call.
    pub fn ok() -> Self {
        Done {
            done: true,
            ..Done::default()
        }
    }

    /// ERROR with `status` for this call.
    pub fn failed(status: crate::Status) -> Self {
        Done {
            error: true,
            status,
            ..Done::default()
        }
    }
}

/// The REQ / R / job machinery every job-starting FB shares (S_SEND, the window's S_VSET,
/// S_VSTAT and parameter FBs, RK 512's request FBs): REQ is edge-triggered and starts at most
/// one job at a time, R cancels the running job (1E0DH), and the job's outcome is taken from
/// the port once.
#[derive(Debug, Default)]
pub struct JobRequest {
    req: RisingEdge,
    job: Option<JobId>,
}

impl JobRequest {
    /// This call's REQ: true on a rising edge while no job of this FB runs, i.e. when the FB
    /// starts a job (an edge while a job runs is ignored, as on the PLC).
    pub fn wants_start(&mut self, req: bool) -> bool {
        self.req.update(req) && self.job.is_none()
    }

    /// The job the FB started on this call's edge.
    pub fn started(&mut self, id: JobId) {
        self.job = Some(id);
    }

    /// R: forgets the running job and cancels it on the port; 1E0DH ("aborted by reset") if a
    /// job ran, for the DONE/ERROR/STATUS of this call ([ET200S SI] §2.10, Table 2-13: "also
    /// updated when the FB is reset"). The next TRUE on REQ counts as an edge.
    pub fn reset<P: JobPort>(&mut self, port: &mut P) -> Option<Status> {
        self.req.reset();
        let id = self.job.take()?;
        port.cancel_job(id);
        Some(common::ABORTED_BY_RESET)
    }

    /// The outcome of the running job once it ended (then the FB is idle again).
    pub fn poll<P: JobPort>(&mut self, port: &mut P) -> Option<Result<P::Output, Status>> {
        let id = self.job?;
        let outcome = port.job_outcome(id)?;
        self.job = None;
        Some(outcome)
    }

    /// The whole call of an FB whose job is built from its inputs: R, then a start on the REQ
    /// edge (`job` builds it; a build error or a refusal ends at once with ERROR), then the
    /// outcome. `None` when nothing ended in this call.
    pub fn call<P: JobPort>(
        &mut self,
        port: &mut P,
        now: Instant,
        req: bool,
        r: bool,
        job: impl FnOnce() -> Result<P::Job, Status>,
    ) -> Option<Result<P::Output, Status>> {
        if r {
            return self.reset(port).map(Err);
        }
        if self.wants_start(req) {
            match job().and_then(|j| {
                port.start_job(now, j).map_err(|e| match e {
                    NotStarted::Refused(status) => status,
                    NotStarted::Busy => common::NOT_POSSIBLE_IN_MODE,
                })
            }) {
                Ok(id) => self.started(id),
                Err(status) => return Some(Err(status)),
            }
        }
        self.poll(port)
    }

    /// True while a job started by this FB runs.
    pub fn busy(&self) -> bool {
        self.job.is_some()
    }
}

impl<T> From<Option<Result<T, Status>>> for Done {
    /// DONE or ERROR/STATUS for an outcome taken in this call, nothing for `None`.
    fn from(outcome: Option<Result<T, Status>>) -> Self {
        match outcome {
            Some(Ok(_)) => Done::ok(),
            Some(Err(status)) => Done::failed(status),
            None => Done::default(),
        }
    }
}

/// Transmit frames of S_SEND are cut from a pool at least this large (twice the ASCII
/// driver's 200-byte maximum, room for a frame in flight and the next).
const SEND_POOL: usize = 400;

/// FB3 S_SEND over any [`JobPort`] ([ET200S SI] §2.10, Table 2-13;
/// [ET200S SI 2005] §2.10, Table 2-14; [Modbus/USS] §3.4.2, §3.4.5–§3.4.16 for the Modbus
/// master, whose source area is the job).
///
/// A rising edge on REQ sends `data` (DB_NO/DBB_NO/LEN as a slice) as one job; DONE, or ERROR
/// with STATUS, follows for exactly one call when the job ends. R ends a running job with
/// ERROR and 1E0DH in that call ([`JobPort::cancel_job`] says what the engine does with it);
/// while R is TRUE no job starts. A refusal (1E41H for a bad LEN, 0502H, 0E4xH) shows at once
/// in the call with the edge. A port that is busy with another caller's job
/// ([`NotStarted::Busy`]) gets the frame again on each later call until it takes it.
#[derive(Debug)]
pub struct SSend {
    run: JobRequest,
    /// A frame waiting for the port to finish another caller's job.
    queued: Option<Bytes>,
    /// Frames are cut from this pool, so a steady state of send jobs allocates nothing per
    /// frame (the si-core contract). Empty until the first job.
    pool: FramePool,
}

impl Default for SSend {
    fn default() -> Self {
        SSend {
            run: JobRequest::default(),
            queued: None,
            pool: FramePool::new(SEND_POOL),
        }
    }
}

impl SSend {
    /// One call of the FB (one PLC cycle); see the [type docs](SSend).
    pub fn call<P: FramePort>(
        &mut self,
        port: &mut P,
        now: Instant,
        req: bool,
        r: bool,
        data: &[u8],
    ) -> Done {
        if r {
            self.queued = None;
            return self.run.reset(port).map_or(Done::default(), Done::failed);
        }
        if self.run.wants_start(req) && self.queued.is_none() {
            self.queued = Some(self.pool.cut(data));
        }
        if let Some(frame) = self.queued.take() {
            match port.start_job(now, P::Job::from(frame.clone())) {
                Ok(id) => self.run.started(id),
                Err(NotStarted::Busy) => self.queued = Some(frame),
                Err(NotStarted::Refused(status)) => return Done::failed(status),
            }
        }
        self.run.poll(port).into()
    }

    /// True while a job is queued or runs (the FB's internal busy state).
    pub fn busy(&self) -> bool {
        self.run.busy() || self.queued.is_some()
    }
}

/// The outputs of S_RCV for one call: the one shape for every engine.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Received {
    /// New data received (this call only); the frame is in the destination area.
    pub ndr: bool,
    /// Receive error (this call only); STATUS says which.
    pub error: bool,
    /// Length of the frame copied into the destination (with NDR), else 0.
    pub len: usize,
    /// The error with ERROR; otherwise 0B01H while the receive buffer is more than 2/3 full
    /// (a warning with ERROR = 0, [ET200S SI] §2.10, Table 2-14, `[derived]`), else 0000H.
    pub status: Status,
}

impl Default for Received {
    /// Nothing received in this call: NDR and ERROR false, LEN 0, STATUS 0000H.
    fn default() -> Self {
        Received {
            ndr: false,
            error: false,
            len: 0,
            status: Status::OK,
        }
    }
}

/// FB2 S_RCV over any [`JobPort`] ([ET200S SI] §2.10, Table 2-14;
/// [ET200S SI 2005] §2.10, Table 2-15; [Modbus/USS] §3.4.5–§3.4.16 for the Modbus
/// master, whose "received frame" is the response of the job S_SEND started).
///
/// With EN_R statically TRUE each call copies at most one received frame into `dest` (NDR,
/// LEN) or reports one receive error (ERROR, STATUS). EN_R = 0 or R = 1 takes nothing and
/// shows NDR/ERROR/LEN 0 (`[derived]`), except that a transfer in flight (the window's) is aborted
/// with ERROR and 1E0DH.
#[derive(Debug, Default)]
pub struct SRcv {
    _private: (),
}

impl SRcv {
    /// One call of the FB (one PLC cycle); see the [type docs](SRcv).
    pub fn call<P: JobPort>(
        &mut self,
        port: &mut P,
        now: Instant,
        en_r: bool,
        r: bool,
        dest: &mut [u8],
    ) -> Received {
        if r || !en_r {
            return if port.stop_receiving(r) {
                Received {
                    error: true,
                    status: common::ABORTED_BY_RESET,
                    ..Received::default()
                }
            } else {
                Received::default()
            };
        }
        let warning = port.receive_warning();
        match port.take_received(now, dest) {
            Some(Reception::Frame { len, status }) => Received {
                ndr: true,
                len,
                status,
                ..Received::default()
            },
            Some(Reception::Error(status)) => Received {
                error: true,
                status,
                ..Received::default()
            },
            None => Received {
                status: warning,
                ..Received::default()
            },
        }
    }
}

/// One S_SEND and one S_RCV instance: the user program's "channel" to a partner, driven the
/// same way whether the port is a line engine on the host's own port or the window host of an
/// ET 200S SI module. The port is passed in on every call (engines live inside a simulator or a
/// driver and are lent for one call), so one program is written once:
///
/// ```
/// use si_core::fb::Channel;
/// use si_core::job::FramePort;
/// use si_core::Instant;
///
/// /// Forwards every received frame back to the partner.
/// fn echo<P: FramePort>(ch: &mut Channel, port: &mut P, now: Instant, buf: &mut [u8; 256], pending: &mut Option<usize>) {
///     let r = ch.s_rcv.call(port, now, true, false, buf);
///     if r.ndr {
///         *pending = Some(r.len);
///     }
///     if let Some(len) = *pending {
///         let d = ch.s_send.call(port, now, true, false, &buf[..len]);
///         if d.done || d.error {
///             *pending = None;
///         }
///     }
/// }
/// ```
#[derive(Debug, Default)]
pub struct Channel {
    /// The S_SEND instance.
    pub s_send: SSend,
    /// The S_RCV instance.
    pub s_rcv: SRcv,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reset_makes_a_held_req_count_again() {
        let mut e = RisingEdge::default();
        assert!(e.update(true));
        e.reset();
        assert!(e.update(true));
    }

    #[test]
    fn pulse_is_overwritten_not_queued() {
        let mut p = Pulse::default();
        p.fire(1);
        p.fire(2);
        assert!(p.is_armed());
        assert_eq!(p.take(), Some(2));
        assert!(!p.is_armed());
    }
}
