//! S_MODB's address conversion: Modbus addresses to SIMATIC memory through the conversion DB
//! ([Modbus/USS] §3.5.3–§3.5.17, Tables 3-19/3-20/3-22–3-25;
//! [ET200S SI 2005] Table 3-20, §3.6.17, §3.6.20).
//!
//! [`ConversionDb`] is the 26-word DB passed to S_MODB as `DB_NO`; [`SimaticStore`] is a
//! [`Store`] over a [`Memory`] that applies it:
//!
//! - FC01/05/15: M bits (aaaaa…bbbbb from MBuuuuu.0), Q bits (ccccc…ddddd from Qooooo.0),
//!   timers (eeeee…fffff from Tttttt) and counters (ggggg…hhhhh from Czzzzz), the latter two
//!   FC01 only, in whole 16-bit words: offset and quantity multiples of 16 (0832H, exc. 03);
//! - FC02: M bits (kkkkk…lllll from MBvvvvv.0, read only) and inputs (nnnnn…rrrrr from Isssss.0);
//! - FC03/06/16 and FC04 (read only): DB = base + (R >> 9), DBW = (R & 1FFH) × 2;
//! - writes only inside [MIN, MAX] of the DB numbers, M bytes and Q bytes; MAX = 0 disables
//!   the area ([Modbus/USS] §3.5.17, §3.5.20).
//!
//! # Readings chosen where the manual is silent ([Modbus/USS] §3.5.3, §3.5.5–§3.5.19 `[derived]`)
//!
//! - The formulas for FC05/FC15 are printed swapped ([Modbus/USS] §3.5.5–§3.5.19 `[derived]`); we
//!   use the consistent ones (M from aaaaa/uuuuu, Q from ccccc/ooooo), which reproduce every worked
//!   example.
//! - The whole span `[A, A + quantity − 1]` must lie in one from/to range, not only its start;
//!   otherwise exception 02 (S_MODB ERROR_NR 11, "invalid start address").
//! - A register span crossing a 512-register boundary continues in the next DB, as the
//!   formula applied to each register gives; base + offset above 65535 is exception 02.
//! - Write-limit violations answer exception 02 (Table 3-12: "outside … limits"); area
//!   overruns (ERROR_NR 14–17) and a missing or short DB (20, 21) answer exception 04 (Table
//!   3-12: "FB reports an error … DB does not exist"); FC05/15 on T/C answer exception 02.
//! - A timer or counter is 16 Modbus bits in S7 memory order: the word's high byte is the
//!   first data byte, LSB of each byte first, as a DB word read through FC01 would be.

use crate::frame::{fc, Bits, ExceptionCode, Registers};
use crate::slave::{Store, StoreError};
use crate::status::slave as codes;
use serde::{Deserialize, Serialize};
use si_core::memory::{Area, Memory, MemoryError, MemorySizes};
use std::fmt;

/// The conversion DB of Table 3-19: 26 WORDs, every initial value 0.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ConversionDb {
    /// aaaaa: first Modbus bit address of the M area (FC01/05/15).
    pub m_from: u16,
    /// bbbbb: last Modbus bit address of the M area (inclusive).
    pub m_to: u16,
    /// uuuuu: first memory byte (MBuuuuu.0).
    pub m_byte: u16,
    /// ccccc: first Modbus bit address of the Q area (FC01/05/15).
    pub q_from: u16,
    /// ddddd: last Modbus bit address of the Q area.
    pub q_to: u16,
    /// ooooo: first output byte (Qooooo.0).
    pub q_byte: u16,
    /// eeeee: first Modbus bit address of the timer area (FC01 only).
    pub t_from: u16,
    /// fffff: last Modbus bit address of the timer area.
    pub t_to: u16,
    /// ttttt: first timer number.
    pub t_number: u16,
    /// ggggg: first Modbus bit address of the counter area (FC01 only).
    pub c_from: u16,
    /// hhhhh: last Modbus bit address of the counter area.
    pub c_to: u16,
    /// zzzzz: first counter number.
    pub c_number: u16,
    /// kkkkk: first Modbus bit address of the FC02 M area.
    pub fc02_m_from: u16,
    /// lllll: last Modbus bit address of the FC02 M area.
    pub fc02_m_to: u16,
    /// vvvvv: first memory byte for FC02.
    pub fc02_m_byte: u16,
    /// nnnnn: first Modbus bit address of the FC02 input area.
    pub i_from: u16,
    /// rrrrr: last Modbus bit address of the FC02 input area.
    pub i_to: u16,
    /// sssss: first input byte (Isssss.0).
    pub i_byte: u16,
    /// DB_Number_FC_03_06_16: base DB for FC03/06/16.
    pub db_fc03_06_16: u16,
    /// DB_Number_FC_04: base DB for FC04.
    pub db_fc04: u16,
    /// DB_Min: lowest DB number FC06/16 may write.
    pub db_min: u16,
    /// DB_Max: highest DB number FC06/16 may write (0 = none).
    pub db_max: u16,
    /// M_Min: lowest M byte FC05/15 may write.
    pub m_min: u16,
    /// M_Max: highest M byte FC05/15 may write (0 = none).
    pub m_max: u16,
    /// Q_Min: lowest Q byte FC05/15 may write.
    pub q_min: u16,
    /// Q_Max: highest Q byte FC05/15 may write (0 = none).
    pub q_max: u16,
}

impl ConversionDb {
    /// The "actual value" column of Table 3-19/3-20: M500.0 for 0–2039, Q21.0 for 2040–4079,
    /// T40 for 4080–6119, C40 for 6120–8159, FC02 M800.0 for 8160–10199 and I17.0 for
    /// 10200–12239, DB6 for FC03/06/16, DB2 for FC04, writes to DB1–6, MB500–1200, QB0–100.
    pub const EXAMPLE: ConversionDb = ConversionDb {
        m_from: 0,
        m_to: 0x7F7,
        m_byte: 0x1F4,
        q_from: 0x7F8,
        q_to: 0xFEF,
        q_byte: 0x15,
        t_from: 0xFF0,
        t_to: 0x17E7,
        t_number: 0x28,
        c_from: 0x17E8,
        c_to: 0x1FDF,
        c_number: 0x28,
        fc02_m_from: 0x1FE0,
        fc02_m_to: 0x27D7,
        fc02_m_byte: 0x320,
        i_from: 0x27D8,
        i_to: 0x2FCF,
        i_byte: 0x11,
        db_fc03_06_16: 6,
        db_fc04: 2,
        db_min: 1,
        db_max: 6,
        m_min: 0x1F4,
        m_max: 0x4B0,
        q_min: 0,
        q_max: 0x64,
    };

    /// The DB's 52 bytes as S7 stores them (WORDs high byte first, Table 3-19 order).
    pub fn to_bytes(&self) -> [u8; 52] {
        let mut out = [0; 52];
        for (i, w) in self.words().iter().enumerate() {
            out[2 * i..2 * i + 2].copy_from_slice(&w.to_be_bytes());
        }
        out
    }

    /// Read the DB from its bytes (at least 52); `None` if too short.
    pub fn from_bytes(bytes: &[u8]) -> Option<Self> {
        let b = bytes.get(..52)?;
        let w = |i: usize| u16::from_be_bytes([b[2 * i], b[2 * i + 1]]);
        Some(ConversionDb {
            m_from: w(0),
            m_to: w(1),
            m_byte: w(2),
            q_from: w(3),
            q_to: w(4),
            q_byte: w(5),
            t_from: w(6),
            t_to: w(7),
            t_number: w(8),
            c_from: w(9),
            c_to: w(10),
            c_number: w(11),
            fc02_m_from: w(12),
            fc02_m_to: w(13),
            fc02_m_byte: w(14),
            i_from: w(15),
            i_to: w(16),
            i_byte: w(17),
            db_fc03_06_16: w(18),
            db_fc04: w(19),
            db_min: w(20),
            db_max: w(21),
            m_min: w(22),
            m_max: w(23),
            q_min: w(24),
            q_max: w(25),
        })
    }

    fn words(&self) -> [u16; 26] {
        [
            self.m_from,
            self.m_to,
            self.m_byte,
            self.q_from,
            self.q_to,
            self.q_byte,
            self.t_from,
            self.t_to,
            self.t_number,
            self.c_from,
            self.c_to,
            self.c_number,
            self.fc02_m_from,
            self.fc02_m_to,
            self.fc02_m_byte,
            self.i_from,
            self.i_to,
            self.i_byte,
            self.db_fc03_06_16,
            self.db_fc04,
            self.db_min,
            self.db_max,
            self.m_min,
            self.m_max,
            self.q_min,
            self.q_max,
        ]
    }

    /// Where Modbus bit address `a` of `function` (01, 02, 05, 15) lands ([Modbus/USS]
    /// §3.5.5–§3.5.19).
    pub fn bit_address(&self, function: u8, a: u16) -> Result<BitAddress, StoreError> {
        let within = |from: u16, to: u16| from <= a && a <= to;
        let bit = |area: Area, from: u16, byte: u16| {
            let off = (a - from) as u32;
            BitAddress::Bit {
                area,
                byte: byte as u32 + off / 8,
                bit: (off % 8) as u8,
            }
        };
        let element = |area: Area, from: u16, number: u16| {
            let off = a - from;
            if off & 0xF != 0 {
                return Err(StoreError {
                    status: Some(codes::QUANTITY),
                    ..StoreError::new(ExceptionCode::IllegalDataValue, 11, a)
                });
            }
            Ok(BitAddress::Element {
                area,
                number: number as u32 + (off / 16) as u32,
            })
        };
        if function == fc::READ_DISCRETE_INPUTS {
            if within(self.fc02_m_from, self.fc02_m_to) {
                return Ok(bit(Area::Flags, self.fc02_m_from, self.fc02_m_byte));
            }
            if within(self.i_from, self.i_to) {
                return Ok(bit(Area::Inputs, self.i_from, self.i_byte));
            }
            return Err(StoreError::new(ExceptionCode::IllegalDataAddress, 11, a));
        }
        if within(self.m_from, self.m_to) {
            return Ok(bit(Area::Flags, self.m_from, self.m_byte));
        }
        if within(self.q_from, self.q_to) {
            return Ok(bit(Area::Outputs, self.q_from, self.q_byte));
        }
        let read_only = function != fc::READ_COILS;
        if within(self.t_from, self.t_to) {
            if read_only {
                return Err(StoreError::new(ExceptionCode::IllegalDataAddress, 18, a));
            }
            return element(Area::Timers, self.t_from, self.t_number);
        }
        if within(self.c_from, self.c_to) {
            if read_only {
                return Err(StoreError::new(ExceptionCode::IllegalDataAddress, 18, a));
            }
            return element(Area::Counters, self.c_from, self.c_number);
        }
        Err(StoreError::new(ExceptionCode::IllegalDataAddress, 11, a))
    }

    /// The last Modbus address of the range `a` lies in, for the span check.
    fn range_end(&self, function: u8, a: u16) -> u16 {
        let ranges: &[(u16, u16)] = if function == fc::READ_DISCRETE_INPUTS {
            &[(self.fc02_m_from, self.fc02_m_to), (self.i_from, self.i_to)]
        } else {
            &[
                (self.m_from, self.m_to),
                (self.q_from, self.q_to),
                (self.t_from, self.t_to),
                (self.c_from, self.c_to),
            ]
        };
        ranges
            .iter()
            .find(|(f, t)| *f <= a && a <= *t)
            .map_or(a, |r| r.1)
    }

    /// Where register `r` lands for `function` (03/06/16 or 04): DB base + (R >> 9),
    /// DBW (R & 1FFH) × 2 ([Modbus/USS] §3.5.5–§3.5.19, Tables 3-24/3-25).
    pub fn register_address(&self, function: u8, r: u16) -> Result<RegisterAddress, StoreError> {
        let base = if function == fc::READ_INPUT_REGISTERS {
            self.db_fc04
        } else {
            self.db_fc03_06_16
        };
        let db = base as u32 + (r >> 9) as u32;
        if db > u16::MAX as u32 || base == 0 {
            return Err(StoreError::new(ExceptionCode::IllegalDataAddress, 11, r));
        }
        Ok(RegisterAddress {
            db: db as u16,
            dbw: (r & 0x1FF) as u32 * 2,
        })
    }

    fn check_db_write(&self, db: u16) -> Result<(), StoreError> {
        if self.db_max == 0 || db > self.db_max {
            return Err(StoreError::new(ExceptionCode::IllegalDataAddress, 23, db));
        }
        if db < self.db_min {
            return Err(StoreError::new(ExceptionCode::IllegalDataAddress, 22, db));
        }
        Ok(())
    }

    fn check_byte_write(&self, area: Area, byte: u32) -> Result<(), StoreError> {
        let (min, max, below, above) = match area {
            Area::Flags => (self.m_min, self.m_max, 24, 25),
            Area::Outputs => (self.q_min, self.q_max, 26, 27),
            _ => return Err(StoreError::new(ExceptionCode::IllegalDataAddress, 18, 0)),
        };
        let info = byte.min(u16::MAX as u32) as u16;
        if max == 0 || byte > max as u32 {
            return Err(StoreError::new(
                ExceptionCode::IllegalDataAddress,
                above,
                info,
            ));
        }
        if byte < min as u32 {
            return Err(StoreError::new(
                ExceptionCode::IllegalDataAddress,
                below,
                info,
            ));
        }
        Ok(())
    }
}

/// A SIMATIC bit or element address, printed the S7 way (`M1004.1`, `Q257.1`, `T101`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BitAddress {
    /// A bit of a byte area.
    Bit {
        /// M, Q or I.
        area: Area,
        /// Byte number.
        byte: u32,
        /// Bit 0–7.
        bit: u8,
    },
    /// A timer or counter (16 Modbus bits).
    Element {
        /// T or C.
        area: Area,
        /// Its number.
        number: u32,
    },
}

impl fmt::Display for BitAddress {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BitAddress::Bit { area, byte, bit } => write!(f, "{area}{byte}.{bit}"),
            BitAddress::Element { area, number } => write!(f, "{area}{number}"),
        }
    }
}

/// A DB word address, printed `DB800.DBW768`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct RegisterAddress {
    /// The DB.
    pub db: u16,
    /// Byte offset of the word (even, 0–1022).
    pub dbw: u32,
}

impl fmt::Display for RegisterAddress {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "DB{}.DBW{}", self.db, self.dbw)
    }
}

/// A [`Store`] over SIMATIC memory through a conversion DB: what S_MODB does in the CPU.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SimaticStore {
    /// The CPU's memory.
    pub memory: Memory,
    /// The conversion DB.
    pub conversion: ConversionDb,
    /// S_MODB initialised (START_OK); while false every request gets exception 04 ([Modbus/USS]
    /// §3.5.1, §3.5.2).
    pub started: bool,
}

impl SimaticStore {
    /// A started store.
    pub fn new(memory: Memory, conversion: ConversionDb) -> Self {
        SimaticStore {
            memory,
            conversion,
            started: true,
        }
    }

    /// What `si modbus serve` uses without a config: Table 3-20's conversion DB over a CPU
    /// with DB1–DB6 (1024 bytes each), MB0–MB1255, QB0–QB127, IB0–IB127, T0–T255, C0–C255.
    pub fn example() -> Self {
        let mut sizes = MemorySizes {
            flags: 1256,
            ..MemorySizes::default()
        };
        for db in 1..=6 {
            sizes.dbs.insert(db, 1024);
        }
        SimaticStore::new(Memory::new(&sizes), ConversionDb::EXAMPLE)
    }

    fn check_started(&self) -> Result<(), StoreError> {
        if self.started {
            Ok(())
        } else {
            Err(StoreError::new(ExceptionCode::SlaveDeviceFailure, 0, 0))
        }
    }

    /// Map and check the span of a bit access.
    fn bit_span(&self, function: u8, a: u16, quantity: u16) -> Result<BitAddress, StoreError> {
        self.check_started()?;
        let target = self.conversion.bit_address(function, a)?;
        let last = a as u32 + quantity as u32 - 1;
        if last > self.conversion.range_end(function, a) as u32 {
            return Err(StoreError::new(ExceptionCode::IllegalDataAddress, 11, a));
        }
        if let BitAddress::Element { .. } = target {
            if quantity & 0xF != 0 {
                return Err(StoreError {
                    status: Some(codes::QUANTITY),
                    ..StoreError::new(ExceptionCode::IllegalDataValue, 0, quantity)
                });
            }
        }
        Ok(target)
    }

    fn read_bits(
        &mut self,
        function: u8,
        a: u16,
        quantity: u16,
        out: &mut [u8],
    ) -> Result<(), StoreError> {
        match self.bit_span(function, a, quantity)? {
            BitAddress::Bit { area, byte, bit } => {
                for i in 0..quantity as u32 {
                    let pos = bit as u32 + i;
                    let v = self
                        .memory
                        .bit(area, byte + pos / 8, (pos % 8) as u8)
                        .map_err(memory_error)?;
                    if v {
                        out[i as usize / 8] |= 1 << (i % 8);
                    }
                }
                Ok(())
            }
            BitAddress::Element { area, number } => {
                let count = quantity as u32 / 16;
                self.memory
                    .check_elements(area, number, count)
                    .map_err(memory_error)?;
                for k in 0..count {
                    let w = self
                        .memory
                        .element(area, number + k)
                        .map_err(memory_error)?;
                    out[2 * k as usize..2 * k as usize + 2].copy_from_slice(&w.to_be_bytes());
                }
                Ok(())
            }
        }
    }

    fn read_regs(
        &mut self,
        function: u8,
        r: u16,
        quantity: u16,
        out: &mut [u8],
    ) -> Result<(), StoreError> {
        self.check_started()?;
        for i in 0..quantity {
            let reg = r.checked_add(i).ok_or(StoreError::new(
                ExceptionCode::IllegalDataAddress,
                11,
                r,
            ))?;
            let at = self.conversion.register_address(function, reg)?;
            let w = self
                .memory
                .word(Area::Db(at.db), at.dbw)
                .map_err(memory_error)?;
            out[2 * i as usize..2 * i as usize + 2].copy_from_slice(&w.to_be_bytes());
        }
        Ok(())
    }
}

/// S_MODB's errors 14–17, 20, 21 ([Modbus/USS] §3.6.4, §3.6.5): exception 04.
fn memory_error(e: MemoryError) -> StoreError {
    let (nr, info) = match e {
        MemoryError::OutOfRange { area, end, .. } => (
            match area {
                Area::Flags => 14,
                Area::Outputs | Area::Inputs => 15,
                Area::Timers => 16,
                Area::Counters => 17,
                Area::Db(_) => 21,
            },
            match area {
                Area::Db(n) => n,
                _ => end.min(u16::MAX as u64) as u16,
            },
        ),
        MemoryError::NoSuchDb(n) => (20, n),
    };
    StoreError::new(ExceptionCode::SlaveDeviceFailure, nr, info)
}

impl Store for SimaticStore {
    fn read_coils(
        &mut self,
        address: u16,
        quantity: u16,
        out: &mut [u8],
    ) -> Result<(), StoreError> {
        self.read_bits(fc::READ_COILS, address, quantity, out)
    }

    fn read_discrete_inputs(
        &mut self,
        address: u16,
        quantity: u16,
        out: &mut [u8],
    ) -> Result<(), StoreError> {
        self.read_bits(fc::READ_DISCRETE_INPUTS, address, quantity, out)
    }

    fn read_holding_registers(
        &mut self,
        address: u16,
        quantity: u16,
        out: &mut [u8],
    ) -> Result<(), StoreError> {
        self.read_regs(fc::READ_HOLDING_REGISTERS, address, quantity, out)
    }

    fn read_input_registers(
        &mut self,
        address: u16,
        quantity: u16,
        out: &mut [u8],
    ) -> Result<(), StoreError> {
        self.read_regs(fc::READ_INPUT_REGISTERS, address, quantity, out)
    }

    fn write_coils(&mut self, address: u16, values: Bits<'_>) -> Result<(), StoreError> {
        let quantity = values.len() as u16;
        let function = if quantity == 1 {
            fc::WRITE_SINGLE_COIL
        } else {
            fc::WRITE_MULTIPLE_COILS
        };
        let BitAddress::Bit { area, byte, bit } = self.bit_span(function, address, quantity)?
        else {
            return Err(StoreError::new(
                ExceptionCode::IllegalDataAddress,
                18,
                address,
            ));
        };
        // Check every byte touched against the limits and the area before writing anything.
        let last = byte + (bit as u32 + quantity as u32 - 1) / 8;
        for b in byte..=last {
            self.conversion.check_byte_write(area, b)?;
        }
        let mut probe = [0u8; 1];
        self.memory
            .read(area, last, &mut probe)
            .map_err(memory_error)?;
        for (i, v) in values.iter().enumerate() {
            let pos = bit as u32 + i as u32;
            self.memory
                .set_bit(area, byte + pos / 8, (pos % 8) as u8, v)
                .map_err(memory_error)?;
        }
        Ok(())
    }

    fn write_registers(&mut self, address: u16, values: Registers<'_>) -> Result<(), StoreError> {
        self.check_started()?;
        let f = fc::WRITE_MULTIPLE_REGISTERS;
        for i in 0..values.len() as u16 {
            let reg = address.checked_add(i).ok_or(StoreError::new(
                ExceptionCode::IllegalDataAddress,
                11,
                address,
            ))?;
            let at = self.conversion.register_address(f, reg)?;
            self.conversion.check_db_write(at.db)?;
            self.memory
                .word(Area::Db(at.db), at.dbw)
                .map_err(memory_error)?;
        }
        for (i, v) in values.iter().enumerate() {
            let at = self.conversion.register_address(f, address + i as u16)?;
            self.memory
                .set_word(Area::Db(at.db), at.dbw, v)
                .map_err(memory_error)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The mapping of the worked examples in §3.5.6 (Table 3-22): M from 1000.0 for 0–2047,
    /// Q256.0 for 2048–2559, T100 from 4096, C200 from 4608.
    fn table_3_22() -> ConversionDb {
        ConversionDb {
            m_from: 0,
            m_to: 2047,
            m_byte: 1000,
            q_from: 2048,
            q_to: 2559,
            q_byte: 256,
            t_from: 4096,
            t_to: 4607,
            t_number: 100,
            c_from: 4608,
            c_to: 5119,
            c_number: 200,
            fc02_m_from: 0,
            fc02_m_to: 4095,
            fc02_m_byte: 2000,
            i_from: 4096,
            i_to: 5119,
            i_byte: 128,
            db_fc03_06_16: 800,
            db_fc04: 900,
            ..ConversionDb::default()
        }
    }

    #[test]
    fn table_3_22_fc01_conversion_examples() {
        let db = table_3_22();
        for (a, s) in [
            (0, "M1000.0"),
            (33, "M1004.1"),
            (64, "M1008.0"),
            (1024, "M1128.0"),
            (1542, "M1192.6"),
            (2112, "Q264.0"),
            (2532, "Q316.4"),
            (4112, "T101"),
            (4288, "T112"),
            (4608, "C200"),
            (5088, "C230"),
        ] {
            assert_eq!(
                db.bit_address(fc::READ_COILS, a).unwrap().to_string(),
                s,
                "A = {a}"
            );
        }
        // §3.5.10: FC05 at 0809H in the Q range from 2048 → Q257.1.
        assert_eq!(
            db.bit_address(fc::WRITE_SINGLE_COIL, 0x0809)
                .unwrap()
                .to_string(),
            "Q257.1"
        );
        // Timers and counters only at multiples of 16, and not for FC05/15.
        let e = db.bit_address(fc::READ_COILS, 4100).unwrap_err();
        assert_eq!(
            (e.exception, e.status),
            (ExceptionCode::IllegalDataValue, Some(codes::QUANTITY))
        );
        assert!(db.bit_address(fc::WRITE_SINGLE_COIL, 4096).is_err());
    }

    #[test]
    fn table_3_23_fc02_conversion_examples() {
        let db = table_3_22();
        for (a, s) in [
            (0, "M2000.0"),
            (113, "M2014.1"),
            (2048, "M2256.0"),
            (3333, "M2416.5"),
            (4096, "I128.0"),
            (4144, "I134.0"),
            (4260, "I148.4"),
        ] {
            assert_eq!(
                db.bit_address(fc::READ_DISCRETE_INPUTS, a)
                    .unwrap()
                    .to_string(),
                s,
                "A = {a}"
            );
        }
    }

    #[test]
    fn tables_3_24_and_3_25_register_conversion_examples() {
        let mut db = table_3_22();
        for (r, s) in [
            (0, "DB800.DBW0"),
            (500, "DB800.DBW1000"),
            (512, "DB801.DBW0"),
            (767, "DB801.DBW510"),
            (768, "DB801.DBW512"),
            (1023, "DB801.DBW1022"),
            (1024, "DB802.DBW0"),
            (0x0180, "DB800.DBW768"),
            (0x0032, "DB800.DBW100"),
        ] {
            assert_eq!(
                db.register_address(fc::READ_HOLDING_REGISTERS, r)
                    .unwrap()
                    .to_string(),
                s,
                "R = {r}"
            );
        }
        db.db_fc03_06_16 = 900;
        for (r, s) in [
            (100, "DB900.DBW200"),
            (200, "DB900.DBW400"),
            (400, "DB900.DBW800"),
            (5120, "DB910.DBW0"),
            (5220, "DB910.DBW200"),
            (5320, "DB910.DBW400"),
        ] {
            assert_eq!(
                db.register_address(fc::WRITE_SINGLE_REGISTER, r)
                    .unwrap()
                    .to_string(),
                s,
                "R = {r}"
            );
        }
        // FC04 R = 02C0H (704) with its own base DB 900 → DB901.DBW384 ([Modbus/USS]
        // §3.5.5–§3.5.19).
        assert_eq!(
            db.register_address(fc::READ_INPUT_REGISTERS, 0x02C0)
                .unwrap()
                .to_string(),
            "DB901.DBW384"
        );
    }

    #[test]
    fn conversion_db_bytes_round_trip_table_3_19() {
        let bytes = ConversionDb::EXAMPLE.to_bytes();
        assert_eq!(&bytes[2..4], &[0x07, 0xF7]); // bbbbb = 7F7H
        assert_eq!(&bytes[36..38], &[0, 6]); // DB_Number_FC_03_06_16
        assert_eq!(
            ConversionDb::from_bytes(&bytes),
            Some(ConversionDb::EXAMPLE)
        );
        assert_eq!(ConversionDb::from_bytes(&bytes[..51]), None);
        assert_eq!(ConversionDb::default().to_bytes(), [0; 52]);
    }

    /// §3.5.14: FC16 at R = 0032H with base DB800 writes CD09H, DE1AH, EF2BH to DBW100/102/104;
    /// §3.5.13: FC15 writes M1144.0…M1145.3 (12 bits; the text says 10 and 12, [Modbus/USS]
    /// §3.5.5–§3.5.19 `[derived]`) from data bytes CDH, 09H.
    #[test]
    fn worked_write_examples() {
        let mut sizes = MemorySizes::default();
        sizes.dbs.insert(800, 1024);
        let mut conv = table_3_22();
        conv.db_min = 800;
        conv.db_max = 800;
        conv.m_min = 1000;
        conv.m_max = 1255;
        let mut s = SimaticStore::new(Memory::new(&sizes), conv);
        s.write_registers(0x0032, Registers::Words(&[0xCD09, 0xDE1A, 0xEF2B]))
            .unwrap();
        let db = Area::Db(800);
        assert_eq!(s.memory.word(db, 100).unwrap(), 0xCD09);
        assert_eq!(s.memory.word(db, 102).unwrap(), 0xDE1A);
        assert_eq!(s.memory.word(db, 104).unwrap(), 0xEF2B);
        s.write_coils(0x0480, Bits::packed(&[0xCD, 0x09], 12))
            .unwrap();
        assert_eq!(s.memory.bytes(Area::Flags).unwrap()[1144], 0xCD);
        assert_eq!(s.memory.bytes(Area::Flags).unwrap()[1145] & 0x0F, 0x09);
    }

    /// [Modbus/USS] §3.5.17, §3.5.20: MAX = 0 disables writes; outside [MIN, MAX] is refused with
    /// ERROR_NR 22–27.
    #[test]
    fn write_limits() {
        let mut s = SimaticStore::example();
        // DB7 (R = 512 from base DB6) is above DB_Max = 6.
        let e = s.write_registers(512, Registers::Words(&[1])).unwrap_err();
        assert_eq!(
            (e.exception, e.error_nr, e.info),
            (ExceptionCode::IllegalDataAddress, 23, 7)
        );
        s.conversion.db_min = 7;
        let e = s.write_registers(0, Registers::Words(&[1])).unwrap_err();
        assert_eq!(e.error_nr, 22);
        s.conversion.db_max = 0;
        assert_eq!(
            s.write_registers(0, Registers::Words(&[1]))
                .unwrap_err()
                .error_nr,
            23
        );
        // Q: coils 2040… map to Q21; Q_Max = 100 allows QB21.
        assert!(s.write_coils(2040, Bits::Bools(&[true])).is_ok());
        s.conversion.q_max = 0;
        assert_eq!(
            s.write_coils(2040, Bits::Bools(&[true]))
                .unwrap_err()
                .error_nr,
            27
        );
        s.conversion.q_max = 100;
        s.conversion.q_min = 22;
        assert_eq!(
            s.write_coils(2040, Bits::Bools(&[true]))
                .unwrap_err()
                .error_nr,
            26
        );
        // M: coils 0… map to MB500 = M_Min; M_Max 1200.
        assert!(s.write_coils(0, Bits::Bools(&[true; 16])).is_ok());
        s.conversion.m_min = 501;
        assert_eq!(
            s.write_coils(0, Bits::Bools(&[true])).unwrap_err().error_nr,
            24
        );
        s.conversion.m_max = 0;
        assert_eq!(
            s.write_coils(8, Bits::Bools(&[true])).unwrap_err().error_nr,
            25
        );
        // Timers are read only (FC05/15 rejected), read in whole words.
        assert_eq!(
            s.write_coils(4080, Bits::Bools(&[true]))
                .unwrap_err()
                .exception,
            ExceptionCode::IllegalDataAddress
        );
        s.memory.set_element(Area::Timers, 40, 0x1234).unwrap();
        let mut out = [0u8; 2];
        s.read_coils(4080, 16, &mut out).unwrap();
        assert_eq!(out, [0x12, 0x34]);
        let e = s.read_coils(4080, 8, &mut out).unwrap_err();
        assert_eq!(e.status, Some(codes::QUANTITY));
    }
}
