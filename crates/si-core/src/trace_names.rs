//! The control characters of a simulated line trace by name: `tx 02  STX`, `rx 10  DLE`, a
//! 3964(R) block's `DLE ETX BCC`, a USS telegram's `STX LGE ADR … BCC`, an ASCII frame's
//! `CR LF`, `XON`/`XOFF` (what `si sim` prints).
//!
//! A byte is named by its place in the protocol, not by its value alone (the protocol crates'
//! frame modules say how: `si_3964r::frame::byte_names`, `si_uss::frame::byte_name`,
//! `si_ascii::frame::control_name`). The names come from the transmitting side, where each
//! engine's transmission is whole (one `tx` entry per control character or block); each
//! received character takes the name of the character its partner sent in that place (the line
//! delivers in order; the characters lost are skipped), and keeps none if a fault changed
//! it.

use crate::trace::{Trace, TraceEntry, TraceKind};
use std::collections::{HashMap, VecDeque};

/// The trace as `si sim` prints it, each line followed by the names of its control characters;
/// `transmission` names each byte of one transmission (`None`: data), the protocol crate's
/// frame module's rule.
pub fn named_trace(
    trace: &Trace,
    transmission: impl Fn(&[u8]) -> Vec<Option<&'static str>>,
) -> String {
    // Per station: the names of the characters on their way to it, in line order.
    let mut in_flight: HashMap<&str, VecDeque<(u8, Option<&'static str>)>> = HashMap::new();
    for e in &trace.entries {
        in_flight.entry(e.station.as_str()).or_default();
    }
    let mut out = String::new();
    for e in &trace.entries {
        let names: Vec<&'static str> = match &e.kind {
            TraceKind::Tx { bytes } => {
                let names = transmission(bytes);
                for (station, queue) in in_flight.iter_mut() {
                    if *station != e.station {
                        queue.extend(bytes.iter().copied().zip(names.iter().copied()));
                    }
                }
                names.into_iter().flatten().collect()
            }
            TraceKind::Rx { byte } => arrived(&mut in_flight, &e.station, Some(*byte))
                .into_iter()
                .collect(),
            // A garbled character still took its place on the line.
            TraceKind::RxError { .. } => {
                arrived(&mut in_flight, &e.station, None);
                Vec::new()
            }
            _ => Vec::new(),
        };
        out.push_str(&with_names(e, &names));
    }
    out
}

/// The name of the character that arrived at `station` (`None`: a line error in its place).
///
/// Normally the next one on its way. A character sent before the stations were connected (the
/// 3964(R) startup NAK) never arrives: the first character on the way that is `byte` is the
/// one, and those before it were lost. A byte nobody sent (a fault changed it) takes the place
/// of the next character and gets no name.
fn arrived(
    in_flight: &mut HashMap<&str, VecDeque<(u8, Option<&'static str>)>>,
    station: &str,
    byte: Option<u8>,
) -> Option<&'static str> {
    let queue = in_flight.get_mut(station)?;
    match queue.iter().position(|(sent, _)| Some(*sent) == byte) {
        Some(i) => queue.drain(..=i).next_back().and_then(|(_, name)| name),
        None => queue.pop_front().and(None),
    }
}

/// One entry as the trace prints it, with `names` after it.
fn with_names(entry: &TraceEntry, names: &[&str]) -> String {
    let line = Trace {
        entries: vec![entry.clone()],
    }
    .to_string();
    if names.is_empty() {
        return line;
    }
    format!("{}  {}\n", line.trim_end_matches('\n'), names.join(" "))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Instant;

    #[test]
    fn a_received_character_takes_the_name_its_partner_sent_and_a_lost_one_is_skipped() {
        let at = Instant::from_micros;
        let entry = |t, station: &str, kind| TraceEntry {
            at: at(t),
            station: station.into(),
            kind,
        };
        let trace = Trace {
            entries: vec![
                entry(
                    0,
                    "a",
                    TraceKind::Tx {
                        bytes: vec![0x15, 0x02],
                    },
                ),
                entry(2000, "b", TraceKind::Rx { byte: 0x02 }),
            ],
        };
        let names = |b: &[u8]| {
            b.iter()
                .map(|&c| match c {
                    0x02 => Some("STX"),
                    0x15 => Some("NAK"),
                    _ => None,
                })
                .collect()
        };
        let text = named_trace(&trace, names);
        let lines: Vec<&str> = text.lines().collect();
        assert!(lines[0].ends_with("NAK STX"), "{text}");
        // The NAK never reached b: the STX did, and keeps its name.
        assert!(
            lines[1].ends_with("STX") && !lines[1].contains("NAK"),
            "{text}"
        );
    }
}
