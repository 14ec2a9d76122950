//! A timestamped record of what happened on a line: what the simulator (`si-sim`) records, the
//! tokio driver and `si --record` write, and the monitors and the module's LEDs read.
//!
//! The types live here, beside the Sans-IO contract, so the simulator and the driver both use
//! them without one depending on the other. The same entries are the lines of a trace file
//! ([`crate::tracefile`]).

use crate::sansio::{LineError, SignalUpdate};
use crate::time::Instant;
use core::fmt;
use serde::{Deserialize, Serialize};

/// One recorded happening.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct TraceEntry {
    /// When it happened: virtual time in the simulator, µs since the recording began on a real
    /// line.
    pub at: Instant,
    /// The station it concerns.
    pub station: String,
    /// What happened.
    #[serde(flatten)]
    pub kind: TraceKind,
}

/// What a trace entry records.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum TraceKind {
    /// The station's engine queued these bytes for transmission (the first starts at `at`, or
    /// when the transmitter is free).
    Tx {
        /// The bytes.
        bytes: Vec<u8>,
    },
    /// A character arrived completely at the station's receiver.
    Rx {
        /// The character.
        byte: u8,
    },
    /// Several characters a real port delivered at once (the tokio driver and `si --record`
    /// read in chunks): the last arrived no later than `at`; their own arrival times are unknown,
    /// so a reader must not judge the gaps between them (tracefile format, see
    /// [`crate::tracefile`]).
    RxChunk {
        /// The characters, in arrival order.
        bytes: Vec<u8>,
    },
    /// The station's UART reported an error instead of a character.
    RxError {
        /// Which error.
        error: LineError,
    },
    /// The engine changed its modem outputs.
    Signals {
        /// The change.
        update: SignalUpdate,
    },
    /// The engine reported an event (its `Debug` form).
    Event {
        /// `format!("{:?}", event)`.
        text: String,
    },
}

/// The whole record, in time order.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Trace {
    /// Entries in the order they happened.
    pub entries: Vec<TraceEntry>,
}

impl Trace {
    /// Entries of one station.
    pub fn of<'a>(&'a self, station: &'a str) -> impl Iterator<Item = &'a TraceEntry> + 'a {
        self.entries.iter().filter(move |e| e.station == station)
    }

    /// The stations named in the entries, in the order they first appear.
    pub fn stations(&self) -> Vec<String> {
        let mut names: Vec<String> = Vec::new();
        for e in &self.entries {
            if !names.contains(&e.station) {
                names.push(e.station.clone());
            }
        }
        names
    }

    /// Arrival times and values of the characters a station received.
    pub fn received(&self, station: &str) -> Vec<(Instant, u8)> {
        self.of(station)
            .filter_map(|e| match e.kind {
                TraceKind::Rx { byte } => Some((e.at, byte)),
                _ => None,
            })
            .collect()
    }
}

impl fmt::Display for Trace {
    /// One line per entry: time, station, what. Consecutive received characters of one station
    /// stay on separate lines so their timing is visible.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for e in &self.entries {
            write!(f, "{:>14}  {:<8} ", e.at.to_string(), e.station)?;
            match &e.kind {
                TraceKind::Tx { bytes } => writeln!(f, "tx {}", crate::hex::format(bytes))?,
                TraceKind::Rx { byte } => writeln!(f, "rx {byte:02X}")?,
                TraceKind::RxChunk { bytes } => writeln!(f, "rx {}", crate::hex::format(bytes))?,
                TraceKind::RxError { error } => writeln!(f, "rx error {error:?}")?,
                TraceKind::Signals { update } => writeln!(f, "signals {update:?}")?,
                TraceKind::Event { text } => writeln!(f, "event {text}")?,
            }
        }
        Ok(())
    }
}
