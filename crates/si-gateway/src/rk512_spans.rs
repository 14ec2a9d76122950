//! Which S7 bytes a Modbus request touches through S_MODB's conversion DB, as RK 512 job
//! addresses: one [`Span`] per FETCH or SEND the gateway runs for the request.
//!
//! The conversion is si-modbus's ([`ConversionDb::bit_address`],
//! [`ConversionDb::register_address`]; [Modbus/USS] §3.5.5–§3.5.19), so a Modbus client
//! sees the RK 512 partner's memory as it would see that CPU's through S_MODB. What RK 512
//! adds ([CP 341] §2.2.3, Table 2-1):
//!
//! - **A register span crossing a 512-register boundary** continues in the next DB (the
//!   conversion formula per register): one span, so one SEND or FETCH, per DB.
//! - **DB number and DW number are one byte each** (header bytes 5 and 6): a DB above 255, or
//!   a span whose first data word is above DW 255 (DBW 512 onward, registers 256–511 of each
//!   DB; with `dw_unit = bytes` DBB 256 onward), cannot be addressed and is refused with
//!   exception 02H (illegal data address). Only the first DW is in the header, so a span
//!   starting at or below DW 255 may run past it. A span crossing the 512-register boundary
//!   starts at DW 387 or later (a request has at most 125 registers), so in practice such a
//!   request is refused as a whole.
//! - **SEND writes only data blocks** (Table 2-1 footnote "when sending, only 'D' is
//!   possible"): FC05/FC15, whose every address is an M or Q bit (or a read-only T/C), are
//!   refused with exception 01H (illegal function) on an RK 512 unit, whatever the
//!   conversion DB's M/Q write limits say.
//! - Flags, inputs and outputs are addressed by byte (`'M'`, `'E'`, `'A'` with a 16-bit byte
//!   number), timers and counters by cell (`'T'`, `'Z'`, one word each).

use super::line::{ILLEGAL_DATA_ADDRESS, ILLEGAL_FUNCTION};
use si_core::memory::{Area, Memory, MemoryError, MemorySizes, MAX_AREA_BYTES, MAX_ELEMENTS};
use si_modbus::frame::{fc, Request};
use si_modbus::simatic::{BitAddress, ConversionDb};
use si_rk512::config::DwUnit;
use si_rk512::frame::Address;

/// The bytes of a data block the mirror holds: DBW 0 … 1022, all S_MODB's conversion reaches
/// ((R & 1FFH) × 2, [Modbus/USS] §3.5.5–§3.5.19).
pub const DB_BYTES: u32 = 1024;

/// One RK 512 job's worth of S7 memory.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Span {
    /// The partner's address (the job header).
    pub address: Address,
    /// The area in the gateway's mirror.
    pub area: Area,
    /// First byte (I, Q, M, DB) or cell number (T, C).
    pub start: u32,
    /// Bytes of the job (two per timer or counter cell).
    pub len: usize,
}

impl Span {
    /// Bytes (I, Q, M, DB) or cells (T, C) of the span.
    fn units(&self) -> u32 {
        match self.area {
            Area::Timers | Area::Counters => (self.len / 2) as u32,
            _ => self.len as u32,
        }
    }

    /// True when `other` lies inside this span.
    pub fn covers(&self, other: &Span) -> bool {
        self.area == other.area
            && self.start <= other.start
            && other.start + other.units() <= self.start + self.units()
    }

    /// The span's bytes in `memory` (T and C cells high byte first).
    pub fn load(&self, memory: &Memory) -> Result<Vec<u8>, MemoryError> {
        let mut out = vec![0; self.len];
        match self.area {
            Area::Timers | Area::Counters => {
                for (k, cell) in out.chunks_mut(2).enumerate() {
                    let w = memory.element(self.area, self.start + k as u32)?;
                    cell.copy_from_slice(&w.to_be_bytes());
                }
            }
            area => memory.read(area, self.start, &mut out)?,
        }
        Ok(out)
    }

    /// Put `data` (the span's bytes, as FETCHed) into `memory`.
    pub fn store(&self, memory: &mut Memory, data: &[u8]) -> Result<(), MemoryError> {
        match self.area {
            Area::Timers | Area::Counters => {
                for (k, cell) in data.chunks_exact(2).enumerate() {
                    let w = u16::from_be_bytes([cell[0], cell[1]]);
                    memory.set_element(self.area, self.start + k as u32, w)?;
                }
                Ok(())
            }
            area => memory.write(area, self.start, data),
        }
    }
}

/// The spans `request` touches, in address order; none for a request without memory (FC08,
/// or one the store refuses anyway). Errors are the exception to answer.
pub fn spans(
    conversion: &ConversionDb,
    dw_unit: DwUnit,
    request: &Request<'_>,
) -> Result<Vec<Span>, u8> {
    let function = request.function();
    match *request {
        Request::ReadCoils { address, quantity }
        | Request::ReadDiscreteInputs { address, quantity } => {
            let target = conversion
                .bit_address(function, address)
                .map_err(|e| e.exception.code())?;
            Ok(vec![bit_span(target, quantity)?])
        }
        Request::ReadHoldingRegisters { address, quantity }
        | Request::ReadInputRegisters { address, quantity } => {
            register_spans(conversion, dw_unit, function, address, quantity)
        }
        Request::WriteSingleRegister { address, .. } => {
            register_spans(conversion, dw_unit, function, address, 1)
        }
        Request::WriteMultipleRegisters { address, values } => {
            register_spans(conversion, dw_unit, function, address, values.len() as u16)
        }
        Request::WriteSingleCoil { .. } | Request::WriteMultipleCoils { .. } => {
            Err(ILLEGAL_FUNCTION)
        }
        _ => Ok(Vec::new()),
    }
}

/// The bytes (or cells) `quantity` bits from `target` occupy.
fn bit_span(target: BitAddress, quantity: u16) -> Result<Span, u8> {
    let (area, start, len) = match target {
        BitAddress::Bit { area, byte, bit } => {
            let bytes = (u32::from(bit) + u32::from(quantity).max(1) - 1) / 8 + 1;
            (area, byte, bytes as usize)
        }
        BitAddress::Element { area, number } => {
            (area, number, 2 * usize::from(quantity.div_ceil(16).max(1)))
        }
    };
    let at = u16::try_from(start).map_err(|_| ILLEGAL_DATA_ADDRESS)?;
    let address = match area {
        Area::Flags => Address::Flags(at),
        Area::Outputs => Address::Outputs(at),
        Area::Inputs => Address::Inputs(at),
        Area::Timers => Address::Timers(at),
        Area::Counters => Address::Counters(at),
        Area::Db(_) => return Err(ILLEGAL_DATA_ADDRESS),
    };
    Ok(Span {
        address,
        area,
        start,
        len,
    })
}

/// Registers `first … first + quantity − 1`, one span per DB they land in.
fn register_spans(
    conversion: &ConversionDb,
    dw_unit: DwUnit,
    function: u8,
    first: u16,
    quantity: u16,
) -> Result<Vec<Span>, u8> {
    db_runs(conversion, function, first, quantity)?
        .into_iter()
        .map(|(db, byte, len)| db_span(db, byte, len, dw_unit))
        .collect()
}

/// The registers' `(DB, first byte, bytes)` runs, one per DB: a run crossing a 512-register
/// boundary continues in the next DB (the conversion applied to each register, [Modbus/USS]
/// §3.5.5–§3.5.19).
fn db_runs(
    conversion: &ConversionDb,
    function: u8,
    first: u16,
    quantity: u16,
) -> Result<Vec<(u16, u32, usize)>, u8> {
    let mut runs: Vec<(u16, u32, usize)> = Vec::new();
    for i in 0..quantity {
        let r = first.checked_add(i).ok_or(ILLEGAL_DATA_ADDRESS)?;
        let at = conversion
            .register_address(function, r)
            .map_err(|e| e.exception.code())?;
        match runs.last_mut() {
            Some((db, _, len)) if *db == at.db => *len += 2,
            _ => runs.push((at.db, at.dbw, 2)),
        }
    }
    Ok(runs)
}

/// `len` bytes of DB `db` from byte `byte`, as RK 512 addresses them (module docs).
pub fn db_span(db: u16, byte: u32, len: usize, dw_unit: DwUnit) -> Result<Span, u8> {
    let number = u8::try_from(db).map_err(|_| ILLEGAL_DATA_ADDRESS)?;
    let dw = match dw_unit {
        DwUnit::Words => byte / 2,
        DwUnit::Bytes => byte,
    };
    let dw = u8::try_from(dw).map_err(|_| ILLEGAL_DATA_ADDRESS)?;
    Ok(Span {
        address: Address::Db { db: number, dw },
        area: Area::Db(db),
        start: byte,
        len,
    })
}

/// The mirror's I, Q, M, T and C sizes: what the conversion DB's ranges reach, each at most
/// the SIMATIC memory's area limit. Data blocks are added when a span first names them.
pub fn mirror_sizes(c: &ConversionDb) -> MemorySizes {
    // Bits `from … to` from byte (or cell) `first`, `per` bits per byte (or cell).
    let reach = |from: u16, to: u16, first: u16, per: u32, cap: u32| {
        if to < from {
            return 0;
        }
        (u32::from(first) + u32::from(to - from) / per + 1).min(cap)
    };
    MemorySizes {
        inputs: reach(c.i_from, c.i_to, c.i_byte, 8, MAX_AREA_BYTES),
        outputs: reach(c.q_from, c.q_to, c.q_byte, 8, MAX_AREA_BYTES),
        flags: reach(c.m_from, c.m_to, c.m_byte, 8, MAX_AREA_BYTES).max(reach(
            c.fc02_m_from,
            c.fc02_m_to,
            c.fc02_m_byte,
            8,
            MAX_AREA_BYTES,
        )),
        timers: reach(c.t_from, c.t_to, c.t_number, 16, MAX_ELEMENTS),
        counters: reach(c.c_from, c.c_to, c.c_number, 16, MAX_ELEMENTS),
        dbs: Default::default(),
    }
}

/// Give `memory` every data block `spans` name that it lacks ([`DB_BYTES`] each; at most
/// 256, the DB numbers RK 512 can address).
pub fn add_dbs(memory: &mut Memory, spans: &[Span]) {
    for s in spans {
        if let Area::Db(n) = s.area {
            if memory.bytes(s.area).is_err() {
                memory.add_db(n, DB_BYTES);
            }
        }
    }
}

/// True for the read functions a mirror answers (FC01–04).
pub fn is_read(function: u8) -> bool {
    matches!(
        function,
        fc::READ_COILS
            | fc::READ_DISCRETE_INPUTS
            | fc::READ_HOLDING_REGISTERS
            | fc::READ_INPUT_REGISTERS
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use si_modbus::frame::Bits;

    const EXAMPLE: ConversionDb = ConversionDb::EXAMPLE;

    fn read(address: u16, quantity: u16) -> Request<'static> {
        Request::ReadHoldingRegisters { address, quantity }
    }

    #[test]
    fn registers_map_to_db_words_and_continue_in_the_next_db() {
        // Base DB6: R 10 … 11 → DB6.DBW20, DW10, 4 bytes.
        let s = spans(&EXAMPLE, DwUnit::Words, &read(10, 2)).unwrap();
        assert_eq!(s.len(), 1);
        assert_eq!(s[0].address, Address::Db { db: 6, dw: 10 });
        assert_eq!((s[0].area, s[0].start, s[0].len), (Area::Db(6), 20, 4));
        // R 510 … 513 crosses into DB7 at R 512 → two spans, the second from DW0. R 510 is
        // DW 510 > 255, so it is refused; from R 255 (DW 255) the first span may run on.
        assert_eq!(
            spans(&EXAMPLE, DwUnit::Words, &read(510, 4)),
            Err(ILLEGAL_DATA_ADDRESS)
        );
        let s = spans(&EXAMPLE, DwUnit::Words, &read(1024 + 255, 2)).unwrap();
        assert_eq!(s[0].address, Address::Db { db: 8, dw: 255 });
        assert_eq!(s[0].len, 4, "a span may run past DW 255");
    }

    #[test]
    fn a_run_over_the_512_boundary_continues_in_the_next_db() {
        let f = fc::READ_HOLDING_REGISTERS;
        assert_eq!(
            db_runs(&EXAMPLE, f, 510, 4),
            Ok(vec![(6, 1020, 4), (7, 0, 4)])
        );
        assert_eq!(db_runs(&EXAMPLE, f, 0, 3), Ok(vec![(6, 0, 6)]));
        // Such a span's first part starts at DW 387 or later (at most 125 registers), beyond
        // the one header byte, so over RK 512 the request is refused as a whole.
        assert_eq!(
            spans(&EXAMPLE, DwUnit::Words, &read(500, 20)),
            Err(ILLEGAL_DATA_ADDRESS)
        );
        // Past register 65535: refused, not wrapped.
        assert_eq!(db_runs(&EXAMPLE, f, 65535, 2), Err(ILLEGAL_DATA_ADDRESS));
    }

    #[test]
    fn db_and_dw_above_255_are_refused() {
        assert_eq!(
            db_span(256, 0, 2, DwUnit::Words),
            Err(ILLEGAL_DATA_ADDRESS),
            "DB number is one byte"
        );
        assert_eq!(db_span(6, 512, 2, DwUnit::Words), Err(ILLEGAL_DATA_ADDRESS));
        assert!(db_span(6, 510, 2, DwUnit::Words).is_ok());
        assert_eq!(db_span(6, 256, 2, DwUnit::Bytes), Err(ILLEGAL_DATA_ADDRESS));
        let s = db_span(6, 200, 2, DwUnit::Bytes).unwrap();
        assert_eq!(s.address, Address::Db { db: 6, dw: 200 });
        // Base DB 300: every register is beyond RK 512's DB numbers.
        let c = ConversionDb {
            db_fc03_06_16: 300,
            ..EXAMPLE
        };
        assert_eq!(
            spans(&c, DwUnit::Words, &read(0, 1)),
            Err(ILLEGAL_DATA_ADDRESS)
        );
    }

    #[test]
    fn bits_map_to_flag_output_input_bytes_and_timer_cells() {
        // Coils 0 … 15 → MB500 … MB501; coil 2043 … 2052 → Q21.3 … Q22.4, two bytes.
        let coils = |address, quantity| Request::ReadCoils { address, quantity };
        let s = spans(&EXAMPLE, DwUnit::Words, &coils(0, 16)).unwrap();
        assert_eq!((s[0].address, s[0].len), (Address::Flags(500), 2));
        let s = spans(&EXAMPLE, DwUnit::Words, &coils(2043, 10)).unwrap();
        assert_eq!(
            (s[0].address, s[0].start, s[0].len),
            (Address::Outputs(21), 21, 2)
        );
        // Timers from 4080 (T40), 32 bits = two cells = 4 bytes.
        let s = spans(&EXAMPLE, DwUnit::Words, &coils(4080 + 16, 32)).unwrap();
        assert_eq!(
            (s[0].address, s[0].start, s[0].len),
            (Address::Timers(41), 41, 4)
        );
        // FC02 from 10200 → IB17.
        let di = Request::ReadDiscreteInputs {
            address: 10200,
            quantity: 1,
        };
        let s = spans(&EXAMPLE, DwUnit::Words, &di).unwrap();
        assert_eq!((s[0].address, s[0].len), (Address::Inputs(17), 1));
        // Coil writes: SEND cannot reach M or Q.
        let w = Request::WriteMultipleCoils {
            address: 0,
            values: Bits::Bools(&[true]),
        };
        assert_eq!(spans(&EXAMPLE, DwUnit::Words, &w), Err(ILLEGAL_FUNCTION));
        // Outside every range: the conversion's own 02H.
        assert_eq!(
            spans(&EXAMPLE, DwUnit::Words, &coils(60000, 1)),
            Err(ILLEGAL_DATA_ADDRESS)
        );
    }

    #[test]
    fn spans_round_trip_through_memory_and_cover_each_other() {
        let mut sizes = mirror_sizes(&EXAMPLE);
        assert_eq!((sizes.flags, sizes.outputs, sizes.inputs), (1055, 276, 272));
        assert_eq!((sizes.timers, sizes.counters), (168, 168));
        sizes.timers = 50;
        let mut m = Memory::new(&sizes);
        let t = Span {
            address: Address::Timers(41),
            area: Area::Timers,
            start: 41,
            len: 4,
        };
        t.store(&mut m, &[0x12, 0x34, 0x56, 0x78]).unwrap();
        assert_eq!(m.element(Area::Timers, 42).unwrap(), 0x5678);
        assert_eq!(t.load(&m).unwrap(), [0x12, 0x34, 0x56, 0x78]);
        let db = db_span(6, 20, 4, DwUnit::Words).unwrap();
        add_dbs(&mut m, &[db]);
        db.store(&mut m, &[1, 2, 3, 4]).unwrap();
        assert_eq!(m.word(Area::Db(6), 22).unwrap(), 0x0304);
        let image = db_span(6, 0, 200, DwUnit::Words).unwrap();
        assert!(image.covers(&db));
        assert!(!db.covers(&image));
        assert!(!t.covers(&db));
    }
}
