//! Async Modbus over any [`Transport`] (feature `tokio`): a master handle with one method per
//! function code, and a slave server task.
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
//! use si_modbus::{tokio::MasterHandle, MasterConfig};
//! let mut master = MasterHandle::spawn(MasterConfig::default(), port)?;
//! let regs = master.read_holding_registers(1, 0, 10).await?;
//! master.write_single_register(1, 4, 0x1234).await?;
//! # Ok(()) }
//! ```

use crate::config::{ConfigError, MasterConfig, SlaveConfig};
use crate::frame::{Adu, Bits, Registers, Request, Response};
use crate::master::{Completion, Master, MasterEvent, RequestError};
use crate::slave::{Slave, SlaveEvent, Store};
use si_core::driver::{spawn, DriverOptions, DriverStopped, Handle, Transport};
use si_core::Status;
use tokio::task::JoinHandle;

/// Why an async job failed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Error {
    /// The master refused the job (0E4xH, or busy).
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
    /// The request could not be encoded (quantity out of range).
    #[error("{0}")]
    Encode(#[from] crate::frame::EncodeError),
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

/// An async Modbus master over one line: one job at a time (§4.2), each `await` is one job.
pub struct MasterHandle {
    handle: Handle<Master>,
    task: JoinHandle<std::io::Result<()>>,
    diagnostics: std::collections::VecDeque<Status>,
    dropped: u64,
    /// A job was started whose end event has not been taken (its `request` future was
    /// dropped): the next request waits for that event first.
    in_flight: bool,
}

/// How many line diagnostics (0E50H, line errors between jobs) a handle keeps; older ones are
/// counted in [`MasterHandle::diagnostics_dropped`].
pub const DIAGNOSTICS_KEPT: usize = 64;

impl MasterHandle {
    /// Start the master on `transport`.
    pub fn spawn<T: Transport>(config: MasterConfig, transport: T) -> Result<Self, Error> {
        Ok(Self::spawn_engine(Master::new(config)?, transport))
    }

    /// Start an engine built by the caller (for options beyond [`MasterConfig`], such as
    /// [`Master::with_frame_end`]) on `transport`.
    pub fn spawn_engine<T: Transport>(master: Master, transport: T) -> Self {
        let options = DriverOptions {
            settings: Some(master.config().line.settings),
            ..DriverOptions::default()
        };
        let (handle, task) = spawn(master, transport, options);
        MasterHandle {
            handle,
            task,
            diagnostics: std::collections::VecDeque::new(),
            dropped: 0,
            in_flight: false,
        }
    }

    /// Send any request and wait for its completion (a broadcast completes after the
    /// turnaround delay with no response).
    ///
    /// The job is checked here ([`Master::check_job`]) and handed to the driver without
    /// waiting for a reply; its one completion or failure event is the answer. If an earlier
    /// `request` future was dropped before its job ended, that job's event is awaited (and
    /// dropped) first, so every call gets its own job's outcome.
    pub async fn request(&mut self, unit: u8, request: &Request<'_>) -> Result<Completion, Error> {
        let adu = Adu::request(unit, request)?;
        Master::check_job(unit, request)?;
        if self.in_flight {
            let _ = self.job_end().await;
        }
        self.in_flight = true;
        self.handle.send(move |m, now| {
            let started = match adu.decode_request() {
                Ok((_, r)) => m.request(now, unit, &r),
                Err(_) => Err(RequestError::Invalid(crate::status::INVALID_FUNCTION)),
            };
            if let Err(e) = started {
                // Not expected after the checks above; reported so the caller is not left
                // waiting.
                m.refuse(&adu, e.status());
            }
        })?;
        self.job_end().await
    }

    /// The end of the running job: its completion or failure; diagnostics on the way are kept.
    async fn job_end(&mut self) -> Result<Completion, Error> {
        loop {
            match self.handle.next_event().await {
                Some(MasterEvent::Completed(c)) => {
                    self.in_flight = false;
                    return Ok(c);
                }
                Some(MasterEvent::Failed { status, .. }) => {
                    self.in_flight = false;
                    return Err(Error::Failed(status));
                }
                Some(MasterEvent::Diagnostic(s)) => {
                    if self.diagnostics.len() == DIAGNOSTICS_KEPT {
                        self.diagnostics.pop_front();
                        self.dropped += 1;
                    }
                    self.diagnostics.push_back(s);
                }
                None => return Err(Error::Stopped(DriverStopped)),
            }
        }
    }

    async fn bits(&mut self, unit: u8, request: Request<'_>) -> Result<Vec<bool>, Error> {
        let c = self.request(unit, &request).await?;
        match c.response() {
            Some(Response::ReadCoils(b) | Response::ReadDiscreteInputs(b)) => {
                Ok(b.iter().collect())
            }
            _ => Ok(Vec::new()),
        }
    }

    async fn registers(&mut self, unit: u8, request: Request<'_>) -> Result<Vec<u16>, Error> {
        let c = self.request(unit, &request).await?;
        match c.response() {
            Some(Response::ReadHoldingRegisters(r) | Response::ReadInputRegisters(r)) => {
                Ok(r.iter().collect())
            }
            _ => Ok(Vec::new()),
        }
    }

    /// FC01.
    pub async fn read_coils(
        &mut self,
        unit: u8,
        address: u16,
        quantity: u16,
    ) -> Result<Vec<bool>, Error> {
        self.bits(unit, Request::ReadCoils { address, quantity })
            .await
    }

    /// FC02.
    pub async fn read_discrete_inputs(
        &mut self,
        unit: u8,
        address: u16,
        quantity: u16,
    ) -> Result<Vec<bool>, Error> {
        self.bits(unit, Request::ReadDiscreteInputs { address, quantity })
            .await
    }

    /// FC03.
    pub async fn read_holding_registers(
        &mut self,
        unit: u8,
        address: u16,
        quantity: u16,
    ) -> Result<Vec<u16>, Error> {
        self.registers(unit, Request::ReadHoldingRegisters { address, quantity })
            .await
    }

    /// FC04.
    pub async fn read_input_registers(
        &mut self,
        unit: u8,
        address: u16,
        quantity: u16,
    ) -> Result<Vec<u16>, Error> {
        self.registers(unit, Request::ReadInputRegisters { address, quantity })
            .await
    }

    /// FC05.
    pub async fn write_single_coil(
        &mut self,
        unit: u8,
        address: u16,
        value: bool,
    ) -> Result<(), Error> {
        self.request(unit, &Request::WriteSingleCoil { address, value })
            .await
            .map(|_| ())
    }

    /// FC06.
    pub async fn write_single_register(
        &mut self,
        unit: u8,
        address: u16,
        value: u16,
    ) -> Result<(), Error> {
        self.request(unit, &Request::WriteSingleRegister { address, value })
            .await
            .map(|_| ())
    }

    /// FC07: the eight exception status bits.
    pub async fn read_exception_status(&mut self, unit: u8) -> Result<u8, Error> {
        let c = self.request(unit, &Request::ReadExceptionStatus).await?;
        match c.response() {
            Some(Response::ReadExceptionStatus(s)) => Ok(s),
            _ => Ok(0),
        }
    }

    /// FC08 sub-function 0000: the slave echoes `data`.
    pub async fn diagnostics(&mut self, unit: u8, data: u16) -> Result<u16, Error> {
        let c = self.request(unit, &Request::Diagnostics { data }).await?;
        match c.response() {
            Some(Response::Diagnostics { data }) => Ok(data),
            _ => Ok(0),
        }
    }

    /// FC11: `(status, event_count)`.
    pub async fn get_comm_event_counter(&mut self, unit: u8) -> Result<(u16, u16), Error> {
        let c = self.request(unit, &Request::GetCommEventCounter).await?;
        match c.response() {
            Some(Response::GetCommEventCounter {
                status,
                event_count,
            }) => Ok((status, event_count)),
            _ => Ok((0, 0)),
        }
    }

    /// FC12.
    pub async fn get_comm_event_log(&mut self, unit: u8) -> Result<CommEventLog, Error> {
        let c = self.request(unit, &Request::GetCommEventLog).await?;
        match c.response() {
            Some(Response::GetCommEventLog {
                status,
                event_count,
                message_count,
                events,
            }) => Ok(CommEventLog {
                status,
                event_count,
                message_count,
                events: events.to_vec(),
            }),
            _ => Ok(CommEventLog {
                status: 0,
                event_count: 0,
                message_count: 0,
                events: Vec::new(),
            }),
        }
    }

    /// FC15.
    pub async fn write_multiple_coils(
        &mut self,
        unit: u8,
        address: u16,
        values: &[bool],
    ) -> Result<(), Error> {
        self.request(
            unit,
            &Request::WriteMultipleCoils {
                address,
                values: Bits::Bools(values),
            },
        )
        .await
        .map(|_| ())
    }

    /// FC16.
    pub async fn write_multiple_registers(
        &mut self,
        unit: u8,
        address: u16,
        values: &[u16],
    ) -> Result<(), Error> {
        self.request(
            unit,
            &Request::WriteMultipleRegisters {
                address,
                values: Registers::Words(values),
            },
        )
        .await
        .map(|_| ())
    }

    /// Line diagnostics seen while waiting for jobs (unsolicited frames 0E50H, line errors in
    /// Normal mode), oldest first; taking them empties the list.
    pub fn take_diagnostics(&mut self) -> Vec<Status> {
        self.diagnostics.drain(..).collect()
    }

    /// Diagnostics discarded because more than [`DIAGNOSTICS_KEPT`] piled up.
    pub fn diagnostics_dropped(&self) -> u64 {
        self.dropped
    }

    /// Stop the driver.
    pub fn abort(self) {
        self.task.abort();
    }
}

/// A Modbus slave serving a [`Store`] on one line, as a tokio task.
pub struct SlaveServer<S: Store + Send + 'static> {
    handle: Handle<Slave<S>>,
    task: JoinHandle<std::io::Result<()>>,
}

impl<S: Store + Send + 'static> SlaveServer<S> {
    /// Start serving `store` on `transport`.
    pub fn spawn<T: Transport>(config: SlaveConfig, store: S, transport: T) -> Result<Self, Error> {
        Ok(Self::spawn_engine(Slave::new(config, store)?, transport))
    }

    /// Serve with an engine built by the caller (for options beyond [`SlaveConfig`], such as
    /// [`Slave::with_frame_end`]) on `transport`.
    pub fn spawn_engine<T: Transport>(slave: Slave<S>, transport: T) -> Self {
        // Report tx-done when the write completes, not after the estimated wire time: on
        // transports without wire time (pseudo-terminals, TCP) a fast master's next request
        // would otherwise look like a sequence error (0837H).
        let options = DriverOptions {
            settings: None,
            ..DriverOptions::default()
        };
        let (handle, task) = spawn(slave, transport, options);
        SlaveServer { handle, task }
    }

    /// The next thing the slave did; `None` once the line has closed.
    pub async fn next_event(&mut self) -> Option<SlaveEvent> {
        self.handle.next_event().await
    }

    /// Look at or change the store (a simulated process) inside the driver.
    pub async fn with_store<R: Send + 'static>(
        &self,
        f: impl FnOnce(&mut S) -> R + Send + 'static,
    ) -> Result<R, Error> {
        Ok(self.handle.call(move |s, _| f(s.store_mut())).await?)
    }

    /// Wait for the driver task to end (the port closed) and return its I/O result.
    pub async fn join(self) -> std::io::Result<()> {
        drop(self.handle);
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
        let mut server = SlaveServer::spawn(config, Tables::new(16, 16, 16, 16), b).unwrap();
        let mut m = MasterHandle::spawn(MasterConfig::default(), a).unwrap();
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
        let _server = SlaveServer::spawn(config, tables, b).unwrap();
        let master_config = MasterConfig {
            response_timeout_ms: 100,
            ..MasterConfig::default()
        };
        let mut m = MasterHandle::spawn(master_config, a).unwrap();
        let dropped = tokio::time::timeout(
            std::time::Duration::from_millis(20),
            m.read_holding_registers(9, 0, 1),
        )
        .await;
        assert!(dropped.is_err(), "unit 9 never answers");
        assert_eq!(m.read_holding_registers(7, 1, 1).await.unwrap(), [0x1234]);
    }
}
