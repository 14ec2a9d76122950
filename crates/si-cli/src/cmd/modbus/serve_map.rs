//! What `si modbus serve` serves: the address map printed at start-up, and for a
//! refused request the address and why.
//!
//! The map follows S_MODB's conversion DB ([Modbus/USS] §3.5.3–§3.5.17, Tables 3-19/3-20,
//! applied by `si_modbus::simatic`) over the simulated CPU's memory sizes: a Modbus range is
//! listed as far as the memory behind it exists (beyond, the slave answers exception 04, area
//! overrun). Registers are listed per DB: DB = base + (R >> 9), 512 registers a DB ([Modbus/USS]
//! §3.5.5–§3.5.19).
//!
//! [`Explaining`] wraps the slave's store: when the store refuses a request, it prints the
//! request's address and count and, from the map, why (outside every range the slave serves,
//! or a write outside the write limits of [Modbus/USS] §3.5.17, §3.5.20) before the engine answers
//! the exception.

use crate::output::Output;
use serde_json::json;
use si_core::memory::{Area, MemorySizes};
use si_modbus::frame::{Bits, ExceptionCode, Registers};
use si_modbus::simatic::ConversionDb;
use si_modbus::slave::{Store, StoreError};

/// The four Modbus tables.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Table {
    Coils,
    DiscreteInputs,
    HoldingRegisters,
    InputRegisters,
}

impl Table {
    fn name(self) -> &'static str {
        match self {
            Table::Coils => "coils",
            Table::DiscreteInputs => "discrete inputs",
            Table::HoldingRegisters => "holding registers",
            Table::InputRegisters => "input registers",
        }
    }

    fn functions(self) -> &'static str {
        match self {
            Table::Coils => "FC01/05/15",
            Table::DiscreteInputs => "FC02",
            Table::HoldingRegisters => "FC03/06/16",
            Table::InputRegisters => "FC04",
        }
    }
}

/// One served range of Modbus addresses.
#[derive(Debug, Clone)]
struct Range {
    table: Table,
    first: u16,
    last: u16,
    /// The SIMATIC memory behind it, e.g. `M500.0 … M754.7`.
    target: String,
    /// What writes may do there (`None` for a table that is read only anyway).
    writes: Option<String>,
}

impl Range {
    fn contains(&self, table: Table, a: u32) -> bool {
        self.table == table && u32::from(self.first) <= a && a <= u32::from(self.last)
    }
}

/// The address map of a slave: what each Modbus address reaches.
#[derive(Debug, Clone)]
pub struct ServeMap {
    ranges: Vec<Range>,
}

/// The write limit of a byte area ([Modbus/USS] §3.5.17, §3.5.20: MAX = 0 disables writes).
fn byte_writes(area: Area, min: u16, max: u16) -> Option<String> {
    Some(if max == 0 {
        format!("no writes ({area}_Max = 0)")
    } else {
        format!("writes to {area}B{min}..={area}B{max} only")
    })
}

/// A bit range onto a byte area from `byte`.0, as far as `size` bytes of memory reach.
fn bits(
    table: Table,
    (from, to): (u16, u16),
    (area, byte, size): (Area, u16, u32),
    writes: Option<String>,
) -> Option<Range> {
    let available = size.saturating_sub(u32::from(byte)).saturating_mul(8);
    if from > to || available == 0 {
        return None;
    }
    let last = u32::from(to).min(u32::from(from).saturating_add(available - 1));
    let end = last - u32::from(from);
    Some(Range {
        table,
        first: from,
        last: last as u16,
        target: format!(
            "{area}{byte}.0 … {area}{}.{}",
            u32::from(byte) + end / 8,
            end % 8
        ),
        writes,
    })
}

/// A bit range onto timers or counters from `number`, 16 bits an element, FC01 only.
fn elements((from, to): (u16, u16), (area, number, count): (Area, u16, u32)) -> Option<Range> {
    let available = count.saturating_sub(u32::from(number)).saturating_mul(16);
    if from > to || available == 0 {
        return None;
    }
    let last = u32::from(to).min(u32::from(from).saturating_add(available - 1));
    Some(Range {
        table: Table::Coils,
        first: from,
        last: last as u16,
        target: format!(
            "{area}{number} … {area}{}",
            u32::from(number) + (last - u32::from(from)) / 16
        ),
        writes: Some("read only (FC01)".to_owned()),
    })
}

/// The register ranges from DB `base` on: 512 registers a DB, as far as each DB exists.
fn registers(
    table: Table,
    base: u16,
    dbs: &std::collections::BTreeMap<u16, u32>,
    writes: impl Fn(u16) -> Option<String>,
) -> Vec<Range> {
    if base == 0 {
        return Vec::new();
    }
    dbs.iter()
        .filter(|(&db, &len)| db >= base && db - base < 128 && len >= 2)
        .map(|(&db, &len)| {
            let first = u32::from(db - base) * 512;
            let count = (len / 2).min(512);
            Range {
                table,
                first: first as u16,
                last: (first + count - 1) as u16,
                target: format!("DB{db}.DBW0 … DB{db}.DBW{}", 2 * (count - 1)),
                writes: writes(db),
            }
        })
        .collect()
}

impl ServeMap {
    /// The map of `conversion` over memory of `sizes`.
    pub fn new(c: &ConversionDb, sizes: &MemorySizes) -> Self {
        let m_writes = byte_writes(Area::Flags, c.m_min, c.m_max);
        let q_writes = byte_writes(Area::Outputs, c.q_min, c.q_max);
        let mut ranges: Vec<Range> = [
            bits(
                Table::Coils,
                (c.m_from, c.m_to),
                (Area::Flags, c.m_byte, sizes.flags),
                m_writes,
            ),
            bits(
                Table::Coils,
                (c.q_from, c.q_to),
                (Area::Outputs, c.q_byte, sizes.outputs),
                q_writes,
            ),
            elements((c.t_from, c.t_to), (Area::Timers, c.t_number, sizes.timers)),
            elements(
                (c.c_from, c.c_to),
                (Area::Counters, c.c_number, sizes.counters),
            ),
            bits(
                Table::DiscreteInputs,
                (c.fc02_m_from, c.fc02_m_to),
                (Area::Flags, c.fc02_m_byte, sizes.flags),
                None,
            ),
            bits(
                Table::DiscreteInputs,
                (c.i_from, c.i_to),
                (Area::Inputs, c.i_byte, sizes.inputs),
                None,
            ),
        ]
        .into_iter()
        .flatten()
        .collect();
        ranges.extend(registers(
            Table::HoldingRegisters,
            c.db_fc03_06_16,
            &sizes.dbs,
            |db| {
                Some(if c.db_max != 0 && (c.db_min..=c.db_max).contains(&db) {
                    "writable".to_owned()
                } else {
                    format!(
                        "no writes (outside DB_Min..=DB_Max {}..={})",
                        c.db_min, c.db_max
                    )
                })
            },
        ));
        ranges.extend(registers(
            Table::InputRegisters,
            c.db_fc04,
            &sizes.dbs,
            |_| None,
        ));
        ranges.sort_by_key(|r| (r.table as u8, r.first));
        ServeMap { ranges }
    }

    /// Print the map, one line a range, for slave `unit`.
    pub fn print(&self, unit: u8, out: &Output) {
        for table in [
            Table::Coils,
            Table::DiscreteInputs,
            Table::HoldingRegisters,
            Table::InputRegisters,
        ] {
            if !self.ranges.iter().any(|r| r.table == table) {
                out.line(
                    &format!(
                        "unit {unit} serves no {} ({})",
                        table.name(),
                        table.functions()
                    ),
                    json!({"unit": unit, "table": table.name(), "ranges": []}),
                );
            }
        }
        for r in &self.ranges {
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

    /// Why a request for `count` addresses from `address` of `table` was refused with
    /// `error`, as far as the map tells.
    fn why(
        &self,
        table: Table,
        write: bool,
        address: u16,
        count: usize,
        error: &StoreError,
    ) -> String {
        let span = u32::from(address)..u32::from(address) + count.max(1) as u32;
        let served: Vec<&Range> = self.ranges.iter().filter(|r| r.table == table).collect();
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

    fn find(map: &ServeMap, table: Table, first: u16) -> &Range {
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
