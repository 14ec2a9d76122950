//! From a recorded trace to the waveform's channels and line items: one transmit line per
//! station that sent anything, one RTS line per station whose trace has RTS changes.
//!
//! The characters are the monitor's line view ([`si_core::monitor::line::from_trace`]): every
//! character once, with its sender and the instant its stop bit ended, so the waveform shows
//! what `si monitor` decodes. A character starts one character time before it ended.

use crate::uart_levels::LineItem;
use si_core::monitor::{line, LineChar};
use si_core::trace::{TraceEntry, TraceKind};
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
    /// Level of each channel at time 0: transmit lines idle high, RTS low until the trace sets
    /// it (`[derived]`: a port opens with RTS off unless told otherwise).
    pub initial: Vec<bool>,
    /// The items, in time order.
    pub items: Vec<LineItem>,
}

/// Assigns channels as characters and signal changes come, one at a time: what a streaming
/// reader of the line view feeds (a first pass learns the channels for the files' headers, a
/// second writes the samples), and what [`waveform`] uses for a whole trace.
#[derive(Debug, Clone, Default)]
pub struct Lanes {
    /// Channel names so far.
    pub channels: Vec<String>,
    /// Levels at time 0, one per channel.
    pub initial: Vec<bool>,
    /// Transmit channel of each station index (`None` slot: unknown sender).
    tx: Vec<(Option<usize>, usize)>,
    /// RTS channel of each station name.
    rts: Vec<(String, usize)>,
}

impl Lanes {
    fn add(&mut self, name: String, high: bool) -> usize {
        self.channels.push(name);
        self.initial.push(high);
        self.channels.len() - 1
    }

    /// The item of one character of the line view: on its sender's transmit channel, starting
    /// one character time before its stop bit ended. `stations` is the line view's list.
    pub fn char_item(
        &mut self,
        c: &LineChar,
        stations: &[String],
        settings: &SerialSettings,
    ) -> LineItem {
        let sender = c.from.filter(|&s| s < stations.len());
        let channel = match self.tx.iter().find(|(s, _)| *s == sender) {
            Some(&(_, k)) => k,
            None => {
                let name = match sender {
                    Some(s) => format!("{}_TxD", stations[s]),
                    None => UNKNOWN_SENDER.to_owned(),
                };
                let k = self.add(name, true);
                self.tx.push((sender, k));
                k
            }
        };
        let char_time = settings.char_time().as_micros();
        LineItem::Char {
            start: Instant::from_micros(c.at.as_micros().saturating_sub(char_time)),
            channel,
            item: c.item,
        }
    }

    /// The item of a trace entry that sets RTS, on its station's RTS channel; `None` for any
    /// other entry.
    pub fn entry_item(&mut self, e: &TraceEntry) -> Option<LineItem> {
        let TraceKind::Signals { update } = &e.kind else {
            return None;
        };
        let high = update.rts?;
        let channel = match self.rts.iter().find(|(s, _)| s == &e.station) {
            Some((_, k)) => *k,
            None => {
                let k = self.add(format!("{}_RTS", e.station), false);
                self.rts.push((e.station.clone(), k));
                k
            }
        };
        Some(LineItem::Level {
            at: e.at,
            channel,
            high,
        })
    }
}

/// The waveform of a whole trace `file` with character format `settings`.
pub fn waveform(file: &TraceFile, settings: SerialSettings) -> Waveform {
    let line = line::from_trace(file, settings);
    let mut lanes = Lanes::default();
    let mut items: Vec<LineItem> = line
        .chars
        .iter()
        .map(|c| lanes.char_item(c, &line.stations, &settings))
        .collect();
    items.extend(
        file.trace
            .entries
            .iter()
            .filter_map(|e| lanes.entry_item(e)),
    );
    // Stable: characters keep their order among themselves, RTS changes theirs.
    items.sort_by_key(|i| match *i {
        LineItem::Char { start, .. } => start,
        LineItem::Level { at, .. } => at,
    });
    Waveform {
        channels: lanes.channels,
        initial: lanes.initial,
        items,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use si_core::sansio::SignalUpdate;
    use si_core::trace::Trace;

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
        assert_eq!(w.initial, [true, true, false]);
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
