//! The ASCII driver's function blocks with S7 call semantics (et200s-si-3964r-ascii.md §8):
//! S_SEND, S_RCV, S_VSTAT, S_VSET, S_XON, S_RTS and S_V24, called once per PLC-style cycle on a
//! [`Link`]. REQ is edge-triggered, R resets, EN_R is a level, and DONE / NDR / ERROR / STATUS /
//! LEN are valid for exactly the call that reports them (§8.9).
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
//! reset"), which is how §8.2's "DONE and ERROR/STATUS are also updated when the FB is reset" is
//! read; data already handed to the link are still sent (§8.2). S_VSET and the parameter FBs
//! complete in the call that sees the REQ edge, since the link applies them at once.

use crate::config::{AutoV24, RtsCts, XonXoff, MAX_FRAME_LEN};
use crate::link::{JobId, Link, Refused, SendError};
use crate::status;
use bytes::{Bytes, BytesMut};
use si_core::fb::RisingEdge;
use si_core::{Instant, SignalUpdate, Status};

pub use si_core::fb::Done;

/// DONE or ERROR for a job the link applied (or refused) at once.
fn done_from(r: Result<(), Refused>) -> Done {
    match r {
        Ok(()) => Done::ok(),
        Err(e) => Done::failed(e.status),
    }
}

/// FB3 S_SEND: send LEN bytes of a data block to the partner (§8.2, Table 2-13).
#[derive(Debug, Default)]
pub struct SSend {
    req: RisingEdge,
    /// A frame waiting for the link to finish the previous job.
    queued: Option<Bytes>,
    job: Option<JobId>,
    /// Frames are cut from this buffer (`split().freeze()`); once the link has dropped the
    /// previous frame, `reserve` reclaims the allocation, so a steady state of send jobs
    /// allocates nothing per frame (the si-core contract). Empty until the first job.
    pool: BytesMut,
}

impl SSend {
    /// One call. `data` is the source area: DB_NO/DBB_NO/LEN become a slice, LEN must be
    /// 1 … 200 (else ERROR with 1E41H).
    pub fn call(&mut self, link: &mut Link, now: Instant, req: bool, r: bool, data: &[u8]) -> Done {
        if r {
            self.req.reset();
            self.queued = None;
            if self.job.take().is_some() {
                return Done::failed(status::ABORTED_BY_RESET);
            }
            return Done::default();
        }
        if self.req.update(req) && self.job.is_none() && self.queued.is_none() {
            if data.is_empty() || data.len() > MAX_FRAME_LEN {
                return Done::failed(status::INVALID_LEN);
            }
            if self.pool.capacity() < data.len() {
                self.pool.reserve(2 * MAX_FRAME_LEN);
            }
            self.pool.extend_from_slice(data);
            self.queued = Some(self.pool.split().freeze());
        }
        if let Some(frame) = self.queued.take() {
            match link.send(now, frame.clone()) {
                Ok(job) => self.job = Some(job),
                Err(SendError::Busy) => self.queued = Some(frame),
                Err(e) => return Done::failed(e.status()),
            }
        }
        if let Some(job) = self.job {
            if let Some(result) = link.send_result(job) {
                self.job = None;
                return match result {
                    Ok(()) => Done::ok(),
                    Err(s) => Done::failed(s),
                };
            }
        }
        Done::default()
    }

    /// True while a job is queued or running (the FB's internal busy state).
    pub fn busy(&self) -> bool {
        self.job.is_some() || self.queued.is_some()
    }
}

/// The outputs of S_RCV.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Received {
    /// New data received (this call only).
    pub ndr: bool,
    /// Receive error (this call only).
    pub error: bool,
    /// Length of the frame copied into the destination (with NDR), else 0.
    pub len: usize,
    /// The error, or 0B01H while the buffer is more than 2/3 full, or 0000H.
    pub status: Status,
}

/// FB2 S_RCV: copy a received frame into a data block (§8.3, Table 2-14).
#[derive(Debug, Default)]
pub struct SRcv {
    _private: (),
}

impl SRcv {
    /// One call. EN_R must be statically 1 to receive; R = 1 resets and blocks receiving.
    /// `dest` is the destination area; one shorter than the waiting frame gives ERROR with
    /// 1E20H and leaves the frame in the buffer.
    pub fn call(
        &mut self,
        link: &mut Link,
        now: Instant,
        en_r: bool,
        r: bool,
        dest: &mut [u8],
    ) -> Received {
        let idle = Received {
            ndr: false,
            error: false,
            len: 0,
            status: link.receive_status(),
        };
        if r || !en_r {
            return Received {
                status: Status::OK,
                ..idle
            };
        }
        if let Some(status) = link.take_receive_error() {
            return Received {
                error: true,
                status,
                ..idle
            };
        }
        match link.buffer().oldest_len() {
            None => idle,
            Some(len) if len > dest.len() => Received {
                error: true,
                status: status::PARAMETER_OUT_OF_RANGE,
                ..idle
            },
            Some(_) => {
                let len = link.read_frame(now, dest).unwrap_or(0);
                Received {
                    ndr: true,
                    len,
                    status: link.receive_status(),
                    ..idle
                }
            }
        }
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

/// FB4 S_VSTAT: read the RS-232C signals (§8.7). The states refresh on every call; a REQ edge
/// gives DONE.
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

/// FB5 S_VSET: set RTS and DTR (§8.8). ERROR with 0502H where §6.7 forbids it.
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
    /// FB6 S_XON: XON/XOFF characters and wait time (§8.4).
    SXon, XonXoff, set_xon_xoff
);
param_fb!(
    /// FB7 S_RTS: wait time for CTS (§8.5).
    SRts, RtsCts, set_rts_cts
);
param_fb!(
    /// FB8 S_V24: RTS-off time and data output wait time (§8.6).
    SV24, AutoV24, set_auto_v24
);
