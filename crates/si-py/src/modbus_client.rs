//! The Modbus client classes: `ModbusClient` (every function code, minimalmodbus's value
//! helpers) and its two constructors `RtuClient` (a serial port, si-modbus's RTU master) and
//! `TcpClient` (si-modbus's Modbus TCP client). Each call blocks with the GIL released.

use crate::errors::{argument_error, modbus, ProtocolError};
use crate::modbus_config::{self, LineArgs};
use crate::options::{narrow, port_options, seconds};
use crate::runtime::{runtime, wait};
use crate::values;
use pyo3::prelude::*;
use pyo3::types::PyTuple;
use si_modbus::tokio::{tcp, Client, Master};
use std::sync::{Arc, Mutex};

/// The connection a client talks over.
enum Line {
    Rtu(Master),
    Tcp(tcp::Client),
}

/// Runs `$body` with `$c` bound to whichever client `$line` holds.
macro_rules! on_line {
    ($line:expr, $c:ident => $body:expr) => {
        match &*$line {
            Line::Rtu($c) => $body,
            Line::Tcp($c) => $body,
        }
    };
}

/// A Modbus client: RTU over a serial port (`RtuClient`) or Modbus TCP (`TcpClient`).
#[pyclass(subclass, frozen, module = "si_serial")]
pub struct ModbusClient {
    line: Mutex<Option<Arc<Line>>>,
    job_bound: f64,
}

impl ModbusClient {
    fn new(line: Line, job_bound: f64) -> Self {
        ModbusClient {
            line: Mutex::new(Some(Arc::new(line))),
            job_bound,
        }
    }

    fn line(&self) -> PyResult<Arc<Line>> {
        self.line
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .clone()
            .ok_or_else(|| ProtocolError::new_err("the client is closed"))
    }
}

fn unit(unit: i64) -> PyResult<u8> {
    narrow("unit", unit)
}

fn address(address: i64) -> PyResult<u16> {
    narrow("address", address)
}

fn count(count: i64) -> PyResult<u16> {
    narrow("count", count)
}

fn byteorder(byteorder: i64) -> PyResult<u8> {
    match byteorder {
        0..=3 => Ok(byteorder as u8),
        _ => Err(argument_error("byteorder", "0 … 3", byteorder)),
    }
}

#[pymethods]
impl ModbusClient {
    /// FC01: `count` coils from `address` of `unit`, as a list of bools.
    #[pyo3(signature = (address, count, unit=1))]
    fn read_coils(
        &self,
        py: Python<'_>,
        address: i64,
        count: i64,
        unit: i64,
    ) -> PyResult<Vec<bool>> {
        let (line, a, n, u) = (
            self.line()?,
            self::address(address)?,
            self::count(count)?,
            self::unit(unit)?,
        );
        wait(py, async move {
            on_line!(line, c => c.read_coils(u, a, n).await)
        })
        .map_err(modbus)
    }

    /// FC02: `count` discrete inputs from `address`.
    #[pyo3(signature = (address, count, unit=1))]
    fn read_discrete_inputs(
        &self,
        py: Python<'_>,
        address: i64,
        count: i64,
        unit: i64,
    ) -> PyResult<Vec<bool>> {
        let (line, a, n, u) = (
            self.line()?,
            self::address(address)?,
            self::count(count)?,
            self::unit(unit)?,
        );
        wait(py, async move {
            on_line!(line, c => c.read_discrete_inputs(u, a, n).await)
        })
        .map_err(modbus)
    }

    /// FC03: `count` holding registers from `address`, as a list of ints.
    #[pyo3(signature = (address, count, unit=1))]
    fn read_holding_registers(
        &self,
        py: Python<'_>,
        address: i64,
        count: i64,
        unit: i64,
    ) -> PyResult<Vec<u16>> {
        let (line, a, n, u) = (
            self.line()?,
            self::address(address)?,
            self::count(count)?,
            self::unit(unit)?,
        );
        wait(py, async move {
            on_line!(line, c => c.read_holding_registers(u, a, n).await)
        })
        .map_err(modbus)
    }

    /// FC04: `count` input registers from `address`.
    #[pyo3(signature = (address, count, unit=1))]
    fn read_input_registers(
        &self,
        py: Python<'_>,
        address: i64,
        count: i64,
        unit: i64,
    ) -> PyResult<Vec<u16>> {
        let (line, a, n, u) = (
            self.line()?,
            self::address(address)?,
            self::count(count)?,
            self::unit(unit)?,
        );
        wait(py, async move {
            on_line!(line, c => c.read_input_registers(u, a, n).await)
        })
        .map_err(modbus)
    }

    /// FC05: one coil.
    #[pyo3(signature = (address, value, unit=1))]
    fn write_single_coil(
        &self,
        py: Python<'_>,
        address: i64,
        value: bool,
        unit: i64,
    ) -> PyResult<()> {
        let (line, a, u) = (self.line()?, self::address(address)?, self::unit(unit)?);
        wait(py, async move {
            on_line!(line, c => c.write_single_coil(u, a, value).await)
        })
        .map_err(modbus)
    }

    /// FC06: one register.
    #[pyo3(signature = (address, value, unit=1))]
    fn write_single_register(
        &self,
        py: Python<'_>,
        address: i64,
        value: i64,
        unit: i64,
    ) -> PyResult<()> {
        let (line, a, u) = (self.line()?, self::address(address)?, self::unit(unit)?);
        let v: u16 = narrow("value", value)?;
        wait(py, async move {
            on_line!(line, c => c.write_single_register(u, a, v).await)
        })
        .map_err(modbus)
    }

    /// FC07: the exception status byte.
    #[pyo3(signature = (unit=1))]
    fn read_exception_status(&self, py: Python<'_>, unit: i64) -> PyResult<u8> {
        let (line, u) = (self.line()?, self::unit(unit)?);
        wait(py, async move {
            on_line!(line, c => c.read_exception_status(u).await)
        })
        .map_err(modbus)
    }

    /// FC08 sub-function 0 (return query data): `data` echoed by the slave.
    #[pyo3(signature = (data=0, unit=1))]
    fn diagnostics(&self, py: Python<'_>, data: i64, unit: i64) -> PyResult<u16> {
        let (line, u) = (self.line()?, self::unit(unit)?);
        let d: u16 = narrow("data", data)?;
        wait(
            py,
            async move { on_line!(line, c => c.diagnostics(u, d).await) },
        )
        .map_err(modbus)
    }

    /// FC11: `(status, event_count)`.
    #[pyo3(signature = (unit=1))]
    fn get_comm_event_counter(&self, py: Python<'_>, unit: i64) -> PyResult<(u16, u16)> {
        let (line, u) = (self.line()?, self::unit(unit)?);
        wait(py, async move {
            on_line!(line, c => c.get_comm_event_counter(u).await)
        })
        .map_err(modbus)
    }

    /// FC12: `(status, event_count, message_count, events)`.
    #[pyo3(signature = (unit=1))]
    fn get_comm_event_log(&self, py: Python<'_>, unit: i64) -> PyResult<(u16, u16, u16, Vec<u8>)> {
        let (line, u) = (self.line()?, self::unit(unit)?);
        let log = wait(py, async move {
            on_line!(line, c => c.get_comm_event_log(u).await)
        })
        .map_err(modbus)?;
        Ok((log.status, log.event_count, log.message_count, log.events))
    }

    /// FC15: coils from `address`.
    #[pyo3(signature = (address, values, unit=1))]
    fn write_multiple_coils(
        &self,
        py: Python<'_>,
        address: i64,
        values: Vec<bool>,
        unit: i64,
    ) -> PyResult<()> {
        let (line, a, u) = (self.line()?, self::address(address)?, self::unit(unit)?);
        wait(py, async move {
            on_line!(line, c => c.write_multiple_coils(u, a, &values).await)
        })
        .map_err(modbus)
    }

    /// FC16: registers from `address`.
    #[pyo3(signature = (address, values, unit=1))]
    fn write_multiple_registers(
        &self,
        py: Python<'_>,
        address: i64,
        values: Vec<i64>,
        unit: i64,
    ) -> PyResult<()> {
        let (line, a, u) = (self.line()?, self::address(address)?, self::unit(unit)?);
        let words = values
            .into_iter()
            .map(|v| narrow::<u16>("values", v))
            .collect::<PyResult<Vec<u16>>>()?;
        wait(py, async move {
            on_line!(line, c => c.write_multiple_registers(u, a, &words).await)
        })
        .map_err(modbus)
    }

    /// A float in 2 (or 4: a double) registers from `address`, read with FC03 (or FC04 with
    /// `function=4`), in minimalmodbus's `byteorder` (BYTEORDER_BIG … BYTEORDER_LITTLE_SWAP).
    #[pyo3(signature = (address, unit=1, number_of_registers=2, byteorder=0, function=3))]
    fn read_float(
        &self,
        py: Python<'_>,
        address: i64,
        unit: i64,
        number_of_registers: i64,
        byteorder: i64,
        function: i64,
    ) -> PyResult<f64> {
        let bytes = self.read_value(py, address, unit, number_of_registers, byteorder, function)?;
        Ok(match bytes.len() {
            4 => f64::from(f32::from_be_bytes([bytes[0], bytes[1], bytes[2], bytes[3]])),
            _ => f64::from_be_bytes(bytes.try_into().unwrap_or_default()),
        })
    }

    /// A 32-bit (or 64-bit with `number_of_registers=4`) integer from `address`, `signed` or
    /// not, in minimalmodbus's `byteorder`.
    #[pyo3(signature = (address, unit=1, signed=false, byteorder=0, number_of_registers=2, function=3))]
    #[allow(clippy::too_many_arguments)]
    fn read_long(
        &self,
        py: Python<'_>,
        address: i64,
        unit: i64,
        signed: bool,
        byteorder: i64,
        number_of_registers: i64,
        function: i64,
    ) -> PyResult<i128> {
        let bytes = self.read_value(py, address, unit, number_of_registers, byteorder, function)?;
        let mut wide = [0u8; 8];
        wide[8 - bytes.len()..].copy_from_slice(&bytes);
        let raw = u64::from_be_bytes(wide);
        Ok(match (signed, bytes.len()) {
            (false, _) => i128::from(raw),
            (true, 4) => i128::from(raw as u32 as i32),
            (true, _) => i128::from(raw as i64),
        })
    }

    /// Writes a float into 2 (or 4) registers from `address` with FC16.
    #[pyo3(signature = (address, value, unit=1, number_of_registers=2, byteorder=0))]
    fn write_float(
        &self,
        py: Python<'_>,
        address: i64,
        value: f64,
        unit: i64,
        number_of_registers: i64,
        byteorder: i64,
    ) -> PyResult<()> {
        let bytes = match number_of_registers {
            2 => (value as f32).to_be_bytes().to_vec(),
            4 => value.to_be_bytes().to_vec(),
            n => return Err(argument_error("number_of_registers", "2 or 4", n)),
        };
        let words = values::to_registers(&bytes, self::byteorder(byteorder)?);
        self.write_multiple_registers(
            py,
            address,
            words.into_iter().map(i64::from).collect(),
            unit,
        )
    }

    /// Writes a 32-bit (or 64-bit) integer into 2 (or 4) registers from `address` with FC16.
    #[pyo3(signature = (address, value, unit=1, signed=false, byteorder=0, number_of_registers=2))]
    #[allow(clippy::too_many_arguments)]
    fn write_long(
        &self,
        py: Python<'_>,
        address: i64,
        value: i128,
        unit: i64,
        signed: bool,
        byteorder: i64,
        number_of_registers: i64,
    ) -> PyResult<()> {
        let (bits, range) = match number_of_registers {
            2 => (
                32,
                if signed {
                    (-(1i128 << 31), (1i128 << 31) - 1)
                } else {
                    (0, (1i128 << 32) - 1)
                },
            ),
            4 => (
                64,
                if signed {
                    (-(1i128 << 63), (1i128 << 63) - 1)
                } else {
                    (0, (1i128 << 64) - 1)
                },
            ),
            n => return Err(argument_error("number_of_registers", "2 or 4", n)),
        };
        if !(range.0..=range.1).contains(&value) {
            return Err(argument_error(
                "value",
                &format!("{} … {}", range.0, range.1),
                value,
            ));
        }
        let all = (value as u128 as u64).to_be_bytes();
        let bytes = &all[8 - bits / 8..];
        let words = values::to_registers(bytes, self::byteorder(byteorder)?);
        self.write_multiple_registers(
            py,
            address,
            words.into_iter().map(i64::from).collect(),
            unit,
        )
    }

    /// The longest a job can take before it ends with an error, in seconds (RTU: retries,
    /// response time, the longest frames and the port's allowance; see si-modbus's "Bounds").
    #[getter]
    fn job_bound(&self) -> f64 {
        self.job_bound
    }

    /// Closes the port or connection; further calls raise ProtocolError. Idempotent.
    fn close(&self, py: Python<'_>) -> PyResult<()> {
        let taken = self.line.lock().unwrap_or_else(|e| e.into_inner()).take();
        let Some(line) = taken else { return Ok(()) };
        // Another thread still in a call keeps the line until its call ends; dropping the last
        // handle releases the port then.
        let Ok(line) = Arc::try_unwrap(line) else {
            return Ok(());
        };
        wait(py, async move {
            match line {
                Line::Rtu(m) => m.close().await,
                Line::Tcp(c) => c.close().await,
            }
        })
        .map_err(modbus)
    }

    fn __enter__(slf: Py<Self>) -> Py<Self> {
        slf
    }

    #[pyo3(signature = (*_args))]
    fn __exit__(&self, py: Python<'_>, _args: &Bound<'_, PyTuple>) -> PyResult<bool> {
        self.close(py)?;
        Ok(false)
    }
}

impl ModbusClient {
    /// The value's big-endian bytes from `number_of_registers` registers.
    fn read_value(
        &self,
        py: Python<'_>,
        address: i64,
        unit: i64,
        number_of_registers: i64,
        byteorder: i64,
        function: i64,
    ) -> PyResult<Vec<u8>> {
        let n = match number_of_registers {
            2 | 4 => number_of_registers,
            n => return Err(argument_error("number_of_registers", "2 or 4", n)),
        };
        let order = self::byteorder(byteorder)?;
        let words = match function {
            3 => self.read_holding_registers(py, address, n, unit)?,
            4 => self.read_input_registers(py, address, n, unit)?,
            f => return Err(argument_error("function", "3 or 4", f)),
        };
        Ok(values::to_value_bytes(&words, order))
    }
}

/// A Modbus RTU client (master) on a serial port, with the module's parameters as keyword
/// arguments ([Modbus/USS] §3.4.3, Table 3-17).
#[pyclass(extends = ModbusClient, frozen, module = "si_serial")]
pub struct RtuClient;

#[pymethods]
impl RtuClient {
    #[new]
    #[pyo3(signature = (port, *, baud=9600, data_bits=8, parity="even", stop_bits=1, mode="normal",
        char_delay_multiplier=1, response_timeout=2.0, retries=0, broadcast_turnaround=0.1,
        rx_latency=None, frame_end="gap"))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        port: &str,
        baud: i64,
        data_bits: i64,
        parity: &str,
        stop_bits: i64,
        mode: &str,
        char_delay_multiplier: i64,
        response_timeout: f64,
        retries: i64,
        broadcast_turnaround: f64,
        rx_latency: Option<f64>,
        frame_end: &str,
    ) -> PyResult<PyClassInitializer<Self>> {
        let line = LineArgs {
            baud,
            data_bits,
            parity,
            stop_bits,
            mode,
            char_delay_multiplier,
        };
        let config = modbus_config::master(&line, response_timeout, retries, broadcast_turnaround)?;
        let options = port_options(rx_latency)?;
        let _entered = runtime().enter();
        let serial = si_core::port::open(port, &config.line.settings, &options)
            .map_err(|e| modbus(e.into()))?;
        let engine = si_modbus::Master::new(config)
            .map_err(|e| modbus(e.into()))?
            .with_frame_end(modbus_config::frame_end(frame_end)?);
        let master = Master::spawn_engine(engine, serial);
        let bound = config.job_bound().as_micros() as f64 / 1e6;
        Ok(
            PyClassInitializer::from(ModbusClient::new(Line::Rtu(master), bound))
                .add_subclass(RtuClient),
        )
    }
}

/// A Modbus TCP client connected to `host`:`port`.
#[pyclass(extends = ModbusClient, frozen, module = "si_serial")]
pub struct TcpClient;

#[pymethods]
impl TcpClient {
    #[new]
    #[pyo3(signature = (host, port=502, *, response_timeout=2.0, retries=0))]
    fn new(
        py: Python<'_>,
        host: &str,
        port: i64,
        response_timeout: f64,
        retries: i64,
    ) -> PyResult<PyClassInitializer<Self>> {
        let config = tcp::ClientConfig {
            response_timeout: seconds("response_timeout", response_timeout)?,
            retries: narrow("retries", retries)?,
        };
        let port: u16 = narrow("port", port)?;
        let address = format!("{host}:{port}");
        let client = wait(py, tcp::Client::connect_with(config, address)).map_err(modbus)?;
        let bound =
            (config.response_timeout.as_micros() as f64 / 1e6) * (f64::from(config.retries) + 1.0);
        Ok(
            PyClassInitializer::from(ModbusClient::new(Line::Tcp(client), bound))
                .add_subclass(TcpClient),
        )
    }
}
