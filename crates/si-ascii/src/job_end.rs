//! Where a send job of the ASCII [`Link`] ends, recognised once for the async handle and any
//! other caller that runs jobs from the link's events ([`JobEnd`]).

use crate::link::{Event, Link, SendError};
use bytes::Bytes;
use si_core::job::{JobEnd, JobId, NotStarted};
use si_core::{Instant, Status};

/// A send job ends with [`Event::Sent`] (its last character has left) or
/// [`Event::SendFailed`] (0708H, 0818H). A busy link is [`NotStarted::Busy`]: the caller offers
/// the frame again, as S_SEND does.
impl JobEnd for Link {
    type Job = Bytes;
    type Output = ();
    type Refusal = SendError;
    type Failure = Status;

    fn begin_job(&mut self, now: Instant, frame: Bytes) -> Result<JobId, NotStarted<SendError>> {
        self.send(now, frame).map_err(|e| match e {
            SendError::Busy => NotStarted::Busy,
            e => NotStarted::Refused(e),
        })
    }

    fn job_end(event: &Event) -> Option<(JobId, Result<(), Status>)> {
        match *event {
            Event::Sent { job, .. } => Some((job, Ok(()))),
            Event::SendFailed { job, status, .. } => Some((job, Err(status))),
            Event::Received { .. } | Event::ReceiveError { .. } => None,
        }
    }
}
