//! Passive monitors: what a listener on a serial line sees and reports, shared by the protocol
//! crates' monitors (`si_3964r::monitor`, `si_rk512::monitor`, `si_ascii::monitor`,
//! `si_modbus::monitor`, `si_uss::monitor`, `si_dp_coord::monitor`).
//!
//! A monitor never transmits. It is fed the characters of a line in time order
//! ([`LineChar`]: the character or the UART's error, its sender and receiver when known, and
//! when its stop bit ended) and emits [`Record`]s: control characters, frames and notes about
//! timers that ran out, each with [`Flag`]s, while it keeps [`Counters`]. Every protocol's
//! monitor implements [`Decoder`]; each judges the line with its crate's own timing functions,
//! so a monitor and the engine it watches apply one rule.
//!
//! * [`mod@line`]: from a recorded trace ([`crate::tracefile`]) to the characters on the line, and
//!   [`line::pace`] for characters a real port delivered in chunks;
//! * [`framer`]: cutting characters into frames by sender, silence and length;
//! * [`exchange`]: which frame answers which request on a master–slave line.
//!
//! Like the engines a monitor reads no clock and does no I/O; unlike them it builds owned
//! records for a human or a SCADA tool to keep, so it allocates per record (each record is
//! bounded by its protocol's longest frame).
//!
//! ```
//! use si_core::monitor::{decode_all, Counters, Decoder, LineChar, Record};
//! use si_core::Instant;
//!
//! /// A toy decoder: every character is a record.
//! #[derive(Default)]
//! struct Each(Counters);
//! impl Decoder for Each {
//!     fn push(&mut self, c: &LineChar, out: &mut Vec<Record>) {
//!         self.0.bump("characters");
//!         out.push(Record::new(si_core::monitor::Kind::Control, c.at, c.at, c.from));
//!     }
//!     fn idle(&mut self, _now: Instant, _out: &mut Vec<Record>) {}
//!     fn counters(&self) -> &Counters {
//!         &self.0
//!     }
//! }
//!
//! let chars: Vec<LineChar> = (0..3u64)
//!     .map(|k| LineChar { at: Instant::from_micros(1_000 * k), from: Some(0), to: None, item: Ok(0x41), exact: true })
//!     .collect();
//! let mut d = Each::default();
//! assert_eq!(decode_all(&mut d, &chars, Instant::from_micros(10_000)).len(), 3);
//! assert_eq!(d.counters().0["characters"], 3);
//! ```

pub mod exchange;
pub mod framer;
pub mod line;
#[cfg(feature = "tokio")]
#[cfg_attr(docsrs, doc(cfg(feature = "tokio")))]
pub mod line_errors;
#[cfg(feature = "tracefile")]
#[cfg_attr(docsrs, doc(cfg(feature = "tracefile")))]
pub mod line_stream;
#[cfg(feature = "tokio")]
#[cfg_attr(docsrs, doc(cfg(feature = "tokio")))]
pub mod live;
pub mod ordered;
pub mod reorder;
#[cfg(feature = "tracefile")]
#[cfg_attr(docsrs, doc(cfg(feature = "tracefile")))]
pub mod streamed;
pub mod whole;

use crate::{Duration, Instant, LineError};
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

/// `!! text` for a fault, `-- text` for a remark: how printers and logs show a flag.
impl core::fmt::Display for Flag {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self.severity {
            Severity::Error => write!(f, "!! {}", self.text),
            Severity::Note => write!(f, "-- {}", self.text),
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

/// Everything a monitor concluded about a line: what a printer or a diagram draws.
#[derive(Debug, Clone, Default)]
pub struct Analysis {
    /// The protocol decoded.
    pub protocol: String,
    /// Station names (records index into it).
    pub stations: Vec<String>,
    /// Records in time order.
    pub records: Vec<Record>,
    /// The decoder's counters.
    pub counters: Counters,
    /// First and last instant of the trace.
    pub span: (Instant, Instant),
}

/// How well `records` explain a line: two points for each frame or control character decoded
/// without an error, minus three for each record with one; notes count nothing. `[derived]`:
/// an error weighs more than a success, so a decoder that sees a few plausible frames in a
/// line full of errors loses to one that sees fewer frames and no errors.
pub fn fit(records: &[Record]) -> i64 {
    let good = records
        .iter()
        .filter(|r| r.kind != Kind::Note && !r.has_error())
        .count() as i64;
    let bad = records.iter().filter(|r| r.has_error()).count() as i64;
    good * 2 - bad * 3
}

/// Which protocol a recording without a header looks like: of `candidates`, the one whose
/// decoder (`make`) explains `chars` best by [`fit`] (the first on a tie), or `fallback` when
/// every candidate scores below zero. The fallback is the protocol that explains every line
/// trivially (ASCII: any bytes are a frame), so it only wins when nothing else does.
pub fn best_fit<P: Copy>(
    chars: &[LineChar],
    end: Instant,
    candidates: &[P],
    fallback: P,
    mut make: impl FnMut(P) -> Box<dyn Decoder>,
) -> P {
    let mut best = (fallback, 0);
    let mut first = true;
    for &p in candidates {
        let score = fit(&decode_all(make(p).as_mut(), chars, end));
        if first || score > best.1 {
            best = (p, score);
            first = false;
        }
    }
    if best.1 < 0 {
        fallback
    } else {
        best.0
    }
}

/// Feed every character, then finish at `end`; the records in time order.
pub fn decode_all(decoder: &mut dyn Decoder, chars: &[LineChar], end: Instant) -> Vec<Record> {
    let mut records = Vec::new();
    for c in chars {
        decoder.push(c, &mut records);
    }
    decoder.finish(end, &mut records);
    records.sort_by_key(|r| r.start);
    records
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A decoder that turns every character into one record, with an error for `bad` ones.
    struct Judge(Counters, fn(u8) -> bool);
    impl Decoder for Judge {
        fn push(&mut self, c: &LineChar, out: &mut Vec<Record>) {
            let mut r = Record::new(Kind::Frame, c.at, c.at, c.from);
            if c.item.as_ref().is_ok_and(|b| (self.1)(*b)) {
                r.flags.push(Flag::error("bad"));
            }
            out.push(r);
        }
        fn idle(&mut self, _now: Instant, _out: &mut Vec<Record>) {}
        fn counters(&self) -> &Counters {
            &self.0
        }
    }

    fn chars(bytes: &[u8]) -> Vec<LineChar> {
        let at = |k: usize| Instant::from_micros(1_000 * k as u64);
        (bytes.iter().enumerate())
            .map(|(k, &b)| LineChar {
                at: at(k),
                from: Some(0),
                to: None,
                item: Ok(b),
                exact: true,
            })
            .collect()
    }

    #[test]
    fn the_best_fit_wins_and_the_fallback_only_when_every_candidate_scores_below_zero() {
        let line = chars(&[1, 2, 3]);
        let end = Instant::from_micros(10_000);
        let make = |p: u8| -> Box<dyn Decoder> {
            match p {
                0 => Box::new(Judge(Counters::default(), |_| true)), // all errors: -9
                1 => Box::new(Judge(Counters::default(), |b| b == 3)), // 2 + 2 - 3 = 1
                _ => Box::new(Judge(Counters::default(), |_| false)), // 6
            }
        };
        assert_eq!(best_fit(&line, end, &[0, 1, 2], 9, make), 2);
        assert_eq!(best_fit(&line, end, &[0, 1], 9, make), 1);
        assert_eq!(best_fit(&line, end, &[0], 9, make), 9);
        // A tie keeps the first; an empty line scores zero and the first candidate wins.
        assert_eq!(best_fit(&line, end, &[2, 2], 9, make), 2);
        assert_eq!(best_fit(&[], end, &[1, 2], 9, make), 1);
        assert_eq!(best_fit(&line, end, &[], 9, make), 9);
    }
}
