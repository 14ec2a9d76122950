//! The async handle (feature `tokio`): a [`Station`] running over any [`Transport`] (serial
//! port, TCP device server, in-memory pipe) on the si-core driver.
//!
//! ```
//! # #[tokio::main(flavor = "current_thread")]
//! # async fn main() {
//! use si_rk512::frame::{Address, Coordination};
//! use si_rk512::passive::ServerConfig;
//! use si_rk512::station::Station;
//! use si_rk512::tokio::Handle;
//! use si_rk512::Config;
//! use si_core::SerialSettings;
//!
//! let (left, right) = tokio::io::duplex(1024);
//! let line = SerialSettings::default();
//! let mut high = Config::default();
//! high.link.priority = si_3964r::Priority::High;
//! let mut memory = ServerConfig::default();
//! memory.memory.dbs.insert(1, 16);
//! let host = Handle::spawn(high, line, left).unwrap();
//! let plc = Station::serving(Config::default(), line, &memory).unwrap();
//! let _plc = Handle::spawn_engine(plc, right);
//! let at = Address::Db { db: 1, dw: 0 };
//! host.send(at, Coordination::NONE, vec![1, 2, 3, 4]).await.unwrap();
//! assert_eq!(host.fetch(at, Coordination::NONE, 4).await.unwrap(), &[1, 2, 3, 4][..]);
//! # }
//! ```
//!
//! Jobs are queued in the driver and run one after the other (one job outstanding at a time,
//! [CP 341] §2.2.3, Fig. 2-17); each call resolves with its own job's outcome (the driver's job
//! routing, `si_core::driver`). What the passive side did comes out of [`Handle::next_event`]; a
//! station that nobody asks drops such news beyond the driver's event capacity rather than
//! stalling the line.

use crate::config::Config;
use crate::frame::{Address, Coordination};
use crate::passive::Server;
use crate::station::{Event, JobId, RequestError, Station};
use bytes::Bytes;
use si_core::driver::{self, DriverOptions, Start, Transport};
use si_core::{Instant, SerialSettings};
use std::ops::ControlFlow::{Break, Continue};

/// Why a call on a [`Handle`] failed: the 3964(R) handle's error, as RK 512 runs on that
/// procedure and fails the same ways (a STATUS: refused with 1E41H, 1E20H, 0515H or 0516H,
/// failed with 051AH after a 3964(R) error (whose 07xxH [`Station::last_cause`] keeps), or with
/// class 09H or 0AH; a configuration out of range; the driver stopped).
pub use si_3964r::tokio::Error;

/// A running RK 512 station.
pub struct Handle {
    driver: driver::Handle<Station>,
}

/// The old name of [`Handle`].
#[deprecated(note = "renamed to si_rk512::tokio::Handle")]
pub type Rk512 = Handle;

impl Handle {
    /// Start an active-only station over `transport` (whose line runs at `settings`); for one
    /// that also serves the partner's jobs, build it with [`Station::serving`] and start it with
    /// [`spawn_engine`](Self::spawn_engine). Call it inside a tokio runtime.
    pub fn spawn<T: Transport>(
        config: Config,
        settings: SerialSettings,
        transport: T,
    ) -> Result<Handle, Error> {
        Ok(Self::spawn_engine(
            Station::new(config, settings)?,
            transport,
        ))
    }

    /// Start a station built by the caller on `transport`.
    pub fn spawn_engine<T: Transport>(station: Station, transport: T) -> Handle {
        // tx-done at the bytes' end on the wire, so QVZ starts when the block has left (a
        // 200-byte block takes 1.8 s at 1200 bit/s); a prompt partner's DLE that arrives
        // before that is still the acknowledgement (see the readings in `crate::link`).
        let options = DriverOptions {
            settings: Some(station.settings()),
            drop_unread_events: true,
            ..DriverOptions::default()
        };
        let (driver, _task) = driver::spawn(station, transport, options);
        Handle { driver }
    }

    async fn job(
        &self,
        mut start: impl FnMut(&mut Station, Instant) -> Result<JobId, RequestError> + Send + 'static,
    ) -> Result<Bytes, Error> {
        let start = move |s: &mut Station, now| match start(s, now) {
            Ok(job) => Start::Running(job),
            Err(RequestError::Busy) => Start::Busy,
            Err(e) => Start::Ended(Err(e.status())),
        };
        let done = |job: &_, event| match event {
            Event::Done { job: j, data } if j == *job => Break(Ok(data)),
            Event::Failed { job: j, status } if j == *job => Break(Err(status)),
            other => Continue(other),
        };
        self.driver.job(start, done).await?.map_err(Error::Status)
    }

    /// SEND `data` to `address` and wait until the partner's reactions accepted all of it, or
    /// for the STATUS.
    pub async fn send(
        &self,
        address: Address,
        coordination: Coordination,
        data: impl Into<Bytes>,
    ) -> Result<(), Error> {
        let data = data.into();
        self.job(move |s, now| s.send(now, address, coordination, data.clone()))
            .await
            .map(|_| ())
    }

    /// FETCH `len` bytes from `address`.
    pub async fn fetch(
        &self,
        address: Address,
        coordination: Coordination,
        len: usize,
    ) -> Result<Bytes, Error> {
        self.job(move |s, now| s.fetch(now, address, coordination, len))
            .await
    }

    /// Run `f` on the passive side's memory (as the CPU program would), e.g. to reset a
    /// coordination flag or read what a partner sent. It does not wait behind a running job.
    pub async fn with_server<R: Send + 'static>(
        &self,
        f: impl FnOnce(&mut Server) -> R + Send + 'static,
    ) -> Result<R, Error> {
        self.call(move |s, _| f(s.server_mut())).await
    }

    /// The next passive-side or receive event (`Served`, `Refused`, `ServeAborted`,
    /// `ProcedureError`, `ReceiveError`); `None` once the station has stopped.
    pub async fn next_event(&mut self) -> Option<Event> {
        self.driver.next_event().await
    }

    /// Run `f` on the station inside the driver.
    pub async fn call<R: Send + 'static>(
        &self,
        f: impl FnOnce(&mut Station, Instant) -> R + Send + 'static,
    ) -> Result<R, Error> {
        Ok(self.driver.call(f).await?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::passive::ServerConfig;
    use si_core::memory::Area;

    #[tokio::test(start_paused = true)]
    async fn jobs_memory_access_and_a_closed_port() {
        let (left, right) = tokio::io::duplex(4096);
        let line = SerialSettings::default();
        let mut high = Config::default();
        high.link.priority = si_3964r::Priority::High;
        let mut memory = ServerConfig::default();
        memory.memory.dbs.insert(2, 8);
        let host = Handle::spawn(high, line, left).unwrap();
        let station = Station::serving(Config::default(), line, &memory).unwrap();
        let mut plc = Handle::spawn_engine(station, right);
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
            Err(Error::Status(crate::status::PARTNER_NO_SUCH_DB))
        );
        assert_eq!(
            host.fetch(at, Coordination::NONE, 3).await,
            Err(Error::Status(si_core::status::common::INVALID_LEN))
        );
        // The partner's end of the pipe closes: the driver stops, jobs end with Stopped.
        drop(plc);
        assert_eq!(
            host.fetch(at, Coordination::NONE, 2).await,
            Err(Error::Stopped(si_core::driver::DriverStopped))
        );
    }
}
