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
//!
//! let (left, right) = tokio::io::duplex(1024);
//! let mut high = Config::default();
//! high.link.priority = si_3964r::Priority::High;
//! let mut memory = ServerConfig::default();
//! memory.memory.dbs.insert(1, 16);
//! let host = Handle::spawn(high, left).unwrap();
//! let line = Config::default().link.settings;
//! let plc = Station::serving(Config::default().with_settings(line), &memory).unwrap();
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
use crate::fb::Rk512Job;
use crate::frame::{Address, Coordination};
use crate::passive::Server;
use crate::station::{Event, RequestError, Station};
use bytes::Bytes;
use si_3964r::ConfigError;
use si_core::driver::{self, DriverOptions, DriverStopped, IoError, JobError, Transport};
use si_core::{Instant, Status};

/// Why a call on a [`Handle`] failed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Error {
    /// The station refused the job (0502H busy is never seen: the driver queues; 1E41H
    /// length, 1E20H not a DB/DX, 0515H flag bit, 0516H CPU number).
    #[error("the RK 512 station refused the job: {0}")]
    Refused(RequestError),
    /// The job at `address` failed: 051AH after a 3964(R) error (whose 07xxH
    /// [`Station::last_cause`] keeps), class 09H from the partner's error number, class 0AH
    /// for a faulty or missing reaction.
    #[error("RK 512 job at {address}: {status}")]
    Failed {
        /// The STATUS.
        status: Status,
        /// The partner's address the job went to.
        address: Address,
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
    /// The STATUS for this error, if it has one: a failed job's, or the one an FB shows for
    /// a refused job.
    pub fn status(&self) -> Option<Status> {
        match self {
            Error::Refused(e) => Some(e.status()),
            Error::Failed { status, .. } => Some(*status),
            Error::Config(_) | Error::Stopped | Error::Io(_) => None,
        }
    }

    fn from_job(e: JobError<RequestError, Status>, address: Address) -> Self {
        match e {
            JobError::Refused(e) => Error::Refused(e),
            JobError::Failed(status) => Error::Failed { status, address },
            JobError::Stopped => Error::Stopped,
        }
    }
}

/// A running RK 512 station. Dropping it stops the driver, which then releases the port;
/// [`close`](Self::close) waits for that.
pub struct Handle {
    driver: driver::Handle<Station>,
}

impl Drop for Handle {
    fn drop(&mut self) {
        self.driver.stop();
    }
}

impl Handle {
    /// Start an active-only station over `transport`, whose line runs at
    /// `config.link.settings`; for one that also serves the partner's jobs, build it with
    /// [`Station::serving`] and start it with [`spawn_engine`](Self::spawn_engine). Call it
    /// inside a tokio runtime.
    pub fn spawn<T: Transport>(config: Config, transport: T) -> Result<Handle, Error> {
        Ok(Self::spawn_engine(Station::new(config)?, transport))
    }

    /// Open the serial port at `path` with the config's line settings
    /// (`config.link.settings`) and start an active-only station on it (feature `serial`). A
    /// port another handle or program holds is reported as [`Error::Io`] with kind
    /// `ResourceBusy`.
    #[cfg(feature = "serial")]
    #[cfg_attr(docsrs, doc(cfg(feature = "serial")))]
    pub fn open(config: Config, path: &str) -> Result<Handle, Error> {
        let settings = config.link.settings;
        let station = Station::new(config)?;
        let options = si_core::port::PortOptions::default();
        let port = si_core::port::open(path, &settings, &options).map_err(IoError::from)?;
        Ok(Self::spawn_engine(station, port))
    }

    /// Start a station built by the caller on `transport`.
    pub fn spawn_engine<T: Transport>(station: Station, transport: T) -> Handle {
        // tx-done at the bytes' end on the wire, so QVZ starts when the block has left (a
        // 200-byte block takes 1.8 s at 1200 bit/s); a prompt partner's DLE that arrives
        // before that is still the acknowledgement (see the readings in `si_3964r::link`).
        let options = DriverOptions {
            settings: Some(station.settings()),
            drop_unread_events: true,
            ..DriverOptions::default()
        };
        let (driver, _task) = driver::spawn(station, transport, options);
        Handle { driver }
    }

    /// SEND `data` to `address` and wait until the partner's reactions accepted all of it, or
    /// for the STATUS.
    pub async fn send(
        &self,
        address: Address,
        coordination: Coordination,
        data: impl Into<Bytes>,
    ) -> Result<(), Error> {
        let job = Rk512Job::Send {
            address,
            coordination,
            data: data.into(),
        };
        self.driver
            .run_job(job)
            .await
            .map(|_| ())
            .map_err(|e| Error::from_job(e, address))
    }

    /// FETCH `len` bytes from `address`.
    pub async fn fetch(
        &self,
        address: Address,
        coordination: Coordination,
        len: usize,
    ) -> Result<Bytes, Error> {
        let job = Rk512Job::Fetch {
            address,
            coordination,
            len,
        };
        self.driver
            .run_job(job)
            .await
            .map_err(|e| Error::from_job(e, address))
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

    /// Wait until the station has stopped (the port closed or failed) and released its port.
    pub async fn closed(&self) {
        self.driver.closed().await
    }

    /// Stop the station and return once its port is released, so it may be opened again at
    /// once. Jobs still waiting end with [`Error::Stopped`].
    pub async fn close(self) {
        self.driver.close().await
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
        let line = Config::default().link.settings;
        let mut high = Config::default();
        high.link.priority = si_3964r::Priority::High;
        let mut memory = ServerConfig::default();
        memory.memory.dbs.insert(2, 8);
        let host = Handle::spawn(high, left).unwrap();
        let station = Station::serving(Config::default().with_settings(line), &memory).unwrap();
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
            Err(Error::Failed {
                status: crate::status::PARTNER_NO_SUCH_DB,
                address: Address::Db { db: 3, dw: 0 }
            })
        );
        assert_eq!(
            host.fetch(at, Coordination::NONE, 3).await,
            Err(Error::Refused(RequestError::Length { len: 3, max: 1024 }))
        );
        // The partner's end of the pipe closes: the driver stops, jobs end with Stopped.
        drop(plc);
        assert_eq!(
            host.fetch(at, Coordination::NONE, 2).await,
            Err(Error::Stopped)
        );
    }
}
