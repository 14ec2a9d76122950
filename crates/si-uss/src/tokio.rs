//! The USS master over tokio (feature `tokio`): [`UssMaster`] runs a [`Master`] on any
//! [`Transport`] with the si-core driver and offers `async` parameter jobs.
//!
//! Timing caveat (si-core `driver` docs): tokio timers are about 1 ms coarse, fine for the 20 ms
//! response timeout; the start interval at high baud rates is kept by the converter's UART, not
//! by us.

use crate::frame::Pkw;
use crate::master::{Event, JobId, Master, ParamRequest, RequestError};
use si_core::driver::{spawn, DriverOptions, DriverStopped, Handle, Transport};
use si_core::Status;
use std::collections::VecDeque;
use tokio::task::JoinHandle;

/// Why an async call failed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum UssError {
    /// The master refused the command.
    #[error(transparent)]
    Refused(#[from] RequestError),
    /// The job ran and failed with this STATUS (and AK 7 error number).
    #[error("{status}{}", .error_number.map(|n| format!(", error number {n}: {}", crate::frame::pkw_error_text(n))).unwrap_or_default())]
    Failed {
        /// The job's STATUS.
        status: Status,
        /// The AK 7 error number.
        error_number: Option<u16>,
    },
    /// The driver has stopped (port closed).
    #[error(transparent)]
    Stopped(#[from] DriverStopped),
}

/// An async USS master: polls cyclically in the background; parameter jobs are awaited.
pub struct UssMaster {
    handle: Handle<Master>,
    backlog: VecDeque<Event>,
}

impl UssMaster {
    /// Start a driver task for `master` over `transport` and begin polling.
    pub async fn spawn<T: Transport>(
        master: Master,
        transport: T,
        options: DriverOptions,
    ) -> Result<(Self, JoinHandle<std::io::Result<()>>), DriverStopped> {
        let (handle, task) = spawn(master, transport, options);
        handle.call(|m, now| m.start(now)).await?;
        Ok((
            UssMaster {
                handle,
                backlog: VecDeque::new(),
            },
            task,
        ))
    }

    /// Set the PZD words sent to `address` (PZD1 = STW, PZD2 = HSW, …).
    pub async fn set_control(&self, address: u8, words: Vec<u16>) -> Result<(), UssError> {
        self.handle
            .call(move |m, _| m.set_control(address, &words))
            .await??;
        Ok(())
    }

    /// Run a parameter job to its end; other events meanwhile stay for [`next_event`](Self::next_event).
    pub async fn parameter(&mut self, address: u8, request: ParamRequest) -> Result<Pkw, UssError> {
        let job: JobId = self
            .handle
            .call(move |m, now| m.request_parameter(now, address, request))
            .await??;
        loop {
            let event = self.handle.next_event().await.ok_or(DriverStopped)?;
            match event {
                Event::ParameterDone {
                    job: j, response, ..
                } if j == job => return Ok(response),
                Event::ParameterFailed {
                    job: j,
                    status,
                    error_number,
                    ..
                } if j == job => {
                    return Err(UssError::Failed {
                        status,
                        error_number,
                    })
                }
                other => self.backlog.push_back(other),
            }
        }
    }

    /// The next event of the polling cycle; `None` once the driver has stopped.
    pub async fn next_event(&mut self) -> Option<Event> {
        match self.backlog.pop_front() {
            Some(e) => Some(e),
            None => self.handle.next_event().await,
        }
    }

    /// Run `f` on the master inside the driver (counters, slave state, special telegrams).
    pub async fn call<R: Send + 'static>(
        &self,
        f: impl FnOnce(&mut Master, si_core::Instant) -> R + Send + 'static,
    ) -> Result<R, DriverStopped> {
        self.handle.call(f).await
    }
}
