//! What `si modbus serve` serves: the address map printed at start-up, and for a refused
//! request the address and why. The map itself is si-modbus's ([`si_modbus::serve_map`]),
//! converted by the slave's own conversion functions; this module prints it.
//!
//! [`Explaining`] wraps the slave's store: when the store refuses a request, it prints the
//! request's address and count and, from the map, why (outside every range the slave serves,
//! or a write outside the write limits) before the engine answers the exception.

use crate::output::Output;
use serde_json::json;
use si_modbus::frame::{Bits, Registers};
use si_modbus::serve_map::{ServeMap, Table};
use si_modbus::slave::{Store, StoreError};

/// Print the map `map`, one line a range, for slave `unit`.
pub fn print(map: &ServeMap, unit: u8, out: &Output) {
    for table in map.unserved() {
        out.line(
            &format!(
                "unit {unit} serves no {} ({})",
                table.name(),
                table.functions()
            ),
            json!({"unit": unit, "table": table.name(), "ranges": []}),
        );
    }
    for r in &map.ranges {
        let writes = r
            .writes
            .as_deref()
            .map(|w| format!(", {w}"))
            .unwrap_or_default();
        out.line(
            &format!(
                "unit {unit} serves {} ({}) {}..={}: {}{writes}",
                r.table.name(),
                r.table.functions(),
                r.first,
                r.last,
                r.target
            ),
            json!({"unit": unit, "table": r.table.name(), "first": r.first, "last": r.last,
                   "target": r.target, "writes": r.writes}),
        );
    }
}

/// A store that says why it refuses: on an error from the wrapped store, prints the request's
/// address, count and the reason from the [`ServeMap`], then passes the error on unchanged.
pub struct Explaining<S> {
    inner: S,
    map: ServeMap,
    out: Output,
}

impl<S: Store> Explaining<S> {
    /// Wrap `inner`, whose addresses `map` describes, printing through `out`.
    pub fn new(inner: S, map: ServeMap, out: Output) -> Self {
        Explaining { inner, map, out }
    }

    fn explain(
        &self,
        result: Result<(), StoreError>,
        (table, write): (Table, bool),
        address: u16,
        count: usize,
    ) -> Result<(), StoreError> {
        if let Err(e) = &result {
            let why = self.map.why(table, write, address, count, e);
            let action = if write { "write" } else { "read" };
            self.out.line(
                &format!(
                    "refused {} {action} address {address} count {count}: {}: {why}",
                    table.name(),
                    e.exception
                ),
                json!({"refused": table.name(), "write": write, "address": address,
                       "count": count, "exception": e.exception.code(), "why": why}),
            );
        }
        result
    }
}

impl<S: Store> Store for Explaining<S> {
    fn read_coils(
        &mut self,
        address: u16,
        quantity: u16,
        out: &mut [u8],
    ) -> Result<(), StoreError> {
        let r = self.inner.read_coils(address, quantity, out);
        self.explain(r, (Table::Coils, false), address, quantity.into())
    }
    fn read_discrete_inputs(
        &mut self,
        address: u16,
        quantity: u16,
        out: &mut [u8],
    ) -> Result<(), StoreError> {
        let r = self.inner.read_discrete_inputs(address, quantity, out);
        self.explain(r, (Table::DiscreteInputs, false), address, quantity.into())
    }
    fn read_holding_registers(
        &mut self,
        address: u16,
        quantity: u16,
        out: &mut [u8],
    ) -> Result<(), StoreError> {
        let r = self.inner.read_holding_registers(address, quantity, out);
        self.explain(
            r,
            (Table::HoldingRegisters, false),
            address,
            quantity.into(),
        )
    }
    fn read_input_registers(
        &mut self,
        address: u16,
        quantity: u16,
        out: &mut [u8],
    ) -> Result<(), StoreError> {
        let r = self.inner.read_input_registers(address, quantity, out);
        self.explain(r, (Table::InputRegisters, false), address, quantity.into())
    }
    fn write_coils(&mut self, address: u16, values: Bits<'_>) -> Result<(), StoreError> {
        let r = self.inner.write_coils(address, values);
        self.explain(r, (Table::Coils, true), address, values.len())
    }
    fn write_registers(&mut self, address: u16, values: Registers<'_>) -> Result<(), StoreError> {
        let r = self.inner.write_registers(address, values);
        self.explain(r, (Table::HoldingRegisters, true), address, values.len())
    }
}
