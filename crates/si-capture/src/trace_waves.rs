//! A recorded trace's UART levels written while it is read (`si trace export --sr/--vcd`), in
//! memory bounded by a second of line, not by the trace: the trace file is read twice.
//!
//! 1. The first pass learns the channels ([`Lanes`]: one transmit line per sender, one RTS line
//!    per station that sets it), which both files name in their headers before any sample.
//! 2. The second pass reads the trace again record by record (the monitor's line view,
//!    [`LineStream`]), turns its characters and RTS changes into line items, and hands them in
//!    time order to the level rebuilder ([`Levels`]) and its edges to the writers.
//!
//! The items come out as [`waveform`](crate::trace_levels::waveform) orders a whole trace:
//! by time, a character before an RTS change at the same instant. Characters come out of the
//! line view up to [`BACKDATE`] late, so an item is held until the trace has passed it by that
//! and a character time.

use crate::sigrok::SrWriter;
use crate::trace_levels::Lanes;
use crate::uart_levels::{sample_rate, Edge, Levels, LineItem};
use crate::vcd::VcdWriter;
use si_core::monitor::line_stream::{LineStream, BACKDATE};
use si_core::monitor::reorder::Reorder;
use si_core::monitor::streamed::TraceStream;
use si_core::trace::TraceEntry;
use si_core::tracefile::{Item, TraceFileError};
use si_core::{Instant, SerialSettings};
use std::io::{self, BufRead, Write};

/// Why an export stopped.
#[derive(Debug, thiserror::Error)]
pub enum WavesError {
    /// The trace could not be opened (for either pass).
    #[error("{0}")]
    Open(io::Error),
    /// The trace is unreadable at a line.
    #[error("{0}")]
    Read(TraceFileError),
    /// The trace has nothing to draw.
    #[error("no characters and no RTS changes to draw")]
    Empty,
    /// The sigrok session file could not be written.
    #[error("{0}")]
    Sr(io::Error),
    /// The VCD could not be written.
    #[error("{0}")]
    Vcd(io::Error),
}

/// One pass over a trace: its line items, with the channels numbered as they first appear
/// (transmit lines from 0, RTS lines from `rts_from`).
struct Pass {
    settings: SerialSettings,
    rts_from: usize,
    tx: Lanes,
    rts: Lanes,
    /// Items waiting for their turn: by time, characters before RTS changes, then arrival.
    held: Reorder<LineItem>,
    chars: Vec<si_core::monitor::LineChar>,
}

impl Pass {
    fn hold(&mut self, at: Instant, class: u8, item: LineItem) {
        self.held.hold(at, class, item);
    }

    /// Hand on every item before `before` (all with `None`).
    fn release(&mut self, before: Option<Instant>, each: &mut impl FnMut(LineItem)) {
        while let Some(item) = match before {
            Some(b) => self.held.pop_before(b),
            None => self.held.pop(),
        } {
            each(item);
        }
    }

    /// Hold the characters the line view gave; their buffer is kept for the next entry (not
    /// freed and grown again per entry).
    fn chars(&mut self, stations: &[String]) {
        let mut chars = std::mem::take(&mut self.chars);
        for c in chars.drain(..) {
            let item = self.tx.char_item(&c, stations, &self.settings);
            if let LineItem::Char { start, .. } = item {
                self.hold(start, 0, item);
            }
        }
        self.chars = chars;
    }

    fn entry(&mut self, e: &TraceEntry, line: &mut LineStream, each: &mut impl FnMut(LineItem)) {
        line.push(e, &mut self.chars);
        self.chars(line.stations());
        if let Some(LineItem::Level { at, channel, high }) = self.rts.entry_item(e) {
            let channel = self.rts_from + channel;
            self.hold(at, 1, LineItem::Level { at, channel, high });
        }
        let hold = BACKDATE + self.settings.char_time().as_micros();
        let safe = e.at.as_micros().saturating_sub(hold);
        self.release(Some(Instant::from_micros(safe)), each);
    }
}

/// Read the trace `input` once at `settings`, every line item to `each` in time order; the
/// transmit and RTS lanes it saw.
fn pass<R: BufRead>(
    input: R,
    settings: SerialSettings,
    rts_from: usize,
    each: &mut impl FnMut(LineItem),
) -> Result<(Lanes, Lanes), TraceFileError> {
    let (header, prefix, rest) = TraceStream::open(input)?.into_parts();
    let mut line = LineStream::plan(header.as_ref(), &prefix, settings, false);
    let mut p = Pass {
        settings,
        rts_from,
        tx: Lanes::default(),
        rts: Lanes::default(),
        held: Reorder::default(),
        chars: Vec::new(),
    };
    for e in &prefix {
        p.entry(e, &mut line, each);
    }
    drop(prefix);
    if let Some(mut stream) = rest {
        while let Some(item) = stream.next_item()? {
            if let Item::Entry(e) = item {
                p.entry(&e, &mut line, each);
            }
        }
    }
    line.finish(&mut p.chars);
    let stations = line.stations().to_vec();
    p.chars(&stations);
    p.release(None, each);
    Ok((p.tx, p.rts))
}

/// Write the UART levels of the trace that `open` opens (once per pass) at `settings` to a
/// sigrok session file on `sr` and a VCD on `vcd`, whichever are given; 16 samples per bit,
/// two character times of idle line after the last edge so a decoder sees the end.
pub fn export<R: BufRead, S: Write, V: Write>(
    mut open: impl FnMut() -> io::Result<R>,
    settings: SerialSettings,
    sr: Option<S>,
    vcd: Option<V>,
) -> Result<(), WavesError> {
    // Pass 1: the channels.
    let (tx, rts) = pass(open().map_err(WavesError::Open)?, settings, 0, &mut |_| {})
        .map_err(WavesError::Read)?;
    let mut channels = tx.channels.clone();
    channels.extend(rts.channels.iter().cloned());
    let mut initial = tx.initial.clone();
    initial.extend(rts.initial.iter().copied());
    if channels.is_empty() {
        return Err(WavesError::Empty);
    }
    let rate = sample_rate(&settings);
    let mut sr = match sr {
        Some(w) => Some(SrWriter::new(w, &channels, rate, &initial).map_err(WavesError::Sr)?),
        None => None,
    };
    let mut vcd = match vcd {
        Some(w) => {
            Some(VcdWriter::new(w, "si", &channels, rate, &initial).map_err(WavesError::Vcd)?)
        }
        None => None,
    };
    // Pass 2: the samples.
    let mut levels = Levels::new(settings, initial);
    let mut failed: Option<WavesError> = None;
    let mut write = |e: Edge| {
        if failed.is_some() {
            return;
        }
        if let Some(w) = &mut sr {
            failed = w.edge(e).err().map(WavesError::Sr);
        }
        if let (None, Some(w)) = (&failed, &mut vcd) {
            failed = w.edge(e).err().map(WavesError::Vcd);
        }
    };
    let input = open().map_err(WavesError::Open)?;
    pass(input, settings, tx.channels.len(), &mut |item| {
        levels.push(item, &mut write)
    })
    .map_err(WavesError::Read)?;
    let end = levels.finish(&mut write) + 2 * u64::from(settings.bits_per_char()) * 16;
    if let Some(e) = failed {
        return Err(e);
    }
    if let Some(w) = sr {
        w.finish(end).map_err(WavesError::Sr)?;
    }
    if let Some(w) = vcd {
        w.finish(end).map_err(WavesError::Vcd)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trace_levels::waveform;
    use si_core::sansio::SignalUpdate;
    use si_core::trace::{Trace, TraceKind};
    use si_core::tracefile::{self, Header, TraceFile};

    /// The whole-trace export: the waveform of the trace in memory, every item at once.
    fn whole(file: &TraceFile, settings: SerialSettings) -> Vec<u8> {
        let wave = waveform(file, settings);
        let rate = sample_rate(&settings);
        let mut vcd =
            VcdWriter::new(Vec::new(), "si", &wave.channels, rate, &wave.initial).unwrap();
        let mut levels = Levels::new(settings, wave.initial.clone());
        let mut edges = Vec::new();
        for item in wave.items {
            levels.push(item, &mut |e| edges.push(e));
        }
        let end =
            levels.finish(&mut |e| edges.push(e)) + 2 * u64::from(settings.bits_per_char()) * 16;
        for e in edges {
            vcd.edge(e).unwrap();
        }
        vcd.finish(end).unwrap()
    }

    #[test]
    fn two_passes_write_what_the_whole_trace_writes() {
        let settings = SerialSettings::default();
        let entry = |at: u64, station: &str, kind| TraceEntry {
            at: Instant::from_micros(at),
            station: station.to_owned(),
            kind,
        };
        let mut entries = Vec::new();
        // Exchanges a second apart over several minutes, RTS raised and dropped around each,
        // so items wait across the hold and RTS changes meet characters at equal instants.
        for k in 0..400u64 {
            let t = k * 1_000_000;
            let rts = |on| TraceKind::Signals {
                update: SignalUpdate {
                    dtr: None,
                    rts: Some(on),
                },
            };
            entries.push(entry(t, "A", rts(true)));
            entries.push(entry(
                t,
                "A",
                TraceKind::Tx {
                    bytes: vec![2, k as u8, 0x10, 3],
                },
            ));
            for (i, b) in [2u8, k as u8, 0x10, 3].into_iter().enumerate() {
                entries.push(entry(
                    t + 1146 * (i as u64 + 1),
                    "B",
                    TraceKind::Rx { byte: b },
                ));
            }
            entries.push(entry(t + 4584, "A", rts(false)));
            entries.push(entry(t + 6000, "B", TraceKind::Tx { bytes: vec![0x10] }));
            entries.push(entry(t + 7146, "A", TraceKind::Rx { byte: 0x10 }));
        }
        let file = TraceFile {
            header: Some(Header::new("sim").settings(settings).stations(&["A", "B"])),
            trace: Trace { entries },
        };
        let mut text = Vec::new();
        tracefile::write(&mut text, file.header.as_ref().unwrap(), &file.trace).unwrap();
        let mut streamed = Vec::new();
        export(
            || Ok(&text[..]),
            settings,
            None::<Vec<u8>>,
            Some(&mut streamed),
        )
        .unwrap();
        assert_eq!(
            String::from_utf8_lossy(&streamed),
            String::from_utf8_lossy(&whole(&file, settings))
        );
    }

    #[test]
    fn a_trace_without_characters_or_rts_has_nothing_to_draw() {
        let text = b"";
        let e = export(
            || Ok(&text[..]),
            SerialSettings::default(),
            None::<Vec<u8>>,
            Some(Vec::new()),
        )
        .unwrap_err();
        assert!(matches!(e, WavesError::Empty), "{e}");
    }
}
