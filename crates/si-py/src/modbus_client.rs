//! The blocking Modbus client classes: `ModbusClient` (every function code, minimalmodbus's
//! value helpers) and its two constructors `RtuClient` (a serial port, si-modbus's RTU master)
//! and `TcpClient` (si-modbus's Modbus TCP client). Each call blocks with the GIL released.
//! (`aio_modbus` is the same over asyncio; both run [`modbus_jobs`](crate::modbus_jobs).)

use crate::modbus_jobs::Jobs;
use crate::runtime::wait;
use pyo3::prelude::*;
use pyo3::types::PyTuple;

/// A Modbus client: RTU over a serial port (`RtuClient`) or Modbus TCP (`TcpClient`).
#[pyclass(subclass, frozen, module = "si_serial")]
pub struct ModbusClient {
    jobs: Jobs,
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
        wait(py, self.jobs.read_coils(address, count, unit)?)
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
        wait(py, self.jobs.read_discrete_inputs(address, count, unit)?)
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
        wait(py, self.jobs.read_holding_registers(address, count, unit)?)
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
        wait(py, self.jobs.read_input_registers(address, count, unit)?)
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
        wait(py, self.jobs.write_single_coil(address, value, unit)?)
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
        wait(py, self.jobs.write_single_register(address, value, unit)?)
    }

    /// FC07: the exception status byte.
    #[pyo3(signature = (unit=1))]
    fn read_exception_status(&self, py: Python<'_>, unit: i64) -> PyResult<u8> {
        wait(py, self.jobs.read_exception_status(unit)?)
    }

    /// FC08 sub-function 0 (return query data): `data` echoed by the slave.
    #[pyo3(signature = (data=0, unit=1))]
    fn diagnostics(&self, py: Python<'_>, data: i64, unit: i64) -> PyResult<u16> {
        wait(py, self.jobs.diagnostics(data, unit)?)
    }

    /// FC11: `(status, event_count)`.
    #[pyo3(signature = (unit=1))]
    fn get_comm_event_counter(&self, py: Python<'_>, unit: i64) -> PyResult<(u16, u16)> {
        wait(py, self.jobs.get_comm_event_counter(unit)?)
    }

    /// FC12: `(status, event_count, message_count, events)`.
    #[pyo3(signature = (unit=1))]
    fn get_comm_event_log(&self, py: Python<'_>, unit: i64) -> PyResult<(u16, u16, u16, Vec<u8>)> {
        wait(py, self.jobs.get_comm_event_log(unit)?)
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
        wait(py, self.jobs.write_multiple_coils(address, values, unit)?)
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
        wait(
            py,
            self.jobs.write_multiple_registers(address, values, unit)?,
        )
    }

    /// A float in 2 registers (a double in 4) from `address`, read with FC03 (or FC04 with
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
        wait(
            py,
            self.jobs
                .read_float(address, unit, number_of_registers, byteorder, function)?,
        )
    }

    /// A 32-bit (64-bit with `number_of_registers=4`) integer from `address`, `signed` or not,
    /// in minimalmodbus's `byteorder`.
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
        wait(
            py,
            self.jobs.read_long(
                address,
                unit,
                signed,
                byteorder,
                number_of_registers,
                function,
            )?,
        )
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
        wait(
            py,
            self.jobs
                .write_float(address, value, unit, number_of_registers, byteorder)?,
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
        wait(
            py,
            self.jobs
                .write_long(address, value, unit, signed, byteorder, number_of_registers)?,
        )
    }

    /// The longest a job can take before it ends with an error, in seconds (RTU: retries,
    /// response time, the longest frames and the port's allowance; see si-modbus's "Bounds").
    #[getter]
    fn job_bound(&self) -> f64 {
        self.jobs.job_bound
    }

    /// Closes the port or connection; further calls raise ProtocolError. Idempotent.
    fn close(&self, py: Python<'_>) -> PyResult<()> {
        wait(py, self.jobs.close())
    }

    fn __enter__(slf: Py<Self>) -> Py<Self> {
        slf
    }

    #[pyo3(signature = (*args))]
    fn __exit__(&self, py: Python<'_>, args: &Bound<'_, PyTuple>) -> PyResult<bool> {
        crate::lifecycle::exit(self.close(py), args)
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
        let jobs = Jobs::rtu(
            port,
            baud,
            data_bits,
            parity,
            stop_bits,
            mode,
            char_delay_multiplier,
            response_timeout,
            retries,
            broadcast_turnaround,
            rx_latency,
            frame_end,
        )?;
        Ok(PyClassInitializer::from(ModbusClient { jobs }).add_subclass(RtuClient))
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
        let jobs = wait(py, Jobs::tcp(host, port, response_timeout, retries)?)?;
        Ok(PyClassInitializer::from(ModbusClient { jobs }).add_subclass(TcpClient))
    }
}
