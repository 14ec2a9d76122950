//! From a recorded trace to the waveform's channels and line items: one transmit line per
//! station that sent anything, one RTS line per station whose trace has RTS changes.
//!
//! The characters are the monitor's line view ([`si_core::monitor::line::from_trace`]): every
//! character once, with its sender and the instant its stop bit ended, so the waveform shows
//! what `si monitor` decodes. A character starts one character time before it ended.

use crate::uart_levels::LineItem;
use si_core::monitor::line;
use si_core::trace::TraceKind;
use si_core::tracefile::TraceFile;
use si_core::{Instant, SerialSettings};

/// Name of the channel that carries characters no recorded station explains (a bus character
/// whose sender is unknown).
pub const UNKNOWN_SENDER: &str = "line";

/// The channels and what happens on them.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Waveform {
    /// Channel names, `<station>_TxD` and `<station>_RTS`.
    pub channels: Vec<String>,
    /// Level of each channel at time 0 (bit k: channel k): transmit lines idle high, RTS low
    /// until the trace sets it (`[derived]`: a port opens with RTS off unless told otherwise).
    pub initial: u64,
    /// The items, in time order.
    pub items: Vec<LineItem>,
}

/// The waveform of `file` with character format `settings`.
pub fn waveform(file: &TraceFile, settings: SerialSettings) -> Waveform {
    let line = line::from_trace(file, settings);
    let char_time = settings.char_time();
    let mut w = Waveform::default();
    let mut tx: Vec<Option<usize>> = vec![None; line.stations.len()];
    let mut unknown: Option<usize> = None;
    for c in &line.chars {
        let slot = match c.from {
            Some(s) if s < tx.len() => &mut tx[s],
            _ => &mut unknown,
        };
        let channel = *slot.get_or_insert_with(|| {
            let name = match c.from.and_then(|s| line.stations.get(s)) {
                Some(station) => format!("{station}_TxD"),
                None => UNKNOWN_SENDER.to_owned(),
            };
            w.channels.push(name);
            w.initial |= 1 << (w.channels.len() - 1).min(63);
            w.channels.len() - 1
        });
        w.items.push(LineItem::Char {
            start: Instant::from_micros(c.at.as_micros().saturating_sub(char_time.as_micros())),
            channel,
            item: c.item,
        });
    }
    let mut rts: Vec<(String, usize)> = Vec::new();
    for e in &file.trace.entries {
        let TraceKind::Signals { update } = &e.kind else {
            continue;
        };
        let Some(high) = update.rts else {
            continue;
        };
        let channel = match rts.iter().find(|(s, _)| s == &e.station) {
            Some((_, k)) => *k,
            None => {
                w.channels.push(format!("{}_RTS", e.station));
                rts.push((e.station.clone(), w.channels.len() - 1));
                w.channels.len() - 1
            }
        };
        w.items.push(LineItem::Level {
            at: e.at,
            channel,
            high,
        });
    }
    // Stable: characters keep their order among themselves, RTS changes theirs.
    w.items.sort_by_key(|i| match *i {
        LineItem::Char { start, .. } => start,
        LineItem::Level { at, .. } => at,
    });
    w
}

#[cfg(test)]
mod tests {
    use super::*;
    use si_core::sansio::SignalUpdate;
    use si_core::trace::{Trace, TraceEntry};

    fn entry(at: u64, station: &str, kind: TraceKind) -> TraceEntry {
        TraceEntry {
            at: Instant::from_micros(at),
            station: station.to_owned(),
            kind,
        }
    }

    #[test]
    fn each_sender_gets_a_transmit_line_and_rts_its_own() {
        let file = TraceFile {
            header: None,
            trace: Trace {
                entries: vec![
                    entry(
                        0,
                        "A",
                        TraceKind::Signals {
                            update: SignalUpdate {
                                dtr: None,
                                rts: Some(true),
                            },
                        },
                    ),
                    entry(0, "A", TraceKind::Tx { bytes: vec![2] }),
                    entry(1146, "B", TraceKind::Rx { byte: 2 }),
                    entry(1146, "B", TraceKind::Tx { bytes: vec![0x10] }),
                    entry(2292, "A", TraceKind::Rx { byte: 0x10 }),
                ],
            },
        };
        let w = waveform(&file, SerialSettings::default());
        assert_eq!(w.channels, vec!["A_TxD", "B_TxD", "A_RTS"]);
        assert_eq!(w.initial, 0b011);
        // 9600 8E1: 1146 µs per character; A's STX started at 0, B's DLE at 1146.
        assert_eq!(
            w.items,
            vec![
                LineItem::Char {
                    start: Instant::from_micros(0),
                    channel: 0,
                    item: Ok(2)
                },
                LineItem::Level {
                    at: Instant::from_micros(0),
                    channel: 2,
                    high: true
                },
                LineItem::Char {
                    start: Instant::from_micros(1146),
                    channel: 1,
                    item: Ok(0x10)
                },
            ]
        );
    }
}
