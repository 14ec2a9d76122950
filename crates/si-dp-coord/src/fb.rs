//! The FB equivalents over the window protocol ([ET200S SI 2005] §2.10,
//! [ET200S SI] §2.10): the [`Host`] is a [`JobPort`], so si-core's S_SEND and S_RCV run
//! on it exactly as on a line engine; S_VSTAT, S_VSET, S_XON, S_RTS and S_V24 are the window's
//! own, built on si-core's [`JobRequest`].
//!
//! Each FB is called once per user cycle, the host engine once per DP cycle; the FB submits its
//! job to the host's arbiter and collects its own completion with [`Host::take_completion`], so
//! several FBs share one host ([ET200S SI 2005] §2.12.1: one job owns byte 0 at a time). REQ is
//! edge-triggered, R aborts, EN_R is a level, and DONE / NDR / ERROR / STATUS / LEN are valid for
//! exactly the call that reports them ([ET200S SI 2005] §2.10). Do not also drain the host with
//! `poll_event` or enable its `auto_receive` while FBs run on it: the FBs would miss their
//! completions or their frames.
//!
//! Readings:
//! * R with a job in progress ends it with ERROR and 1E0DH in that call ("DONE and ERROR/STATUS
//!   are also output on RESET", [ET200S SI 2005] §2.10, Table 2-14); the host writes idle, which
//!   aborts the module's side. For S_RCV, EN_R = 0 or R aborts a running transfer the same way; the
//!   module keeps the aborted frame and offers it again ([ET200S SI 2005] §2.10, Table 2-15).
//! * S_RCV fetches a frame only while the idle status shows one (0001H/0B01H) and EN_R = 1; a frame
//!   longer than the destination area is fetched and reported with ERROR and 1E20H (the window
//!   protocol cannot leave it in the module once read).
//! * S_VSTAT reads the signals with a read V.24 job on each REQ edge; the signal outputs keep the
//!   last states read (the window has no other way to see them, `[derived]`).
//! * The TIME inputs of S_XON / S_RTS / S_V24 are rounded down to 10 ms, the unit of the window
//!   (Table 2-27); values outside the manual's ranges give ERROR with 1E20H.

use crate::frame::{ParamBlock, RxStatus, V24Signals};
use crate::host::{Host, Job, JobId, Outcome};
use crate::status::{BUFFER_TWO_THIRDS_FULL, PARAMETER_OUT_OF_RANGE};
use si_core::fb::JobRequest;
use si_core::job::{JobPort, NotStarted, Reception};
use si_core::{Duration, Instant, Status};

pub use si_core::fb::{Done, Received, SRcv, SSend};

/// The window host's jobs take no start time: the host runs them in its DP cycles
/// ([`Host::cycle`] carries the time).
const NO_START_TIME: Instant = Instant::ZERO;

impl JobPort for Host {
    type Job = Job;
    type Output = Outcome;

    /// [`Host::submit`]: 1E41H for a bad LEN, 0502H when the job queue is full.
    fn start_job(&mut self, _now: Instant, job: Job) -> Result<JobId, NotStarted> {
        self.submit(job)
            .map_err(|e| NotStarted::Refused(e.status()))
    }

    /// [`Host::take_completion`]: several FBs share one host, each takes its own completion.
    fn job_outcome(&mut self, id: JobId) -> Option<Result<Outcome, Status>> {
        self.take_completion(id)
    }

    /// [`Host::abort`]: writing idle aborts the module's side ([ET200S SI 2005] §2.12.7); the 1E0DH
    /// completion is taken here, the FB reports it itself.
    fn cancel_job(&mut self, id: JobId) {
        self.abort(id);
        self.take_completion(id);
    }

    /// A frame is fetched with a receive job only while the idle status shows one
    /// (0001H/0B01H); the job runs over several DP cycles and this call hands its frame over
    /// once it ended. A frame longer than `dest` is reported with 1E20H: the window protocol
    /// cannot leave it in the module once read.
    fn take_received(&mut self, _now: Instant, dest: &mut [u8]) -> Option<Reception> {
        let warning = JobPort::receive_warning(self);
        if let Some(id) = self.fb_receive {
            let result = self.take_completion(id)?;
            self.fb_receive = None;
            match result {
                Ok(Outcome::Received(frame)) => {
                    let Some(slot) = dest.get_mut(..frame.len()) else {
                        return Some(Reception::Error(PARAMETER_OUT_OF_RANGE));
                    };
                    slot.copy_from_slice(&frame);
                    return Some(Reception::Frame {
                        len: frame.len(),
                        status: warning,
                    });
                }
                Ok(_) => {}
                Err(status) => return Some(Reception::Error(status)),
            }
        }
        if self.receive_status().is_some_and(RxStatus::frame_waiting) {
            self.fb_receive = self.submit(Job::Receive).ok();
        }
        None
    }

    fn receive_warning(&self) -> Status {
        if self.receive_status() == Some(RxStatus::TwoThirdsFull) {
            BUFFER_TWO_THIRDS_FULL
        } else {
            Status::OK
        }
    }

    /// EN_R = 0 and R both abort a running receive job ([ET200S SI 2005] §2.10, Table 2-15: the
    /// module keeps the frame and offers it again).
    fn stop_receiving(&mut self, _reset: bool) -> bool {
        let Some(id) = self.fb_receive.take() else {
            return false;
        };
        self.cancel_job(id);
        true
    }
}

/// The common call of the FBs whose result is DONE/ERROR only.
fn done_only(
    t: &mut JobRequest,
    host: &mut Host,
    req: bool,
    r: bool,
    job: impl FnOnce() -> Result<Job, Status>,
) -> Done {
    t.call(host, NO_START_TIME, req, r, job).into()
}

/// The outputs of S_VSTAT.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct V24State {
    /// DONE / ERROR / STATUS.
    pub result: Done,
    /// The signal states last read (DTR_OUT, DSR_IN, RTS_OUT, CTS_IN, DCD_IN).
    pub signals: V24Signals,
}

/// FB4 S_VSTAT: reads the V.24 signals with a read V.24 job ([ET200S SI 2005] §2.10, Table 2-19).
#[derive(Debug, Default)]
pub struct SVstat {
    t: JobRequest,
    signals: V24Signals,
}

impl SVstat {
    /// One call; a REQ edge starts a read.
    pub fn call(&mut self, host: &mut Host, req: bool, r: bool) -> V24State {
        let outcome = self
            .t
            .call(host, NO_START_TIME, req, r, || Ok(Job::ReadV24));
        if let Some(Ok(Outcome::Signals(s))) = outcome {
            self.signals = s;
        }
        V24State {
            result: outcome.into(),
            signals: self.signals,
        }
    }
}

/// FB5 S_VSET: sets RTS and DTR with a write V.24 job ([ET200S SI 2005] §2.10, Table 2-20).
#[derive(Debug, Default)]
pub struct SVset {
    t: JobRequest,
}

impl SVset {
    /// One call; a REQ edge writes `rts` and `dtr`.
    pub fn call(&mut self, host: &mut Host, req: bool, r: bool, rts: bool, dtr: bool) -> Done {
        done_only(&mut self.t, host, req, r, || Ok(Job::WriteV24 { rts, dtr }))
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

/// FB6 S_XON: XON/XOFF parameters, block 20H ([ET200S SI 2005] §2.10, Table 2-16).
#[derive(Debug, Default)]
pub struct SXon {
    t: JobRequest,
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
        done_only(&mut self.t, host, req, r, || {
            Ok(Job::Parameters(ParamBlock::XonXoff {
                xon,
                xoff,
                xon_wait: ten_ms(wait_for_xon, 20)?,
            }))
        })
    }
}

/// FB7 S_RTS: RTS/CTS parameters, block 21H ([ET200S SI 2005] §2.10, Table 2-17).
#[derive(Debug, Default)]
pub struct SRts {
    t: JobRequest,
}

impl SRts {
    /// One call; a REQ edge sends WAIT_FOR_CTS (20 ms … 655 350 ms, default 2 s).
    pub fn call(&mut self, host: &mut Host, req: bool, r: bool, wait_for_cts: Duration) -> Done {
        done_only(&mut self.t, host, req, r, || {
            Ok(Job::Parameters(ParamBlock::RtsCts {
                cts_wait: ten_ms(wait_for_cts, 20)?,
            }))
        })
    }
}

/// FB8 S_V24: automatic V.24 control parameters, block 22H ([ET200S SI 2005] §2.10, Table 2-18).
#[derive(Debug, Default)]
pub struct SV24 {
    t: JobRequest,
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
        done_only(&mut self.t, host, req, r, || {
            Ok(Job::Parameters(ParamBlock::AutoV24 {
                rts_off_delay: ten_ms(time_rts_off, 0)?,
                cts_wait: ten_ms(data_wait_time, 0)?,
            }))
        })
    }
}
