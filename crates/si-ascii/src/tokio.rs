//! An async handle on a [`Link`] running under the si-core tokio driver (feature `tokio`).
//!
//! ```no_run
//! # async fn demo() -> Result<(), Box<dyn std::error::Error>> {
//! use si_ascii::tokio::Handle;
//! use si_ascii::{Config, EndCriterion};
//!
//! let (ours, _theirs) = tokio::io::duplex(256);
//! let config = Config { end: EndCriterion::EndChars { first: b'\r', second: b'\n' }, ..Config::default() };
//! let mut port = Handle::spawn(config, ours)?;
//! port.send(&b"hello\r\n"[..]).await?;
//! let line = port.recv().await?;
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
use si_core::driver::{self, DriverOptions, DriverStopped, Start, Transport};
use si_core::{Instant, ModemSignals, SignalUpdate, Status};
use std::ops::ControlFlow::{Break, Continue};

/// Why a call on a [`Handle`] failed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Error {
    /// The link refused the frame.
    #[error(transparent)]
    Send(#[from] SendError),
    /// The protocol reported a STATUS (send failed, or a receive error).
    #[error("{0}")]
    Status(Status),
    /// A signal or parameter job was refused.
    #[error(transparent)]
    Refused(#[from] Refused),
    /// The driver stopped (port closed or failed).
    #[error(transparent)]
    Stopped(#[from] DriverStopped),
    /// The parameters are out of range.
    #[error(transparent)]
    Config(#[from] ConfigError),
}

impl Error {
    /// The STATUS for this error, if it has one.
    pub fn status(&self) -> Option<Status> {
        match self {
            Error::Send(e) => Some(e.status()),
            Error::Status(s) => Some(*s),
            Error::Refused(e) => Some(e.status),
            Error::Config(e) => Some(e.status()),
            Error::Stopped(_) => None,
        }
    }
}

/// The old name of [`Error`].
#[deprecated(note = "renamed to si_ascii::tokio::Error")]
pub type AsciiError = Error;

/// The old name of [`Handle`].
#[deprecated(note = "renamed to si_ascii::tokio::Handle")]
pub type AsciiHandle = Handle;

/// A frame or a receive error, in arrival order.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Incoming {
    /// A received frame and when it was cut (driver time).
    Frame {
        /// The bytes.
        data: Vec<u8>,
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

/// The application's side of a running ASCII link.
pub struct Handle {
    driver: driver::Handle<Link>,
}

impl Handle {
    /// Validate `config`, start a driver task over `transport`, and return the handle.
    pub fn spawn<T: Transport>(config: Config, transport: T) -> Result<Self, Error> {
        Ok(Self::spawn_engine(Link::new(config)?, transport))
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
        let frame = frame.into();
        let start = move |l: &mut Link, now| match l.send(now, frame.clone()) {
            Ok(job) => Start::Running(job),
            Err(SendError::Busy) => Start::Busy,
            Err(e) => Start::Ended(Err(Error::Send(e))),
        };
        let done = |job: &_, event| match event {
            Event::Sent { job: j, .. } if j == *job => Break(Ok(())),
            Event::SendFailed { job: j, status, .. } if j == *job => {
                Break(Err(Error::Status(status)))
            }
            other => Continue(other),
        };
        self.driver.job(start, done).await?
    }

    /// The next received frame or receive error.
    pub async fn next(&mut self) -> Result<Incoming, Error> {
        loop {
            let event = self.driver.next_event().await.ok_or(DriverStopped)?;
            match event {
                Event::Received { at, .. } => {
                    if let Some(data) = self.driver.call(|l, now| l.read_frame_vec(now)).await? {
                        return Ok(Incoming::Frame { data, at });
                    }
                }
                Event::ReceiveError { status, at } => return Ok(Incoming::Error { status, at }),
                Event::Sent { .. } | Event::SendFailed { .. } => {}
            }
        }
    }

    /// The next received frame; a receive error is returned as [`Error::Status`].
    pub async fn recv(&mut self) -> Result<Vec<u8>, Error> {
        match self.next().await? {
            Incoming::Frame { data, .. } => Ok(data),
            Incoming::Error { status, .. } => Err(Error::Status(status)),
        }
    }

    /// The V.24 signals (S_VSTAT).
    pub async fn signals(&self) -> Result<ModemSignals, Error> {
        Ok(self.driver.call(|l, _| l.signals()).await?)
    }

    /// Set RTS/DTR by job (S_VSET).
    pub async fn set_signals(&self, update: SignalUpdate) -> Result<(), Error> {
        Ok(self
            .driver
            .call(move |l, _| l.set_signals(update))
            .await??)
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
