//! What a slave over S_MODB's conversion DB serves: the Modbus address ranges of each table
//! with the SIMATIC memory behind them, and why a refused request was refused.
//!
//! The map follows the conversion DB ([Modbus/USS] §3.5.3, Table 3-19; write limits §3.5.17,
//! §3.5.20) over the
//! CPU's memory sizes: a Modbus range is listed as far as the memory behind it exists (beyond,
//! the slave answers exception 04, area overrun). Registers are listed per DB: DB = base +
//! (R >> 9), 512 registers a DB. Each range's ends are converted by
//! [`ConversionDb::bit_address`] and [`ConversionDb::register_address`], the functions the
//! slave itself uses, so the printed map cannot drift from what is served.

use crate::frame::{fc, Bits, ExceptionCode, Registers};
use crate::simatic::ConversionDb;
use crate::slave::{Store, StoreError};
use si_core::memory::{Area, MemorySizes};
use std::collections::BTreeMap;

/// The four Modbus tables.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Table {
    /// Coils: FC01, FC05, FC15.
    Coils,
    /// Discrete inputs: FC02.
    DiscreteInputs,
    /// Holding registers: FC03, FC06, FC16.
    HoldingRegisters,
    /// Input registers: FC04.
    InputRegisters,
}

impl Table {
    /// Every table, in the order of their function codes.
    pub const ALL: [Table; 4] = [
        Table::Coils,
        Table::DiscreteInputs,
        Table::HoldingRegisters,
        Table::InputRegisters,
    ];

    /// The table's name (`holding registers`).
    pub const fn name(self) -> &'static str {
        match self {
            Table::Coils => "coils",
            Table::DiscreteInputs => "discrete inputs",
            Table::HoldingRegisters => "holding registers",
            Table::InputRegisters => "input registers",
        }
    }

    /// The function codes that reach it (`FC03/06/16`).
    pub const fn functions(self) -> &'static str {
        match self {
            Table::Coils => "FC01/05/15",
            Table::DiscreteInputs => "FC02",
            Table::HoldingRegisters => "FC03/06/16",
            Table::InputRegisters => "FC04",
        }
    }

    /// The read function whose conversion this table follows.
    const fn read_function(self) -> u8 {
        match self {
            Table::Coils => fc::READ_COILS,
            Table::DiscreteInputs => fc::READ_DISCRETE_INPUTS,
            Table::HoldingRegisters => fc::READ_HOLDING_REGISTERS,
            Table::InputRegisters => fc::READ_INPUT_REGISTERS,
        }
    }
}

/// One served range of Modbus addresses.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ServedRange {
    /// The table.
    pub table: Table,
    /// First address served.
    pub first: u16,
    /// Last address served.
    pub last: u16,
    /// The SIMATIC memory behind it, e.g. `M500.0 … M754.7`.
    pub target: String,
    /// What writes may do there (`None` for a table that is read only anyway).
    pub writes: Option<String>,
}

impl ServedRange {
    /// Whether address `a` of `table` is in this range.
    pub fn contains(&self, table: Table, a: u32) -> bool {
        self.table == table && u32::from(self.first) <= a && a <= u32::from(self.last)
    }
}

/// The address map of a slave: what each Modbus address reaches.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ServeMap {
    /// The ranges, by table and first address.
    pub ranges: Vec<ServedRange>,
}

/// The write limit of a byte area ([Modbus/USS] §3.5.17: MAX = 0 disables writes).
fn byte_writes(area: Area, min: u16, max: u16) -> Option<String> {
    Some(if max == 0 {
        format!("no writes ({area}_Max = 0)")
    } else {
        format!("writes to {area}B{min}..={area}B{max} only")
    })
}

/// The last address of `from..=to` whose memory exists: `per_unit` Modbus bits a byte or an
/// element, `units` of them from the range's first one.
fn clipped_last((from, to): (u16, u16), units: u32, per_unit: u32) -> Option<u16> {
    let available = units.saturating_mul(per_unit);
    if from > to || available == 0 {
        return None;
    }
    Some(u32::from(to).min(u32::from(from).saturating_add(available - 1)) as u16)
}

impl ServeMap {
    /// The map of `c` over memory of `sizes`.
    pub fn new(c: &ConversionDb, sizes: &MemorySizes) -> Self {
        let bits = |table: Table, range: (u16, u16), (byte, size): (u16, u32), writes| {
            let last = clipped_last(range, size.saturating_sub(u32::from(byte)), 8)?;
            self::range(c, table, range.0, last, 1, writes)
        };
        // Timers and counters: 16 Modbus bits an element, read only (FC01).
        let elements = |range: (u16, u16), (number, count): (u16, u32)| {
            let last = clipped_last(range, count.saturating_sub(u32::from(number)), 16)?;
            let read_only = Some("read only (FC01)".to_owned());
            self::range(c, Table::Coils, range.0, last, 16, read_only)
        };
        let mut ranges: Vec<ServedRange> = [
            bits(
                Table::Coils,
                (c.m_from, c.m_to),
                (c.m_byte, sizes.flags),
                byte_writes(Area::Flags, c.m_min, c.m_max),
            ),
            bits(
                Table::Coils,
                (c.q_from, c.q_to),
                (c.q_byte, sizes.outputs),
                byte_writes(Area::Outputs, c.q_min, c.q_max),
            ),
            elements((c.t_from, c.t_to), (c.t_number, sizes.timers)),
            elements((c.c_from, c.c_to), (c.c_number, sizes.counters)),
            bits(
                Table::DiscreteInputs,
                (c.fc02_m_from, c.fc02_m_to),
                (c.fc02_m_byte, sizes.flags),
                None,
            ),
            bits(
                Table::DiscreteInputs,
                (c.i_from, c.i_to),
                (c.i_byte, sizes.inputs),
                None,
            ),
        ]
        .into_iter()
        .flatten()
        .collect();
        let writable = |db: u16| {
            Some(if c.db_max != 0 && (c.db_min..=c.db_max).contains(&db) {
                "writable".to_owned()
            } else {
                format!(
                    "no writes (outside DB_Min..=DB_Max {}..={})",
                    c.db_min, c.db_max
                )
            })
        };
        ranges.extend(registers(c, Table::HoldingRegisters, &sizes.dbs, writable));
        ranges.extend(registers(c, Table::InputRegisters, &sizes.dbs, |_| None));
        ranges.sort_by_key(|r| (r.table, r.first));
        ServeMap { ranges }
    }

    /// The tables with no range at all.
    pub fn unserved(&self) -> impl Iterator<Item = Table> + '_ {
        Table::ALL
            .into_iter()
            .filter(|&t| !self.ranges.iter().any(|r| r.table == t))
    }

    /// Why a request for `count` addresses from `address` of `table` (a write if `write`) was
    /// refused with `error`, as far as the map tells: the first address outside every range
    /// served, or the write limit of the range, or else S_MODB's ERROR_NR and ERROR_INFO.
    pub fn why(
        &self,
        table: Table,
        write: bool,
        address: u16,
        count: usize,
        error: &StoreError,
    ) -> String {
        let span = u32::from(address)..u32::from(address) + count.max(1) as u32;
        let served: Vec<&ServedRange> = self.ranges.iter().filter(|r| r.table == table).collect();
        if let Some(outside) = span
            .clone()
            .find(|&a| !served.iter().any(|r| r.contains(table, a)))
        {
            if served.is_empty() {
                return format!("this slave serves no {}", table.name());
            }
            let list: Vec<String> = served
                .iter()
                .map(|r| format!("{}..={}", r.first, r.last))
                .collect();
            return format!(
                "{outside} is outside the {} served: {}",
                table.name(),
                list.join(", ")
            );
        }
        let range = served.iter().find(|r| r.contains(table, span.start));
        match (write, range.and_then(|r| r.writes.as_deref())) {
            (true, Some(limit)) if error.exception == ExceptionCode::IllegalDataAddress => {
                format!(
                    "inside {}, but {limit}",
                    range.map_or("", |r| r.target.as_str())
                )
            }
            _ => format!(
                "S_MODB ERROR_NR {} ERROR_INFO {}",
                error.error_nr, error.info
            ),
        }
    }
}

/// The range `first..=last` of a bit table, its target converted at both ends by
/// [`ConversionDb::bit_address`]; `step` Modbus bits an element (16 for timers and counters,
/// whose last element starts at a multiple of 16 from `first`).
fn range(
    c: &ConversionDb,
    table: Table,
    first: u16,
    last: u16,
    step: u16,
    writes: Option<String>,
) -> Option<ServedRange> {
    let function = table.read_function();
    let from = c.bit_address(function, first).ok()?;
    let to = c.bit_address(function, last - (last - first) % step).ok()?;
    Some(ServedRange {
        table,
        first,
        last,
        target: format!("{from} … {to}"),
        writes,
    })
}

/// The register ranges of `table` from its base DB on: 512 registers a DB, as far as each DB
/// exists, the targets converted by [`ConversionDb::register_address`].
fn registers(
    c: &ConversionDb,
    table: Table,
    dbs: &BTreeMap<u16, u32>,
    writes: impl Fn(u16) -> Option<String>,
) -> Vec<ServedRange> {
    let function = table.read_function();
    let base = if table == Table::InputRegisters {
        c.db_fc04
    } else {
        c.db_fc03_06_16
    };
    if base == 0 {
        return Vec::new();
    }
    dbs.iter()
        .filter(|(&db, &len)| db >= base && db - base < 128 && len >= 2)
        .filter_map(|(&db, &len)| {
            let first = u32::from(db - base) * 512;
            let count = (len / 2).min(512);
            let (first, last) = (first as u16, (first + count - 1) as u16);
            let from = c.register_address(function, first).ok()?;
            let to = c.register_address(function, last).ok()?;
            Some(ServedRange {
                table,
                first,
                last,
                target: format!("{from} … {to}"),
                writes: writes(db),
            })
        })
        .collect()
}

/// A request the wrapped store refused, and why as far as the map tells ([`ServeMap::why`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Refusal {
    /// The table asked for.
    pub table: Table,
    /// A write (else a read).
    pub write: bool,
    /// The first address asked for.
    pub address: u16,
    /// How many addresses.
    pub count: usize,
    /// The exception the slave answers with.
    pub exception: ExceptionCode,
    /// Why, from the map.
    pub why: String,
}

/// A store that says why it refuses: on an error from the wrapped store, hands a [`Refusal`]
/// to `tell`, then passes the error on unchanged (the engine answers the exception as before).
pub struct Explaining<S, F> {
    inner: S,
    map: ServeMap,
    tell: F,
}

impl<S: Store, F: FnMut(&Refusal)> Explaining<S, F> {
    /// Wrap `inner`, whose addresses `map` describes, telling `tell` of each refusal.
    pub fn new(inner: S, map: ServeMap, tell: F) -> Self {
        Explaining { inner, map, tell }
    }

    fn explain(
        &mut self,
        result: Result<(), StoreError>,
        (table, write): (Table, bool),
        address: u16,
        count: usize,
    ) -> Result<(), StoreError> {
        if let Err(e) = &result {
            (self.tell)(&Refusal {
                table,
                write,
                address,
                count,
                exception: e.exception,
                why: self.map.why(table, write, address, count, e),
            });
        }
        result
    }
}

impl<S: Store, F: FnMut(&Refusal)> Store for Explaining<S, F> {
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
        let table = (Table::HoldingRegisters, false);
        self.explain(r, table, address, quantity.into())
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

#[cfg(test)]
mod tests {
    use super::*;

    fn example_sizes() -> MemorySizes {
        let mut sizes = MemorySizes {
            inputs: 128,
            outputs: 128,
            flags: 1256,
            timers: 256,
            counters: 256,
            ..MemorySizes::default()
        };
        for db in 1..=6 {
            sizes.dbs.insert(db, 1024);
        }
        sizes
    }

    fn find(map: &ServeMap, table: Table, first: u16) -> &ServedRange {
        map.ranges
            .iter()
            .find(|r| r.table == table && r.first == first)
            .unwrap_or_else(|| panic!("no {table:?} range at {first}: {map:#?}"))
    }

    #[test]
    fn table_3_20_over_the_example_memory() {
        let map = ServeMap::new(&ConversionDb::EXAMPLE, &example_sizes());
        // M500.0 for 0–2039 (255 bytes: MB500–MB754), writes limited to MB500–MB1200.
        let m = find(&map, Table::Coils, 0);
        assert_eq!((m.last, m.target.as_str()), (2039, "M500.0 … M754.7"));
        assert_eq!(m.writes.as_deref(), Some("writes to MB500..=MB1200 only"));
        // Q21.0 for 2040–4079 needs QB21–QB275, but the CPU has QB0–QB127: 856 bits served.
        let q = find(&map, Table::Coils, 2040);
        assert_eq!(
            (q.last, q.target.as_str()),
            (2040 + 107 * 8 - 1, "Q21.0 … Q127.7")
        );
        // T40 for 4080–6119: 2040 bits = 127.5 timers, T40–T167.
        let t = find(&map, Table::Coils, 4080);
        assert_eq!((t.last, t.target.as_str()), (6119, "T40 … T167"));
        // FC03 from DB6: only DB6 exists at or above it.
        let holding: Vec<_> = map
            .ranges
            .iter()
            .filter(|r| r.table == Table::HoldingRegisters)
            .collect();
        assert_eq!(holding.len(), 1);
        assert_eq!((holding[0].first, holding[0].last), (0, 511));
        assert_eq!(holding[0].target, "DB6.DBW0 … DB6.DBW1022");
        // FC04 from DB2: DB2–DB6, 512 registers each.
        let input: Vec<_> = map
            .ranges
            .iter()
            .filter(|r| r.table == Table::InputRegisters)
            .collect();
        assert_eq!(input.len(), 5);
        assert_eq!(input[4].last, 2559);
    }

    #[test]
    fn huge_memory_sizes_from_a_config_file_do_not_overflow() {
        let sizes = MemorySizes {
            inputs: u32::MAX,
            outputs: u32::MAX,
            flags: u32::MAX,
            timers: u32::MAX,
            counters: u32::MAX,
            ..MemorySizes::default()
        };
        let map = ServeMap::new(&ConversionDb::EXAMPLE, &sizes);
        assert_eq!(find(&map, Table::Coils, 0).last, 2039);
    }

    #[test]
    fn a_refusal_names_the_first_address_outside_and_the_served_ranges() {
        let map = ServeMap::new(&ConversionDb::EXAMPLE, &example_sizes());
        let e = StoreError::address();
        let why = map.why(Table::HoldingRegisters, false, 500, 20, &e);
        assert_eq!(why, "512 is outside the holding registers served: 0..=511");
        let why = map.why(Table::Coils, true, 0, 1, &e);
        assert_eq!(
            why,
            "inside M500.0 … M754.7, but writes to MB500..=MB1200 only"
        );
        let no_memory = ServeMap::new(&ConversionDb::EXAMPLE, &MemorySizes::default());
        let why = no_memory.why(Table::InputRegisters, false, 0, 1, &e);
        assert_eq!(why, "this slave serves no input registers");
    }
}
