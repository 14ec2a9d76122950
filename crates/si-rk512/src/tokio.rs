//! The async handle (feature `tokio`): a [`Station`] running over any [`Transport`] (serial
//! port, TCP device server, in-memory pipe) on the si-core driver.
//!
//! ```
//! # #[tokio::main(flavor = "current_thread")]
//! # async fn main() {
//! use si_rk512::frame::{Address, Coordination};
//! use si_rk512::passive::ServerConfig;
//! use si_rk512::tokio::Rk512;
//! use si_rk512::Config;
//! use si_core::SerialSettings;
//!
//! let (left, right) = tokio::io::duplex(1024);
//! let line = SerialSettings::default();
//! let mut high = Config::default();
//! high.link.priority = si_3964r::Priority::High;
//! let mut memory = ServerConfig::default();
//! memory.memory.dbs.insert(1, 16);
//! let host = Rk512::spawn(high, line, None, left).unwrap();
//! let _plc = Rk512::spawn(Config::default(), line, Some(&memory), right).unwrap();
//! let at = Address::Db { db: 1, dw: 0 };
//! host.send(at, Coordination::NONE, vec![1, 2, 3, 4]).await.unwrap();
//! assert_eq!(host.fetch(at, Coordination::NONE, 4).await.unwrap(), &[1, 2, 3, 4][..]);
//! # }
//! ```
//!
//! Jobs are queued and run one after the other (one job outstanding at a time, §4.6); each
//! call resolves with its own job's outcome. What the passive side did comes out of
//! [`Rk512::next_event`].

use crate::config::Config;
use crate::frame::{Address, Coordination};
use crate::passive::{Server, ServerConfig};
use crate::station::{Event, JobId, Station};
use bytes::Bytes;
use si_3964r::ConfigError;
use si_core::driver::{spawn, DriverOptions, Handle, Transport};
use si_core::status::common;
use si_core::{SerialSettings, Status};
use std::collections::VecDeque;
use tokio::sync::{mpsc, oneshot};

type Reply = oneshot::Sender<Result<Bytes, Status>>;
type ServerFn = Box<dyn FnOnce(&mut Server) + Send>;

enum Request {
    Send(Address, Coordination, Bytes, Reply),
    Fetch(Address, Coordination, usize, Reply),
    Server(ServerFn),
}

/// Passive-side events kept for the application before the oldest is dropped.
const EVENT_BACKLOG: usize = 256;

/// A running RK 512 station.
pub struct Rk512 {
    requests: mpsc::Sender<Request>,
    events: mpsc::Receiver<Event>,
}

impl Rk512 {
    /// Start a station over `transport`; with `server`, it also serves the partner's jobs from
    /// memory of those sizes. Call it inside a tokio runtime.
    pub fn spawn<T: Transport>(
        config: Config,
        settings: SerialSettings,
        server: Option<&ServerConfig>,
        transport: T,
    ) -> Result<Rk512, ConfigError> {
        let station = match server {
            Some(s) => Station::serving(config, settings, s)?,
            None => Station::new(config, settings)?,
        };
        let options = DriverOptions {
            settings: None,
            ..DriverOptions::default()
        };
        let (handle, _driver) = spawn(station, transport, options);
        let (requests, requests_rx) = mpsc::channel(16);
        let (events_tx, events) = mpsc::channel(EVENT_BACKLOG);
        tokio::spawn(route(handle, requests_rx, events_tx));
        Ok(Rk512 { requests, events })
    }

    async fn job(&self, make: impl FnOnce(Reply) -> Request) -> Result<Bytes, Status> {
        let (reply, outcome) = oneshot::channel();
        self.requests
            .send(make(reply))
            .await
            .map_err(|_| common::NOT_POSSIBLE_IN_MODE)?;
        outcome.await.unwrap_or(Err(common::NOT_POSSIBLE_IN_MODE))
    }

    /// SEND `data` to `address` and wait until the partner's reactions accepted all of it, or
    /// for the STATUS (0502 once the port has closed).
    pub async fn send(
        &self,
        address: Address,
        coordination: Coordination,
        data: impl Into<Bytes>,
    ) -> Result<(), Status> {
        let data = data.into();
        self.job(|r| Request::Send(address, coordination, data, r))
            .await
            .map(|_| ())
    }

    /// FETCH `len` bytes from `address`.
    pub async fn fetch(
        &self,
        address: Address,
        coordination: Coordination,
        len: usize,
    ) -> Result<Bytes, Status> {
        self.job(|r| Request::Fetch(address, coordination, len, r))
            .await
    }

    /// Run `f` on the passive side's memory (as the CPU program would), e.g. to reset a
    /// coordination flag or read what a partner sent.
    pub async fn with_server<R: Send + 'static>(
        &self,
        f: impl FnOnce(&mut Server) -> R + Send + 'static,
    ) -> Result<R, Status> {
        let (tx, rx) = oneshot::channel();
        let call: ServerFn = Box::new(move |s| {
            let _ = tx.send(f(s));
        });
        self.requests
            .send(Request::Server(call))
            .await
            .map_err(|_| common::NOT_POSSIBLE_IN_MODE)?;
        rx.await.map_err(|_| common::NOT_POSSIBLE_IN_MODE)
    }

    /// The next passive-side or receive event (`Served`, `Refused`, `ServeAborted`,
    /// `ReceiveError`); `None` once the station has stopped.
    pub async fn next_event(&mut self) -> Option<Event> {
        self.events.recv().await
    }
}

async fn route(
    mut handle: Handle<Station>,
    mut requests: mpsc::Receiver<Request>,
    events: mpsc::Sender<Event>,
) {
    let mut queue: VecDeque<Request> = VecDeque::new();
    let mut current: Option<(JobId, Reply)> = None;
    loop {
        while current.is_none() {
            let Some(request) = queue.pop_front() else {
                break;
            };
            let (started, reply) = match request {
                Request::Send(a, c, d, reply) => {
                    (handle.call(move |s, now| s.send(now, a, c, d)).await, reply)
                }
                Request::Fetch(a, c, n, reply) => (
                    handle.call(move |s, now| s.fetch(now, a, c, n)).await,
                    reply,
                ),
                Request::Server(f) => {
                    if handle.call(move |s, _| f(s.server_mut())).await.is_err() {
                        return;
                    }
                    continue;
                }
            };
            match started {
                Ok(Ok(job)) => current = Some((job, reply)),
                Ok(Err(e)) => {
                    let _ = reply.send(Err(e.status()));
                }
                Err(_) => return,
            }
        }
        tokio::select! {
            request = requests.recv() => match request {
                // Memory access does not wait behind a running job.
                Some(Request::Server(f)) => {
                    if handle.call(move |s, _| f(s.server_mut())).await.is_err() {
                        return;
                    }
                }
                Some(request) => queue.push_back(request),
                None => return,
            },
            event = handle.next_event() => match event {
                None => return,
                Some(Event::Done { job, data }) => finish(&mut current, job, Ok(data)),
                Some(Event::Failed { job, status }) => finish(&mut current, job, Err(status)),
                Some(other) => {
                    // Beyond the backlog, news is dropped rather than stalling the line.
                    let _ = events.try_send(other);
                }
            },
        }
    }
}

fn finish(current: &mut Option<(JobId, Reply)>, job: JobId, outcome: Result<Bytes, Status>) {
    if current.as_ref().is_some_and(|(j, _)| *j == job) {
        if let Some((_, reply)) = current.take() {
            let _ = reply.send(outcome);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use si_core::memory::Area;

    #[tokio::test(start_paused = true)]
    async fn jobs_memory_access_and_a_closed_port() {
        let (left, right) = tokio::io::duplex(4096);
        let line = SerialSettings::default();
        let mut high = Config::default();
        high.link.priority = si_3964r::Priority::High;
        let mut memory = ServerConfig::default();
        memory.memory.dbs.insert(2, 8);
        let host = Rk512::spawn(high, line, None, left).unwrap();
        let mut plc = Rk512::spawn(Config::default(), line, Some(&memory), right).unwrap();
        let at = Address::Db { db: 2, dw: 1 };
        host.send(at, Coordination::NONE, vec![0xAB, 0xCD])
            .await
            .unwrap();
        let word = plc
            .with_server(|s| s.memory().word(Area::Db(2), 2).unwrap())
            .await
            .unwrap();
        assert_eq!(word, 0xABCD);
        assert_eq!(
            plc.next_event().await,
            Some(Event::Served {
                command: crate::Command::Send,
                address: at,
                len: 2
            })
        );
        assert_eq!(
            host.fetch(Address::Db { db: 3, dw: 0 }, Coordination::NONE, 2)
                .await,
            Err(crate::status::PARTNER_NO_SUCH_AREA)
        );
        assert_eq!(
            host.fetch(at, Coordination::NONE, 3).await,
            Err(common::INVALID_LEN)
        );
        // The partner's end of the pipe closes: the driver stops, jobs end with 0502.
        drop(plc);
        assert_eq!(
            host.fetch(at, Coordination::NONE, 2).await,
            Err(common::NOT_POSSIBLE_IN_MODE)
        );
    }
}
