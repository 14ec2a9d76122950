//! The async RTU master handle: the engine runs in a driver task that owns the port, and each
//! job is sent there and its outcome routed back (si-core's driver, `Caller::run_job`).

use super::client::{unexpected, Client};
use super::error::{Error, Job};
use super::lifetime::Lifetime;
use crate::config::MasterConfig;
use crate::frame::{Request, Response};
use crate::master::{self, Attempts, CheckedRequest, Completion, MasterEvent};
use si_core::driver::{self, Caller, DriverOptions, JobError, Transport};
use si_core::{Instant, Status};
use std::collections::VecDeque;
use std::sync::Mutex;

/// How many line diagnostics (0E50H, line errors between jobs) a handle keeps; older ones are
/// counted in [`Master::diagnostics_dropped`].
pub const DIAGNOSTICS_KEPT: usize = 64;

/// The line diagnostics a handle has kept, and how many it dropped.
#[derive(Debug, Default)]
pub(crate) struct Diagnostics {
    kept: VecDeque<Status>,
    dropped: u64,
}

impl Diagnostics {
    /// Keep `status`, dropping the oldest beyond [`DIAGNOSTICS_KEPT`].
    pub(crate) fn keep(&mut self, status: Status) {
        if self.kept.len() == DIAGNOSTICS_KEPT {
            self.kept.pop_front();
            self.dropped += 1;
        }
        self.kept.push_back(status);
    }

    /// Everything kept, oldest first; the list is emptied.
    pub(crate) fn take(&mut self) -> Vec<Status> {
        self.kept.drain(..).collect()
    }

    /// How many were dropped.
    pub(crate) fn dropped(&self) -> u64 {
        self.dropped
    }
}

/// An async Modbus master over one line: one job at a time ([Modbus/USS] §4.2); each `await` is
/// one job. Its methods take `&self`: calls from several tasks queue in the driver in call
/// order. The function codes are the [`Client`] trait's.
///
/// Dropping the handle stops the driver task and releases the port; [`close`](Self::close)
/// waits until it has.
pub struct Master {
    caller: Caller<master::Master>,
    /// The driver's event side (diagnostics), taken without waiting.
    events: Mutex<driver::Handle<master::Master>>,
    diagnostics: Mutex<Diagnostics>,
    lifetime: Lifetime,
}

impl Master {
    /// Start the master on `transport`.
    pub fn spawn<T: Transport>(config: MasterConfig, transport: T) -> Result<Self, Error> {
        Ok(Self::spawn_engine(master::Master::new(config)?, transport))
    }

    /// Open the serial port at `path` with the config's own line settings and start the master
    /// on it (feature `serial`): the settings exist once, in the config.
    #[cfg(feature = "serial")]
    #[cfg_attr(docsrs, doc(cfg(feature = "serial")))]
    pub fn open(config: MasterConfig, path: &str) -> Result<Self, Error> {
        let engine = master::Master::new(config)?;
        let port = si_core::port::open(
            path,
            &config.line.settings,
            &si_core::port::PortOptions::default(),
        )?;
        Ok(Self::spawn_engine(engine, port))
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
            caller: driver.caller(),
            events: Mutex::new(driver),
            diagnostics: Mutex::new(Diagnostics::default()),
            lifetime: Lifetime::watch(task),
        }
    }

    /// Send any request and wait for its completion (a broadcast completes after the
    /// turnaround delay with no response).
    ///
    /// The job is checked here ([`master::Master::check_job`]) and started in the driver, which
    /// routes its one completion or failure event back here. If an earlier `request` future
    /// was dropped before its job ended, this job waits in the driver until that one has ended
    /// (its outcome is dropped), so every call gets its own job's outcome.
    pub async fn request(&self, unit: u8, request: &Request<'_>) -> Result<Completion, Error> {
        let job = Job::of(unit, request);
        let checked =
            CheckedRequest::new(unit, request).map_err(|reason| Error::Refused { job, reason })?;
        self.run(job, checked).await
    }

    /// Run a checked job in the driver ([`Caller::run_job`]; its end is recognised by the
    /// engine's [`JobEnd`](si_core::job::JobEnd) impl), naming `job` in its error.
    async fn run(&self, job: Job, checked: CheckedRequest) -> Result<Completion, Error> {
        self.keep_diagnostics();
        self.caller.run_job(checked).await.map_err(|e| match e {
            JobError::Refused(reason) => Error::Refused { job, reason },
            JobError::Failed(status) => Error::failed(job, status),
            JobError::Stopped => Error::Stopped,
        })
    }

    /// [`request`](Self::request), and what the job's attempts met ([`Attempts`]): a job that
    /// completed after a retry still shows the corrupt answer or the timeout before it. A job
    /// refused before it started met nothing. The attempts are read from the engine once the
    /// job has ended; with calls from several tasks, another job may have ended in between.
    pub async fn request_with_attempts(
        &self,
        unit: u8,
        request: &Request<'_>,
    ) -> (Result<Completion, Error>, Attempts) {
        let result = self.request(unit, request).await;
        if matches!(result, Err(Error::Refused { .. } | Error::Stopped)) {
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
        &self,
        unit_pdu: &[u8],
    ) -> (Result<Completion, Error>, Attempts) {
        let job = Job {
            unit: unit_pdu.first().copied().unwrap_or(0),
            function: unit_pdu.get(1).copied().unwrap_or(0),
            address: None,
        };
        let result = match CheckedRequest::pass_through(unit_pdu) {
            Ok(checked) => self.run(job, checked).await,
            Err(reason) => Err(Error::Refused { job, reason }),
        };
        if matches!(result, Err(Error::Refused { .. } | Error::Stopped)) {
            return (result, Attempts::default());
        }
        let attempts = self.call(|m, _| m.attempts()).await.unwrap_or_default();
        (result, attempts)
    }

    /// Move the diagnostics the driver has reported into the kept list.
    fn keep_diagnostics(&self) {
        let mut events = self.events.lock().unwrap_or_else(|e| e.into_inner());
        let mut kept = self.diagnostics.lock().unwrap_or_else(|e| e.into_inner());
        while let Some(event) = events.try_next_event() {
            if let MasterEvent::Diagnostic(s) = event {
                kept.keep(s);
            }
        }
    }

    /// Line diagnostics seen while waiting for jobs (unsolicited frames 0E50H, line errors in
    /// Normal mode), oldest first; taking them empties the list.
    pub fn take_diagnostics(&self) -> Vec<Status> {
        self.keep_diagnostics();
        self.diagnostics
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .take()
    }

    /// Diagnostics discarded because more than [`DIAGNOSTICS_KEPT`] piled up.
    pub fn diagnostics_dropped(&self) -> u64 {
        self.diagnostics
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .dropped()
    }

    /// Run `f` on the engine inside the driver (counters, state).
    pub async fn call<R: Send + 'static>(
        &self,
        f: impl FnOnce(&mut master::Master, Instant) -> R + Send + 'static,
    ) -> Result<R, Error> {
        Ok(self.caller.call(f).await?)
    }

    /// Wait until the line has closed (the port failed); its I/O result.
    pub async fn closed(&self) -> Result<(), Error> {
        Ok(self.lifetime.ended().await?)
    }

    /// Stop the master and wait until the port is released; the line's I/O result. A job
    /// still running is abandoned.
    pub async fn close(self) -> Result<(), Error> {
        let Master {
            caller,
            events,
            lifetime,
            ..
        } = self;
        drop((caller, events));
        Ok(lifetime.ended().await?)
    }
}

impl Client for Master {
    async fn exchange<T: Send>(
        &self,
        unit: u8,
        request: &Request<'_>,
        pick: impl FnOnce(Option<Response<'_>>) -> Option<T> + Send,
    ) -> Result<T, Error> {
        let c = self.request(unit, request).await?;
        pick(c.response()).ok_or_else(|| unexpected(unit, request))
    }
}
