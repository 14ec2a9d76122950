//! The V.24 family of function blocks, written once: FB4 S_VSTAT, FB5 S_VSET, FB6 S_XON, FB7
//! S_RTS and FB8 S_V24 (`[ET200S SI]` §2.10, Tables 2-15 to 2-19; `[ET200S SI 2005]` §2.10,
//! Tables 2-16 to 2-20), generic over a [`V24Port`].
//!
//! Two kinds of port implement it, and one user program drives either:
//!
//! - the ASCII driver's link (si-ascii), which applies a job at once, so DONE or ERROR comes in
//!   the call with the REQ edge;
//! - the coordination window's host (si-dp-coord), whose read V.24, write V.24 and parameter
//!   jobs (job codes 3, 4 and 5) run over several DP cycles, so DONE or ERROR comes in a later
//!   call.
//!
//! The call semantics are the manual's (`[ET200S SI]` §2.10): REQ is edge-triggered and starts
//! at most one job per FB at a time; DONE / ERROR / STATUS are valid for exactly the call that
//! reports them. R forgets the running job, cancels it on the port and reports ERROR with 1E0DH
//! in that call, as S_SEND does ("DONE and ERROR/STATUS are also updated when the FB is reset",
//! Table 2-13; read for the whole family `[derived]`); while R is TRUE no job starts.
//!
//! The TIME inputs of S_XON, S_RTS and S_V24 become the blocks' counts of 10 ms through
//! [`ten_ms_count`]; a time outside the FB's range or off the 10 ms grid gives ERROR with 1E20H
//! in the call with the edge, and nothing is sent.
//!
//! ```
//! use si_core::fb_v24::{SXon, V24Job, V24Port, V24Start};
//! use si_core::job::JobId;
//! use si_core::param_block::ParamBlock;
//! use si_core::{Duration, ModemSignals, Status};
//!
//! /// A port that applies every job at once and remembers the last block.
//! #[derive(Default)]
//! struct Port(Option<ParamBlock>);
//!
//! impl V24Port for Port {
//!     fn start_v24(&mut self, job: V24Job) -> V24Start {
//!         if let V24Job::Parameters(block) = job {
//!             self.0 = Some(block);
//!         }
//!         V24Start::Done(Ok(None))
//!     }
//!     fn v24_outcome(&mut self, _: JobId) -> Option<Result<Option<ModemSignals>, Status>> {
//!         None
//!     }
//!     fn cancel_v24(&mut self, _: JobId) {}
//! }
//!
//! let (mut port, mut s_xon) = (Port::default(), SXon::default());
//! let out = s_xon.call(&mut port, true, false, 0x11, 0x13, Duration::from_secs(2));
//! assert!(out.done);
//! assert_eq!(port.0, Some(ParamBlock::XON_XOFF_DEFAULT));
//! // Valid for one call: REQ still TRUE is no new edge.
//! assert!(!s_xon.call(&mut port, true, false, 0x11, 0x13, Duration::from_secs(2)).done);
//! ```

use crate::fb::{Done, RisingEdge};
use crate::job::JobId;
use crate::param_block::{ten_ms_count, ParamBlock, MIN_WAIT};
use crate::sansio::ModemSignals;
use crate::status::{common, Status};
use crate::time::Duration;

/// A job of the V.24 family, as the port receives it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum V24Job {
    /// S_VSTAT: read the signal states (the window's read V.24 job).
    ReadSignals,
    /// S_VSET: set RTS and DTR (the window's write V.24 job).
    WriteSignals {
        /// New RTS level.
        rts: bool,
        /// New DTR level.
        dtr: bool,
    },
    /// S_XON, S_RTS, S_V24: a flow-control parameter block (the window's parameter job).
    Parameters(ParamBlock),
}

/// What a port did with a V.24 job it was handed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum V24Start {
    /// The job ended at once (applied, or refused with its STATUS); for a read, the signals.
    Done(Result<Option<ModemSignals>, Status>),
    /// The job runs; [`V24Port::v24_outcome`] returns its end.
    Running(JobId),
}

/// A port the V.24 FBs run on: the ASCII link and the window host implement it.
pub trait V24Port {
    /// Start `job`. A refusal (busy, a parameter block of another flow control, a signal that
    /// the configured mode owns) is `V24Start::Done(Err(status))`.
    fn start_v24(&mut self, job: V24Job) -> V24Start;

    /// The end of a running job, taken once: `Ok(Some(signals))` for a read, `Ok(None)` for
    /// the others, `Err(status)` for an error. `None` while it runs.
    fn v24_outcome(&mut self, id: JobId) -> Option<Result<Option<ModemSignals>, Status>>;

    /// R: abort a running job (the FB reports 1E0DH itself; the port keeps no outcome for it).
    fn cancel_v24(&mut self, id: JobId);

    /// The signal states the port sees without a job, refreshed on every S_VSTAT call
    /// (`[ET200S SI]` §2.10, Table 2-18: "refreshed on each call"); `None` where only a read
    /// job can see them (the window).
    fn signals_now(&self) -> Option<ModemSignals> {
        None
    }
}

/// The REQ / R / job core the five FBs share (their own, since a V.24 job may end in the call
/// that starts it).
#[derive(Debug, Default)]
struct V24Request {
    req: RisingEdge,
    job: Option<JobId>,
}

impl V24Request {
    /// R, then a start on the REQ edge (`job` builds it; a build error ends at once with
    /// ERROR), then the outcome. `None` when nothing ended in this call.
    fn call<P: V24Port + ?Sized>(
        &mut self,
        port: &mut P,
        req: bool,
        r: bool,
        job: impl FnOnce() -> Result<V24Job, Status>,
    ) -> Option<Result<Option<ModemSignals>, Status>> {
        if r {
            self.req.reset();
            let id = self.job.take()?;
            port.cancel_v24(id);
            return Some(Err(common::ABORTED_BY_RESET));
        }
        if self.req.update(req) && self.job.is_none() {
            match job().map(|job| port.start_v24(job)) {
                Err(status) => return Some(Err(status)),
                Ok(V24Start::Done(outcome)) => return Some(outcome),
                Ok(V24Start::Running(id)) => self.job = Some(id),
            }
        }
        let id = self.job?;
        let outcome = port.v24_outcome(id)?;
        self.job = None;
        Some(outcome)
    }

    fn busy(&self) -> bool {
        self.job.is_some()
    }
}

/// The outputs of S_VSTAT (`[ET200S SI]` §2.10, Table 2-18).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct V24State {
    /// DONE / ERROR / STATUS.
    pub result: Done,
    /// DTR_OUT (module output).
    pub dtr_out: bool,
    /// DSR_IN (input).
    pub dsr_in: bool,
    /// RTS_OUT (module output).
    pub rts_out: bool,
    /// CTS_IN (input).
    pub cts_in: bool,
    /// DCD_IN (input).
    pub dcd_in: bool,
}

impl V24State {
    /// The five signal outputs as one value.
    pub const fn signals(&self) -> ModemSignals {
        ModemSignals {
            dtr: self.dtr_out,
            dsr: self.dsr_in,
            rts: self.rts_out,
            cts: self.cts_in,
            dcd: self.dcd_in,
        }
    }
}

/// FB4 S_VSTAT: read the RS-232C signal states (`[ET200S SI]` §2.10, Table 2-18).
///
/// A REQ edge reads them (DONE when read); the signal outputs keep the states last seen. On a
/// port that sees them without a job ([`V24Port::signals_now`], the ASCII link) they are
/// refreshed on every call; on the window only a read job sees them (`[ET200S SI 2005]`
/// §2.12.4).
#[derive(Debug, Default)]
pub struct SVstat {
    run: V24Request,
    signals: ModemSignals,
}

impl SVstat {
    /// One call (one PLC cycle).
    pub fn call<P: V24Port + ?Sized>(&mut self, port: &mut P, req: bool, r: bool) -> V24State {
        if let Some(now) = port.signals_now() {
            self.signals = now;
        }
        let outcome = self.run.call(port, req, r, || Ok(V24Job::ReadSignals));
        if let Some(Ok(Some(read))) = outcome {
            self.signals = read;
        }
        let s = self.signals;
        V24State {
            result: outcome.into(),
            dtr_out: s.dtr,
            dsr_in: s.dsr,
            rts_out: s.rts,
            cts_in: s.cts,
            dcd_in: s.dcd,
        }
    }

    /// True while a read runs.
    pub fn busy(&self) -> bool {
        self.run.busy()
    }
}

/// FB5 S_VSET: set RTS and DTR (`[ET200S SI]` §2.10, Table 2-19). The port refuses with 0502H
/// where the configured mode owns a signal (`[ET200S SI]` §2.8: no RTS/DTR under automatic
/// V.24, no RTS under RTS/CTS flow control).
#[derive(Debug, Default)]
pub struct SVset {
    run: V24Request,
}

impl SVset {
    /// One call; a REQ edge writes `rts` and `dtr`.
    pub fn call<P: V24Port + ?Sized>(
        &mut self,
        port: &mut P,
        req: bool,
        r: bool,
        rts: bool,
        dtr: bool,
    ) -> Done {
        self.run
            .call(port, req, r, || Ok(V24Job::WriteSignals { rts, dtr }))
            .into()
    }

    /// True while the write runs.
    pub fn busy(&self) -> bool {
        self.run.busy()
    }
}

/// A TIME input as a count of 10 ms; 1E20H outside the FB's range or off the 10 ms grid.
fn count(parameter: &'static str, time: Duration, min: Duration) -> Result<u16, Status> {
    ten_ms_count(parameter, time, min).map_err(|_| common::PARAMETER_OUT_OF_RANGE)
}

/// FB6 S_XON: XON/XOFF parameters, block 20H (`[ET200S SI]` §2.10, Table 2-15). Only with
/// XON/XOFF flow control; otherwise the port refuses with 0550H.
#[derive(Debug, Default)]
pub struct SXon {
    run: V24Request,
}

impl SXon {
    /// One call; a REQ edge sends XON, XOFF and WAIT_FOR_XON (20 ms … 655 350 ms in 10 ms
    /// steps, default 2 s).
    pub fn call<P: V24Port + ?Sized>(
        &mut self,
        port: &mut P,
        req: bool,
        r: bool,
        xon: u8,
        xoff: u8,
        wait_for_xon: impl Into<Duration>,
    ) -> Done {
        let wait_for_xon = wait_for_xon.into();
        self.run
            .call(port, req, r, || {
                Ok(V24Job::Parameters(ParamBlock::XonXoff {
                    xon,
                    xoff,
                    xon_wait: count("WAIT_FOR_XON", wait_for_xon, MIN_WAIT)?,
                }))
            })
            .into()
    }

    /// True while the parameter job runs.
    pub fn busy(&self) -> bool {
        self.run.busy()
    }
}

/// FB7 S_RTS: RTS/CTS parameters, block 21H (`[ET200S SI]` §2.10, Table 2-16). Only with
/// RTS/CTS flow control; otherwise the port refuses with 0550H.
#[derive(Debug, Default)]
pub struct SRts {
    run: V24Request,
}

impl SRts {
    /// One call; a REQ edge sends WAIT_FOR_CTS (20 ms … 655 350 ms in 10 ms steps, default
    /// 2 s).
    pub fn call<P: V24Port + ?Sized>(
        &mut self,
        port: &mut P,
        req: bool,
        r: bool,
        wait_for_cts: impl Into<Duration>,
    ) -> Done {
        let wait_for_cts = wait_for_cts.into();
        self.run
            .call(port, req, r, || {
                Ok(V24Job::Parameters(ParamBlock::RtsCts {
                    cts_wait: count("WAIT_FOR_CTS", wait_for_cts, MIN_WAIT)?,
                }))
            })
            .into()
    }

    /// True while the parameter job runs.
    pub fn busy(&self) -> bool {
        self.run.busy()
    }
}

/// FB8 S_V24: automatic V.24 parameters, block 22H (`[ET200S SI]` §2.10, Table 2-17). Only
/// with automatic V.24 operation; otherwise the port refuses with 0550H.
#[derive(Debug, Default)]
pub struct SV24 {
    run: V24Request,
}

impl SV24 {
    /// One call; a REQ edge sends TIME_RTS_OFF and DATA_WAIT_TIME (0 … 655 350 ms in 10 ms
    /// steps each, default 10 ms).
    pub fn call<P: V24Port + ?Sized>(
        &mut self,
        port: &mut P,
        req: bool,
        r: bool,
        time_rts_off: impl Into<Duration>,
        data_wait_time: impl Into<Duration>,
    ) -> Done {
        let (rts_off, data_wait) = (time_rts_off.into(), data_wait_time.into());
        self.run
            .call(port, req, r, || {
                Ok(V24Job::Parameters(ParamBlock::AutoV24 {
                    rts_off_delay: count("TIME_RTS_OFF", rts_off, Duration::ZERO)?,
                    cts_wait: count("DATA_WAIT_TIME", data_wait, Duration::ZERO)?,
                }))
            })
            .into()
    }

    /// True while the parameter job runs.
    pub fn busy(&self) -> bool {
        self.run.busy()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A port whose jobs run until `finish` ends them, as the window host's do.
    #[derive(Default)]
    struct Slow {
        next: u64,
        running: Option<JobId>,
        ended: Option<(JobId, Result<Option<ModemSignals>, Status>)>,
        cancelled: Vec<JobId>,
        jobs: Vec<V24Job>,
    }

    impl Slow {
        fn finish(&mut self, outcome: Result<Option<ModemSignals>, Status>) {
            let id = self.running.take().expect("a job runs");
            self.ended = Some((id, outcome));
        }
    }

    impl V24Port for Slow {
        fn start_v24(&mut self, job: V24Job) -> V24Start {
            self.next += 1;
            let id = JobId(self.next);
            self.jobs.push(job);
            self.running = Some(id);
            V24Start::Running(id)
        }
        fn v24_outcome(&mut self, id: JobId) -> Option<Result<Option<ModemSignals>, Status>> {
            match self.ended {
                Some((done, outcome)) if done == id => {
                    self.ended = None;
                    Some(outcome)
                }
                _ => None,
            }
        }
        fn cancel_v24(&mut self, id: JobId) {
            self.cancelled.push(id);
            self.running = None;
        }
    }

    #[test]
    fn done_comes_in_the_call_after_the_job_ended_and_only_once() {
        let mut port = Slow::default();
        let mut vstat = SVstat::default();
        assert_eq!(vstat.call(&mut port, true, false), V24State::default());
        assert!(vstat.busy());
        // A second edge while the read runs starts nothing.
        vstat.call(&mut port, false, false);
        vstat.call(&mut port, true, false);
        assert_eq!(port.jobs, [V24Job::ReadSignals]);
        let read = ModemSignals {
            cts: true,
            dtr: true,
            ..ModemSignals::default()
        };
        port.finish(Ok(Some(read)));
        let out = vstat.call(&mut port, true, false);
        assert!(out.result.done && !out.result.error);
        assert_eq!(out.signals(), read);
        let again = vstat.call(&mut port, true, false);
        assert_eq!(again.result, Done::default());
        assert_eq!(again.signals(), read, "the states last read stay");
    }

    #[test]
    fn r_cancels_the_running_job_with_1e0d_once() {
        let mut port = Slow::default();
        let mut vset = SVset::default();
        vset.call(&mut port, true, false, true, false);
        let out = vset.call(&mut port, true, true, true, false);
        assert_eq!(out, Done::failed(common::ABORTED_BY_RESET));
        assert_eq!(port.cancelled.len(), 1);
        assert_eq!(
            vset.call(&mut port, true, true, true, false),
            Done::default()
        );
        // After R the held REQ counts as a new edge.
        vset.call(&mut port, true, false, true, false);
        assert_eq!(port.jobs.len(), 2);
    }

    #[test]
    fn times_outside_the_range_or_grid_are_1e20_and_nothing_is_sent() {
        let mut port = Slow::default();
        let ms = Duration::from_millis;
        let bad = [
            SXon::default().call(&mut port, true, false, 0x11, 0x13, ms(10)),
            SRts::default().call(&mut port, true, false, ms(655_360)),
            SV24::default().call(&mut port, true, false, ms(5), ms(10)),
            SV24::default().call(
                &mut port,
                true,
                false,
                ms(10),
                std::time::Duration::from_secs(700),
            ),
        ];
        for out in bad {
            assert_eq!(out, Done::failed(common::PARAMETER_OUT_OF_RANGE));
        }
        assert!(port.jobs.is_empty());
        SV24::default().call(&mut port, true, false, Duration::ZERO, ms(655_350));
        assert_eq!(
            port.jobs,
            [V24Job::Parameters(ParamBlock::AutoV24 {
                rts_off_delay: 0,
                cts_wait: 65_535
            })]
        );
    }
}
