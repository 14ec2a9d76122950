//! The async handle (feature `tokio`): a [`Link`] running over any
//! [`Transport`] (serial port, TCP device server, in-memory pipe) on the si-core driver.
//!
//! ```
//! # #[tokio::main(flavor = "current_thread")]
//! # async fn main() {
//! use si_3964r::tokio::Handle;
//! use si_3964r::{Config, Priority};
//!
//! let (left, right) = tokio::io::duplex(1024);
//! let high = Config { priority: Priority::High, ..Config::default() };
//! let a = Handle::spawn(high, left).unwrap();
//! let mut b = Handle::spawn(Config::default(), right).unwrap();
//! a.send(&b"over the pipe"[..]).await.unwrap();
//! assert_eq!(b.recv().await.unwrap(), &b"over the pipe"[..]);
//! a.close().await; // returns once the port is released
//! # }
//! ```
//!
//! On a serial port, [`Handle::open`] (feature `serial`) opens the port with the config's own
//! line settings ([`Config::settings`]) and spawns the link in one call.
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
use si_core::driver::{self, Caller, DriverOptions, DriverStopped, IoError, JobError, Transport};
use si_core::{Instant, Status};

/// Why a call on a [`Handle`] failed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Error {
    /// The link refused the job: an empty or overlong block (1E41H).
    #[error("the 3964(R) link refused the block: {0}")]
    Refused(SendError),
    /// The job failed on the line (class 07H), or a reception failed (class 08H): the
    /// manual's STATUS.
    #[error("{status}")]
    Failed {
        /// The STATUS.
        status: Status,
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
    /// The STATUS for this error, if it has one: a failed job's or reception's, or the one an
    /// FB would show for a refused job.
    pub fn status(&self) -> Option<Status> {
        match self {
            Error::Refused(e) => Some(e.status()),
            Error::Failed { status } => Some(*status),
            Error::Config(_) | Error::Stopped | Error::Io(_) => None,
        }
    }
}

impl From<JobError<SendError, Status>> for Error {
    fn from(e: JobError<SendError, Status>) -> Self {
        match e {
            JobError::Refused(e) => Error::Refused(e),
            JobError::Failed(status) => Error::Failed { status },
            JobError::Stopped => Error::Stopped,
        }
    }
}

/// A running 3964(R) link: send blocks, receive blocks. Dropping it stops the driver, which
/// then releases the port; [`close`](Self::close) waits for that.
pub struct Handle {
    driver: driver::Handle<Link>,
}

impl Drop for Handle {
    fn drop(&mut self) {
        self.driver.stop();
    }
}

/// The sending half of a [`Handle`]: cheap to clone, so several tasks can send while one
/// receives. Its sends end with [`Error::Stopped`] once the handle is dropped or closed.
#[derive(Clone)]
pub struct Sender {
    caller: Caller<Link>,
}

impl Sender {
    /// Send `data` as one block and wait for its outcome: `Ok` when the partner acknowledged it
    /// with DLE, else the manual's STATUS (class 07H …) or the refusal (1E41H for an empty or
    /// overlong block).
    pub async fn send(&self, data: impl Into<Bytes>) -> Result<(), Error> {
        Ok(self.caller.run_job(data.into()).await?)
    }
}

impl Handle {
    /// Start a link with `config` over `transport`, whose line runs at `config.settings`. Call
    /// it inside a tokio runtime: it spawns the driver (and panics otherwise, as
    /// `tokio::spawn` does).
    pub fn spawn<T: Transport>(config: Config, transport: T) -> Result<Handle, Error> {
        Ok(Self::spawn_engine(Link::new(config)?, transport))
    }

    /// Open the serial port at `path` with the config's line settings and start a link on it
    /// (feature `serial`). A port another handle or program holds is reported as
    /// [`Error::Io`] with kind `ResourceBusy`.
    #[cfg(feature = "serial")]
    #[cfg_attr(docsrs, doc(cfg(feature = "serial")))]
    pub fn open(config: Config, path: &str) -> Result<Handle, Error> {
        let link = Link::new(config)?;
        let options = si_core::port::PortOptions::default();
        let port = si_core::port::open(path, &config.settings, &options).map_err(IoError::from)?;
        Ok(Self::spawn_engine(link, port))
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

    /// The next block received intact, receive errors already reported first: a receive
    /// error (class 08H) is returned as [`Error::Failed`], a stopped link as
    /// [`Error::Stopped`]. Blocks stay in the link's receive buffer until asked for here;
    /// receive errors beyond the driver's event capacity are dropped.
    pub async fn recv(&mut self) -> Result<Bytes, Error> {
        loop {
            while let Some(event) = self.driver.try_next_event() {
                if let Event::ReceiveError(status) = event {
                    return Err(Error::Failed { status });
                }
            }
            if let Some(block) = self.driver.call(|l, now| l.take_block(now)).await? {
                return Ok(block);
            }
            match self.driver.next_event().await {
                Some(Event::ReceiveError(status)) => return Err(Error::Failed { status }),
                Some(_) => {}
                None => return Err(Error::Stopped),
            }
        }
    }

    /// The next event no job took ([`Event::Received`] announcing a block that
    /// [`recv`](Self::recv) takes, [`Event::ReceiveError`]); `None` once the link has stopped.
    /// A program reads blocks with `recv` or events here, not both.
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
        let high = Config {
            priority: Priority::High,
            ..Config::default()
        };
        (
            Handle::spawn(high, left).unwrap(),
            Handle::spawn(Config::default(), right).unwrap(),
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
        let link = Handle::spawn(Config::default(), left).unwrap();
        let refused = link.send(Vec::new()).await.unwrap_err();
        assert_eq!(refused, Error::Refused(SendError::Empty));
        assert_eq!(refused.status(), Some(common::INVALID_LEN));
        assert_eq!(
            link.send(vec![1]).await,
            Err(Error::Failed {
                status: status::SETUP_TIMEOUT
            })
        );
    }

    #[tokio::test(start_paused = true)]
    async fn restart_drops_waiting_blocks_only_when_clearing_is_set() {
        for clear in [true, false] {
            let (left, right) = tokio::io::duplex(4096);
            let high = Config {
                priority: Priority::High,
                ..Config::default()
            };
            let receiver = Config {
                clear_at_startup: clear,
                ..Config::default()
            };
            let a = Handle::spawn(high, left).unwrap();
            let mut b = Handle::spawn(receiver, right).unwrap();
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
        let mut link = Handle::spawn(Config::default(), left).unwrap();
        drop(right);
        assert_eq!(link.next_event().await, None);
        assert_eq!(link.recv().await, Err(Error::Stopped));
        assert_eq!(link.send(vec![1]).await, Err(Error::Stopped));
        link.closed().await;
    }

    #[tokio::test(start_paused = true)]
    async fn close_returns_once_the_transport_is_dropped_and_ends_waiting_sends() {
        let (left, mut right) = tokio::io::duplex(4096);
        let link = Handle::spawn(Config::default(), left).unwrap();
        let sender = link.sender();
        link.close().await;
        // The driver dropped its end of the pipe: the partner reads to its end at once.
        let mut rest = Vec::new();
        tokio::io::AsyncReadExt::read_to_end(&mut right, &mut rest)
            .await
            .unwrap();
        assert_eq!(sender.send(vec![1]).await, Err(Error::Stopped));
    }

    #[tokio::test(start_paused = true)]
    async fn dropping_the_handle_releases_the_transport() {
        let (left, mut right) = tokio::io::duplex(4096);
        let link = Handle::spawn(Config::default(), left).unwrap();
        drop(link);
        // Ends only once the driver has dropped its end of the pipe (the clock is paused, so
        // the minute passes at once if it never does).
        let mut rest = Vec::new();
        let eof = tokio::io::AsyncReadExt::read_to_end(&mut right, &mut rest);
        tokio::time::timeout(std::time::Duration::from_secs(60), eof)
            .await
            .expect("the port is still held after the handle was dropped")
            .unwrap();
    }
}
