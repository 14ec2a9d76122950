//! Where a slave's data live: the [`Store`] trait (S_MODB's part of a request, [Modbus/USS]
//! §3.5.1, §3.5.2), its refusal [`StoreError`], and plain [`Tables`]. Shared by the RTU slave
//! engine ([`crate::slave`]) and the request execution ([`crate::serve`]) that the Modbus TCP
//! server runs too.

use crate::frame::{Bits, ExceptionCode, Registers};
use si_core::Status;

/// Why a [`Store`] refused an access: the exception the master gets, and S_MODB's view of it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("{exception} (S_MODB ERROR_NR {error_nr}, ERROR_INFO {info})")]
pub struct StoreError {
    /// Exception code sent to the master (Table 3-12: 02 area not enabled or limits, 03 value,
    /// 04 FB or CPU error).
    pub exception: ExceptionCode,
    /// The driver event to log, if the manual names one (0832H for T/C not in 16-bit steps).
    pub status: Option<Status>,
    /// S_MODB ERROR_NR ([Modbus/USS] §3.6.4, §3.6.5), 0 if none applies.
    pub error_nr: u16,
    /// S_MODB ERROR_INFO.
    pub info: u16,
}

impl StoreError {
    /// An error with this exception and S_MODB number.
    pub const fn new(exception: ExceptionCode, error_nr: u16, info: u16) -> Self {
        StoreError {
            exception,
            status: None,
            error_nr,
            info,
        }
    }

    /// Exception 02, illegal data address, no S_MODB number.
    pub const fn address() -> Self {
        StoreError::new(ExceptionCode::IllegalDataAddress, 0, 0)
    }
}

/// Where a slave's data live. Quantities are already checked against the manual's limits
/// (1–2040 bits, 1–127 registers) when these are called.
pub trait Store {
    /// FC01: `quantity` coils from `address`, packed LSB first into `out`
    /// (`ceil(quantity / 8)` bytes, zeroed).
    fn read_coils(&mut self, address: u16, quantity: u16, out: &mut [u8])
        -> Result<(), StoreError>;
    /// FC02: discrete inputs, packed like [`read_coils`](Store::read_coils).
    fn read_discrete_inputs(
        &mut self,
        address: u16,
        quantity: u16,
        out: &mut [u8],
    ) -> Result<(), StoreError>;
    /// FC03: `quantity` holding registers into `out`, high byte first (`2 × quantity` bytes).
    fn read_holding_registers(
        &mut self,
        address: u16,
        quantity: u16,
        out: &mut [u8],
    ) -> Result<(), StoreError>;
    /// FC04: input registers, like [`read_holding_registers`](Store::read_holding_registers).
    fn read_input_registers(
        &mut self,
        address: u16,
        quantity: u16,
        out: &mut [u8],
    ) -> Result<(), StoreError>;
    /// FC05 (one value) and FC15.
    fn write_coils(&mut self, address: u16, values: Bits<'_>) -> Result<(), StoreError>;
    /// FC06 (one value) and FC16.
    fn write_registers(&mut self, address: u16, values: Registers<'_>) -> Result<(), StoreError>;
}

/// Plain Modbus tables: coils, discrete inputs, holding and input registers from address 0.
/// An access beyond a table's end is exception 02.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Tables {
    /// Coils (FC01/05/15).
    pub coils: Vec<bool>,
    /// Discrete inputs (FC02).
    pub discrete_inputs: Vec<bool>,
    /// Holding registers (FC03/06/16).
    pub holding_registers: Vec<u16>,
    /// Input registers (FC04).
    pub input_registers: Vec<u16>,
}

impl Tables {
    /// Tables of these sizes, all zero.
    pub fn new(coils: usize, discrete_inputs: usize, holding: usize, input: usize) -> Self {
        Tables {
            coils: vec![false; coils],
            discrete_inputs: vec![false; discrete_inputs],
            holding_registers: vec![0; holding],
            input_registers: vec![0; input],
        }
    }
}

fn span<T>(
    table: &[T],
    address: u16,
    quantity: usize,
) -> Result<core::ops::Range<usize>, StoreError> {
    let start = address as usize;
    let end = start + quantity;
    if end > table.len() {
        return Err(StoreError::address());
    }
    Ok(start..end)
}

fn pack(bits: &[bool], out: &mut [u8]) {
    for (i, &b) in bits.iter().enumerate() {
        if b {
            out[i / 8] |= 1 << (i % 8);
        }
    }
}

fn words(regs: &[u16], out: &mut [u8]) {
    for (i, r) in regs.iter().enumerate() {
        out[2 * i..2 * i + 2].copy_from_slice(&r.to_be_bytes());
    }
}

impl Store for Tables {
    fn read_coils(
        &mut self,
        address: u16,
        quantity: u16,
        out: &mut [u8],
    ) -> Result<(), StoreError> {
        let r = span(&self.coils, address, quantity as usize)?;
        pack(&self.coils[r], out);
        Ok(())
    }
    fn read_discrete_inputs(
        &mut self,
        address: u16,
        quantity: u16,
        out: &mut [u8],
    ) -> Result<(), StoreError> {
        let r = span(&self.discrete_inputs, address, quantity as usize)?;
        pack(&self.discrete_inputs[r], out);
        Ok(())
    }
    fn read_holding_registers(
        &mut self,
        address: u16,
        quantity: u16,
        out: &mut [u8],
    ) -> Result<(), StoreError> {
        let r = span(&self.holding_registers, address, quantity as usize)?;
        words(&self.holding_registers[r], out);
        Ok(())
    }
    fn read_input_registers(
        &mut self,
        address: u16,
        quantity: u16,
        out: &mut [u8],
    ) -> Result<(), StoreError> {
        let r = span(&self.input_registers, address, quantity as usize)?;
        words(&self.input_registers[r], out);
        Ok(())
    }
    fn write_coils(&mut self, address: u16, values: Bits<'_>) -> Result<(), StoreError> {
        let r = span(&self.coils, address, values.len())?;
        for (slot, v) in self.coils[r].iter_mut().zip(values.iter()) {
            *slot = v;
        }
        Ok(())
    }
    fn write_registers(&mut self, address: u16, values: Registers<'_>) -> Result<(), StoreError> {
        let r = span(&self.holding_registers, address, values.len())?;
        for (slot, v) in self.holding_registers[r].iter_mut().zip(values.iter()) {
            *slot = v;
        }
        Ok(())
    }
}
