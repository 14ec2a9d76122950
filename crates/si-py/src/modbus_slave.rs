//! The Modbus slave on a serial port (si-modbus's slave handle) and the Modbus TCP server,
//! both serving a [`ModbusStore`]. A task per slave keeps its events, so an unread event never
//! pauses the line: the newest 1024 wait for `next_event`, older ones are dropped.

use crate::callback_store::{CallbackStore, Callbacks};
use crate::errors::{argument_error, modbus, SiError};
use crate::lifecycle::pymethods_with_close;
use crate::modbus_config::{self, LineArgs};
use crate::options::{narrow, port_options, seconds};
use crate::runtime::{runtime, wait, Job};
use crate::store_class::ModbusStore;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use si_modbus::slave::SlaveEvent;
use si_modbus::tokio::{tcp, Error as ModbusError, Slave};
use std::sync::Mutex;
use tokio::sync::{mpsc, oneshot};
use tokio::task::JoinHandle;

/// Events kept for `next_event`.
const EVENTS_KEPT: usize = 1024;

/// A running service: its stop signal and the task that ends once the port is released,
/// with the line's I/O result.
struct Running {
    stop: oneshot::Sender<()>,
    task: JoinHandle<Result<(), ModbusError>>,
}

/// Stops a service (once); the job ends when its port or socket is released, with the
/// line's error if it failed (SiError).
fn stop(running: &Mutex<Option<Running>>) -> Job<()> {
    let taken = running.lock().unwrap_or_else(|e| e.into_inner()).take();
    Box::pin(async move {
        let Some(Running { stop, task }) = taken else {
            return Ok(());
        };
        // Err: the service ended already (its line failed), its result is in the task.
        let _ = stop.send(());
        match task.await {
            Ok(closed) => closed.map_err(modbus),
            Err(ended) => Err(SiError::new_err(format!(
                "the service's task ended: {ended}"
            ))),
        }
    })
}

/// The callbacks, each checked to be callable (else ConfigError naming it).
fn callbacks(
    py: Python<'_>,
    on_read: Option<Py<PyAny>>,
    on_write: Option<Py<PyAny>>,
) -> PyResult<Callbacks> {
    for (name, callback) in [("on_read", &on_read), ("on_write", &on_write)] {
        if let Some(c) = callback.as_ref().filter(|c| !c.bind(py).is_callable()) {
            let type_name = c.bind(py).get_type().name()?;
            return Err(argument_error(name, "a callable or None", type_name));
        }
    }
    Ok(Callbacks { on_read, on_write })
}

/// An event as a dict: `kind` ("served", "broadcast", "exception", "error") and its fields.
fn event_dict<'py>(py: Python<'py>, event: &SlaveEvent) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    match *event {
        SlaveEvent::Served {
            function,
            address,
            quantity,
        }
        | SlaveEvent::Broadcast {
            function,
            address,
            quantity,
        } => {
            let kind = if matches!(event, SlaveEvent::Served { .. }) {
                "served"
            } else {
                "broadcast"
            };
            d.set_item("kind", kind)?;
            d.set_item("function", function)?;
            d.set_item("address", address)?;
            d.set_item("quantity", quantity)?;
        }
        SlaveEvent::Exception {
            function,
            code,
            status,
            ..
        } => {
            d.set_item("kind", "exception")?;
            d.set_item("function", function)?;
            d.set_item("exception_code", code.code())?;
            d.set_item("status", status.map(|s| s.code()))?;
        }
        SlaveEvent::Error(status) => {
            d.set_item("kind", "error")?;
            d.set_item("status", status.code())?;
            d.set_item("status_text", status.to_string())?;
        }
    }
    Ok(d)
}

/// A Modbus RTU slave on a serial port serving `store` (default: plain tables) at `address`
/// ([Modbus/USS] §3.5.4, Table 3-20); it answers until `close()`.
///
/// `on_read(table, address, count)` returns `count` values, registers as ints, bits by their
/// truth (or None: the store answers);
/// `on_write(table, address, values)` sees a write before the store takes it. They run on
/// the module's threads with the GIL held only meanwhile; one that raises answers the master
/// with exception 04, SERVER DEVICE FAILURE ([Modbus AP] §7), and the slave keeps serving.
#[pyclass(frozen, module = "si_serial")]
pub struct ModbusSlave {
    store: Py<ModbusStore>,
    events: tokio::sync::Mutex<mpsc::Receiver<SlaveEvent>>,
    running: Mutex<Option<Running>>,
}

pymethods_with_close! {
    close = "Stops answering and releases the port (raises if the line failed). Idempotent.";
    impl ModbusSlave {
        #[new]
        #[pyo3(signature = (port, *, address=222, store=None, baud=9600, data_bits=8, parity="even",
            stop_bits=1, mode="normal", char_delay_multiplier=1, rx_latency=None, frame_end="gap",
            on_read=None, on_write=None))]
        #[allow(clippy::too_many_arguments)]
        fn new(
            py: Python<'_>,
            port: &str,
            address: i64,
            store: Option<Py<ModbusStore>>,
            baud: i64,
            data_bits: i64,
            parity: &str,
            stop_bits: i64,
            mode: &str,
            char_delay_multiplier: i64,
            rx_latency: Option<f64>,
            frame_end: &str,
            on_read: Option<Py<PyAny>>,
            on_write: Option<Py<PyAny>>,
        ) -> PyResult<Self> {
            let line = LineArgs {
                baud,
                data_bits,
                parity,
                stop_bits,
                mode,
                char_delay_multiplier,
            };
            let config = modbus_config::slave(&line, address)?;
            let options = port_options(rx_latency)?;
            let store = match store {
                Some(s) => s,
                None => Py::new(py, ModbusStore::new(10000, 10000, 10000, 10000)?)?,
            };
            let shared = CallbackStore::new(
                store.get().shared.clone(),
                callbacks(py, on_read, on_write)?,
            );
            let _entered = runtime().enter();
            let serial = si_core::port::open(port, &config.line.settings, &options)
                .map_err(|e| modbus(e.into()))?;
            let engine = si_modbus::Slave::new(config, shared)
                .map_err(|e| modbus(e.into()))?
                .with_frame_end(modbus_config::frame_end(frame_end)?);
            let mut slave = Slave::spawn_engine(engine, serial);
            let (tx, rx) = mpsc::channel(EVENTS_KEPT);
            let (stop_tx, mut stop_rx) = oneshot::channel();
            let task = runtime().spawn(async move {
                loop {
                    tokio::select! {
                        event = slave.next_event() => match event {
                            // Full: the oldest are kept, this one is dropped.
                            Some(event) => { let _ = tx.try_send(event); }
                            None => break,
                        },
                        _ = &mut stop_rx => break,
                    }
                }
                slave.close().await
            });
            Ok(ModbusSlave {
                store,
                events: tokio::sync::Mutex::new(rx),
                running: Mutex::new(Some(Running {
                    stop: stop_tx,
                    task,
                })),
            })
        }

        /// The store this slave serves.
        #[getter]
        fn store(&self, py: Python<'_>) -> Py<ModbusStore> {
            self.store.clone_ref(py)
        }

        /// The next event (a dict with `kind` "served", "broadcast", "exception" or "error"),
        /// waiting up to `timeout` seconds; None if none came.
        #[pyo3(signature = (timeout=1.0))]
        fn next_event<'py>(
            &self,
            py: Python<'py>,
            timeout: f64,
        ) -> PyResult<Option<Bound<'py, PyDict>>> {
            let limit = std::time::Duration::from_micros(seconds("timeout", timeout)?.as_micros());
            let event = wait(py, async {
                let mut events = self.events.lock().await;
                tokio::time::timeout(limit, events.recv())
                    .await
                    .ok()
                    .flatten()
            });
            event.map(|e| event_dict(py, &e)).transpose()
        }
    }
}

impl ModbusSlave {
    fn close_job(&self) -> Job<()> {
        stop(&self.running)
    }
}

/// A Modbus TCP server on `host`:`port` (0: any free port, see `.port`) serving `store`,
/// answering every unit id, with `on_read` / `on_write` as for `ModbusSlave`.
#[pyclass(frozen, module = "si_serial")]
pub struct TcpServer {
    store: Py<ModbusStore>,
    port: u16,
    running: Mutex<Option<Running>>,
}

pymethods_with_close! {
    close = "Stops listening and closes every connection. Idempotent.";
    impl TcpServer {
        #[new]
        #[pyo3(signature = (host="127.0.0.1", port=0, *, store=None, on_read=None, on_write=None))]
        fn new(
            py: Python<'_>,
            host: &str,
            port: i64,
            store: Option<Py<ModbusStore>>,
            on_read: Option<Py<PyAny>>,
            on_write: Option<Py<PyAny>>,
        ) -> PyResult<Self> {
            let port: u16 = narrow("port", port)?;
            let store = match store {
                Some(s) => s,
                None => Py::new(py, ModbusStore::new(10000, 10000, 10000, 10000)?)?,
            };
            let shared = CallbackStore::new(
                store.get().shared.clone(),
                callbacks(py, on_read, on_write)?,
            );
            let address = format!("{host}:{port}");
            let server = wait(
                py,
                tcp::Server::bind(address, tcp::ServerConfig::default(), shared),
            )
            .map_err(|e| modbus(e.into()))?;
            let port = server.local_addr().map_err(|e| modbus(e.into()))?.port();
            let (stop_tx, stop_rx) = oneshot::channel::<()>();
            let task = runtime().spawn(async move {
                tokio::select! {
                    _ = server.run() => {}
                    _ = stop_rx => {}
                }
                Ok(())
            });
            Ok(TcpServer {
                store,
                port,
                running: Mutex::new(Some(Running {
                    stop: stop_tx,
                    task,
                })),
            })
        }

        /// The store this server serves.
        #[getter]
        fn store(&self, py: Python<'_>) -> Py<ModbusStore> {
            self.store.clone_ref(py)
        }

        /// The TCP port listened on.
        #[getter]
        fn port(&self) -> u16 {
            self.port
        }
    }
}

impl TcpServer {
    fn close_job(&self) -> Job<()> {
        stop(&self.running)
    }
}
