//! `si_serial.Rk512Station`: an RK 512 station on a serial port (si-rk512's handle): `send`
//! and `fetch` as the active side, and, with `serve=True`, the passive partner answering the
//! other side's jobs from its own memory.

use crate::errors::{argument_error, range_error, rk512};
use crate::lifecycle::pymethods_with_close;
use crate::link3964r::link_config;
use crate::options::{narrow, port_options, seconds, settings};
use crate::runtime::{close_handle, runtime, shared, wait, with_handle, Data, Job, Shared};
use crate::store_class::area;
use pyo3::prelude::*;
use pyo3_async_runtimes::tokio::future_into_py;
use si_core::memory::MemorySizes;
use si_rk512::area::{Area, UnknownArea};
use si_rk512::frame::{Address, Coordination};
use si_rk512::passive::ServerConfig;
use si_rk512::tokio::Handle;
use si_rk512::{Config, Station};
use std::collections::BTreeMap;

/// The RK 512 address of a job: `area` by name (si-rk512's `Area`: "DBn", "DXn", "E"/"I",
/// "A"/"Q", "M"/"F", "T", "Z"/"C"), `start` the data word in a DB or DX, else the byte or cell
/// number ([CP 341] §2.2.3, Table 2-1).
pub fn address(area: &str, start: i64) -> PyResult<Address> {
    let area: Area = area
        .parse()
        .map_err(|e: UnknownArea| argument_error("area", Area::NAMES, e.value))?;
    u16::try_from(start)
        .ok()
        .and_then(|s| area.at(s).ok())
        .ok_or_else(|| argument_error("start", &format!("0 … {}", area.max_start()), start))
}

/// The exception for a failed job; for 051AH "command telegram not sent" with the 3964(R)
/// error that caused it, which the station keeps ([CP 341 Diag] §8.1).
async fn job_error(h: &Handle, e: si_rk512::tokio::Error) -> PyErr {
    let cause = match e.status() {
        Some(s) if s == si_rk512::status::COMMAND_NOT_SENT => {
            h.call(|s, _| s.last_cause()).await.ok().flatten()
        }
        _ => None,
    };
    rk512(e, cause)
}

/// An RK 512 station on the serial port `port`: the 3964(R) keyword arguments of
/// `Link3964R`, plus `response_timeout` (TRES, 0.01 … 655.35 s, default 10) and
/// `max_job_len` (2 … 65534 bytes, default 1024). With `serve=True` it also serves the
/// partner's SEND and FETCH jobs from its own memory (`dbs` {number: bytes}, and the byte
/// sizes of `inputs`, `outputs`, `flags`, cells of `timers`, `counters`).
#[pyclass(frozen, module = "si_serial")]
pub struct Rk512Station {
    handle: Shared<Handle>,
}

pymethods_with_close! {
    aio, close = "Stops the station and releases the port. Idempotent.";
    impl Rk512Station {
        #[new]
        #[pyo3(signature = (port, *, serve=false, dbs=None, inputs=None, outputs=None, flags=None,
            timers=None, counters=None, response_timeout=10.0, max_job_len=1024, priority="low",
            block_check=true, char_delay=0.22, ack_delay=None, connection_attempts=6,
            transmission_attempts=6, max_block_len=200, receive_buffer_blocks=5, baud=9600,
            data_bits=8, parity="even", stop_bits=1, rx_latency=None))]
        #[allow(clippy::too_many_arguments)]
        fn new(
            port: &str,
            serve: bool,
            dbs: Option<BTreeMap<u16, u32>>,
            inputs: Option<u32>,
            outputs: Option<u32>,
            flags: Option<u32>,
            timers: Option<u32>,
            counters: Option<u32>,
            response_timeout: f64,
            max_job_len: i64,
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
            let line = settings(baud, data_bits, parity, stop_bits)?;
            let config = Config {
                link: link_config(
                    priority,
                    block_check,
                    char_delay,
                    ack_delay,
                    connection_attempts,
                    transmission_attempts,
                    max_block_len,
                    receive_buffer_blocks,
                    line,
                )?,
                response_timeout: seconds("response_timeout", response_timeout)?,
                max_job_len: narrow("max_job_len", max_job_len)?,
                ..Config::default()
            };
            config.validate().map_err(|e| range_error(&e, None))?;
            let station = if serve {
                let defaults = MemorySizes::default();
                let memory = MemorySizes {
                    inputs: inputs.unwrap_or(defaults.inputs),
                    outputs: outputs.unwrap_or(defaults.outputs),
                    flags: flags.unwrap_or(defaults.flags),
                    timers: timers.unwrap_or(defaults.timers),
                    counters: counters.unwrap_or(defaults.counters),
                    dbs: dbs.unwrap_or(defaults.dbs),
                };
                memory.check().map_err(|e| range_error(&e, None))?;
                let server = ServerConfig {
                    memory,
                    ..ServerConfig::default()
                };
                Station::serving(config.with_settings(line), &server)
            } else {
                Station::new(config.with_settings(line))
            }
            .map_err(|e| range_error(&e, None))?;
            let options = port_options(rx_latency)?;
            let _entered = runtime().enter();
            let serial = si_core::port::open(port, &line, &options)
                .map_err(|e| rk512(si_rk512::tokio::Error::Io(e.into()), None))?;
            Ok(Rk512Station {
                handle: shared(Handle::spawn_engine(station, serial)),
            })
        }

        /// SEND: writes `data` into the partner's `area` from `start` (DB/DX: data word; I, Q, M:
        /// byte; T, C: cell); returns once the partner's reaction telegram reported success.
        fn send(&self, py: Python<'_>, area: &str, start: i64, data: Vec<u8>) -> PyResult<()> {
            wait(py, self.send_job(area, start, data)?)
        }

        /// `send` as an awaitable (`si_serial.aio`).
        fn _aio_send<'py>(
            &self,
            py: Python<'py>,
            area: &str,
            start: i64,
            data: Vec<u8>,
        ) -> PyResult<Bound<'py, PyAny>> {
            future_into_py(py, self.send_job(area, start, data)?)
        }

        /// FETCH: reads `length` bytes from the partner's `area` from `start`.
        fn fetch(&self, py: Python<'_>, area: &str, start: i64, length: usize) -> PyResult<Data> {
            wait(py, self.fetch_job(area, start, length)?)
        }

        /// `fetch` as an awaitable (`si_serial.aio`).
        fn _aio_fetch<'py>(
            &self,
            py: Python<'py>,
            area: &str,
            start: i64,
            length: usize,
        ) -> PyResult<Bound<'py, PyAny>> {
            future_into_py(py, self.fetch_job(area, start, length)?)
        }

        /// `count` bytes of this station's own memory (`serve=True`): `area` "DBn", "I", "Q",
        /// "M", "T", "C" from byte `start`.
        fn read_memory(
            &self,
            py: Python<'_>,
            area: &str,
            start: u32,
            count: usize,
        ) -> PyResult<Data> {
            let area = self::area(area)?;
            wait(
                py,
                with_handle(
                    self.handle.clone(),
                    "station",
                    async move |h: &mut Handle| {
                        h.with_server(move |s| {
                            let mut out = vec![0; count];
                            s.memory()
                                .read(area, start, &mut out)
                                .map(|()| out)
                                .map_err(|e| e.to_string())
                        })
                        .await
                        .map_err(|e| rk512(e, None))?
                        .map(Data::Owned)
                        .map_err(|e| argument_error("start", &e, start))
                    },
                ),
            )
        }

        /// Writes `data` into this station's own memory from byte `start` of `area`.
        fn write_memory(
            &self,
            py: Python<'_>,
            area: &str,
            start: u32,
            data: Vec<u8>,
        ) -> PyResult<()> {
            let area = self::area(area)?;
            wait(
                py,
                with_handle(
                    self.handle.clone(),
                    "station",
                    async move |h: &mut Handle| {
                        h.with_server(move |s| {
                            s.memory_mut()
                                .write(area, start, &data)
                                .map_err(|e| e.to_string())
                        })
                        .await
                        .map_err(|e| rk512(e, None))?
                        .map_err(|e| argument_error("start", &e, start))
                    },
                ),
            )
        }
    }
}

impl Rk512Station {
    fn send_job(&self, area: &str, start: i64, data: Vec<u8>) -> PyResult<Job<()>> {
        let at = address(area, start)?;
        Ok(Box::pin(with_handle(
            self.handle.clone(),
            "station",
            async move |h: &mut Handle| match h.send(at, Coordination::NONE, data).await {
                Ok(()) => Ok(()),
                Err(e) => Err(job_error(h, e).await),
            },
        )))
    }

    fn fetch_job(&self, area: &str, start: i64, length: usize) -> PyResult<Job<Data>> {
        let at = address(area, start)?;
        Ok(Box::pin(with_handle(
            self.handle.clone(),
            "station",
            async move |h: &mut Handle| match h.fetch(at, Coordination::NONE, length).await {
                Ok(data) => Ok(Data::Owned(data.to_vec())),
                Err(e) => Err(job_error(h, e).await),
            },
        )))
    }

    fn close_job(&self) -> Job<()> {
        Box::pin(close_handle(self.handle.clone(), async |h: Handle| {
            h.close().await
        }))
    }
}
