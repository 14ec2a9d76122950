//! The DP window ([ET200S SI 2005] §2.12): `WindowHost`, the master's side of the
//! coordination-byte protocol (si-dp-coord's host engine), which a test rig drives with the
//! input window it read from the DP master card each cycle; and `WindowModule`, the module's
//! side with a loopback serial line, to test a rig without a module.

use crate::errors::{argument_error, range_error, ProtocolError, SiError};
use crate::options::seconds;
use pyo3::prelude::*;
use pyo3::types::PyBytes;
use si_core::Instant;
use si_dp_coord::{
    Host, HostConfig, Job, JobId, LoopbackSerial, Module, ModuleConfig, Outcome, WindowSize,
};

fn window_size(bytes: i64) -> PyResult<WindowSize> {
    match bytes {
        4 => Ok(WindowSize::Four),
        8 => Ok(WindowSize::Eight),
        32 => Ok(WindowSize::ThirtyTwo),
        other => Err(argument_error("window", "4, 8 or 32 bytes", other)),
    }
}

fn at(now: f64) -> PyResult<Instant> {
    Ok(Instant::ZERO + seconds("now", now)?)
}

/// The host side of the window: submit jobs (`send`, `receive`), call `cycle` once per DP
/// cycle with the input window and write the output window it returns to the module, then
/// collect each job's `result`.
#[pyclass(unsendable, module = "si_serial")]
pub struct WindowHost {
    host: Host,
}

#[pymethods]
impl WindowHost {
    #[new]
    #[pyo3(signature = (*, window=8))]
    fn new(window: i64) -> PyResult<Self> {
        let host =
            Host::new(HostConfig::new(window_size(window)?)).map_err(|e| range_error(&e, None))?;
        Ok(WindowHost { host })
    }

    /// Queues a send job of `data`; returns its job number.
    fn send(&mut self, data: Vec<u8>) -> PyResult<u64> {
        self.submit(Job::Send(data.into()))
    }

    /// Queues a receive job; returns its job number.
    fn receive(&mut self) -> PyResult<u64> {
        self.submit(Job::Receive)
    }

    /// One DP cycle at `now` seconds: `input` is the input window read from the module; the
    /// result is the output window to write to it.
    fn cycle<'py>(
        &mut self,
        py: Python<'py>,
        now: f64,
        input: &[u8],
    ) -> PyResult<Bound<'py, PyBytes>> {
        Ok(PyBytes::new(py, self.host.cycle(at(now)?, input)))
    }

    /// Job `job`'s outcome once it has ended: None while it runs, bytes for a receive (empty:
    /// no message), True for a send; raises with the STATUS the window reported.
    fn result(&mut self, py: Python<'_>, job: u64) -> PyResult<Option<Py<PyAny>>> {
        let Some(outcome) = self.host.take_completion(JobId(job)) else {
            return Ok(None);
        };
        match outcome {
            Ok(Outcome::Received(data)) => Ok(Some(PyBytes::new(py, &data).into_any().unbind())),
            Ok(Outcome::NoMessage) => Ok(Some(PyBytes::new(py, b"").into_any().unbind())),
            Ok(_) => Ok(Some(true.into_pyobject(py)?.to_owned().into_any().unbind())),
            Err(status) => {
                let err = ProtocolError::new_err(format!("window job {job}: {status}"));
                err.value(py).setattr("status", status.code())?;
                err.value(py).setattr("status_text", status.to_string())?;
                Err(err)
            }
        }
    }
}

impl WindowHost {
    fn submit(&mut self, job: Job) -> PyResult<u64> {
        self.host
            .submit(job)
            .map(|id| id.0)
            .map_err(|e| SiError::new_err(format!("{e} ({})", e.status())))
    }
}

/// The module's side of the window with a loopback serial line (what it sends it receives):
/// `cycle` it with the host's output window to get the input window.
#[pyclass(unsendable, module = "si_serial")]
pub struct WindowModule {
    module: Module<LoopbackSerial>,
}

#[pymethods]
impl WindowModule {
    #[new]
    #[pyo3(signature = (*, window=8))]
    fn new(window: i64) -> PyResult<Self> {
        let module = Module::new(
            ModuleConfig::new(window_size(window)?),
            LoopbackSerial::new(),
        )
        .map_err(|e| range_error(&e, None))?;
        Ok(WindowModule { module })
    }

    /// One DP cycle at `now` seconds: `output` is the host's output window; the result is the
    /// module's input window.
    fn cycle<'py>(
        &mut self,
        py: Python<'py>,
        now: f64,
        output: &[u8],
    ) -> PyResult<Bound<'py, PyBytes>> {
        Ok(PyBytes::new(py, self.module.cycle(at(now)?, output)))
    }
}
