//! The ASCII driver's function blocks with S7 call semantics ([ET200S SI] §2.10):
//! S_SEND and S_RCV are si-core's, run on the [`Link`] as a [`JobPort`]; S_VSTAT, S_VSET, S_XON,
//! S_RTS and S_V24 are si-core's too ([`si_core::fb_v24`]), run on the link as a [`V24Port`],
//! the same code that drives them through the coordination window. Each is called once per
//! PLC-style cycle. REQ is
//! edge-triggered, R resets, EN_R is a level, and DONE / NDR / ERROR / STATUS / LEN are valid
//! for exactly the call that reports them ([ET200S SI] §2.10 `[derived]`).
//!
//! ```
//! use si_ascii::fb::{SRcv, SSend};
//! use si_ascii::{Config, EndCriterion, Link};
//! use si_core::{Engine, Instant};
//!
//! let mut link = Link::new(Config { end: EndCriterion::DEFAULT_END_CHARS, ..Config::default() }).unwrap();
//! let mut rcv = SRcv::default();
//! let mut db = [0u8; 200];
//! link.handle_rx(Instant::ZERO, b"OK\x03");
//! let out = rcv.call(&mut link, Instant::ZERO, true, false, &mut db);
//! assert!(out.ndr && !out.error);
//! assert_eq!(&db[..out.len], b"OK\x03");
//! // Valid for one call only.
//! assert!(!rcv.call(&mut link, Instant::ZERO, true, false, &mut db).ndr);
//! ```
//!
//! Readings: R on S_SEND with a job in progress ends it with ERROR and 1E0DH ("job aborted by …
//! reset"), which is how [ET200S SI] §2.10, Table 2-13's "DONE and ERROR/STATUS are also updated when the FB is reset" is
//! read; data already handed to the link are still sent ([ET200S SI]
//! §2.10, Table 2-13). S_SEND waits while the link
//! runs another caller's job and hands its frame over once the link is free. A frame longer
//! than S_RCV's destination area gives ERROR with 1E20H and stays in the buffer. S_VSTAT, S_VSET and
//! the parameter FBs complete in the call that sees the REQ edge, since the link applies them at
//! once; their TIME inputs go through the parameter blocks' counts of 10 ms, so a time off the
//! 10 ms grid is 1E20H.

use crate::link::{Link, SendError};
use crate::status;
use bytes::Bytes;
use si_core::fb_v24::{V24Job, V24Port, V24Start};
use si_core::job::{JobId, JobPort, NotStarted, Reception};
use si_core::{Instant, ModemSignals, SignalUpdate, Status};

pub use si_core::fb::{Done, Received, SRcv, SSend};
pub use si_core::fb_v24::{SRts, SVset, SVstat, SXon, V24State, SV24};

impl JobPort for Link {
    type Job = Bytes;
    type Output = ();

    /// [`Link::send`]. A bad LEN (1 … the maximum frame length, 200 on the ET 200S 1SI, Table
    /// 2-13: 1E41H) is refused even while the link is busy; a busy link takes the frame later.
    fn start_job(&mut self, now: Instant, frame: Bytes) -> Result<JobId, NotStarted> {
        if frame.is_empty() || frame.len() > self.config().max_frame() {
            return Err(NotStarted::Refused(status::INVALID_LEN));
        }
        self.send(now, frame).map_err(|e| match e {
            SendError::Busy => NotStarted::Busy,
            e => NotStarted::Refused(e.status()),
        })
    }

    fn job_outcome(&mut self, id: JobId) -> Option<Result<(), Status>> {
        self.send_result(id)
    }

    /// The frame is still sent ([ET200S SI] §2.10, Table 2-13); nothing to do.
    fn cancel_job(&mut self, _id: JobId) {}

    /// A receive error first (taken once), else the oldest frame if it fits `dest` (1E20H and
    /// the frame stays if not). The 0B01H warning with NDR is the buffer's state after the
    /// read ([ET200S SI] §2.8: the warning shows while the buffer stays above 2/3).
    fn take_received(&mut self, now: Instant, dest: &mut [u8]) -> Option<Reception> {
        if let Some(status) = self.take_receive_error() {
            return Some(Reception::Error(status));
        }
        let len = self.buffer().oldest_len()?;
        if len > dest.len() {
            return Some(Reception::Error(status::PARAMETER_OUT_OF_RANGE));
        }
        let len = self.read_frame(now, dest).unwrap_or(0);
        Some(Reception::Frame {
            len,
            status: self.receive_status(),
        })
    }

    fn receive_warning(&self) -> Status {
        self.receive_status()
    }
}

impl V24Port for Link {
    /// The link applies every V.24 job at once, so DONE or ERROR comes in the call with the
    /// REQ edge: S_VSTAT reads [`Link::signals`], S_VSET is [`Link::set_signals`] (0502H
    /// where [ET200S SI] §2.8 forbids it), S_XON / S_RTS / S_V24 are
    /// [`Link::apply_param_block`] (0550H under another flow control, 1E20H out of range).
    fn start_v24(&mut self, job: V24Job) -> V24Start {
        let applied = match job {
            V24Job::ReadSignals => return V24Start::Done(Ok(Some(self.signals()))),
            V24Job::WriteSignals { rts, dtr } => self.set_signals(SignalUpdate {
                rts: Some(rts),
                dtr: Some(dtr),
            }),
            V24Job::Parameters(block) => self.apply_param_block(block),
        };
        V24Start::Done(applied.map(|()| None).map_err(|e| e.status))
    }

    /// No job of the link outlives its start.
    fn v24_outcome(&mut self, _id: JobId) -> Option<Result<Option<ModemSignals>, Status>> {
        None
    }

    fn cancel_v24(&mut self, _id: JobId) {}

    /// The link sees its signals at all times: S_VSTAT refreshes them on every call
    /// ([ET200S SI] §2.10, Table 2-18).
    fn signals_now(&self) -> Option<ModemSignals> {
        Some(self.signals())
    }
}
