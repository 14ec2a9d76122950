//! The async handle (feature `tokio`): a [`Link`] running over any
//! [`Transport`] (serial port, TCP device server, in-memory pipe) on the si-core driver.
//!
//! ```
//! # #[tokio::main(flavor = "current_thread")]
//! # async fn main() {
//! use si_3964r::tokio::Handle;
//! use si_3964r::{Config, Priority};
//! use si_core::SerialSettings;
//!
//! let (left, right) = tokio::io::duplex(1024);
//! let line = SerialSettings::default();
//! let high = Config { priority: Priority::High, ..Config::default() };
//! let a = Handle::spawn(high, line, left).unwrap();
//! let mut b = Handle::spawn(Config::default(), line, right).unwrap();
//! a.send(&b"over the pipe"[..]).await.unwrap();
//! assert_eq!(b.recv().await.unwrap(), &b"over the pipe"[..]);
//! # }
//! ```
//!
//! Sends are queued in the driver and run one after the other (one S_SEND job at a time); each
//! `send` resolves with its own job's outcome (the driver's job routing, `si_core::driver`). Received blocks stay in the link's bounded receive buffer until
//! [`Handle::recv`] asks for them, so a slow reader makes the link use the manual's
//! buffer-wait-then-NAK path instead of growing a queue.
//!
//! The driver reports "transmission done" once the block's character time has passed since the
//! write began, so the acknowledgement delay time (QVZ) runs from the block's end on the wire
//! even at low baud rates; a partner's prompt DLE that arrives before that is taken as the
//! acknowledgement, not as "too early" (0706); see the readings in [`crate::link`].

use crate::config::{Config, ConfigError};
use crate::link::{Event, Link, SendError};
use bytes::Bytes;
use si_core::driver::{self, Caller, DriverOptions, DriverStopped, Start, Transport};
use si_core::{Instant, SerialSettings, Status};
use std::ops::ControlFlow::{Break, Continue};

/// Why a call on a [`Handle`] failed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Error {
    /// The job was refused (1E41H for an empty or overlong block) or failed on the line
    /// (class 07H), or a reception failed (class 08H): the manual's STATUS.
    #[error("{0}")]
    Status(Status),
    /// The parameters are out of range.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// The driver has stopped (the port closed or failed).
    #[error(transparent)]
    Stopped(#[from] DriverStopped),
}

impl Error {
    /// The STATUS for this error, if it has one.
    pub fn status(&self) -> Option<Status> {
        match self {
            Error::Status(s) => Some(*s),
            Error::Config(_) | Error::Stopped(_) => None,
        }
    }
}

/// A running 3964(R) link: send blocks, receive blocks.
pub struct Handle {
    driver: driver::Handle<Link>,
}

/// The old name of [`Handle`].
#[deprecated(note = "renamed to si_3964r::tokio::Handle")]
pub type Link3964r = Handle;

/// The sending half of a [`Handle`]: cheap to clone, so several tasks can send while one
/// receives.
#[derive(Clone)]
pub struct Sender {
    caller: Caller<Link>,
}

impl Sender {
    /// Send `data` as one block and wait for its outcome: `Ok` when the partner acknowledged it
    /// with DLE, or the manual's STATUS (class 07H …; 1E41 for an empty or overlong block).
    pub async fn send(&self, data: impl Into<Bytes>) -> Result<(), Error> {
        let data = data.into();
        let start = move |link: &mut Link, now| match link.send(now, data.clone()) {
            Ok(job) => Start::Running(job),
            Err(SendError::Busy) => Start::Busy,
            Err(e) => Start::Ended(Err(e.status())),
        };
        let done = |job: &_, event| match event {
            Event::Sent { job: j } if j == *job => Break(Ok(())),
            Event::SendFailed { job: j, status } if j == *job => Break(Err(status)),
            other => Continue(other),
        };
        self.caller.job(start, done).await?.map_err(Error::Status)
    }
}

impl Handle {
    /// Start a link with `config` over `transport` (whose line runs at `settings`). Call it
    /// inside a tokio runtime: it spawns the driver (and panics otherwise, as `tokio::spawn`
    /// does).
    pub fn spawn<T: Transport>(
        config: Config,
        settings: SerialSettings,
        transport: T,
    ) -> Result<Handle, Error> {
        Ok(Self::spawn_engine(Link::new(config, settings)?, transport))
    }

    /// Start a link built by the caller on `transport`.
    pub fn spawn_engine<T: Transport>(link: Link, transport: T) -> Handle {
        // tx-done at the bytes' end on the wire, so QVZ starts when the block has left (a
        // 200-byte block takes 1.8 s at 1200 bit/s); a prompt partner's DLE that arrives
        // before that is still the acknowledgement (see the readings in `crate::link`).
        let options = DriverOptions {
            settings: Some(link.settings()),
            drop_unread_events: true,
            ..DriverOptions::default()
        };
        let (driver, _task) = driver::spawn(link, transport, options);
        Handle { driver }
    }

    /// Send `data` as one block; see [`Sender::send`].
    pub async fn send(&self, data: impl Into<Bytes>) -> Result<(), Error> {
        self.sender().send(data).await
    }

    /// A clonable sending half.
    pub fn sender(&self) -> Sender {
        Sender {
            caller: self.driver.caller(),
        }
    }

    /// The next block received intact; a receive error (class 08H) is returned as
    /// [`Error::Status`], a stopped link as [`Error::Stopped`].
    pub async fn recv(&mut self) -> Result<Bytes, Error> {
        match self.next().await {
            Some(Ok(block)) => Ok(block),
            Some(Err(status)) => Err(Error::Status(status)),
            None => Err(Error::Stopped(DriverStopped)),
        }
    }

    /// The next received block or receive error (class 08H), errors already reported first;
    /// `None` once the link has stopped. Blocks stay in the link's receive buffer until asked
    /// for here; receive errors beyond the driver's event capacity are dropped.
    pub async fn next(&mut self) -> Option<Result<Bytes, Status>> {
        loop {
            while let Some(event) = self.driver.try_next_event() {
                if let Event::ReceiveError(status) = event {
                    return Some(Err(status));
                }
            }
            if let Some(block) = self.driver.call(|l, now| l.take_block(now)).await.ok()? {
                return Some(Ok(block));
            }
            if let Event::ReceiveError(status) = self.driver.next_event().await? {
                return Some(Err(status));
            }
        }
    }

    /// CPU STOP → RUN ([`Link::restart`]): with [`Config::clear_at_startup`] (the default) the
    /// blocks waiting in the receive buffer are dropped, else they are delivered as before.
    pub async fn restart(&self) -> Result<(), Error> {
        Ok(self.driver.call(|l, now| l.restart(now)).await?)
    }

    /// Run `f` on the link inside the driver (counters, state).
    pub async fn call<R: Send + 'static>(
        &self,
        f: impl FnOnce(&mut Link, Instant) -> R + Send + 'static,
    ) -> Result<R, Error> {
        Ok(self.driver.call(f).await?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Priority;
    use crate::status;
    use si_core::status::common;

    fn pair() -> (Handle, Handle) {
        let (left, right) = tokio::io::duplex(4096);
        let line = SerialSettings::default();
        let high = Config {
            priority: Priority::High,
            ..Config::default()
        };
        (
            Handle::spawn(high, line, left).unwrap(),
            Handle::spawn(Config::default(), line, right).unwrap(),
        )
    }

    #[tokio::test(start_paused = true)]
    async fn blocks_flow_both_ways_in_order() {
        let (mut a, mut b) = pair();
        let sa = a.sender();
        let sb = b.sender();
        let sends = tokio::spawn(async move {
            for i in 0..5u8 {
                sa.send(vec![b'a', i]).await.unwrap();
                sb.send(vec![b'b', i, 0x10]).await.unwrap();
            }
        });
        for i in 0..5u8 {
            assert_eq!(b.recv().await.unwrap(), &[b'a', i][..]);
            assert_eq!(a.recv().await.unwrap(), &[b'b', i, 0x10][..]);
        }
        sends.await.unwrap();
    }

    #[tokio::test(start_paused = true)]
    async fn a_send_nobody_answers_fails_with_0703_and_bad_lengths_with_1e41() {
        let (left, _right) = tokio::io::duplex(4096);
        let link = Handle::spawn(Config::default(), SerialSettings::default(), left).unwrap();
        assert_eq!(
            link.send(Vec::new()).await,
            Err(Error::Status(common::INVALID_LEN))
        );
        assert_eq!(
            link.send(vec![1]).await,
            Err(Error::Status(status::SETUP_TIMEOUT))
        );
    }

    #[tokio::test(start_paused = true)]
    async fn restart_drops_waiting_blocks_only_when_clearing_is_set() {
        for clear in [true, false] {
            let (left, right) = tokio::io::duplex(4096);
            let line = SerialSettings::default();
            let high = Config {
                priority: Priority::High,
                ..Config::default()
            };
            let receiver = Config {
                clear_at_startup: clear,
                ..Config::default()
            };
            let a = Handle::spawn(high, line, left).unwrap();
            let mut b = Handle::spawn(receiver, line, right).unwrap();
            // Acknowledged with DLE: the block waits in B's receive buffer.
            a.send(&b"before"[..]).await.unwrap();
            b.restart().await.unwrap();
            a.send(&b"after"[..]).await.unwrap();
            let first = b.recv().await.unwrap();
            let expected: &[u8] = if clear { b"after" } else { b"before" };
            assert_eq!(first, expected, "clear_at_startup = {clear}");
        }
    }

    #[tokio::test(start_paused = true)]
    async fn a_closed_port_ends_the_link() {
        let (left, right) = tokio::io::duplex(4096);
        let mut link = Handle::spawn(Config::default(), SerialSettings::default(), left).unwrap();
        drop(right);
        assert_eq!(link.next().await, None);
        assert_eq!(link.send(vec![1]).await, Err(Error::Stopped(DriverStopped)));
    }
}
