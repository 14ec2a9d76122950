//! A whole line in memory decoded at once: what `si sim --svg` draws and tests compare the
//! streamed analysis (`monitor::streamed`) with.

use crate::monitor::line::Line;
use crate::monitor::{decode_all, Analysis, Decoder, Kind, Record};
use crate::trace::{TraceEntry, TraceKind};
use crate::Instant;

/// A whole line decoded at once up to `end` (a simulated trace, a test): the analysis of
/// `protocol` with every record; with `events`, each engine event entry among them becomes a
/// [`Kind::Event`] record, after the line's records of the same instant.
pub fn analyse_line(
    line: Line,
    end: Instant,
    decoder: &mut dyn Decoder,
    protocol: &str,
    events: Option<&[TraceEntry]>,
) -> Analysis {
    let mut records = decode_all(decoder, &line.chars, end);
    if let Some(entries) = events {
        for e in entries {
            if let TraceKind::Event { text } = &e.kind {
                let from = line.stations.iter().position(|s| s == &e.station);
                let mut r = Record::new(Kind::Event, e.at, e.at, from);
                r.label = text.clone();
                records.push(r);
            }
        }
        // Stable: at equal times the line comes before what the engine made of it.
        records.sort_by_key(|r| r.start);
    }
    Analysis {
        protocol: protocol.to_owned(),
        span: (line.chars.first().map(|c| c.at).unwrap_or_default(), end),
        stations: line.stations,
        records,
        counters: decoder.counters().clone(),
    }
}
