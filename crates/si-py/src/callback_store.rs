//! A slave's or server's values from Python callbacks: `on_read(table, address, count)` and
//! `on_write(table, address, values)`, called for each request in front of the
//! [`SharedStore`] that serves whatever a callback leaves to it.
//!
//! The GIL is taken only around a callback, on the runtime's thread that serves the request;
//! no lock of the store is held meanwhile, so Python may read and write the store from the
//! callback or from any thread.
//!
//! A callback that raises (or returns something that is not `count` values) never stops the
//! service: the request is answered with exception 04, SERVER DEVICE FAILURE ([Modbus AP] §7,
//! "an unrecoverable error occurred while the server was attempting to perform the requested
//! action"), and the Python exception goes to `sys.unraisablehook`, as for any exception
//! Python cannot raise to a caller.

use crate::store::SharedStore;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyList;
use si_modbus::frame::{Bits, ExceptionCode, Registers};
use si_modbus::slave::{Store, StoreError};

/// The four Modbus tables by the names the callbacks get.
const COILS: &str = "coils";
const DISCRETE_INPUTS: &str = "discrete_inputs";
const HOLDING_REGISTERS: &str = "holding_registers";
const INPUT_REGISTERS: &str = "input_registers";

/// The Python callbacks of a slave or server; without either, it is its store alone.
#[derive(Debug, Default)]
pub struct Callbacks {
    /// `on_read(table, address, count)`: `count` values, or None to read the store.
    pub on_read: Option<Py<PyAny>>,
    /// `on_write(table, address, values)`: sees a write before the store takes it.
    pub on_write: Option<Py<PyAny>>,
}

/// A [`SharedStore`] with [`Callbacks`] in front of it.
#[derive(Debug)]
pub struct CallbackStore {
    store: SharedStore,
    callbacks: Callbacks,
}

/// The answer to a callback that failed: exception 04 ([Modbus AP] §7), S_MODB numbers none
/// (the failure is not the module's).
fn device_failure(py: Python<'_>, err: PyErr, callback: &Py<PyAny>) -> StoreError {
    err.write_unraisable(py, Some(callback.bind(py)));
    StoreError::new(ExceptionCode::SlaveDeviceFailure, 0, 0)
}

impl CallbackStore {
    /// `store` behind `callbacks`.
    pub fn new(store: SharedStore, callbacks: Callbacks) -> Self {
        CallbackStore { store, callbacks }
    }

    /// `count` values of `table` from the read callback as `T` (a register or a bit),
    /// `Ok(None)` if there is no callback or it returned None.
    fn read<T: Value>(
        &self,
        table: &str,
        address: u16,
        count: u16,
    ) -> Result<Option<Vec<T>>, StoreError> {
        let Some(callback) = &self.callbacks.on_read else {
            return Ok(None);
        };
        Python::attach(|py| {
            let called = callback
                .bind(py)
                .call1((table, address, count))
                .and_then(|values| {
                    if values.is_none() {
                        return Ok(None);
                    }
                    let values = values
                        .try_iter()?
                        .map(|v| T::from_py(&v?))
                        .collect::<PyResult<Vec<T>>>()?;
                    if values.len() != usize::from(count) {
                        return Err(PyValueError::new_err(format!(
                            "on_read returned {} values for {count} {table} from {address}",
                            values.len()
                        )));
                    }
                    Ok(Some(values))
                });
            called.map_err(|e| device_failure(py, e, callback))
        })
    }

    /// Hands a write of `values` to `table` at `address` to the write callback, if any.
    fn written<'py, T: IntoPyObject<'py>>(
        &self,
        py: Python<'py>,
        table: &str,
        address: u16,
        values: Vec<T>,
    ) -> Result<(), StoreError> {
        let Some(callback) = &self.callbacks.on_write else {
            return Ok(());
        };
        PyList::new(py, values)
            .and_then(|values| callback.call1(py, (table, address, values)))
            .map(drop)
            .map_err(|e| device_failure(py, e, callback))
    }
}

/// One value a read callback returns.
trait Value: Sized {
    /// The value of `v`, or the Python error to report.
    fn from_py(v: &Bound<'_, PyAny>) -> PyResult<Self>;
}

/// A register: an int 0 … 65535 (else OverflowError or TypeError).
impl Value for u16 {
    fn from_py(v: &Bound<'_, PyAny>) -> PyResult<Self> {
        v.extract()
    }
}

/// A bit: any object, by its truth (True, 1, …), as Python's `bool()` would take it.
impl Value for bool {
    fn from_py(v: &Bound<'_, PyAny>) -> PyResult<Self> {
        v.is_truthy()
    }
}

/// Packs `bits` LSB first into `out`, as FC01/FC02 answer ([Modbus AP] §6.1).
fn pack(bits: &[bool], out: &mut [u8]) -> Result<(), StoreError> {
    out.fill(0);
    for (i, _) in bits.iter().enumerate().filter(|(_, b)| **b) {
        out[i / 8] |= 1 << (i % 8);
    }
    Ok(())
}

/// Registers big-endian into `out`, as FC03/FC04 answer ([Modbus AP] §6.3).
fn words(registers: &[u16], out: &mut [u8]) -> Result<(), StoreError> {
    for (chunk, r) in out.chunks_exact_mut(2).zip(registers) {
        chunk.copy_from_slice(&r.to_be_bytes());
    }
    Ok(())
}

impl Store for CallbackStore {
    fn read_coils(
        &mut self,
        address: u16,
        quantity: u16,
        out: &mut [u8],
    ) -> Result<(), StoreError> {
        match self.read::<bool>(COILS, address, quantity)? {
            Some(bits) => pack(&bits, out),
            None => self.store.read_coils(address, quantity, out),
        }
    }

    fn read_discrete_inputs(
        &mut self,
        address: u16,
        quantity: u16,
        out: &mut [u8],
    ) -> Result<(), StoreError> {
        match self.read::<bool>(DISCRETE_INPUTS, address, quantity)? {
            Some(bits) => pack(&bits, out),
            None => self.store.read_discrete_inputs(address, quantity, out),
        }
    }

    fn read_holding_registers(
        &mut self,
        address: u16,
        quantity: u16,
        out: &mut [u8],
    ) -> Result<(), StoreError> {
        match self.read::<u16>(HOLDING_REGISTERS, address, quantity)? {
            Some(registers) => words(&registers, out),
            None => self.store.read_holding_registers(address, quantity, out),
        }
    }

    fn read_input_registers(
        &mut self,
        address: u16,
        quantity: u16,
        out: &mut [u8],
    ) -> Result<(), StoreError> {
        match self.read::<u16>(INPUT_REGISTERS, address, quantity)? {
            Some(registers) => words(&registers, out),
            None => self.store.read_input_registers(address, quantity, out),
        }
    }

    fn write_coils(&mut self, address: u16, values: Bits<'_>) -> Result<(), StoreError> {
        if self.callbacks.on_write.is_some() {
            Python::attach(|py| self.written(py, COILS, address, values.iter().collect()))?;
        }
        self.store.write_coils(address, values)
    }

    fn write_registers(&mut self, address: u16, values: Registers<'_>) -> Result<(), StoreError> {
        if self.callbacks.on_write.is_some() {
            Python::attach(|py| {
                self.written(py, HOLDING_REGISTERS, address, values.iter().collect())
            })?;
        }
        self.store.write_registers(address, values)
    }
}
