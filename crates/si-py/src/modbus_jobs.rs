//! The Modbus client's jobs as futures, shared by the blocking classes (`si_serial`) and the
//! asyncio ones (`si_serial.aio`): arguments checked and converted here, once, then each
//! class either waits for the future or hands it to asyncio.

use crate::errors::{argument_error, modbus, ProtocolError};
use crate::modbus_config::{self, LineArgs};
use crate::options::{narrow, port_options, seconds};
use crate::runtime::{runtime, Job};
use crate::values;
use pyo3::prelude::*;
use si_modbus::tokio::{tcp, Client, Master};
use std::sync::{Arc, Mutex};

/// The connection a client talks over.
pub enum Line {
    /// Modbus RTU on a serial port.
    Rtu(Master),
    /// Modbus TCP (boxed: its receive buffer makes it the larger).
    Tcp(Box<tcp::Client>),
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

/// A read (FC01 to FC04) as a job: its arguments checked ([`Jobs::read_args`]), then the
/// client's `$method` on whichever line the client holds.
macro_rules! read_job {
    ($jobs:ident, $address:expr, $count:expr, $unit:expr, $method:ident) => {{
        let (line, a, n, u) = $jobs.read_args($address, $count, $unit)?;
        Ok(Box::pin(async move {
            on_line!(line, c => c.$method(u, a, n).await).map_err(modbus)
        }))
    }};
}

/// FC12's answer: status, event count, message count, events.
pub type EventLog = (u16, u16, u16, Vec<u8>);

/// A client's line and its job bound; `close` takes the line away.
pub struct Jobs {
    line: Mutex<Option<Arc<Line>>>,
    /// The longest a job can take before it ends, in seconds.
    pub job_bound: f64,
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

fn registers(number_of_registers: i64) -> PyResult<u16> {
    match number_of_registers {
        2 | 4 => Ok(number_of_registers as u16),
        n => Err(argument_error("number_of_registers", "2 or 4", n)),
    }
}

impl Jobs {
    fn new(line: Line, job_bound: f64) -> Self {
        Jobs {
            line: Mutex::new(Some(Arc::new(line))),
            job_bound,
        }
    }

    /// An RTU master on a serial port, its config checked first: the keyword arguments of
    /// `RtuClient` (blocking and asyncio alike), times in seconds.
    #[allow(clippy::too_many_arguments)]
    pub fn rtu(
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
    ) -> PyResult<Jobs> {
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
        Ok(Jobs::new(
            Line::Rtu(master),
            config.job_bound().as_micros() as f64 / 1e6,
        ))
    }

    /// A Modbus TCP connection to `host`:`port`, as a future.
    pub fn tcp(host: &str, port: i64, response_timeout: f64, retries: i64) -> PyResult<Job<Jobs>> {
        let config = tcp::ClientConfig {
            response_timeout: seconds("response_timeout", response_timeout)?,
            retries: narrow("retries", retries)?,
        };
        let address = format!("{host}:{}", narrow::<u16>("port", port)?);
        let bound =
            (config.response_timeout.as_micros() as f64 / 1e6) * (f64::from(config.retries) + 1.0);
        Ok(Box::pin(async move {
            let client = tcp::Client::connect_with(config, address)
                .await
                .map_err(modbus)?;
            Ok(Jobs::new(Line::Tcp(Box::new(client)), bound))
        }))
    }

    fn line(&self) -> PyResult<Arc<Line>> {
        self.line
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .clone()
            .ok_or_else(|| ProtocolError::new_err("the client is closed"))
    }

    /// The line and the checked arguments of a read (FC01 to FC04).
    fn read_args(
        &self,
        address: i64,
        count: i64,
        unit: i64,
    ) -> PyResult<(Arc<Line>, u16, u16, u8)> {
        Ok((
            self.line()?,
            self::address(address)?,
            self::count(count)?,
            self::unit(unit)?,
        ))
    }

    /// FC01.
    pub fn read_coils(&self, address: i64, count: i64, unit: i64) -> PyResult<Job<Vec<bool>>> {
        read_job!(self, address, count, unit, read_coils)
    }

    /// FC02.
    pub fn read_discrete_inputs(
        &self,
        address: i64,
        count: i64,
        unit: i64,
    ) -> PyResult<Job<Vec<bool>>> {
        read_job!(self, address, count, unit, read_discrete_inputs)
    }

    /// FC03.
    pub fn read_holding_registers(
        &self,
        address: i64,
        count: i64,
        unit: i64,
    ) -> PyResult<Job<Vec<u16>>> {
        read_job!(self, address, count, unit, read_holding_registers)
    }

    /// FC04.
    pub fn read_input_registers(
        &self,
        address: i64,
        count: i64,
        unit: i64,
    ) -> PyResult<Job<Vec<u16>>> {
        read_job!(self, address, count, unit, read_input_registers)
    }

    /// FC05.
    pub fn write_single_coil(&self, address: i64, value: bool, unit: i64) -> PyResult<Job<()>> {
        let (line, a, u) = (self.line()?, self::address(address)?, self::unit(unit)?);
        Ok(Box::pin(async move {
            on_line!(line, c => c.write_single_coil(u, a, value).await).map_err(modbus)
        }))
    }

    /// FC06.
    pub fn write_single_register(&self, address: i64, value: i64, unit: i64) -> PyResult<Job<()>> {
        let (line, a, u) = (self.line()?, self::address(address)?, self::unit(unit)?);
        let v: u16 = narrow("value", value)?;
        Ok(Box::pin(async move {
            on_line!(line, c => c.write_single_register(u, a, v).await).map_err(modbus)
        }))
    }

    /// FC07.
    pub fn read_exception_status(&self, unit: i64) -> PyResult<Job<u8>> {
        let (line, u) = (self.line()?, self::unit(unit)?);
        Ok(Box::pin(async move {
            on_line!(line, c => c.read_exception_status(u).await).map_err(modbus)
        }))
    }

    /// FC08 sub-function 0.
    pub fn diagnostics(&self, data: i64, unit: i64) -> PyResult<Job<u16>> {
        let (line, u) = (self.line()?, self::unit(unit)?);
        let d: u16 = narrow("data", data)?;
        Ok(Box::pin(async move {
            on_line!(line, c => c.diagnostics(u, d).await).map_err(modbus)
        }))
    }

    /// FC11.
    pub fn get_comm_event_counter(&self, unit: i64) -> PyResult<Job<(u16, u16)>> {
        let (line, u) = (self.line()?, self::unit(unit)?);
        Ok(Box::pin(async move {
            on_line!(line, c => c.get_comm_event_counter(u).await).map_err(modbus)
        }))
    }

    /// FC12.
    pub fn get_comm_event_log(&self, unit: i64) -> PyResult<Job<EventLog>> {
        let (line, u) = (self.line()?, self::unit(unit)?);
        Ok(Box::pin(async move {
            let log = on_line!(line, c => c.get_comm_event_log(u).await).map_err(modbus)?;
            Ok((log.status, log.event_count, log.message_count, log.events))
        }))
    }

    /// FC15.
    pub fn write_multiple_coils(
        &self,
        address: i64,
        values: Vec<bool>,
        unit: i64,
    ) -> PyResult<Job<()>> {
        let (line, a, u) = (self.line()?, self::address(address)?, self::unit(unit)?);
        Ok(Box::pin(async move {
            on_line!(line, c => c.write_multiple_coils(u, a, &values).await).map_err(modbus)
        }))
    }

    /// FC16.
    pub fn write_multiple_registers(
        &self,
        address: i64,
        values: Vec<i64>,
        unit: i64,
    ) -> PyResult<Job<()>> {
        let (line, a, u) = (self.line()?, self::address(address)?, self::unit(unit)?);
        let words = values
            .into_iter()
            .map(|v| narrow::<u16>("values", v))
            .collect::<PyResult<Vec<u16>>>()?;
        Ok(Box::pin(async move {
            on_line!(line, c => c.write_multiple_registers(u, a, &words).await).map_err(modbus)
        }))
    }

    /// A value's big-endian bytes from 2 or 4 registers read with FC03 or FC04.
    fn read_value(
        &self,
        address: i64,
        unit: i64,
        number_of_registers: i64,
        byteorder: i64,
        function: i64,
    ) -> PyResult<Job<Vec<u8>>> {
        let n = i64::from(registers(number_of_registers)?);
        let order = self::byteorder(byteorder)?;
        let words = match function {
            3 => self.read_holding_registers(address, n, unit)?,
            4 => self.read_input_registers(address, n, unit)?,
            f => return Err(argument_error("function", "3 or 4", f)),
        };
        Ok(Box::pin(async move {
            Ok(values::to_value_bytes(&words.await?, order))
        }))
    }

    /// minimalmodbus's `read_float`.
    pub fn read_float(
        &self,
        address: i64,
        unit: i64,
        number_of_registers: i64,
        byteorder: i64,
        function: i64,
    ) -> PyResult<Job<f64>> {
        let bytes = self.read_value(address, unit, number_of_registers, byteorder, function)?;
        Ok(Box::pin(async move {
            let b = bytes.await?;
            Ok(match b.len() {
                4 => f64::from(f32::from_be_bytes([b[0], b[1], b[2], b[3]])),
                _ => f64::from_be_bytes(b.try_into().unwrap_or_default()),
            })
        }))
    }

    /// minimalmodbus's `read_long`.
    pub fn read_long(
        &self,
        address: i64,
        unit: i64,
        signed: bool,
        byteorder: i64,
        number_of_registers: i64,
        function: i64,
    ) -> PyResult<Job<i128>> {
        let bytes = self.read_value(address, unit, number_of_registers, byteorder, function)?;
        Ok(Box::pin(async move {
            let b = bytes.await?;
            let mut wide = [0u8; 8];
            wide[8 - b.len()..].copy_from_slice(&b);
            let raw = u64::from_be_bytes(wide);
            Ok(match (signed, b.len()) {
                (false, _) => i128::from(raw),
                (true, 4) => i128::from(raw as u32 as i32),
                (true, _) => i128::from(raw as i64),
            })
        }))
    }

    /// minimalmodbus's `write_float`.
    pub fn write_float(
        &self,
        address: i64,
        value: f64,
        unit: i64,
        number_of_registers: i64,
        byteorder: i64,
    ) -> PyResult<Job<()>> {
        let bytes = match registers(number_of_registers)? {
            2 => (value as f32).to_be_bytes().to_vec(),
            _ => value.to_be_bytes().to_vec(),
        };
        let words = values::to_registers(&bytes, self::byteorder(byteorder)?);
        self.write_multiple_registers(address, words.into_iter().map(i64::from).collect(), unit)
    }

    /// minimalmodbus's `write_long`.
    #[allow(clippy::too_many_arguments)]
    pub fn write_long(
        &self,
        address: i64,
        value: i128,
        unit: i64,
        signed: bool,
        byteorder: i64,
        number_of_registers: i64,
    ) -> PyResult<Job<()>> {
        let bits = 16 * u32::from(registers(number_of_registers)?);
        let (min, max) = if signed {
            (-(1i128 << (bits - 1)), (1i128 << (bits - 1)) - 1)
        } else {
            (0, (1i128 << bits) - 1)
        };
        if !(min..=max).contains(&value) {
            return Err(argument_error("value", &format!("{min} … {max}"), value));
        }
        let all = (value as u128 as u64).to_be_bytes();
        let words =
            values::to_registers(&all[8 - bits as usize / 8..], self::byteorder(byteorder)?);
        self.write_multiple_registers(address, words.into_iter().map(i64::from).collect(), unit)
    }

    /// Takes the line away; the returned future releases the port (None: already closed or
    /// another call still holds it, which releases it when it ends).
    pub fn close(&self) -> Job<()> {
        let taken = self.line.lock().unwrap_or_else(|e| e.into_inner()).take();
        Box::pin(async move {
            let Some(line) = taken.and_then(|l| Arc::try_unwrap(l).ok()) else {
                return Ok(());
            };
            match line {
                Line::Rtu(m) => m.close().await,
                Line::Tcp(c) => (*c).close().await,
            }
            .map_err(modbus)
        })
    }
}
