//! What a slave or server started from Python serves: plain Modbus tables, or the SIMATIC
//! memory behind S_MODB's conversion DB. Both are si-modbus's stores; this only picks one.

use si_modbus::frame::{Bits, Registers};
use si_modbus::slave::{Store, StoreError, Tables};
use si_modbus::SimaticStore;
use std::sync::{Arc, Mutex};

/// The store of a Python slave or server.
#[derive(Debug)]
pub enum PyStore {
    /// Coils, discrete inputs, holding and input registers from address 0.
    Tables(Tables),
    /// A CPU's memory (DB1–DB6, M, Q, I, T, C) through the manual's example conversion DB.
    Simatic(Box<SimaticStore>),
}

impl PyStore {
    /// The store picked, for the requests to go to.
    fn picked(&mut self) -> &mut dyn Store {
        match self {
            PyStore::Tables(s) => s,
            PyStore::Simatic(s) => &mut **s,
        }
    }
}

impl Store for PyStore {
    fn read_coils(
        &mut self,
        address: u16,
        quantity: u16,
        out: &mut [u8],
    ) -> Result<(), StoreError> {
        self.picked().read_coils(address, quantity, out)
    }

    fn read_discrete_inputs(
        &mut self,
        address: u16,
        quantity: u16,
        out: &mut [u8],
    ) -> Result<(), StoreError> {
        self.picked().read_discrete_inputs(address, quantity, out)
    }

    fn read_holding_registers(
        &mut self,
        address: u16,
        quantity: u16,
        out: &mut [u8],
    ) -> Result<(), StoreError> {
        self.picked().read_holding_registers(address, quantity, out)
    }

    fn read_input_registers(
        &mut self,
        address: u16,
        quantity: u16,
        out: &mut [u8],
    ) -> Result<(), StoreError> {
        self.picked().read_input_registers(address, quantity, out)
    }

    fn write_coils(&mut self, address: u16, values: Bits<'_>) -> Result<(), StoreError> {
        self.picked().write_coils(address, values)
    }

    fn write_registers(&mut self, address: u16, values: Registers<'_>) -> Result<(), StoreError> {
        self.picked().write_registers(address, values)
    }
}

/// A store shared between its slave or server and Python: the engine locks it for one
/// request, Python for one read or write.
#[derive(Debug, Clone)]
pub struct SharedStore(pub Arc<Mutex<PyStore>>);

impl SharedStore {
    /// Runs `f` on the store.
    pub fn with<R>(&self, f: impl FnOnce(&mut PyStore) -> R) -> R {
        f(&mut self.0.lock().unwrap_or_else(|e| e.into_inner()))
    }
}

impl Store for SharedStore {
    fn read_coils(
        &mut self,
        address: u16,
        quantity: u16,
        out: &mut [u8],
    ) -> Result<(), StoreError> {
        self.with(|s| s.read_coils(address, quantity, out))
    }

    fn read_discrete_inputs(
        &mut self,
        address: u16,
        quantity: u16,
        out: &mut [u8],
    ) -> Result<(), StoreError> {
        self.with(|s| s.read_discrete_inputs(address, quantity, out))
    }

    fn read_holding_registers(
        &mut self,
        address: u16,
        quantity: u16,
        out: &mut [u8],
    ) -> Result<(), StoreError> {
        self.with(|s| s.read_holding_registers(address, quantity, out))
    }

    fn read_input_registers(
        &mut self,
        address: u16,
        quantity: u16,
        out: &mut [u8],
    ) -> Result<(), StoreError> {
        self.with(|s| s.read_input_registers(address, quantity, out))
    }

    fn write_coils(&mut self, address: u16, values: Bits<'_>) -> Result<(), StoreError> {
        self.with(|s| s.write_coils(address, values))
    }

    fn write_registers(&mut self, address: u16, values: Registers<'_>) -> Result<(), StoreError> {
        self.with(|s| s.write_registers(address, values))
    }
}
