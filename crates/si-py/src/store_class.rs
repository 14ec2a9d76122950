//! `si_serial.ModbusStore`: the values a slave or server serves, read and written from Python
//! while it runs. Plain tables, or a SIMATIC CPU's memory behind the example conversion DB of
//! [Modbus/USS] §3.5.4, Table 3-20.

use crate::errors::argument_error;
use crate::options::narrow;
use crate::store::{PyStore, SharedStore};
use pyo3::prelude::*;
use pyo3::types::PyBytes;
use si_core::memory::Area;
use si_modbus::slave::Tables;
use si_modbus::SimaticStore;
use std::sync::{Arc, Mutex};

/// The data a Modbus slave or server serves.
#[pyclass(frozen, module = "si_serial")]
pub struct ModbusStore {
    pub(crate) shared: SharedStore,
}

/// One of the four Modbus tables of a plain store.
fn table<'a, T>(tables: &'a mut Tables, name: &str, bits: bool) -> PyResult<&'a mut Vec<T>>
where
    Tables: TableOf<T>,
{
    tables.table(name).ok_or_else(|| {
        let names = if bits {
            "coils, discrete_inputs"
        } else {
            "holding_registers, input_registers"
        };
        argument_error("table", names, name)
    })
}

/// Picks a table of registers or of bits by name.
pub trait TableOf<T> {
    /// The table called `name`, if this element type has one.
    fn table(&mut self, name: &str) -> Option<&mut Vec<T>>;
}

impl TableOf<u16> for Tables {
    fn table(&mut self, name: &str) -> Option<&mut Vec<u16>> {
        match name {
            "holding_registers" => Some(&mut self.holding_registers),
            "input_registers" => Some(&mut self.input_registers),
            _ => None,
        }
    }
}

impl TableOf<bool> for Tables {
    fn table(&mut self, name: &str) -> Option<&mut Vec<bool>> {
        match name {
            "coils" => Some(&mut self.coils),
            "discrete_inputs" => Some(&mut self.discrete_inputs),
            _ => None,
        }
    }
}

/// `count` elements from `address` of `values`, or a ConfigError naming the span.
fn span<T>(values: &mut [T], address: i64, count: usize) -> PyResult<&mut [T]> {
    let len = values.len();
    usize::try_from(address)
        .ok()
        .and_then(|a| values.get_mut(a..a.checked_add(count)?))
        .ok_or_else(|| {
            argument_error(
                "address",
                &format!("0 … {len} minus the count {count}"),
                address,
            )
        })
}

/// An area of SIMATIC memory by its S7 name: I (or E), Q (or A), M (or F), T, C, DBn.
pub fn area(name: &str) -> PyResult<Area> {
    let upper = name.to_ascii_uppercase();
    Ok(match upper.as_str() {
        "I" | "E" => Area::Inputs,
        "Q" | "A" => Area::Outputs,
        "M" | "F" => Area::Flags,
        "T" => Area::Timers,
        "C" | "Z" => Area::Counters,
        db => match db.strip_prefix("DB").and_then(|n| n.parse().ok()) {
            Some(n) => Area::Db(n),
            None => return Err(argument_error("area", "I, Q, M, T, C, DBn", name)),
        },
    })
}

impl ModbusStore {
    fn tables<R>(&self, f: impl FnOnce(&mut Tables) -> PyResult<R>) -> PyResult<R> {
        self.shared.with(|s| match s {
            PyStore::Tables(t) => f(t),
            PyStore::Simatic(_) => Err(argument_error(
                "store",
                "plain tables (this store is SIMATIC memory)",
                "simatic",
            )),
        })
    }

    fn memory<R>(&self, f: impl FnOnce(&mut SimaticStore) -> PyResult<R>) -> PyResult<R> {
        self.shared.with(|s| match s {
            PyStore::Simatic(m) => f(m),
            PyStore::Tables(_) => Err(argument_error(
                "store",
                "SIMATIC memory (this store is plain tables)",
                "tables",
            )),
        })
    }
}

#[pymethods]
impl ModbusStore {
    /// Plain tables of these sizes from address 0, all zero; an access beyond a table's end
    /// is answered with exception 02.
    #[new]
    #[pyo3(signature = (*, coils=10000, discrete_inputs=10000, holding_registers=10000, input_registers=10000))]
    pub fn new(
        coils: i64,
        discrete_inputs: i64,
        holding_registers: i64,
        input_registers: i64,
    ) -> PyResult<Self> {
        let size = |name, n| narrow::<u16>(name, n).map(|_| n as usize + usize::from(n == 65535));
        let tables = Tables::new(
            size("coils", coils)?,
            size("discrete_inputs", discrete_inputs)?,
            size("holding_registers", holding_registers)?,
            size("input_registers", input_registers)?,
        );
        Ok(ModbusStore {
            shared: SharedStore(Arc::new(Mutex::new(PyStore::Tables(tables)))),
        })
    }

    /// SIMATIC memory served as S_MODB does ([Modbus/USS] §3.5): the example conversion DB of
    /// Table 3-20 over DB1–DB6 (1024 bytes each), MB0–MB1255, QB0–QB127, IB0–IB127, T0–T255,
    /// C0–C255.
    #[staticmethod]
    fn simatic() -> Self {
        ModbusStore {
            shared: SharedStore(Arc::new(Mutex::new(PyStore::Simatic(Box::new(
                SimaticStore::example(),
            ))))),
        }
    }

    /// `count` registers of `table` ("holding_registers" or "input_registers") from `address`.
    #[pyo3(signature = (table, address, count))]
    fn get_registers(&self, table: &str, address: i64, count: usize) -> PyResult<Vec<u16>> {
        self.tables(|t| Ok(span(self::table::<u16>(t, table, false)?, address, count)?.to_vec()))
    }

    /// Writes `values` into `table` from `address`.
    fn set_registers(&self, table: &str, address: i64, values: Vec<u16>) -> PyResult<()> {
        self.tables(|t| {
            span(self::table::<u16>(t, table, false)?, address, values.len())?
                .copy_from_slice(&values);
            Ok(())
        })
    }

    /// `count` bits of `table` ("coils" or "discrete_inputs") from `address`.
    fn get_bits(&self, table: &str, address: i64, count: usize) -> PyResult<Vec<bool>> {
        self.tables(|t| Ok(span(self::table::<bool>(t, table, true)?, address, count)?.to_vec()))
    }

    /// Writes `values` into `table` from `address`.
    fn set_bits(&self, table: &str, address: i64, values: Vec<bool>) -> PyResult<()> {
        self.tables(|t| {
            span(self::table::<bool>(t, table, true)?, address, values.len())?
                .copy_from_slice(&values);
            Ok(())
        })
    }

    /// `count` bytes of SIMATIC `area` ("DB1", "M", "Q", "I", "T", "C") from byte `start`.
    fn read_memory<'py>(
        &self,
        py: Python<'py>,
        area: &str,
        start: u32,
        count: usize,
    ) -> PyResult<Bound<'py, PyBytes>> {
        let area = self::area(area)?;
        let mut out = vec![0; count];
        self.memory(|m| {
            m.memory
                .read(area, start, &mut out)
                .map_err(|e| argument_error("start", &e.to_string(), start))
        })?;
        Ok(PyBytes::new(py, &out))
    }

    /// Writes `data` into SIMATIC `area` from byte `start`.
    fn write_memory(&self, area: &str, start: u32, data: &[u8]) -> PyResult<()> {
        let area = self::area(area)?;
        self.memory(|m| {
            m.memory
                .write(area, start, data)
                .map_err(|e| argument_error("start", &e.to_string(), start))
        })
    }
}
