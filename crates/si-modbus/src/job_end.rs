//! Where a job of the RTU [`Master`] ends, recognised once for the async handle ([`JobEnd`]).

use crate::master::{CheckedRequest, Completion, Master, MasterEvent, RequestError};
use si_core::job::{JobEnd, JobId, NotStarted};
use si_core::{Instant, Status};

/// A job ends with [`MasterEvent::Completed`] or [`MasterEvent::Failed`], both naming the job.
/// While another job runs the master is [`NotStarted::Busy`] (one job at a time,
/// [Modbus/USS] §3.4.2): the caller offers the job again.
impl JobEnd for Master {
    type Job = CheckedRequest;
    type Output = Completion;
    type Refusal = RequestError;
    type Failure = Status;

    fn begin_job(
        &mut self,
        now: Instant,
        job: CheckedRequest,
    ) -> Result<JobId, NotStarted<RequestError>> {
        self.request_checked(now, job).map_err(|e| match e {
            RequestError::Busy => NotStarted::Busy,
            e => NotStarted::Refused(e),
        })
    }

    fn job_end(event: &MasterEvent) -> Option<(JobId, Result<Completion, Status>)> {
        match *event {
            MasterEvent::Completed(c) => Some((c.job(), Ok(c))),
            MasterEvent::Failed { job, status, .. } => Some((job, Err(status))),
            MasterEvent::Diagnostic(_) => None,
        }
    }
}
