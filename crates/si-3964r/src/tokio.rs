//! The async handle (feature `tokio`): a [`Link`] running over any
//! [`Transport`] (serial port, TCP device server, in-memory pipe) on the si-core driver.
//!
//! ```
//! # #[tokio::main(flavor = "current_thread")]
//! # async fn main() {
//! use si_3964r::tokio::Link3964r;
//! use si_3964r::{Config, Priority};
//! use si_core::SerialSettings;
//!
//! let (left, right) = tokio::io::duplex(1024);
//! let line = SerialSettings::default();
//! let high = Config { priority: Priority::High, ..Config::default() };
//! let a = Link3964r::spawn(high, line, left).unwrap();
//! let mut b = Link3964r::spawn(Config::default(), line, right).unwrap();
//! a.send(&b"over the pipe"[..]).await.unwrap();
//! assert_eq!(b.recv().await.unwrap(), &b"over the pipe"[..]);
//! # }
//! ```
//!
//! Sends are queued and run one after the other (one S_SEND job at a time); each `send` resolves
//! with its own job's outcome. Received blocks stay in the link's bounded receive buffer until
//! [`Link3964r::recv`] asks for them, so a slow reader makes the link use the manual's
//! buffer-wait-then-NAK path instead of growing a queue.
//!
//! The driver reports "transmission done" when the write completes (no character-time
//! estimate), so a partner's prompt DLE is never mistaken for one that came too early (0706);
//! see the readings in [`crate::link`].

use crate::config::{Config, ConfigError};
use crate::link::{Event, JobId, Link};
use bytes::Bytes;
use si_core::driver::{spawn, DriverOptions, Handle, Transport};
use si_core::status::common;
use si_core::{SerialSettings, Status};
use std::collections::VecDeque;
use tokio::sync::{mpsc, oneshot};

/// Receive errors kept for the application before the oldest is dropped.
const ERROR_BACKLOG: usize = 64;

type Reply = oneshot::Sender<Result<(), Status>>;

/// A running 3964(R) link: send blocks, receive blocks.
pub struct Link3964r {
    sender: Sender,
    received: mpsc::Receiver<Result<Bytes, Status>>,
}

/// The sending half of a [`Link3964r`]: cheap to clone, so several tasks can send while one
/// receives.
#[derive(Clone)]
pub struct Sender {
    requests: mpsc::Sender<(Bytes, Reply)>,
}

impl Sender {
    /// Send `data` as one block and wait for its outcome: `Ok` when the partner acknowledged it
    /// with DLE, or the manual's STATUS (class 07H …; 1E41 for an empty or overlong block;
    /// 0502 when the link has stopped because its port closed).
    pub async fn send(&self, data: impl Into<Bytes>) -> Result<(), Status> {
        let (reply, outcome) = oneshot::channel();
        self.requests
            .send((data.into(), reply))
            .await
            .map_err(|_| common::NOT_POSSIBLE_IN_MODE)?;
        outcome.await.unwrap_or(Err(common::NOT_POSSIBLE_IN_MODE))
    }
}

impl Link3964r {
    /// Start a link with `config` over `transport` (whose line runs at `settings`). Call it
    /// inside a tokio runtime: it spawns the driver and a routing task (and panics otherwise,
    /// as `tokio::spawn` does).
    pub fn spawn<T: Transport>(
        config: Config,
        settings: SerialSettings,
        transport: T,
    ) -> Result<Link3964r, ConfigError> {
        let link = Link::new(config, settings)?;
        let options = DriverOptions {
            settings: None,
            ..DriverOptions::default()
        };
        let (handle, _driver) = spawn(link, transport, options);
        let (requests, requests_rx) = mpsc::channel(16);
        let (received_tx, received) = mpsc::channel(1);
        tokio::spawn(route(handle, requests_rx, received_tx));
        Ok(Link3964r {
            sender: Sender { requests },
            received,
        })
    }

    /// Send `data` as one block; see [`Sender::send`].
    pub async fn send(&self, data: impl Into<Bytes>) -> Result<(), Status> {
        self.sender.send(data).await
    }

    /// A clonable sending half.
    pub fn sender(&self) -> Sender {
        self.sender.clone()
    }

    /// The next block received intact; `None` once the link has stopped. Receive errors are
    /// skipped (see [`next`](Self::next)).
    pub async fn recv(&mut self) -> Option<Bytes> {
        loop {
            if let Ok(block) = self.received.recv().await? {
                return Some(block);
            }
        }
    }

    /// The next received block or receive error (class 08H), in the order they happened;
    /// `None` once the link has stopped.
    pub async fn next(&mut self) -> Option<Result<Bytes, Status>> {
        self.received.recv().await
    }
}

/// Runs between the application and the driver: queues sends, matches completions to jobs,
/// and takes received blocks only when the application can take them.
async fn route(
    mut handle: Handle<Link>,
    mut requests: mpsc::Receiver<(Bytes, Reply)>,
    received: mpsc::Sender<Result<Bytes, Status>>,
) {
    let mut queue: VecDeque<(Bytes, Reply)> = VecDeque::new();
    let mut current: Option<(JobId, Reply)> = None;
    let mut errors: VecDeque<Status> = VecDeque::new();
    let mut blocks_waiting = false;
    loop {
        while current.is_none() {
            let Some((data, reply)) = queue.pop_front() else {
                break;
            };
            match handle.call(move |link, now| link.send(now, data)).await {
                Ok(Ok(job)) => current = Some((job, reply)),
                Ok(Err(e)) => {
                    let _ = reply.send(Err(e.status()));
                }
                Err(_) => return,
            }
        }
        let deliver = (blocks_waiting || !errors.is_empty()) && !received.is_closed();
        tokio::select! {
            request = requests.recv() => match request {
                Some(request) => queue.push_back(request),
                None => return, // the application dropped the link
            },
            event = handle.next_event() => match event {
                None => return, // the driver stopped: pending replies see 0502
                Some(Event::Sent { job }) => finish(&mut current, job, Ok(())),
                Some(Event::SendFailed { job, status }) => finish(&mut current, job, Err(status)),
                Some(Event::Received { .. }) => blocks_waiting = true,
                Some(Event::ReceiveError(status)) => {
                    if errors.len() == ERROR_BACKLOG {
                        errors.pop_front();
                    }
                    errors.push_back(status);
                }
            },
            permit = received.reserve(), if deliver => {
                let Ok(permit) = permit else { continue };
                if let Some(status) = errors.pop_front() {
                    permit.send(Err(status));
                } else {
                    match handle.call(|link, now| link.take_block(now)).await {
                        Ok(Some(block)) => permit.send(Ok(block)),
                        Ok(None) => blocks_waiting = false,
                        Err(_) => return,
                    }
                }
            }
        }
    }
}

fn finish(current: &mut Option<(JobId, Reply)>, job: JobId, outcome: Result<(), Status>) {
    if current.as_ref().is_some_and(|(j, _)| *j == job) {
        if let Some((_, reply)) = current.take() {
            let _ = reply.send(outcome);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Priority;
    use crate::status;

    fn pair() -> (Link3964r, Link3964r) {
        let (left, right) = tokio::io::duplex(4096);
        let line = SerialSettings::default();
        let high = Config {
            priority: Priority::High,
            ..Config::default()
        };
        (
            Link3964r::spawn(high, line, left).unwrap(),
            Link3964r::spawn(Config::default(), line, right).unwrap(),
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
        let link = Link3964r::spawn(Config::default(), SerialSettings::default(), left).unwrap();
        assert_eq!(link.send(Vec::new()).await, Err(common::INVALID_LEN));
        assert_eq!(link.send(vec![1]).await, Err(status::SETUP_TIMEOUT));
    }

    #[tokio::test(start_paused = true)]
    async fn a_closed_port_ends_the_link() {
        let (left, right) = tokio::io::duplex(4096);
        let mut link =
            Link3964r::spawn(Config::default(), SerialSettings::default(), left).unwrap();
        drop(right);
        assert_eq!(link.next().await, None);
        assert_eq!(link.send(vec![1]).await, Err(common::NOT_POSSIBLE_IN_MODE));
    }
}
