//! Where a parameter (PKW) job of the USS [`Master`] ends, recognised once for the async handle
//! ([`JobEnd`]).

use crate::frame::Pkw;
use crate::master::{Event, Master, ParamRequest, RequestError};
use si_core::job::{JobEnd, JobId, NotStarted};
use si_core::{Instant, Status};

/// One parameter job: the node's address and the request.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ParamJob {
    /// The node (USS address 0 … 31).
    pub address: u8,
    /// What to read or write.
    pub request: ParamRequest,
}

/// How a parameter job failed: its STATUS and, for a rejection by the drive (response ID 7),
/// the error number from PWE.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PkwFailure {
    /// The job's STATUS.
    pub status: Status,
    /// The AK 7 error number.
    pub error_number: Option<u16>,
}

/// A parameter job ends with [`Event::ParameterDone`] (the response's PKW area) or
/// [`Event::ParameterFailed`]. A node whose previous job still runs is [`NotStarted::Busy`]
/// (one PKW job per slave): the caller offers the job again.
impl JobEnd for Master {
    type Job = ParamJob;
    type Output = Pkw;
    type Refusal = RequestError;
    type Failure = PkwFailure;

    fn begin_job(
        &mut self,
        now: Instant,
        job: ParamJob,
    ) -> Result<JobId, NotStarted<RequestError>> {
        self.request_parameter(now, job.address, job.request)
            .map_err(|e| match e {
                RequestError::Busy(_) => NotStarted::Busy,
                e => NotStarted::Refused(e),
            })
    }

    fn job_end(event: &Event) -> Option<(JobId, Result<Pkw, PkwFailure>)> {
        match *event {
            Event::ParameterDone { job, response, .. } => Some((job, Ok(response))),
            Event::ParameterFailed {
                job,
                status,
                error_number,
                ..
            } => Some((
                job,
                Err(PkwFailure {
                    status,
                    error_number,
                }),
            )),
            _ => None,
        }
    }
}
