//! The asyncio Modbus client classes of `si_serial.aio`: the same names and arguments as the
//! blocking ones, every job a coroutine run on the shared runtime (pyo3-async-runtimes).
//! `RtuClient` opens its port at once; `TcpClient.connect(...)` is a coroutine.

use crate::modbus_jobs::Jobs;
use pyo3::prelude::*;
use pyo3::types::PyTuple;
use pyo3_async_runtimes::tokio::future_into_py;

/// A Modbus client whose jobs are awaited: RTU (`RtuClient`) or TCP (`TcpClient.connect`).
#[pyclass(name = "ModbusClient", subclass, frozen, module = "si_serial.aio")]
pub struct AioModbusClient {
    jobs: Jobs,
}

#[pymethods]
impl AioModbusClient {
    /// FC01: `count` coils from `address` of `unit`, as a list of bools.
    #[pyo3(signature = (address, count, unit=1))]
    fn read_coils<'py>(
        &self,
        py: Python<'py>,
        address: i64,
        count: i64,
        unit: i64,
    ) -> PyResult<Bound<'py, PyAny>> {
        future_into_py(py, self.jobs.read_coils(address, count, unit)?)
    }

    /// FC02: `count` discrete inputs from `address`.
    #[pyo3(signature = (address, count, unit=1))]
    fn read_discrete_inputs<'py>(
        &self,
        py: Python<'py>,
        address: i64,
        count: i64,
        unit: i64,
    ) -> PyResult<Bound<'py, PyAny>> {
        future_into_py(py, self.jobs.read_discrete_inputs(address, count, unit)?)
    }

    /// FC03: `count` holding registers from `address`, as a list of ints.
    #[pyo3(signature = (address, count, unit=1))]
    fn read_holding_registers<'py>(
        &self,
        py: Python<'py>,
        address: i64,
        count: i64,
        unit: i64,
    ) -> PyResult<Bound<'py, PyAny>> {
        future_into_py(py, self.jobs.read_holding_registers(address, count, unit)?)
    }

    /// FC04: `count` input registers from `address`.
    #[pyo3(signature = (address, count, unit=1))]
    fn read_input_registers<'py>(
        &self,
        py: Python<'py>,
        address: i64,
        count: i64,
        unit: i64,
    ) -> PyResult<Bound<'py, PyAny>> {
        future_into_py(py, self.jobs.read_input_registers(address, count, unit)?)
    }

    /// FC05: one coil.
    #[pyo3(signature = (address, value, unit=1))]
    fn write_single_coil<'py>(
        &self,
        py: Python<'py>,
        address: i64,
        value: bool,
        unit: i64,
    ) -> PyResult<Bound<'py, PyAny>> {
        future_into_py(py, self.jobs.write_single_coil(address, value, unit)?)
    }

    /// FC06: one register.
    #[pyo3(signature = (address, value, unit=1))]
    fn write_single_register<'py>(
        &self,
        py: Python<'py>,
        address: i64,
        value: i64,
        unit: i64,
    ) -> PyResult<Bound<'py, PyAny>> {
        future_into_py(py, self.jobs.write_single_register(address, value, unit)?)
    }

    /// FC07: the exception status byte.
    #[pyo3(signature = (unit=1))]
    fn read_exception_status<'py>(
        &self,
        py: Python<'py>,
        unit: i64,
    ) -> PyResult<Bound<'py, PyAny>> {
        future_into_py(py, self.jobs.read_exception_status(unit)?)
    }

    /// FC08 sub-function 0 (return query data): `data` echoed by the slave.
    #[pyo3(signature = (data=0, unit=1))]
    fn diagnostics<'py>(
        &self,
        py: Python<'py>,
        data: i64,
        unit: i64,
    ) -> PyResult<Bound<'py, PyAny>> {
        future_into_py(py, self.jobs.diagnostics(data, unit)?)
    }

    /// FC11: `(status, event_count)`.
    #[pyo3(signature = (unit=1))]
    fn get_comm_event_counter<'py>(
        &self,
        py: Python<'py>,
        unit: i64,
    ) -> PyResult<Bound<'py, PyAny>> {
        future_into_py(py, self.jobs.get_comm_event_counter(unit)?)
    }

    /// FC12: `(status, event_count, message_count, events)`.
    #[pyo3(signature = (unit=1))]
    fn get_comm_event_log<'py>(&self, py: Python<'py>, unit: i64) -> PyResult<Bound<'py, PyAny>> {
        future_into_py(py, self.jobs.get_comm_event_log(unit)?)
    }

    /// FC15: coils from `address`.
    #[pyo3(signature = (address, values, unit=1))]
    fn write_multiple_coils<'py>(
        &self,
        py: Python<'py>,
        address: i64,
        values: Vec<bool>,
        unit: i64,
    ) -> PyResult<Bound<'py, PyAny>> {
        future_into_py(py, self.jobs.write_multiple_coils(address, values, unit)?)
    }

    /// FC16: registers from `address`.
    #[pyo3(signature = (address, values, unit=1))]
    fn write_multiple_registers<'py>(
        &self,
        py: Python<'py>,
        address: i64,
        values: Vec<i64>,
        unit: i64,
    ) -> PyResult<Bound<'py, PyAny>> {
        future_into_py(
            py,
            self.jobs.write_multiple_registers(address, values, unit)?,
        )
    }

    /// A float in 2 registers (a double in 4) from `address`, read with FC03 (or FC04 with
    /// `function=4`), in minimalmodbus's `byteorder` (BYTEORDER_BIG … BYTEORDER_LITTLE_SWAP).
    #[pyo3(signature = (address, unit=1, number_of_registers=2, byteorder=0, function=3))]
    fn read_float<'py>(
        &self,
        py: Python<'py>,
        address: i64,
        unit: i64,
        number_of_registers: i64,
        byteorder: i64,
        function: i64,
    ) -> PyResult<Bound<'py, PyAny>> {
        future_into_py(
            py,
            self.jobs
                .read_float(address, unit, number_of_registers, byteorder, function)?,
        )
    }

    /// A 32-bit (64-bit with `number_of_registers=4`) integer from `address`, `signed` or not,
    /// in minimalmodbus's `byteorder`.
    #[pyo3(signature = (address, unit=1, signed=false, byteorder=0, number_of_registers=2, function=3))]
    #[allow(clippy::too_many_arguments)]
    fn read_long<'py>(
        &self,
        py: Python<'py>,
        address: i64,
        unit: i64,
        signed: bool,
        byteorder: i64,
        number_of_registers: i64,
        function: i64,
    ) -> PyResult<Bound<'py, PyAny>> {
        future_into_py(
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
    fn write_float<'py>(
        &self,
        py: Python<'py>,
        address: i64,
        value: f64,
        unit: i64,
        number_of_registers: i64,
        byteorder: i64,
    ) -> PyResult<Bound<'py, PyAny>> {
        future_into_py(
            py,
            self.jobs
                .write_float(address, value, unit, number_of_registers, byteorder)?,
        )
    }

    /// Writes a 32-bit (or 64-bit) integer into 2 (or 4) registers from `address` with FC16.
    #[pyo3(signature = (address, value, unit=1, signed=false, byteorder=0, number_of_registers=2))]
    #[allow(clippy::too_many_arguments)]
    fn write_long<'py>(
        &self,
        py: Python<'py>,
        address: i64,
        value: i128,
        unit: i64,
        signed: bool,
        byteorder: i64,
        number_of_registers: i64,
    ) -> PyResult<Bound<'py, PyAny>> {
        future_into_py(
            py,
            self.jobs
                .write_long(address, value, unit, signed, byteorder, number_of_registers)?,
        )
    }

    /// The longest a job can take before it ends with an error, in seconds.
    #[getter]
    fn job_bound(&self) -> f64 {
        self.jobs.job_bound
    }

    /// Closes the port or connection (a coroutine); further calls raise ProtocolError.
    fn close<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        future_into_py(py, self.jobs.close())
    }

    fn __aenter__<'py>(slf: Py<Self>, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        future_into_py(py, async move { Ok(slf) })
    }

    /// Closes the client; a failed close raises unless an exception already propagates
    /// (`lifecycle::exit`'s rule).
    #[pyo3(signature = (*args))]
    fn __aexit__<'py>(
        &self,
        py: Python<'py>,
        args: &Bound<'_, PyTuple>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let close = self.jobs.close();
        let propagating = crate::lifecycle::propagating(args);
        future_into_py(py, async move {
            crate::lifecycle::exit_with(close.await, propagating)
        })
    }
}

/// A Modbus RTU client on a serial port; the keyword arguments of `si_serial.RtuClient`.
#[pyclass(name = "RtuClient", extends = AioModbusClient, frozen, module = "si_serial.aio")]
pub struct AioRtuClient;

#[pymethods]
impl AioRtuClient {
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
        Ok(PyClassInitializer::from(AioModbusClient { jobs }).add_subclass(AioRtuClient))
    }
}

/// A Modbus TCP client: `await TcpClient.connect(host, port, ...)`.
#[pyclass(name = "TcpClient", extends = AioModbusClient, frozen, module = "si_serial.aio")]
pub struct AioTcpClient;

#[pymethods]
impl AioTcpClient {
    /// Connects to `host`:`port` (a coroutine returning the client).
    #[staticmethod]
    #[pyo3(signature = (host, port=502, *, response_timeout=2.0, retries=0))]
    fn connect<'py>(
        py: Python<'py>,
        host: &str,
        port: i64,
        response_timeout: f64,
        retries: i64,
    ) -> PyResult<Bound<'py, PyAny>> {
        let connecting = Jobs::tcp(host, port, response_timeout, retries)?;
        future_into_py(py, async move {
            let jobs = connecting.await?;
            Python::attach(|py| {
                Py::new(
                    py,
                    PyClassInitializer::from(AioModbusClient { jobs }).add_subclass(AioTcpClient),
                )
            })
        })
    }
}
