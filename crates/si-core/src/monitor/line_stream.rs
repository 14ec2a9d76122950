//! The line view of a trace built entry by entry, for traces of any length: the same rules
//! as `crate::monitor::line::from_trace` (serial lines) and `si_dp_coord::monitor::line`
//! (DP windows), which hold the whole trace, in memory bounded by a few seconds of line.
//!
//! The whole-trace builders decide three things from the whole file: the station list, whether
//! the line is an RS-485 bus (several receivers, or most characters heard twice), and whether
//! the trace is one-sided (no per-character receptions: a real port's recording). Here they are
//! decided from the first [`LOOKAHEAD`] entries `[derived]`: a recording does not change its
//! kind of line half way, and a trace that short gives exactly what the whole-trace builder
//! gives. A station first named later gets its lane when it appears.
//!
//! Characters are released in time order: those of a read chunk are dated back from the
//! instant it was read (a microsecond apart), so a character is held until the trace has
//! passed it by [`BACKDATE`], the most a chunk of a [`MAX_LINE`]-long trace line can date
//! back.

use crate::monitor::line::PARTNER;
use crate::monitor::reorder::Reorder;
use crate::monitor::LineChar;
use crate::trace::{TraceEntry, TraceKind};
use crate::tracefile::{Header, MAX_LINE};
use crate::{Duration, Instant, LineError, SerialSettings};
use std::collections::{HashMap, VecDeque};

/// Entries read before the kind of line is decided.
pub const LOOKAHEAD: usize = 4096;

/// How far (µs) a chunk's characters can date back before its entry: a trace line holds at
/// most `MAX_LINE / 4` bytes (each at least a digit and a comma… of JSON), one µs apart.
pub const BACKDATE: u64 = (MAX_LINE / 4) as u64;

/// A transmission window: `station` had characters on the line from `start` to `end`.
struct Window {
    station: usize,
    start: Instant,
    end: Instant,
}

/// The line of a trace, fed entry by entry.
pub struct LineStream {
    stations: Vec<String>,
    windows_mode: bool,
    bus: bool,
    listener: Option<usize>,
    two: bool,
    one_sided: bool,
    settings: SerialSettings,
    windows: VecDeque<Window>,
    free: HashMap<usize, Instant>,
    partner: Option<usize>,
    /// Characters waiting for their turn: by time, then exact receptions before the
    /// characters of chunks and writes (the whole-trace builder's stable sort), then arrival.
    pending: Reorder<LineChar>,
    last_out: Instant,
    /// The latest entry time.
    pub end: Instant,
}

impl LineStream {
    /// Decide the kind of line from the header and the first entries (`prefix`, which are
    /// then fed like the rest); `windows` for a DP window trace.
    pub fn plan(
        header: Option<&Header>,
        prefix: &[TraceEntry],
        settings: SerialSettings,
        windows: bool,
    ) -> LineStream {
        let mut stations: Vec<String> = header.map(|h| h.stations.clone()).unwrap_or_default();
        for e in prefix {
            if !stations.iter().any(|n| n == &e.station) {
                stations.push(e.station.clone());
            }
        }
        if windows {
            if let Some(h) = stations.iter().position(|s| s == "host") {
                let host = stations.remove(h);
                stations.insert(0, host);
            }
        }
        let index = |name: &str| stations.iter().position(|s| s == name);
        let exact_rx: Vec<(Instant, usize, Result<u8, LineError>)> = prefix
            .iter()
            .filter_map(|e| {
                let s = index(&e.station)?;
                match &e.kind {
                    TraceKind::Rx { byte } => Some((e.at, s, Ok(*byte))),
                    TraceKind::RxError { error } => Some((e.at, s, Err(*error))),
                    _ => None,
                }
            })
            .collect();
        let mut receivers: Vec<usize> = exact_rx.iter().map(|x| x.1).collect();
        receivers.sort_unstable();
        receivers.dedup();
        let mut twins = 0usize;
        let mut seen: HashMap<(Instant, Result<u8, LineError>), usize> = HashMap::new();
        for &(at, s, item) in &exact_rx {
            match seen.get(&(at, item)) {
                Some(&other) if other != s => twins += 1,
                Some(_) => {}
                None => {
                    seen.insert((at, item), s);
                }
            }
        }
        let bus = receivers.len() > 2 || (twins > 0 && twins * 2 >= exact_rx.len() / 2);
        LineStream {
            two: stations.len() == 2,
            stations,
            windows_mode: windows,
            bus,
            listener: receivers.first().copied(),
            one_sided: exact_rx.is_empty(),
            settings,
            windows: VecDeque::new(),
            free: HashMap::new(),
            partner: None,
            pending: Reorder::default(),
            last_out: Instant::ZERO,
            end: Instant::ZERO,
        }
    }

    /// Station names; `LineChar::from`/`to` index into it.
    pub fn stations(&self) -> &[String] {
        &self.stations
    }

    fn station(&mut self, name: &str) -> usize {
        match self.stations.iter().position(|s| s == name) {
            Some(i) => i,
            None => {
                self.stations.push(name.to_owned());
                self.stations.len() - 1
            }
        }
    }

    fn partner(&mut self) -> usize {
        match self.partner {
            Some(p) => p,
            None => {
                self.stations.push(PARTNER.to_owned());
                self.partner = Some(self.stations.len() - 1);
                self.stations.len() - 1
            }
        }
    }

    fn hold(&mut self, class: u8, c: LineChar) {
        self.pending.hold(c.at, class, c);
    }

    /// The window that was on the line when a character ended at `at`; the latest start wins.
    fn sender_at(&self, at: Instant, exclude: Option<usize>) -> Option<usize> {
        let ct = self.settings.char_time();
        self.windows
            .iter()
            .filter(|w| Some(w.station) != exclude)
            .filter(|w| w.start < at && at <= w.end + ct + ct)
            .max_by_key(|w| w.start)
            .map(|w| w.station)
    }

    /// Feed one entry (in time order); characters that can no longer be overtaken go to `out`.
    pub fn push(&mut self, e: &TraceEntry, out: &mut Vec<LineChar>) {
        self.end = self.end.max(e.at);
        let s = self.station(&e.station);
        if self.windows_mode {
            if let TraceKind::Tx { bytes } = &e.kind {
                let to = (self.stations.len() == 2).then(|| 1 - s.min(1));
                for (k, &b) in bytes.iter().enumerate() {
                    let c = LineChar {
                        at: e.at + Duration::from_micros(k as u64),
                        from: Some(s),
                        to,
                        item: Ok(b),
                        exact: k == 0,
                    };
                    self.hold(0, c);
                }
            }
            self.release(e.at, out);
            return;
        }
        match &e.kind {
            TraceKind::Tx { bytes } => {
                let start =
                    e.at.max(self.free.get(&s).copied().unwrap_or(Instant::ZERO));
                let end = start + self.settings.chars_time(bytes.len() as u64);
                self.free.insert(s, end);
                self.windows.push_back(Window {
                    station: s,
                    start,
                    end,
                });
                if self.one_sided {
                    let to = self.partner();
                    for (k, &b) in bytes.iter().enumerate() {
                        let c = LineChar {
                            at: e.at + Duration::from_micros(k as u64),
                            from: Some(s),
                            to: Some(to),
                            item: Ok(b),
                            exact: k == 0,
                        };
                        self.hold(1, c);
                    }
                }
            }
            TraceKind::Rx { .. } | TraceKind::RxError { .. } => {
                let item = match &e.kind {
                    TraceKind::Rx { byte } => Ok(*byte),
                    TraceKind::RxError { error } => Err(*error),
                    _ => unreachable!("matched above"),
                };
                // Windows that ended long before this character explain no later one.
                if self.windows.len() > 64 {
                    let ct = self.settings.char_time();
                    let at = e.at;
                    self.windows.retain(|w| at <= w.end + ct + ct);
                }
                if self.bus {
                    if Some(s) == self.listener {
                        let c = LineChar {
                            at: e.at,
                            from: self.sender_at(e.at, None),
                            to: None,
                            item,
                            exact: true,
                        };
                        self.hold(0, c);
                    }
                } else {
                    let from = if self.two {
                        Some(1 - s.min(1))
                    } else {
                        self.sender_at(e.at, Some(s))
                    };
                    let c = LineChar {
                        at: e.at,
                        from,
                        to: Some(s),
                        item,
                        exact: true,
                    };
                    self.hold(0, c);
                }
            }
            TraceKind::RxChunk { bytes } => {
                let p = self.partner();
                let n = bytes.len() as u64;
                for (k, &b) in bytes.iter().enumerate() {
                    let before = n - 1 - k as u64;
                    let c = LineChar {
                        at: Instant::from_micros(e.at.as_micros().saturating_sub(before)),
                        from: Some(p),
                        to: Some(s),
                        item: Ok(b),
                        exact: k == 0,
                    };
                    self.hold(1, c);
                }
            }
            TraceKind::Signals { .. } | TraceKind::Event { .. } => {}
        }
        self.release(e.at, out);
    }

    fn release(&mut self, now: Instant, out: &mut Vec<LineChar>) {
        let horizon = Instant::from_micros(now.as_micros().saturating_sub(BACKDATE));
        while let Some(c) = self.pending.pop_before(horizon) {
            self.out(c, out);
        }
    }

    fn out(&mut self, mut c: LineChar, out: &mut Vec<LineChar>) {
        // A trace out of time order is put in order as far as it can be held.
        c.at = c.at.max(self.last_out);
        self.last_out = c.at;
        out.push(c);
    }

    /// The end of the trace: every character still held.
    pub fn finish(&mut self, out: &mut Vec<LineChar>) {
        while let Some(c) = self.pending.pop() {
            self.out(c, out);
        }
    }
}
