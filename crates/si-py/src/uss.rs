//! `si_serial.UssMaster`: the USS master on a serial port (si-uss's handle): parameter jobs,
//! the control words it sends, the status words it receives, and the cycle's events.

use crate::errors::{argument_error, uss};
use crate::lifecycle::pymethods_with_close;
use crate::options::{narrow, port_options, seconds, settings_error};
use crate::runtime::{close_handle, runtime, shared, wait, with_handle, within, Job, Shared};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use pyo3_async_runtimes::tokio::future_into_py;
use si_uss::config::{uss_settings, MasterConfig, PollEntry};
use si_uss::frame::PkwWords;
use si_uss::master::{Event, Width};
use si_uss::tokio::Handle;

/// A polling list entry from `(address, pkw_words, pzd_words)`; PKW words 0, 3, 4 or 127
/// (variable, as the USS protocol writes it).
fn poll_entry((address, pkw, pzd): (i64, i64, i64)) -> PyResult<PollEntry> {
    let pkw = match pkw {
        0 => PkwWords::None,
        3 => PkwWords::Three,
        4 => PkwWords::Four,
        127 => PkwWords::Variable,
        other => {
            return Err(argument_error(
                "nodes",
                "PKW words 0, 3, 4 or 127 (variable)",
                other,
            ))
        }
    };
    Ok(PollEntry::new(
        narrow("nodes", address)?,
        pkw,
        narrow("nodes", pzd)?,
    ))
}

/// An event that becomes a dict ([`event_dict`]) once it reaches Python, as an awaited job's
/// result does.
struct EventDict(Event);

impl<'py> IntoPyObject<'py> for EventDict {
    type Target = PyDict;
    type Output = Bound<'py, PyDict>;
    type Error = PyErr;

    fn into_pyobject(self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        event_dict(py, &self.0)
    }
}

/// An event as a dict: `kind` and its fields.
fn event_dict<'py>(py: Python<'py>, event: &Event) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    match event {
        Event::Response {
            cycle,
            address,
            net,
        } => {
            d.set_item("kind", "response")?;
            d.set_item("cycle", cycle)?;
            d.set_item("address", address)?;
            d.set_item("pzd", net.pzd.words().to_vec())?;
        }
        Event::NoAnswer { cycle, address } => {
            d.set_item("kind", "no_answer")?;
            d.set_item("cycle", cycle)?;
            d.set_item("address", address)?;
        }
        Event::Rejected {
            cycle,
            address,
            status,
            ..
        } => {
            d.set_item("kind", "rejected")?;
            d.set_item("cycle", cycle)?;
            d.set_item("address", address)?;
            d.set_item("status", status.code())?;
            d.set_item("status_text", status.to_string())?;
        }
        Event::CycleDone { cycle } => {
            d.set_item("kind", "cycle_done")?;
            d.set_item("cycle", cycle)?;
        }
        other => {
            d.set_item("kind", "other")?;
            d.set_item("text", format!("{other:?}"))?;
        }
    }
    Ok(d)
}

/// The USS master on the serial port `port` ([Modbus/USS] §3.8), polling `nodes`, a list of
/// `(address, pkw_words, pzd_words)`, cyclically from the moment it is built.
#[pyclass(frozen, module = "si_serial")]
pub struct UssMaster {
    handle: Shared<Handle>,
}

pymethods_with_close! {
    aio, close = "Stops polling and releases the port. Idempotent.";
    impl UssMaster {
        #[new]
        #[pyo3(signature = (port, nodes, *, response_timeout=0.02, retries=20, cycle_pause=0.0,
            baud=9600, rx_latency=None))]
        fn new(
            port: &str,
            nodes: Vec<(i64, i64, i64)>,
            response_timeout: f64,
            retries: i64,
            cycle_pause: f64,
            baud: i64,
            rx_latency: Option<f64>,
        ) -> PyResult<Self> {
            let list = nodes
                .into_iter()
                .map(poll_entry)
                .collect::<PyResult<Vec<_>>>()?;
            let config = MasterConfig {
                settings: uss_settings(narrow("baud", baud)?).map_err(|e| settings_error(&e))?,
                response_timeout: seconds("response_timeout", response_timeout)?,
                retries: narrow("retries", retries)?,
                cycle_pause: seconds("cycle_pause", cycle_pause)?,
                ..MasterConfig::new(list)
            };
            config.validate().map_err(|e| uss(e.into()))?;
            let options = port_options(rx_latency)?;
            let _entered = runtime().enter();
            let serial = si_core::port::open(port, &config.settings, &options)
                .map_err(|e| uss(si_uss::tokio::Error::Io(e.into())))?;
            let handle = Handle::spawn(config, serial).map_err(uss)?;
            Ok(UssMaster {
                handle: shared(handle),
            })
        }

        /// Reads parameter `number` (element `index`) of node `node` (PKW task 1).
        #[pyo3(signature = (node, number, index=0))]
        fn read_parameter(
            &self,
            py: Python<'_>,
            node: i64,
            number: i64,
            index: i64,
        ) -> PyResult<u32> {
            wait(py, self.read_job(node, number, index)?)
        }

        /// `read_parameter` as an awaitable (`si_serial.aio`).
        #[pyo3(signature = (node, number, index=0))]
        fn _aio_read_parameter<'py>(
            &self,
            py: Python<'py>,
            node: i64,
            number: i64,
            index: i64,
        ) -> PyResult<Bound<'py, PyAny>> {
            future_into_py(py, self.read_job(node, number, index)?)
        }

        /// Writes `value` to parameter `number` of node `node` (task 2, or 3 with `double=True`);
        /// returns the value the drive answered.
        #[pyo3(signature = (node, number, value, index=0, double=false))]
        fn write_parameter(
            &self,
            py: Python<'_>,
            node: i64,
            number: i64,
            value: u32,
            index: i64,
            double: bool,
        ) -> PyResult<u32> {
            wait(py, self.write_job(node, number, value, index, double)?)
        }

        /// `write_parameter` as an awaitable (`si_serial.aio`).
        #[pyo3(signature = (node, number, value, index=0, double=false))]
        fn _aio_write_parameter<'py>(
            &self,
            py: Python<'py>,
            node: i64,
            number: i64,
            value: u32,
            index: i64,
            double: bool,
        ) -> PyResult<Bound<'py, PyAny>> {
            future_into_py(py, self.write_job(node, number, value, index, double)?)
        }

        /// Sets the PZD the master sends to `node` from the next poll on: control word STW,
        /// main setpoint HSW, …
        fn set_control(&self, py: Python<'_>, node: i64, words: Vec<u16>) -> PyResult<()> {
            let node = narrow("node", node)?;
            wait(
                py,
                with_handle(
                    self.handle.clone(),
                    "master",
                    async move |h: &mut Handle| h.set_control(node, words).await.map_err(uss),
                ),
            )
        }

        /// The PZD `node` answered last: status word ZSW, main actual value HIW, …
        fn get_status(&self, py: Python<'_>, node: i64) -> PyResult<Vec<u16>> {
            let node: u8 = narrow("node", node)?;
            wait(
                py,
                with_handle(
                    self.handle.clone(),
                    "master",
                    async move |h: &mut Handle| {
                        h.call(move |m, _| m.slave(node).map(|s| s.status.words().to_vec()))
                            .await
                            .map_err(uss)?
                            .ok_or_else(|| {
                                argument_error("node", "a node of the polling list", node)
                            })
                    },
                ),
            )
        }

        /// The next event of the cycle (a dict with `kind` "response", "no_answer", "rejected",
        /// "cycle_done" or "other"), waiting up to `timeout` seconds; None if none came. Jobs
        /// from other threads wait while it waits.
        #[pyo3(signature = (timeout=1.0))]
        fn next_event<'py>(
            &self,
            py: Python<'py>,
            timeout: f64,
        ) -> PyResult<Option<Bound<'py, PyDict>>> {
            let event = wait(py, self.event_job(timeout)?)?;
            event.map(|e| event_dict(py, &e.0)).transpose()
        }

        /// `next_event` as an awaitable (`si_serial.aio`).
        #[pyo3(signature = (timeout=1.0))]
        fn _aio_next_event<'py>(
            &self,
            py: Python<'py>,
            timeout: f64,
        ) -> PyResult<Bound<'py, PyAny>> {
            future_into_py(py, self.event_job(timeout)?)
        }
    }
}

impl UssMaster {
    fn read_job(&self, node: i64, number: i64, index: i64) -> PyResult<Job<u32>> {
        let (node, number, index) = (
            narrow("node", node)?,
            narrow("number", number)?,
            narrow("index", index)?,
        );
        Ok(Box::pin(with_handle(
            self.handle.clone(),
            "master",
            async move |h: &mut Handle| h.read_parameter(node, number, index).await.map_err(uss),
        )))
    }

    fn write_job(
        &self,
        node: i64,
        number: i64,
        value: u32,
        index: i64,
        double: bool,
    ) -> PyResult<Job<u32>> {
        let (node, number, index) = (
            narrow("node", node)?,
            narrow("number", number)?,
            narrow("index", index)?,
        );
        let width = if double {
            Width::DoubleWord
        } else {
            Width::Word
        };
        Ok(Box::pin(with_handle(
            self.handle.clone(),
            "master",
            async move |h: &mut Handle| {
                h.write_parameter(node, number, index, value, width)
                    .await
                    .map_err(uss)
            },
        )))
    }

    fn event_job(&self, timeout: f64) -> PyResult<Job<Option<EventDict>>> {
        let limit = seconds("timeout", timeout)?;
        Ok(Box::pin(with_handle(
            self.handle.clone(),
            "master",
            async move |h: &mut Handle| {
                Ok(within(Some(limit), h.next_event())
                    .await
                    .flatten()
                    .map(EventDict))
            },
        )))
    }

    fn close_job(&self) -> Job<()> {
        Box::pin(close_handle(self.handle.clone(), async |h: Handle| {
            h.close().await
        }))
    }
}
