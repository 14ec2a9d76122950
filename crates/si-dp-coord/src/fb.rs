//! The FB equivalents over the window protocol: S_SEND, S_RCV, S_VSTAT, S_VSET, S_XON, S_RTS and
//! S_V24 as a non-S7 host runs them against a [`Host`] (et200s-si-2005-window-protocol.md §5,
//! et200s-si-3964r-ascii.md §8).
//!
//! Each FB is called once per user cycle, the host engine once per DP cycle; the FB submits its
//! job to the host's arbiter and collects its own completion with [`Host::take_completion`], so
//! several FBs share one host (§2.4: one job owns byte 0 at a time). REQ is edge-triggered, R
//! aborts, EN_R is a level, and DONE / NDR / ERROR / STATUS / LEN are valid for exactly the call
//! that reports them (§5.2). Do not also drain the host with `poll_event` or enable its
//! `auto_receive` while FBs run on it: the FBs would miss their completions or their frames.
//!
//! Readings:
//! * R with a job in progress ends it with ERROR and 1E0DH in that call ("DONE and ERROR/STATUS
//!   are also output on RESET", §5.3); the host writes idle, which aborts the module's side. For
//!   S_RCV the module keeps the aborted frame and offers it again (§5.4).
//! * S_RCV fetches a frame only while the idle status shows one (0001H/0B01H) and EN_R = 1; a frame
//!   longer than the destination area is fetched and reported with ERROR and 1E20H (the window
//!   protocol cannot leave it in the module once read).
//! * S_VSTAT reads the signals with a read V.24 job on each REQ edge; the signal outputs keep the
//!   last states read (the window has no other way to see them, H-63).
//! * The TIME inputs of S_XON / S_RTS / S_V24 are rounded down to 10 ms, the unit of the window
//!   (Table 2-27); values outside the manual's ranges give ERROR with 1E20H.

use crate::frame::{ParamBlock, RxStatus, V24Signals};
use crate::host::{Host, Job, JobId, Outcome};
use crate::status::{ABORTED_BY_RESET, BUFFER_TWO_THIRDS_FULL, PARAMETER_OUT_OF_RANGE};
use bytes::Bytes;
use si_core::fb::RisingEdge;
use si_core::{Duration, Status};

pub use si_core::fb::Done;

/// The job-tracking core every FB shares: REQ edge, the running job, R.
#[derive(Debug, Default)]
struct Tracker {
    req: RisingEdge,
    job: Option<JobId>,
}

impl Tracker {
    /// R: aborts the running job; true if there was one.
    fn reset(&mut self, host: &mut Host) -> bool {
        self.req.reset();
        match self.job.take() {
            Some(id) => {
                host.abort(id);
                host.take_completion(id);
                true
            }
            None => false,
        }
    }

    /// Submits `job()` on a REQ edge when idle; a refusal is reported at once.
    fn start(
        &mut self,
        host: &mut Host,
        req: bool,
        job: impl FnOnce() -> Result<Job, Status>,
    ) -> Option<Done> {
        if !self.req.update(req) || self.job.is_some() {
            return None;
        }
        match job().and_then(|j| host.submit(j).map_err(|e| e.status())) {
            Ok(id) => {
                self.job = Some(id);
                None
            }
            Err(status) => Some(Done::failed(status)),
        }
    }

    /// The job's result if it completed.
    fn poll(&mut self, host: &mut Host) -> Option<Result<Outcome, Status>> {
        let id = self.job?;
        let result = host.take_completion(id)?;
        self.job = None;
        Some(result)
    }

    /// The common call of the FBs whose result is DONE/ERROR only.
    fn call(
        &mut self,
        host: &mut Host,
        req: bool,
        r: bool,
        job: impl FnOnce() -> Result<Job, Status>,
    ) -> Done {
        if r {
            return if self.reset(host) {
                Done::failed(ABORTED_BY_RESET)
            } else {
                Done::default()
            };
        }
        if let Some(refused) = self.start(host, req, job) {
            return refused;
        }
        match self.poll(host) {
            Some(Ok(_)) => Done::ok(),
            Some(Err(status)) => Done::failed(status),
            None => Done::default(),
        }
    }
}

/// FB3 S_SEND: sends LEN bytes to the partner (§5.3).
#[derive(Debug, Default)]
pub struct SSend {
    t: Tracker,
}

impl SSend {
    /// One call; `data` is the source area (LEN = its length, 1 … the host's maximum, else
    /// ERROR with 1E41H).
    pub fn call(&mut self, host: &mut Host, req: bool, r: bool, data: &[u8]) -> Done {
        self.t
            .call(host, req, r, || Ok(Job::Send(Bytes::copy_from_slice(data))))
    }

    /// True while the FB's job is queued or running.
    pub fn busy(&self) -> bool {
        self.t.job.is_some()
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
    /// The error, or 0B01H while the module's buffer is more than 2/3 full, or 0000H.
    pub status: Status,
}

/// FB2 S_RCV: copies a received frame into the destination area (§5.4).
#[derive(Debug, Default)]
pub struct SRcv {
    job: Option<JobId>,
}

impl SRcv {
    /// One call. EN_R = 1 enables receiving (0 aborts a running transfer with ERROR and 1E0DH);
    /// R = 1 aborts and blocks.
    pub fn call(&mut self, host: &mut Host, en_r: bool, r: bool, dest: &mut [u8]) -> Received {
        let warning = if host.receive_status() == Some(RxStatus::TwoThirdsFull) {
            BUFFER_TWO_THIRDS_FULL
        } else {
            Status::OK
        };
        let quiet = Received {
            ndr: false,
            error: false,
            len: 0,
            status: warning,
        };
        if r || !en_r {
            return match self.job.take() {
                Some(id) => {
                    host.abort(id);
                    host.take_completion(id);
                    Received {
                        error: true,
                        status: ABORTED_BY_RESET,
                        ..quiet
                    }
                }
                None => Received {
                    status: Status::OK,
                    ..quiet
                },
            };
        }
        if let Some(id) = self.job {
            match host.take_completion(id) {
                None => return quiet,
                Some(result) => {
                    self.job = None;
                    match result {
                        Ok(Outcome::Received(frame)) if frame.len() <= dest.len() => {
                            dest[..frame.len()].copy_from_slice(&frame);
                            return Received {
                                ndr: true,
                                len: frame.len(),
                                ..quiet
                            };
                        }
                        Ok(Outcome::Received(_)) => {
                            return Received {
                                error: true,
                                status: PARAMETER_OUT_OF_RANGE,
                                ..quiet
                            }
                        }
                        Ok(_) => {}
                        Err(status) => {
                            return Received {
                                error: true,
                                status,
                                ..quiet
                            }
                        }
                    }
                }
            }
        }
        if host.receive_status().is_some_and(RxStatus::frame_waiting) {
            self.job = host.submit(Job::Receive).ok();
        }
        quiet
    }
}

/// The outputs of S_VSTAT.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct V24State {
    /// DONE / ERROR / STATUS.
    pub result: Done,
    /// The signal states last read (DTR_OUT, DSR_IN, RTS_OUT, CTS_IN, DCD_IN).
    pub signals: V24Signals,
}

/// FB4 S_VSTAT: reads the V.24 signals with a read V.24 job (§5.8).
#[derive(Debug, Default)]
pub struct SVstat {
    t: Tracker,
    signals: V24Signals,
}

impl SVstat {
    /// One call; a REQ edge starts a read.
    pub fn call(&mut self, host: &mut Host, req: bool, r: bool) -> V24State {
        let result = if r {
            if self.t.reset(host) {
                Done::failed(ABORTED_BY_RESET)
            } else {
                Done::default()
            }
        } else if let Some(refused) = self.t.start(host, req, || Ok(Job::ReadV24)) {
            refused
        } else {
            match self.t.poll(host) {
                Some(Ok(Outcome::Signals(s))) => {
                    self.signals = s;
                    Done::ok()
                }
                Some(Ok(_)) => Done::ok(),
                Some(Err(status)) => Done::failed(status),
                None => Done::default(),
            }
        };
        V24State {
            result,
            signals: self.signals,
        }
    }
}

/// FB5 S_VSET: sets RTS and DTR with a write V.24 job (§5.9).
#[derive(Debug, Default)]
pub struct SVset {
    t: Tracker,
}

impl SVset {
    /// One call; a REQ edge writes `rts` and `dtr`.
    pub fn call(&mut self, host: &mut Host, req: bool, r: bool, rts: bool, dtr: bool) -> Done {
        self.t.call(host, req, r, || Ok(Job::WriteV24 { rts, dtr }))
    }
}

/// A TIME input as a count of 10 ms within `min ..= 655 350 ms` (10 min 55 s 350 ms).
fn ten_ms(time: Duration, min_ms: u64) -> Result<u16, Status> {
    let ms = time.as_millis();
    if ms < min_ms || ms > 655_350 {
        return Err(PARAMETER_OUT_OF_RANGE);
    }
    u16::try_from(ms / 10).map_err(|_| PARAMETER_OUT_OF_RANGE)
}

/// FB6 S_XON: XON/XOFF parameters, block 20H (§5.5).
#[derive(Debug, Default)]
pub struct SXon {
    t: Tracker,
}

impl SXon {
    /// One call; a REQ edge sends XON, XOFF and WAIT_FOR_XON (20 ms … 655 350 ms, default 2 s).
    pub fn call(
        &mut self,
        host: &mut Host,
        req: bool,
        r: bool,
        xon: u8,
        xoff: u8,
        wait_for_xon: Duration,
    ) -> Done {
        self.t.call(host, req, r, || {
            Ok(Job::Parameters(ParamBlock::XonXoff {
                xon,
                xoff,
                xon_wait: ten_ms(wait_for_xon, 20)?,
            }))
        })
    }
}

/// FB7 S_RTS: RTS/CTS parameters, block 21H (§5.6).
#[derive(Debug, Default)]
pub struct SRts {
    t: Tracker,
}

impl SRts {
    /// One call; a REQ edge sends WAIT_FOR_CTS (20 ms … 655 350 ms, default 2 s).
    pub fn call(&mut self, host: &mut Host, req: bool, r: bool, wait_for_cts: Duration) -> Done {
        self.t.call(host, req, r, || {
            Ok(Job::Parameters(ParamBlock::RtsCts {
                cts_wait: ten_ms(wait_for_cts, 20)?,
            }))
        })
    }
}

/// FB8 S_V24: automatic V.24 control parameters, block 22H (§5.7).
#[derive(Debug, Default)]
pub struct SV24 {
    t: Tracker,
}

impl SV24 {
    /// One call; a REQ edge sends TIME_RTS_OFF and DATA_WAIT_TIME (0 … 655 350 ms each, default
    /// 10 ms).
    pub fn call(
        &mut self,
        host: &mut Host,
        req: bool,
        r: bool,
        time_rts_off: Duration,
        data_wait_time: Duration,
    ) -> Done {
        self.t.call(host, req, r, || {
            Ok(Job::Parameters(ParamBlock::AutoV24 {
                rts_off_delay: ten_ms(time_rts_off, 0)?,
                cts_wait: ten_ms(data_wait_time, 0)?,
            }))
        })
    }
}
