//! An async handle on a [`Link`] running under the si-core tokio driver (feature `tokio`).
//!
//! ```no_run
//! # async fn demo() -> Result<(), Box<dyn std::error::Error>> {
//! use si_ascii::tokio::Handle;
//! use si_ascii::{Config, EndCriterion};
//!
//! let (ours, _theirs) = tokio::io::duplex(256);
//! let config = Config { end: EndCriterion::EndChars { first: b'\r', second: b'\n' }, ..Config::default() };
//! let mut port = Handle::spawn(config, ours)?; // or Handle::open(config, "/dev/ttyUSB0")?
//! port.send(&b"hello\r\n"[..]).await?;
//! let line = port.recv().await?;
//! port.close().await; // returns once the port is released
//! # Ok(()) }
//! ```

//! Timing: the driver reports a write's tx-done after the characters' time on the line, and its
//! timers have about 1 ms granularity (see `si_core::driver`). Under flow control the link hands
//! out [`Config::tx_chunk`] characters per tx-done, so a real UART sees a gap of about that
//! latency between chunks; a pseudo-terminal, which does not pace characters at the baud rate,
//! shows a whole chunk time instead.

use crate::config::{Config, ConfigError};
use crate::link::{Event, Link, Refused, SendError};
use bytes::Bytes;
use si_core::driver::{self, DriverOptions, DriverStopped, IoError, JobError, Transport};
use si_core::{Instant, ModemSignals, SignalUpdate, Status};

/// Why the link refused a job: a frame it cannot send, or a signal or parameter job the
/// configuration does not allow.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Refusal {
    /// The frame was refused (1E41H empty, 050EH too long, 0502H a flow-control character).
    #[error(transparent)]
    Send(#[from] SendError),
    /// A signal or parameter job was refused.
    #[error(transparent)]
    Job(#[from] Refused),
}

impl Refusal {
    /// The STATUS an FB shows for it.
    pub fn status(&self) -> Status {
        match self {
            Refusal::Send(e) => e.status(),
            Refusal::Job(e) => e.status,
        }
    }
}

/// Why a call on a [`Handle`] failed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Error {
    /// The link refused the job.
    #[error("the ASCII link refused the job: {0}")]
    Refused(Refusal),
    /// A send failed (0708H, 0818H) or a reception failed (08xxH): the manual's STATUS.
    #[error("{status}")]
    Failed {
        /// The STATUS.
        status: Status,
    },
    /// The parameters are out of range.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// The driver stopped (the port closed or failed, or the handle was closed).
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
    /// The STATUS for this error, if it has one.
    pub fn status(&self) -> Option<Status> {
        match self {
            Error::Refused(e) => Some(e.status()),
            Error::Failed { status } => Some(*status),
            Error::Config(e) => Some(e.status()),
            Error::Stopped | Error::Io(_) => None,
        }
    }
}

impl From<JobError<SendError, Status>> for Error {
    fn from(e: JobError<SendError, Status>) -> Self {
        match e {
            JobError::Refused(e) => Error::Refused(Refusal::Send(e)),
            JobError::Failed(status) => Error::Failed { status },
            JobError::Stopped => Error::Stopped,
        }
    }
}

/// A frame or a receive error, in arrival order, with the time the link saw it
/// ([`Handle::recv_timed`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Incoming {
    /// A received frame and when it was cut (driver time).
    Frame {
        /// The bytes.
        data: Bytes,
        /// When the end criterion was met.
        at: Instant,
    },
    /// A receive error (0806H, 0810H, …).
    Error {
        /// What went wrong.
        status: Status,
        /// When.
        at: Instant,
    },
}

/// The application's side of a running ASCII link. Dropping it stops the driver, which then
/// releases the port; [`close`](Self::close) waits for that.
pub struct Handle {
    driver: driver::Handle<Link>,
}

impl Drop for Handle {
    fn drop(&mut self) {
        self.driver.stop();
    }
}

impl Handle {
    /// Validate `config`, start a driver task over `transport` (whose line runs at
    /// `config.settings`), and return the handle. Call it inside a tokio runtime.
    pub fn spawn<T: Transport>(config: Config, transport: T) -> Result<Self, Error> {
        Ok(Self::spawn_engine(Link::new(config)?, transport))
    }

    /// Open the serial port at `path` with the config's line settings and start a link on it
    /// (feature `serial`). A port another handle or program holds is reported as
    /// [`Error::Io`] with kind `ResourceBusy`.
    #[cfg(feature = "serial")]
    #[cfg_attr(docsrs, doc(cfg(feature = "serial")))]
    pub fn open(config: Config, path: &str) -> Result<Self, Error> {
        let settings = config.settings;
        let link = Link::new(config)?;
        let options = si_core::port::PortOptions::default();
        let port = si_core::port::open(path, &settings, &options).map_err(IoError::from)?;
        Ok(Self::spawn_engine(link, port))
    }

    /// Start a link built by the caller on `transport`.
    pub fn spawn_engine<T: Transport>(link: Link, transport: T) -> Self {
        let options = DriverOptions {
            settings: Some(link.config().settings),
            // Frames are announced only by their events (with the time they were cut): keep
            // every event, pausing the line when the application does not read.
            ..DriverOptions::default()
        };
        let (driver, _task) = driver::spawn(link, transport, options);
        Handle { driver }
    }

    /// Send one frame and wait until it has left (or failed with 0708H / 0818H). Sends from
    /// several callers queue in the driver.
    pub async fn send(&self, frame: impl Into<Bytes>) -> Result<(), Error> {
        Ok(self.driver.run_job(frame.into()).await?)
    }

    /// The next received frame or receive error, with the time the link saw it.
    pub async fn recv_timed(&mut self) -> Result<Incoming, Error> {
        loop {
            let event = self.driver.next_event().await.ok_or(DriverStopped)?;
            match event {
                Event::Received { at, .. } => {
                    if let Some(data) = self.driver.call(|l, now| l.read_frame_bytes(now)).await? {
                        return Ok(Incoming::Frame { data, at });
                    }
                }
                Event::ReceiveError { status, at } => return Ok(Incoming::Error { status, at }),
                Event::Sent { .. } | Event::SendFailed { .. } => {}
            }
        }
    }

    /// The next received frame; a receive error is returned as [`Error::Failed`], a stopped
    /// link as [`Error::Stopped`].
    pub async fn recv(&mut self) -> Result<Bytes, Error> {
        match self.recv_timed().await? {
            Incoming::Frame { data, .. } => Ok(data),
            Incoming::Error { status, .. } => Err(Error::Failed { status }),
        }
    }

    /// The next event no job took ([`Event::Received`] announcing a frame that stays in the
    /// link's buffer, [`Event::ReceiveError`]); `None` once the link has stopped. A program
    /// reads frames with [`recv`](Self::recv) or events here, not both.
    pub async fn next_event(&mut self) -> Option<Event> {
        self.driver.next_event().await
    }

    /// Wait until the link has stopped (the port closed or failed) and released its port.
    pub async fn closed(&self) {
        self.driver.closed().await
    }

    /// Stop the link and return once its port is released, so it may be opened again at once.
    /// Sends still waiting end with [`Error::Stopped`].
    pub async fn close(self) {
        self.driver.close().await
    }

    /// The V.24 signals (S_VSTAT).
    pub async fn signals(&self) -> Result<ModemSignals, Error> {
        Ok(self.driver.call(|l, _| l.signals()).await?)
    }

    /// Set RTS/DTR by job (S_VSET).
    pub async fn set_signals(&self, update: SignalUpdate) -> Result<(), Error> {
        self.driver
            .call(move |l, _| l.set_signals(update))
            .await?
            .map_err(|e| Error::Refused(Refusal::Job(e)))
    }

    /// CPU STOP → RUN ([`Link::restart`]): with [`Config::clear_at_startup`] (the default) the
    /// frames waiting in the receive buffer are dropped, else they are delivered as before.
    pub async fn restart(&self) -> Result<(), Error> {
        Ok(self.driver.call(|l, now| l.restart(now)).await?)
    }

    /// Run any command on the link inside the driver.
    pub async fn call<R: Send + 'static>(
        &self,
        f: impl FnOnce(&mut Link, Instant) -> R + Send + 'static,
    ) -> Result<R, Error> {
        Ok(self.driver.call(f).await?)
    }
}
