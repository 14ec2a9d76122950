//! The ASCII driver's function blocks with S7 call semantics ([ET200S SI] §2.10):
//! S_SEND and S_RCV are si-core's, run on the [`Link`] as a [`JobPort`]; S_VSTAT, S_VSET, S_XON,
//! S_RTS and S_V24 are this driver's own, called once per PLC-style cycle. REQ is
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
//! reset"), which is how [ET200S SI] §2.10, Table 2-13's "DONE and ERROR/STATUS are also updated
//! when the FB is reset" is read; data already handed to the link are still sent ([ET200S SI]
//! §2.10, Table 2-13). S_SEND waits while the link runs another caller's job and hands its frame
//! over once the link is free. A frame longer than S_RCV's destination area gives ERROR with 1E20H
//! and stays in the buffer. S_VSET and the parameter FBs complete in the call that sees the REQ
//! edge, since the link applies them at once.

use crate::config::{AutoV24, RtsCts, XonXoff};
use crate::link::{Link, Refused, SendError};
use crate::status;
use bytes::Bytes;
use si_core::fb::RisingEdge;
use si_core::job::{JobId, JobPort, NotStarted, Reception};
use si_core::{Instant, SignalUpdate, Status};

pub use si_core::fb::{Done, Received, SRcv, SSend};

/// DONE or ERROR for a job the link applied (or refused) at once.
fn done_from(r: Result<(), Refused>) -> Done {
    match r {
        Ok(()) => Done::ok(),
        Err(e) => Done::failed(e.status),
    }
}

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

/// The outputs of S_VSTAT.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct V24State {
    /// DONE / ERROR / STATUS.
    pub result: Done,
    /// DTR (module output).
    pub dtr_out: bool,
    /// DSR (input).
    pub dsr_in: bool,
    /// RTS (module output).
    pub rts_out: bool,
    /// CTS (input).
    pub cts_in: bool,
    /// DCD (input).
    pub dcd_in: bool,
}

/// FB4 S_VSTAT: read the RS-232C signals ([ET200S SI] §2.10, Table 2-18). The states refresh on
/// every call; a REQ edge gives DONE.
#[derive(Debug, Default)]
pub struct SVstat {
    req: RisingEdge,
}

impl SVstat {
    /// One call.
    pub fn call(&mut self, link: &Link, req: bool, r: bool) -> V24State {
        if r {
            self.req.reset();
        }
        let s = link.signals();
        let result = if !r && self.req.update(req) {
            Done::ok()
        } else {
            Done::default()
        };
        V24State {
            result,
            dtr_out: s.dtr,
            dsr_in: s.dsr,
            rts_out: s.rts,
            cts_in: s.cts,
            dcd_in: s.dcd,
        }
    }
}

/// FB5 S_VSET: set RTS and DTR ([ET200S SI] §2.10, Table 2-19). ERROR with 0502H where §2.8 forbids
/// it.
#[derive(Debug, Default)]
pub struct SVset {
    req: RisingEdge,
}

impl SVset {
    /// One call.
    pub fn call(&mut self, link: &mut Link, req: bool, r: bool, rts: bool, dtr: bool) -> Done {
        if r {
            self.req.reset();
            return Done::default();
        }
        if !self.req.update(req) {
            return Done::default();
        }
        done_from(link.set_signals(SignalUpdate {
            rts: Some(rts),
            dtr: Some(dtr),
        }))
    }
}

macro_rules! param_fb {
    ($(#[$m:meta])* $name:ident, $params:ty, $setter:ident) => {
        $(#[$m])*
        #[derive(Debug, Default)]
        pub struct $name {
            req: RisingEdge,
        }

        impl $name {
            /// One call; 0550H if the configured flow control differs, 1E20H if out of range.
            pub fn call(&mut self, link: &mut Link, req: bool, r: bool, params: $params) -> Done {
                if r {
                    self.req.reset();
                    return Done::default();
                }
                if !self.req.update(req) {
                    return Done::default();
                }
                done_from(link.$setter(params))
            }
        }
    };
}

param_fb!(
    /// FB6 S_XON: XON/XOFF characters and wait time ([ET200S SI] §2.10, Table 2-15).
    SXon, XonXoff, set_xon_xoff
);
param_fb!(
    /// FB7 S_RTS: wait time for CTS ([ET200S SI] §2.10, Table 2-16).
    SRts, RtsCts, set_rts_cts
);
param_fb!(
    /// FB8 S_V24: RTS-off time and data output wait time ([ET200S SI] §2.10, Table 2-17).
    SV24, AutoV24, set_auto_v24
);
