//! The FB equivalents over the window protocol ([ET200S SI 2005] §2.10,
//! [ET200S SI] §2.10): the [`Host`] is a [`JobPort`], so si-core's S_SEND and S_RCV run
//! on it exactly as on a line engine; S_VSTAT, S_VSET, S_XON, S_RTS and S_V24 are si-core's
//! too ([`si_core::fb_v24`]), run on the host as a [`V24Port`]: the same code that drives them
//! on the ASCII link.
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
//! * The TIME inputs of S_XON / S_RTS / S_V24 become counts of 10 ms, the unit of the window
//!   (Table 2-27), through si-core's one conversion; values outside the manual's ranges or off
//!   the 10 ms grid give ERROR with 1E20H and nothing is sent.

use crate::frame::RxStatus;
use crate::host::{Host, Job, JobId, Outcome};
use crate::status::{BUFFER_TWO_THIRDS_FULL, PARAMETER_OUT_OF_RANGE};
use si_core::fb_v24::{V24Job, V24Port, V24Start};
use si_core::job::{JobPort, NotStarted, Reception};
use si_core::{Instant, ModemSignals, Status};

pub use si_core::fb::{Done, Received, SRcv, SSend};
pub use si_core::fb_v24::{SRts, SVset, SVstat, SXon, V24State, SV24};

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

impl V24Port for Host {
    /// A read V.24, write V.24 or parameter job (job codes 3, 4, 5) through
    /// [`Host::submit`]; it runs over several DP cycles. 0502H when the job queue is full.
    fn start_v24(&mut self, job: V24Job) -> V24Start {
        let job = match job {
            V24Job::ReadSignals => Job::ReadV24,
            V24Job::WriteSignals { rts, dtr } => Job::WriteV24 { rts, dtr },
            V24Job::Parameters(block) => Job::Parameters(block),
        };
        match self.submit(job) {
            Ok(id) => V24Start::Running(id),
            Err(e) => V24Start::Done(Err(e.status())),
        }
    }

    /// [`Host::take_completion`]: the signals read for a read V.24 job.
    fn v24_outcome(&mut self, id: JobId) -> Option<Result<Option<ModemSignals>, Status>> {
        let outcome = self.take_completion(id)?;
        Some(outcome.map(|o| match o {
            Outcome::Signals(s) => Some(s.into()),
            _ => None,
        }))
    }

    /// [`Host::abort`], as for S_SEND (§2.8).
    fn cancel_v24(&mut self, id: JobId) {
        JobPort::cancel_job(self, id);
    }
}
