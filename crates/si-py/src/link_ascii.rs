//! `si_serial.AsciiLink`: the ASCII driver on a serial port (si-ascii's handle), `send` and
//! `recv` of frames with the end criterion of the config.

use crate::errors::{argument_error, ascii, nothing_received};
use crate::lifecycle::pymethods_with_close;
use crate::options::{narrow, port_options, seconds, settings};
use crate::runtime::{close_handle, runtime, shared, wait, with_handle, within, Data, Job, Shared};
use pyo3::prelude::*;
use pyo3_async_runtimes::tokio::future_into_py;
use si_ascii::config::{EndCriterion, FlowControl};
use si_ascii::tokio::Handle;
use si_ascii::Config;

/// The frame end from the keyword arguments.
fn end_criterion(end: &str, end_chars: (i64, i64), fixed_length: i64) -> PyResult<EndCriterion> {
    Ok(match end {
        "char-delay" => EndCriterion::CharDelay,
        "end-chars" => EndCriterion::EndChars {
            first: narrow("end_chars", end_chars.0)?,
            second: narrow("end_chars", end_chars.1)?,
        },
        "fixed-length" => EndCriterion::FixedLength {
            len: narrow("fixed_length", fixed_length)?,
        },
        other => {
            return Err(argument_error(
                "end",
                "char-delay, end-chars, fixed-length",
                other,
            ))
        }
    })
}

/// The ASCII driver on the serial port `port` ([ET200S SI] §2.8, Table 2-10): `send` a frame,
/// `recv` the next frame cut by the configured end criterion.
#[pyclass(frozen, module = "si_serial")]
pub struct AsciiLink {
    handle: Shared<Handle>,
}

pymethods_with_close! {
    aio, close = "Stops the link and releases the port. Idempotent.";
    impl AsciiLink {
        #[new]
        #[pyo3(signature = (port, *, end="char-delay", end_chars=(3, 0), fixed_length=100,
            char_delay=0.004, max_frame_len=200, flow_control="none", baud=9600, data_bits=8,
            parity="even", stop_bits=1, rx_latency=None))]
        #[allow(clippy::too_many_arguments)]
        fn new(
            port: &str,
            end: &str,
            end_chars: (i64, i64),
            fixed_length: i64,
            char_delay: f64,
            max_frame_len: i64,
            flow_control: &str,
            baud: i64,
            data_bits: i64,
            parity: &str,
            stop_bits: i64,
            rx_latency: Option<f64>,
        ) -> PyResult<Self> {
            let config = Config {
                settings: settings(baud, data_bits, parity, stop_bits)?,
                end: end_criterion(end, end_chars, fixed_length)?,
                char_delay: seconds("char_delay", char_delay)?,
                max_frame_len: narrow("max_frame_len", max_frame_len)?,
                flow_control: match flow_control {
                    "none" => FlowControl::None,
                    "xon-xoff" => FlowControl::XonXoff,
                    "rts-cts" => FlowControl::RtsCts,
                    "auto-v24" => FlowControl::AutoV24,
                    other => {
                        return Err(argument_error(
                            "flow_control",
                            "none, xon-xoff, rts-cts, auto-v24",
                            other,
                        ))
                    }
                },
                ..Config::default()
            };
            config.validate().map_err(|e| ascii(e.into()))?;
            let options = port_options(rx_latency)?;
            let _entered = runtime().enter();
            let serial = si_core::port::open(port, &config.settings, &options)
                .map_err(|e| ascii(si_ascii::tokio::Error::Io(e.into())))?;
            let handle = Handle::spawn(config, serial).map_err(ascii)?;
            Ok(AsciiLink {
                handle: shared(handle),
            })
        }

        /// Sends `data` as one frame (the end characters, if any, are the caller's to include);
        /// returns once it is on the line. A `send` from another thread waits while a `recv`
        /// waits.
        fn send(&self, py: Python<'_>, data: Vec<u8>) -> PyResult<()> {
            wait(py, self.send_job(data))
        }

        /// `send` as an awaitable (`si_serial.aio`).
        fn _aio_send<'py>(&self, py: Python<'py>, data: Vec<u8>) -> PyResult<Bound<'py, PyAny>> {
            future_into_py(py, self.send_job(data))
        }

        /// The next frame received, waiting up to `timeout` seconds (None: for ever); raises
        /// NoResponseError when none came, InvalidResponseError for a receive error.
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

impl AsciiLink {
    fn send_job(&self, data: Vec<u8>) -> Job<()> {
        Box::pin(with_handle(
            self.handle.clone(),
            "link",
            async move |h: &mut Handle| h.send(data).await.map_err(ascii),
        ))
    }

    fn recv_job(&self, timeout: Option<f64>) -> PyResult<Job<Data>> {
        let limit = timeout.map(|t| seconds("timeout", t)).transpose()?;
        Ok(Box::pin(with_handle(
            self.handle.clone(),
            "link",
            async move |h: &mut Handle| match within(limit, h.recv()).await {
                Some(r) => r.map(|b| Data::Owned(b.to_vec())).map_err(ascii),
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
