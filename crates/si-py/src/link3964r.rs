//! `si_serial.Link3964R`: a 3964(R) link on a serial port (si-3964r's handle), `send` and
//! `recv` of blocks.

use crate::errors::{nothing_received, p3964r, range_error};
use crate::lifecycle::pymethods_with_close;
use crate::options::{narrow, port_options, seconds, settings};
use crate::runtime::{close_handle, runtime, shared, wait, with_handle, within, Data, Job, Shared};
use pyo3::prelude::*;
use pyo3_async_runtimes::tokio::future_into_py;
use si_3964r::tokio::{Handle, Sender};
use si_3964r::{Config, Priority};

/// The 3964(R) config from its keyword arguments (unchecked: `validate` checks the ranges).
#[allow(clippy::too_many_arguments)]
pub fn link_config(
    priority: &str,
    block_check: bool,
    char_delay: f64,
    ack_delay: Option<f64>,
    connection_attempts: i64,
    transmission_attempts: i64,
    max_block_len: i64,
    receive_buffer_blocks: i64,
    settings: si_core::SerialSettings,
) -> PyResult<Config> {
    let defaults = if block_check {
        Config::default()
    } else {
        Config::without_block_check()
    };
    Ok(Config {
        block_check,
        priority: match priority {
            "low" => Priority::Low,
            "high" => Priority::High,
            other => {
                return Err(crate::errors::argument_error(
                    "priority",
                    "low, high",
                    other,
                ))
            }
        },
        char_delay: seconds("char_delay", char_delay)?,
        ack_delay: match ack_delay {
            Some(s) => seconds("ack_delay", s)?,
            None => defaults.ack_delay,
        },
        connection_attempts: narrow("connection_attempts", connection_attempts)?,
        transmission_attempts: narrow("transmission_attempts", transmission_attempts)?,
        max_block_len: narrow("max_block_len", max_block_len)?,
        receive_buffer_blocks: narrow("receive_buffer_blocks", receive_buffer_blocks)?,
        settings,
        ..defaults
    })
}

/// A 3964(R) link on the serial port `port` ([ET200S SI] §2.9, Table 2-11): `send` a block
/// and wait for its acknowledgement, `recv` the next block received.
#[pyclass(frozen, module = "si_serial")]
pub struct Link3964R {
    sender: Sender,
    handle: Shared<Handle>,
}

pymethods_with_close! {
    aio, close = "Stops the link and releases the port. Idempotent.";
    impl Link3964R {
        #[new]
        #[pyo3(signature = (port, *, priority="low", block_check=true, char_delay=0.22,
            ack_delay=None, connection_attempts=6, transmission_attempts=6, max_block_len=200,
            receive_buffer_blocks=5, baud=9600, data_bits=8, parity="even", stop_bits=1, rx_latency=None))]
        #[allow(clippy::too_many_arguments)]
        fn new(
            port: &str,
            priority: &str,
            block_check: bool,
            char_delay: f64,
            ack_delay: Option<f64>,
            connection_attempts: i64,
            transmission_attempts: i64,
            max_block_len: i64,
            receive_buffer_blocks: i64,
            baud: i64,
            data_bits: i64,
            parity: &str,
            stop_bits: i64,
            rx_latency: Option<f64>,
        ) -> PyResult<Self> {
            let config = link_config(
                priority,
                block_check,
                char_delay,
                ack_delay,
                connection_attempts,
                transmission_attempts,
                max_block_len,
                receive_buffer_blocks,
                settings(baud, data_bits, parity, stop_bits)?,
            )?;
            config.validate().map_err(|e| range_error(&e, None))?;
            let options = port_options(rx_latency)?;
            let _entered = runtime().enter();
            let serial = si_core::port::open(port, &config.settings, &options)
                .map_err(|e| p3964r(si_3964r::tokio::Error::Io(e.into())))?;
            let handle = Handle::spawn(config, serial).map_err(p3964r)?;
            Ok(Link3964R {
                sender: handle.sender(),
                handle: shared(handle),
            })
        }

        /// Sends `data` as one block; returns once the partner acknowledged it (DLE), else raises
        /// with the manual's STATUS (NoResponseError for 0703H/0707H, ProtocolError for a NAK).
        fn send(&self, py: Python<'_>, data: Vec<u8>) -> PyResult<()> {
            wait(py, self.send_job(data))
        }

        /// `send` as an awaitable (`si_serial.aio`).
        fn _aio_send<'py>(&self, py: Python<'py>, data: Vec<u8>) -> PyResult<Bound<'py, PyAny>> {
            future_into_py(py, self.send_job(data))
        }

        /// The next block received, waiting up to `timeout` seconds (None: for ever); raises
        /// NoResponseError when none came, InvalidResponseError for a receive error (BCC …).
        #[pyo3(signature = (timeout=None))]
        fn recv(&self, py: Python<'_>, timeout: Option<f64>) -> PyResult<Data> {
            wait(py, self.recv_job(timeout)?)
        }

        /// `recv` as an awaitable (`si_serial.aio`).
        #[pyo3(signature = (timeout=None))]
        fn _aio_recv<'py>(
            &self,
            py: Python<'py>,
            timeout: Option<f64>,
        ) -> PyResult<Bound<'py, PyAny>> {
            future_into_py(py, self.recv_job(timeout)?)
        }
    }
}

impl Link3964R {
    fn send_job(&self, data: Vec<u8>) -> Job<()> {
        let sender = self.sender.clone();
        Box::pin(async move { sender.send(data).await.map_err(p3964r) })
    }

    fn recv_job(&self, timeout: Option<f64>) -> PyResult<Job<Data>> {
        let limit = timeout.map(|t| seconds("timeout", t)).transpose()?;
        Ok(Box::pin(with_handle(
            self.handle.clone(),
            "link",
            async move |h: &mut Handle| match within(limit, h.recv()).await {
                Some(r) => r.map(|b| Data::Owned(b.to_vec())).map_err(p3964r),
                None => Err(nothing_received(timeout.unwrap_or_default())),
            },
        )))
    }

    fn close_job(&self) -> Job<()> {
        Box::pin(close_handle(self.handle.clone(), async |h: Handle| {
            h.close().await
        }))
    }
}
