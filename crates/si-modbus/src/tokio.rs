//! Async Modbus over any [`Transport`] (feature `tokio`): a [`Master`] handle with one method
//! per function code, and a [`Slave`] handle serving a store; Modbus TCP client and server in
//! [`tcp`].
//!
//! Both run the Sans-IO engines on the si-core driver, which feeds them tokio's clock and fires
//! short deadlines precisely (see its "Timing, honestly"), so the end-of-frame gap (4 ms at
//! 9600–38 400 bit/s, 1 ms above, Table 3-11) is detected some 0.1 ms late on an idle machine;
//! that delays responses slightly but never merges frames that the gap separates on the wire.
//! To answer without waiting for the gap, build the engines with
//! [`FrameEnd::Length`](crate::config::FrameEnd) and start them with `spawn_engine`.
//!
//! ```no_run
//! # async fn demo(port: tokio::io::DuplexStream) -> Result<(), si_modbus::tokio::Error> {
//! use si_modbus::{tokio::Master, MasterConfig};
//! let mut master = Master::spawn(MasterConfig::default(), port)?;
//! let regs = master.read_holding_registers(1, 0, 10).await?;
//! master.write_single_register(1, 4, 0x1234).await?;
//! # Ok(()) }
//! ```

use crate::config::{ConfigError, MasterConfig, SlaveConfig};
use crate::frame::{Request, Response};
use crate::master::{Attempts, Completion, MasterEvent, RequestError};
use crate::slave::{SlaveEvent, Store};
use crate::{master, slave};
use si_core::driver::{self, DriverOptions, DriverStopped, Start, Transport};
use si_core::{Instant, Status};
use std::ops::ControlFlow::{Break, Continue};
use tokio::task::JoinHandle;

pub mod tcp;
mod typed;

/// Why an async job failed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Error {
    /// The master refused the job (0E4xH: a quantity out of range, a function not allowed as
    /// broadcast).
    #[error("{0}")]
    Refused(#[from] RequestError),
    /// The job failed on the line with the manual's STATUS (0830H, 0E57H, 0E61H …).
    #[error("{0}")]
    Failed(Status),
    /// The driver task ended (port closed).
    #[error("{0}")]
    Stopped(#[from] DriverStopped),
    /// The parameters are out of range.
    #[error("{0}")]
    Config(#[from] ConfigError),
}

impl Error {
    /// The STATUS for this error, if it has one.
    pub fn status(&self) -> Option<Status> {
        match self {
            Error::Refused(e) => Some(e.status()),
            Error::Failed(s) => Some(*s),
            Error::Config(e) => Some(e.status),
            _ => None,
        }
    }
}

/// A completed job whose response is not the one its request calls for (a broadcast has none):
/// the engine's checks ([Modbus/USS] §3.4.5–§3.4.16) make this unreachable for a unicast job, so it
/// is reported as the manual's "wrong function code in the response" rather than as an invented
/// value.
fn unexpected() -> Error {
    Error::Failed(crate::status::WRONG_FUNCTION)
}

/// The FC12 answer.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CommEventLog {
    /// Status word.
    pub status: u16,
    /// Event counter.
    pub event_count: u16,
    /// Message counter.
    pub message_count: u16,
    /// Event bytes.
    pub events: Vec<u8>,
}

/// An async Modbus master over one line: one job at a time ([Modbus/USS] §3.4.2), each `await` is
/// one job.
pub struct Master {
    driver: driver::Handle<master::Master>,
    task: JoinHandle<std::io::Result<()>>,
    diagnostics: std::collections::VecDeque<Status>,
    dropped: u64,
}

/// The old name of [`Master`].
#[deprecated(note = "renamed to si_modbus::tokio::Master")]
pub type MasterHandle = Master;

/// How many line diagnostics (0E50H, line errors between jobs) a handle keeps; older ones are
/// counted in [`Master::diagnostics_dropped`].
pub const DIAGNOSTICS_KEPT: usize = 64;

impl Master {
    /// Start the master on `transport`.
    pub fn spawn<T: Transport>(config: MasterConfig, transport: T) -> Result<Self, Error> {
        Ok(Self::spawn_engine(master::Master::new(config)?, transport))
    }

    /// Start an engine built by the caller (for options beyond [`MasterConfig`], such as
    /// [`master::Master::with_frame_end`]) on `transport`.
    pub fn spawn_engine<T: Transport>(master: master::Master, transport: T) -> Self {
        let options = DriverOptions {
            settings: Some(master.config().line.settings),
            // Diagnostics are taken only when the program asks or starts a job: beyond the
            // driver's event capacity they are dropped rather than stalling the line.
            drop_unread_events: true,
            ..DriverOptions::default()
        };
        let (driver, task) = driver::spawn(master, transport, options);
        Master {
            driver,
            task,
            diagnostics: std::collections::VecDeque::new(),
            dropped: 0,
        }
    }

    /// Send any request and wait for its completion (a broadcast completes after the
    /// turnaround delay with no response).
    ///
    /// The job is checked here ([`master::Master::check_job`]) and started in the driver, which
    /// routes its one completion or failure event back here. If an earlier `request` future
    /// was dropped before its job ended, this job waits in the driver until that one has ended
    /// (its outcome is dropped), so every call gets its own job's outcome.
    pub async fn request(&mut self, unit: u8, request: &Request<'_>) -> Result<Completion, Error> {
        let adu = master::Master::check_job(unit, request)?;
        self.keep_diagnostics();
        let start = move |m: &mut master::Master, now| {
            let started = match adu.decode_request() {
                Ok((_, r)) => m.request(now, unit, &r),
                Err(_) => Err(RequestError::Invalid(crate::status::INVALID_FUNCTION)),
            };
            match started {
                Ok(()) => Start::Running(()),
                Err(RequestError::Busy) => Start::Busy,
                Err(e) => Start::Ended(Err(Error::Refused(e))),
            }
        };
        let done = |_: &(), event| match event {
            MasterEvent::Completed(c) => Break(Ok(c)),
            MasterEvent::Failed { status, .. } => Break(Err(Error::Failed(status))),
            other @ MasterEvent::Diagnostic(_) => Continue(other),
        };
        self.driver.job(start, done).await?
    }

    /// [`request`](Self::request), and what the job's attempts met ([`Attempts`]): a job that
    /// completed after a retry still shows the corrupt answer or the timeout before it. A job
    /// refused before it started met nothing. The attempts are read from the engine once the
    /// job has ended, before this handle can start another (one job at a time, [Modbus/USS]
    /// §3.4.2).
    pub async fn request_with_attempts(
        &mut self,
        unit: u8,
        request: &Request<'_>,
    ) -> (Result<Completion, Error>, Attempts) {
        let result = self.request(unit, request).await;
        if matches!(result, Err(Error::Refused(_) | Error::Stopped(_))) {
            return (result, Attempts::default());
        }
        let attempts = self.call(|m, _| m.attempts()).await.unwrap_or_default();
        (result, attempts)
    }

    /// Pass a request of a function this crate does not know through to the slave, as it is
    /// (`unit | PDU` without CRC; [`master::Master::request_pass_through`]), and wait for its
    /// completion, with what its attempts met as [`request_with_attempts`] gives.
    ///
    /// [`request_with_attempts`]: Self::request_with_attempts
    pub async fn request_pass_through(
        &mut self,
        unit_pdu: &[u8],
    ) -> (Result<Completion, Error>, Attempts) {
        self.keep_diagnostics();
        let unit_pdu = unit_pdu.to_vec();
        let start = move |m: &mut master::Master, now| match m.request_pass_through(now, &unit_pdu)
        {
            Ok(()) => Start::Running(()),
            Err(RequestError::Busy) => Start::Busy,
            Err(e) => Start::Ended(Err(Error::Refused(e))),
        };
        let done = |_: &(), event| match event {
            MasterEvent::Completed(c) => Break(Ok(c)),
            MasterEvent::Failed { status, .. } => Break(Err(Error::Failed(status))),
            other @ MasterEvent::Diagnostic(_) => Continue(other),
        };
        let result = match self.driver.job(start, done).await {
            Ok(r) => r,
            Err(e) => Err(e.into()),
        };
        if matches!(result, Err(Error::Refused(_) | Error::Stopped(_))) {
            return (result, Attempts::default());
        }
        let attempts = self.call(|m, _| m.attempts()).await.unwrap_or_default();
        (result, attempts)
    }

    /// Move the diagnostics the driver has reported into the kept list.
    fn keep_diagnostics(&mut self) {
        while let Some(event) = self.driver.try_next_event() {
            if let MasterEvent::Diagnostic(s) = event {
                if self.diagnostics.len() == DIAGNOSTICS_KEPT {
                    self.diagnostics.pop_front();
                    self.dropped += 1;
                }
                self.diagnostics.push_back(s);
            }
        }
    }

    /// Send `request` and pick the typed result out of its completion ([`typed`]).
    async fn exchange_typed<T>(
        &mut self,
        unit: u8,
        request: Request<'_>,
        pick: impl FnOnce(Response<'_>) -> Option<T>,
    ) -> Result<T, Error> {
        let c = self.request(unit, &request).await?;
        c.response().and_then(pick).ok_or_else(unexpected)
    }

    typed::typed_requests!(Error);

    /// Line diagnostics seen while waiting for jobs (unsolicited frames 0E50H, line errors in
    /// Normal mode), oldest first; taking them empties the list.
    pub fn take_diagnostics(&mut self) -> Vec<Status> {
        self.keep_diagnostics();
        self.diagnostics.drain(..).collect()
    }

    /// Diagnostics discarded because more than [`DIAGNOSTICS_KEPT`] piled up.
    pub fn diagnostics_dropped(&self) -> u64 {
        self.dropped
    }

    /// Run `f` on the engine inside the driver (counters, state).
    pub async fn call<R: Send + 'static>(
        &self,
        f: impl FnOnce(&mut master::Master, Instant) -> R + Send + 'static,
    ) -> Result<R, Error> {
        Ok(self.driver.call(f).await?)
    }

    /// Stop the driver.
    pub fn abort(self) {
        self.task.abort();
    }
}

/// A Modbus slave serving a [`Store`] on one line, as a tokio task.
pub struct Slave<S: Store + Send + 'static> {
    driver: driver::Handle<slave::Slave<S>>,
    task: JoinHandle<std::io::Result<()>>,
}

/// The old name of [`Slave`].
#[deprecated(note = "renamed to si_modbus::tokio::Slave")]
pub type SlaveServer<S> = Slave<S>;

impl<S: Store + Send + 'static> Slave<S> {
    /// Start serving `store` on `transport`.
    pub fn spawn<T: Transport>(config: SlaveConfig, store: S, transport: T) -> Result<Self, Error> {
        Ok(Self::spawn_engine(
            slave::Slave::new(config, store)?,
            transport,
        ))
    }

    /// Serve with an engine built by the caller (for options beyond [`SlaveConfig`], such as
    /// [`slave::Slave::with_frame_end`]) on `transport`.
    pub fn spawn_engine<T: Transport>(slave: slave::Slave<S>, transport: T) -> Self {
        // Report tx-done when the write completes, not after the estimated wire time: on
        // transports without wire time (pseudo-terminals, TCP) a fast master's next request
        // would otherwise look like a sequence error (0837H).
        let options = DriverOptions {
            settings: None,
            ..DriverOptions::default()
        };
        let (driver, task) = driver::spawn(slave, transport, options);
        Slave { driver, task }
    }

    /// The next thing the slave did; `None` once the line has closed.
    pub async fn next_event(&mut self) -> Option<SlaveEvent> {
        self.driver.next_event().await
    }

    /// Look at or change the store (a simulated process) inside the driver.
    pub async fn with_store<R: Send + 'static>(
        &self,
        f: impl FnOnce(&mut S) -> R + Send + 'static,
    ) -> Result<R, Error> {
        self.call(move |s, _| f(s.store_mut())).await
    }

    /// Run `f` on the slave engine inside the driver (counters, state).
    pub async fn call<R: Send + 'static>(
        &self,
        f: impl FnOnce(&mut slave::Slave<S>, Instant) -> R + Send + 'static,
    ) -> Result<R, Error> {
        Ok(self.driver.call(f).await?)
    }

    /// Wait for the driver task to end (the port closed) and return its I/O result.
    pub async fn join(self) -> std::io::Result<()> {
        drop(self.driver);
        self.task.await.unwrap_or(Ok(()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::slave::Tables;

    #[tokio::test]
    async fn master_and_slave_over_a_duplex_pipe() {
        let (a, b) = tokio::io::duplex(1024);
        let config = SlaveConfig {
            address: 7,
            ..SlaveConfig::default()
        };
        let mut server = Slave::spawn(config, Tables::new(16, 16, 16, 16), b).unwrap();
        let mut m = Master::spawn(MasterConfig::default(), a).unwrap();
        m.write_multiple_registers(7, 2, &[0xAAAA, 0x5555])
            .await
            .unwrap();
        assert_eq!(
            m.read_holding_registers(7, 1, 3).await.unwrap(),
            vec![0, 0xAAAA, 0x5555]
        );
        m.write_single_coil(7, 3, true).await.unwrap();
        m.write_multiple_coils(7, 8, &[true, false, true])
            .await
            .unwrap();
        let coils = m.read_coils(7, 0, 11).await.unwrap();
        assert_eq!(coils.iter().filter(|&&c| c).count(), 3);
        assert_eq!(m.diagnostics(7, 0xA537).await.unwrap(), 0xA537);
        let e = m.read_holding_registers(7, 15, 2).await.unwrap_err();
        assert_eq!(
            e.status(),
            Some(crate::status::EXCEPTION_ILLEGAL_DATA_ADDRESS)
        );
        assert!(matches!(
            server.next_event().await,
            Some(SlaveEvent::Served { function: 16, .. })
        ));
        let regs = server.with_store(|s| s.holding_registers[2]).await.unwrap();
        assert_eq!(regs, 0xAAAA);
    }

    /// `request_with_attempts`: a corrupt first answer and a good retry complete the job and
    /// still show the CRC error; a silent unit shows its timeouts.
    #[tokio::test]
    async fn a_job_reports_what_its_attempts_met() {
        use tokio::io::{AsyncReadExt, AsyncWriteExt};
        let (a, mut b) = tokio::io::duplex(1024);
        let config = MasterConfig {
            retries: 1,
            response_timeout_ms: 50,
            ..MasterConfig::default()
        };
        let mut m = Master::spawn(config, a).unwrap();
        let peer = tokio::spawn(async move {
            let mut request = [0u8; 8];
            for corrupt in [true, false] {
                b.read_exact(&mut request).await.unwrap();
                let mut answer = vec![7, 3, 2, 0x12, 0x34];
                answer.extend(crate::frame::crc16(&answer).to_le_bytes());
                answer[6] ^= u8::from(corrupt);
                b.write_all(&answer).await.unwrap();
            }
            b
        });
        let read = Request::ReadHoldingRegisters {
            address: 0,
            quantity: 1,
        };
        let (result, attempts) = m.request_with_attempts(7, &read).await;
        assert!(result.is_ok(), "{result:?}");
        assert_eq!(
            (attempts.sent, attempts.crc_errors, attempts.timeouts),
            (2, 1, 0)
        );
        let _b = peer.await.unwrap();
        let (result, attempts) = m.request_with_attempts(9, &read).await;
        assert_eq!(
            result.unwrap_err().status(),
            Some(crate::status::RESPONSE_TIMEOUT)
        );
        assert_eq!(
            (attempts.sent, attempts.crc_errors, attempts.timeouts),
            (2, 0, 2)
        );
    }

    /// A `request` future dropped before its job ended (here: no answer from unit 9, which
    /// does not exist) does not leave its outcome to the next call: the next request waits
    /// for that job to time out (0830H) and then gets its own answer.
    #[tokio::test(start_paused = true)]
    async fn a_dropped_request_does_not_hand_its_outcome_to_the_next() {
        let (a, b) = tokio::io::duplex(1024);
        let config = SlaveConfig {
            address: 7,
            ..SlaveConfig::default()
        };
        let mut tables = Tables::new(0, 0, 4, 0);
        tables.holding_registers[1] = 0x1234;
        let _server = Slave::spawn(config, tables, b).unwrap();
        let master_config = MasterConfig {
            response_timeout_ms: 100,
            ..MasterConfig::default()
        };
        let mut m = Master::spawn(master_config, a).unwrap();
        let dropped = tokio::time::timeout(
            std::time::Duration::from_millis(20),
            m.read_holding_registers(9, 0, 1),
        )
        .await;
        assert!(dropped.is_err(), "unit 9 never answers");
        assert_eq!(m.read_holding_registers(7, 1, 1).await.unwrap(), [0x1234]);
    }
}
