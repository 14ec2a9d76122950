//! The USS master over tokio (feature `tokio`): [`Handle`] runs a [`Master`] on any
//! [`Transport`] with the si-core driver and offers `async` parameter jobs
//! ([`Handle::read_parameter`], [`Handle::write_parameter`], [`Handle::parameter`]), routed to
//! their callers by the driver (`si_core::driver`, "Job routing").
//!
//! Timing caveat (si-core `driver` docs): tokio timers are about 1 ms coarse, fine for the 20 ms
//! response timeout; the start interval at high baud rates is kept by the converter's UART, not
//! by us.

use crate::config::{ConfigError, MasterConfig};
use crate::frame::Pkw;
use crate::job_end::{ParamJob, PkwFailure};
use crate::master::{Event, Master, ParamRequest, RequestError, Width};
use si_core::driver::{self, DriverOptions, DriverStopped, IoError, JobError, Transport};
use si_core::{Instant, Status};

/// Why a call on a [`Handle`] failed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Error {
    /// The master refused the command (the error names the node and, where it is at fault,
    /// the task or parameter number).
    #[error(transparent)]
    Refused(#[from] RequestError),
    /// The parameter job for parameter `number` of node `address` ran and failed with this
    /// STATUS (and AK 7 error number).
    #[error("node {address}, parameter {number}: {status}{}", .error_number.map(|n| format!(", error number {n}: {}", crate::frame::pkw_error_text(n))).unwrap_or_default())]
    Failed {
        /// The job's STATUS.
        status: Status,
        /// The AK 7 error number.
        error_number: Option<u16>,
        /// The node (USS address).
        address: u8,
        /// The parameter number (PNU).
        number: u16,
    },
    /// The parameters are out of range.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// The driver has stopped (the port closed or failed, or the handle was closed).
    #[error("the driver has stopped: the port was closed or failed")]
    Stopped,
    /// The port could not be opened ([`Handle::open`]).
    #[error("{0}")]
    Io(#[from] IoError),
}

impl From<DriverStopped> for Error {
    fn from(_: DriverStopped) -> Self {
        Error::Stopped
    }
}

impl Error {
    /// The STATUS for this error, if it has one: a failed job's, or a refused command's
    /// ([`RequestError::status`]). A stopped driver, a configuration error and a port that
    /// did not open have none.
    pub fn status(&self) -> Option<Status> {
        match self {
            Error::Failed { status, .. } => Some(*status),
            Error::Refused(e) => Some(e.status()),
            Error::Config(_) | Error::Stopped | Error::Io(_) => None,
        }
    }

    fn from_job(e: JobError<RequestError, PkwFailure>, job: ParamJob) -> Self {
        match e {
            JobError::Refused(e) => Error::Refused(e),
            JobError::Failed(PkwFailure {
                status,
                error_number,
            }) => Error::Failed {
                status,
                error_number,
                address: job.address,
                number: job.request.param.number,
            },
            JobError::Stopped => Error::Stopped,
        }
    }
}

/// An async USS master: polls cyclically in the background; parameter jobs are awaited.
/// Dropping it stops the driver, which then releases the port; [`close`](Self::close) waits
/// for that.
pub struct Handle {
    driver: driver::Handle<Master>,
}

impl Drop for Handle {
    fn drop(&mut self) {
        self.driver.stop();
    }
}

impl Handle {
    /// Start a master with `config` over `transport` (whose line runs at `config.settings`)
    /// and begin polling. Call it inside a tokio runtime.
    pub fn spawn<T: Transport>(config: MasterConfig, transport: T) -> Result<Handle, Error> {
        Ok(Self::spawn_engine(Master::new(config)?, transport))
    }

    /// Open the serial port at `path` with the config's line settings, start a master on it
    /// and begin polling (feature `serial`). A port another handle or program holds is
    /// reported as [`Error::Io`] with kind `ResourceBusy`.
    #[cfg(feature = "serial")]
    #[cfg_attr(docsrs, doc(cfg(feature = "serial")))]
    pub fn open(config: MasterConfig, path: &str) -> Result<Handle, Error> {
        let settings = config.settings;
        let master = Master::new(config)?;
        let options = si_core::port::PortOptions::default();
        let port = si_core::port::open(path, &settings, &options).map_err(IoError::from)?;
        Ok(Self::spawn_engine(master, port))
    }

    /// Start a master built by the caller on `transport` and begin polling. The driver reports
    /// tx-done after the telegram's character time at the master's line settings.
    pub fn spawn_engine<T: Transport>(master: Master, transport: T) -> Handle {
        let options = DriverOptions {
            settings: Some(master.config().settings),
            // The polling cycle reports every response: a program that only runs parameter
            // jobs must not stall the bus by not reading them.
            drop_unread_events: true,
            ..DriverOptions::default()
        };
        let (driver, _task) = driver::spawn(master, transport, options);
        // Queued before any other command, so the first job sees a started master.
        let _ = driver.send(|m, now| m.start(now));
        Handle { driver }
    }

    /// Set the PZD words sent to `address` (PZD1 = STW, PZD2 = HSW, …).
    pub async fn set_control(&self, address: u8, words: Vec<u16>) -> Result<(), Error> {
        self.driver
            .call(move |m, _| m.set_control(address, &words))
            .await??;
        Ok(())
    }

    /// Run one parameter job as the only one on the line: a master polling `config`'s nodes
    /// is started on `transport` with the job for node `address` already entered, and stops in
    /// the step that ends it ([`Master::stop_when_idle`]), so every telegram carries the job
    /// and none comes before or after it.
    pub async fn only_job<T: Transport>(
        config: MasterConfig,
        transport: T,
        address: u8,
        request: ParamRequest,
    ) -> Result<Pkw, Error> {
        let mut master = Master::new(config)?;
        let job = master.request_parameter(Instant::ZERO, address, request)?;
        master.stop_when_idle();
        let mut m = Handle::spawn_engine(master, transport);
        while let Some(event) = m.next_event().await {
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
                    return Err(Error::Failed {
                        status,
                        error_number,
                        address,
                        number: request.param.number,
                    })
                }
                _ => {}
            }
        }
        Err(Error::Stopped)
    }

    /// Run a parameter job to its end and return the response's PKW area. Jobs for a node whose
    /// previous job still runs wait in the driver; other events stay for
    /// [`next_event`](Self::next_event).
    pub async fn parameter(&self, address: u8, request: ParamRequest) -> Result<Pkw, Error> {
        let job = ParamJob { address, request };
        self.driver
            .run_job(job)
            .await
            .map_err(|e| Error::from_job(e, job))
    }

    /// Read parameter `number` (sub-index `index`) of node `address` (AK 1): its value.
    pub async fn read_parameter(&self, address: u8, number: u16, index: u8) -> Result<u32, Error> {
        let response = self
            .parameter(address, ParamRequest::read(number, index))
            .await?;
        Ok(response.value())
    }

    /// Write `value` to parameter `number` (sub-index `index`) of node `address` as a word
    /// (AK 2) or a double word (AK 3), as `width` says: the value the drive reports back.
    pub async fn write_parameter(
        &self,
        address: u8,
        number: u16,
        index: u8,
        value: u32,
        width: Width,
    ) -> Result<u32, Error> {
        let request = ParamRequest::write(number, index, value, width);
        Ok(self.parameter(address, request).await?.value())
    }

    /// The next event of the polling cycle that no job took; `None` once the driver has
    /// stopped. Beyond the driver's event capacity, unread events are dropped.
    pub async fn next_event(&mut self) -> Option<Event> {
        self.driver.next_event().await
    }

    /// Wait until the master has stopped (the port closed or failed) and released its port.
    pub async fn closed(&self) {
        self.driver.closed().await
    }

    /// Stop the master and return once its port is released, so it may be opened again at
    /// once. Jobs still waiting end with [`Error::Stopped`].
    pub async fn close(self) {
        self.driver.close().await
    }

    /// Run `f` on the master inside the driver (counters, slave state, special telegrams).
    pub async fn call<R: Send + 'static>(
        &self,
        f: impl FnOnce(&mut Master, Instant) -> R + Send + 'static,
    ) -> Result<R, Error> {
        Ok(self.driver.call(f).await?)
    }
}
