//! What `si modbus serve` serves: the address map printed at start-up, and for a refused
//! request the address and why. The map itself is si-modbus's ([`si_modbus::serve_map`]),
//! converted by the slave's own conversion functions; this module prints it.
//!
//! `si_modbus::serve_map::Explaining` wraps the slave's store and tells of each request the
//! store refuses; [`print_refusal`] prints it before the engine answers the exception.

use crate::output::Output;
use serde_json::json;
use si_modbus::serve_map::{Refusal, ServeMap};

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

/// Print a refusal: the request's address and count and, from the map, why (outside every
/// range the slave serves, or a write outside the write limits).
pub fn print_refusal(r: &Refusal, out: &Output) {
    let action = if r.write { "write" } else { "read" };
    out.line(
        &format!(
            "refused {} {action} address {} count {}: {}: {}",
            r.table.name(),
            r.address,
            r.count,
            r.exception,
            r.why
        ),
        json!({"refused": r.table.name(), "write": r.write, "address": r.address,
               "count": r.count, "exception": r.exception.code(), "why": r.why}),
    );
}
