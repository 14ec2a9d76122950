//! What the monitor sees and what it reports: characters on the line, decoded records with
//! their flags, and counters.

use si_core::{Duration, Instant, LineError};
use std::collections::BTreeMap;

/// One character (or line error) on the line, as the monitor sees it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LineChar {
    /// When its stop bit ended (simulator: exact; real port: when the OS handed it over).
    pub at: Instant,
    /// Index of the transmitting station in the station list (`None`: unknown, e.g. a bus
    /// character no recorded transmission explains).
    pub from: Option<usize>,
    /// Index of the receiving station (`None`: everyone on a bus).
    pub to: Option<usize>,
    /// The character, or the error the receiving UART reported instead.
    pub item: Result<u8, LineError>,
    /// False when the time is an estimate (the later characters of a chunk a real port
    /// delivered at once, or of a write): the gap before it is not judged.
    pub exact: bool,
}

/// How bad a flag is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Severity {
    /// Part of the protocol's normal recovery worth seeing (a retry, a conflict resolved).
    Note,
    /// A fault: bad check sum, timer exceeded, NAK, line error.
    Error,
}

/// A remark on a record.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct Flag {
    /// How bad.
    pub severity: Severity,
    /// One short line, with the manual's name of the timer or check.
    pub text: String,
}

impl Flag {
    /// A fault.
    pub fn error(text: impl Into<String>) -> Flag {
        Flag {
            severity: Severity::Error,
            text: text.into(),
        }
    }
    /// A remark.
    pub fn note(text: impl Into<String>) -> Flag {
        Flag {
            severity: Severity::Note,
            text: text.into(),
        }
    }
}

/// What a record is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Kind {
    /// A single control character (STX, DLE, NAK, XON, …).
    Control,
    /// A frame, block or telegram.
    Frame,
    /// Something the monitor concluded without a character: a timer ran out, a gap.
    Note,
    /// What a station's own engine reported (an `event` entry of the trace, `--events`).
    Event,
}

/// One decoded happening on the line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Record {
    /// First character's end (or the note's instant).
    pub start: Instant,
    /// Last character's end.
    pub end: Instant,
    /// Transmitting station.
    pub from: Option<usize>,
    /// Receiving station.
    pub to: Option<usize>,
    /// Control, frame or note.
    pub kind: Kind,
    /// Short label for the diagram: `STX`, `DLE`, `block 5 B`, `FC03 req`.
    pub label: String,
    /// The decoded meaning.
    pub text: String,
    /// The raw characters.
    pub bytes: Vec<u8>,
    /// Faults and remarks.
    pub flags: Vec<Flag>,
}

impl Record {
    /// A record of `bytes` sent by `from` between `start` and `end`.
    pub fn new(kind: Kind, start: Instant, end: Instant, from: Option<usize>) -> Record {
        Record {
            start,
            end,
            from,
            to: None,
            kind,
            label: String::new(),
            text: String::new(),
            bytes: Vec::new(),
            flags: Vec::new(),
        }
    }

    /// A note at `at` about `from`'s side of the line.
    pub fn note(at: Instant, from: Option<usize>, flag: Flag) -> Record {
        let mut r = Record::new(Kind::Note, at, at, from);
        r.label = flag.text.clone();
        r.flags.push(flag);
        r
    }

    /// Set the label and text.
    pub fn labelled(mut self, label: impl Into<String>, text: impl Into<String>) -> Record {
        self.label = label.into();
        self.text = text.into();
        self
    }

    /// True if any flag is an error.
    pub fn has_error(&self) -> bool {
        self.flags.iter().any(|f| f.severity == Severity::Error)
    }
}

/// Named counters, printed in name order.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Counters(pub BTreeMap<&'static str, u64>);

impl Counters {
    /// Add one to `name`.
    pub fn bump(&mut self, name: &'static str) {
        *self.0.entry(name).or_default() += 1;
    }
    /// Make `name` appear (at zero) so a clean run still lists it.
    pub fn declare(&mut self, names: &[&'static str]) {
        for n in names {
            self.0.entry(n).or_default();
        }
    }
}

/// A passive protocol decoder: fed characters in time order, it emits records.
pub trait Decoder {
    /// One more character. `out` receives every record completed by it (and notes about timers
    /// that ran out before it).
    fn push(&mut self, c: &LineChar, out: &mut Vec<Record>);
    /// The line went quiet until `now` (the end of the trace, or a live idle tick): report what
    /// is overdue.
    fn idle(&mut self, now: Instant, out: &mut Vec<Record>);
    /// The end of the trace at `now`: end whatever is in progress and report what is overdue.
    fn finish(&mut self, now: Instant, out: &mut Vec<Record>) {
        self.idle(now, out);
    }
    /// The counters so far.
    fn counters(&self) -> &Counters;
}

/// `gap` written the way the manuals write timers.
pub fn ms(d: Duration) -> String {
    let us = d.as_micros();
    if us.is_multiple_of(1000) {
        format!("{} ms", us / 1000)
    } else {
        format!("{:.3} ms", us as f64 / 1000.0)
    }
}
