//! An async handle on a [`Link`] running under the si-core tokio driver (feature `tokio`).
//!
//! ```no_run
//! # async fn demo() -> Result<(), Box<dyn std::error::Error>> {
//! use si_ascii::tokio::AsciiHandle;
//! use si_ascii::{Config, EndCriterion};
//!
//! let (ours, _theirs) = tokio::io::duplex(256);
//! let config = Config { end: EndCriterion::EndChars { first: b'\r', second: b'\n' }, ..Config::default() };
//! let mut port = AsciiHandle::spawn(config, ours)?;
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
use si_core::driver::{spawn, DriverOptions, DriverStopped, Handle, Transport};
use si_core::{Instant, ModemSignals, SignalUpdate, Status};
use std::collections::VecDeque;

/// Why an async ASCII operation failed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum AsciiError {
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
}

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
pub struct AsciiHandle {
    inner: Handle<Link>,
    /// Receive events seen while waiting for a send to finish.
    backlog: VecDeque<Event>,
}

impl AsciiHandle {
    /// Validate `config`, start a driver task over `transport`, and return the handle.
    pub fn spawn<T: Transport>(config: Config, transport: T) -> Result<Self, ConfigError> {
        let link = Link::new(config)?;
        let options = DriverOptions {
            settings: Some(config.settings),
            ..DriverOptions::default()
        };
        let (inner, _task) = spawn(link, transport, options);
        Ok(AsciiHandle {
            inner,
            backlog: VecDeque::new(),
        })
    }

    /// Send one frame and wait until it has left (or failed with 0708H / 0818H).
    pub async fn send(&mut self, frame: impl Into<Bytes>) -> Result<(), AsciiError> {
        let frame = frame.into();
        let job = self.inner.call(move |l, now| l.send(now, frame)).await??;
        loop {
            match self.inner.next_event().await.ok_or(DriverStopped)? {
                Event::Sent { job: j, .. } if j == job => return Ok(()),
                Event::SendFailed { job: j, status, .. } if j == job => {
                    return Err(AsciiError::Status(status))
                }
                other => self.backlog.push_back(other),
            }
        }
    }

    /// The next received frame or receive error.
    pub async fn next(&mut self) -> Result<Incoming, AsciiError> {
        loop {
            let event = match self.backlog.pop_front() {
                Some(e) => e,
                None => self.inner.next_event().await.ok_or(DriverStopped)?,
            };
            match event {
                Event::Received { at, .. } => {
                    if let Some(data) = self.inner.call(|l, now| l.read_frame_vec(now)).await? {
                        return Ok(Incoming::Frame { data, at });
                    }
                }
                Event::ReceiveError { status, at } => return Ok(Incoming::Error { status, at }),
                Event::Sent { .. } | Event::SendFailed { .. } => {}
            }
        }
    }

    /// The next received frame; a receive error is returned as [`AsciiError::Status`].
    pub async fn recv(&mut self) -> Result<Vec<u8>, AsciiError> {
        match self.next().await? {
            Incoming::Frame { data, .. } => Ok(data),
            Incoming::Error { status, .. } => Err(AsciiError::Status(status)),
        }
    }

    /// The V.24 signals (S_VSTAT).
    pub async fn signals(&self) -> Result<ModemSignals, AsciiError> {
        Ok(self.inner.call(|l, _| l.signals()).await?)
    }

    /// Set RTS/DTR by job (S_VSET).
    pub async fn set_signals(&self, update: SignalUpdate) -> Result<(), AsciiError> {
        Ok(self.inner.call(move |l, _| l.set_signals(update)).await??)
    }

    /// Run any command on the link inside the driver.
    pub async fn call<R: Send + 'static>(
        &self,
        f: impl FnOnce(&mut Link, Instant) -> R + Send + 'static,
    ) -> Result<R, AsciiError> {
        Ok(self.inner.call(f).await?)
    }
}
