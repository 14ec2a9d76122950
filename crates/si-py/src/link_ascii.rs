//! `si_serial.AsciiLink`: the ASCII driver on a serial port (si-ascii's handle), `send` and
//! `recv` of frames with the end criterion of the config.

use crate::errors::{argument_error, ascii, nothing_received, ProtocolError};
use crate::options::{narrow, port_options, seconds, settings};
use crate::runtime::{runtime, wait};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyTuple};
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
    handle: tokio::sync::Mutex<Option<Handle>>,
}

#[pymethods]
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
            handle: tokio::sync::Mutex::new(Some(handle)),
        })
    }

    /// Sends `data` as one frame (the end characters, if any, are the caller's to include);
    /// returns once it is on the line.
    fn send(&self, py: Python<'_>, data: Vec<u8>) -> PyResult<()> {
        wait(py, async {
            let guard = self.handle.lock().await;
            let handle = guard
                .as_ref()
                .ok_or_else(|| ProtocolError::new_err("the link is closed"))?;
            handle.send(data).await.map_err(ascii)
        })
    }

    /// The next frame received, waiting up to `timeout` seconds (None: for ever); raises
    /// NoResponseError when none came, InvalidResponseError for a receive error. A `send`
    /// from another thread waits while a `recv` waits.
    #[pyo3(signature = (timeout=None))]
    fn recv<'py>(&self, py: Python<'py>, timeout: Option<f64>) -> PyResult<Bound<'py, PyBytes>> {
        let limit = timeout.map(|t| seconds("timeout", t)).transpose()?;
        let frame = wait(py, async {
            let mut guard = self.handle.lock().await;
            let handle = guard
                .as_mut()
                .ok_or_else(|| ProtocolError::new_err("the link is closed"))?;
            let received = match limit {
                Some(l) => tokio::time::timeout(l.into(), handle.recv()).await.ok(),
                None => Some(handle.recv().await),
            };
            match received {
                Some(r) => r.map_err(ascii),
                None => Err(nothing_received(timeout.unwrap_or_default())),
            }
        })?;
        Ok(PyBytes::new(py, &frame))
    }

    /// Stops the link and releases the port. Idempotent.
    fn close(&self, py: Python<'_>) {
        wait(py, async {
            if let Some(handle) = self.handle.lock().await.take() {
                handle.close().await;
            }
        });
    }

    fn __enter__(slf: Py<Self>) -> Py<Self> {
        slf
    }

    #[pyo3(signature = (*_args))]
    fn __exit__(&self, py: Python<'_>, _args: &Bound<'_, PyTuple>) -> bool {
        self.close(py);
        false
    }
}
