//! From a recorded trace to the characters on the line, with who sent each.
//!
//! A trace holds what each station transmitted (`tx`, when it queued the bytes) and what each
//! received (`rx` exact per character from the simulator, `rx_chunk` from a real port). The
//! monitor wants the line itself: every character once, with its sender and its arrival time.
//!
//! - **Received characters are the truth** (they carry the injected faults: a flipped bit, a
//!   BREAK). Point to point, a character received by one station was sent by the other.
//! - **RS-485 bus** (more than two stations, or most characters heard by several stations at the
//!   same instant): every member hears every character, its own echo included. The monitor
//!   listens at one member (the first station that received anything) and finds the sender
//!   whose transmission was on the line when the character arrived.
//! - **One-sided traces** (a real port: `si --record` sees only its own side, no per-character
//!   receptions): the characters of a write are placed at the instant the write began, those
//!   of a read chunk at the instant it was read (a microsecond apart, to keep their order),
//!   and the chunks come from a station called `partner`. A simulator trace never takes this
//!   path, so a silenced station's transmissions (which never reached the line) are not
//!   shown. Gaps inside a write or a chunk are not judged.

use super::LineChar;
use crate::trace::TraceKind;
use crate::tracefile::TraceFile;
use crate::{Duration, Instant, SerialSettings};
use std::collections::HashMap;

/// Name of the station that stands for "the other end" in a one-sided (real port) trace.
pub const PARTNER: &str = "partner";

/// The line view of a trace.
#[derive(Debug, Clone, Default)]
pub struct Line {
    /// Station names; `LineChar::from`/`to` index into it.
    pub stations: Vec<String>,
    /// Every character once, in time order.
    pub chars: Vec<LineChar>,
}

/// A transmission window: `station` had characters on the line from `start` to `end`.
struct Window {
    station: usize,
    start: Instant,
    end: Instant,
}

/// Build the line view of `file` with character format `settings`.
pub fn from_trace(file: &TraceFile, settings: SerialSettings) -> Line {
    let mut stations = file.stations();
    let index = |stations: &[String], name: &str| stations.iter().position(|s| s == name);
    let entries = &file.trace.entries;

    // Transmission windows, as the simulator schedules them: a burst continues where the
    // previous one ends.
    let mut windows = Vec::new();
    let mut free: HashMap<usize, Instant> = HashMap::new();
    for e in entries {
        if let TraceKind::Tx { bytes } = &e.kind {
            let Some(s) = index(&stations, &e.station) else {
                continue;
            };
            let start = e.at.max(free.get(&s).copied().unwrap_or(Instant::ZERO));
            let end = start + settings.chars_time(bytes.len() as u64);
            free.insert(s, end);
            windows.push(Window {
                station: s,
                start,
                end,
            });
        }
    }

    // Who received exactly (per character), and is it a bus?
    let mut exact_rx: Vec<(Instant, usize, Result<u8, crate::LineError>)> = Vec::new();
    for e in entries {
        let Some(s) = index(&stations, &e.station) else {
            continue;
        };
        match &e.kind {
            TraceKind::Rx { byte } => exact_rx.push((e.at, s, Ok(*byte))),
            TraceKind::RxError { error } => exact_rx.push((e.at, s, Err(*error))),
            _ => {}
        }
    }
    let receivers: Vec<usize> = {
        let mut r: Vec<usize> = exact_rx.iter().map(|x| x.1).collect();
        r.sort_unstable();
        r.dedup();
        r
    };
    let mut twins = 0usize;
    {
        let mut seen: HashMap<(Instant, Result<u8, crate::LineError>), usize> = HashMap::new();
        for &(at, s, item) in &exact_rx {
            if let Some(&other) = seen.get(&(at, item)) {
                if other != s {
                    twins += 1;
                }
            } else {
                seen.insert((at, item), s);
            }
        }
    }
    let bus = receivers.len() > 2 || (twins > 0 && twins * 2 >= exact_rx.len() / 2);
    let char_time = settings.char_time();
    let sender_at = |at: Instant, exclude: Option<usize>| -> Option<usize> {
        // The window that was on the line when the character ended; the latest start wins.
        windows
            .iter()
            .filter(|w| Some(w.station) != exclude)
            .filter(|w| w.start < at && at <= w.end + char_time + char_time)
            .max_by_key(|w| w.start)
            .map(|w| w.station)
    };

    let mut chars = Vec::new();
    if bus {
        let listener = receivers.first().copied();
        for &(at, s, item) in &exact_rx {
            if Some(s) == listener {
                chars.push(LineChar {
                    at,
                    from: sender_at(at, None),
                    to: None,
                    item,
                    exact: true,
                });
            }
        }
    } else {
        let n = stations.len();
        for &(at, s, item) in &exact_rx {
            let from = if n == 2 {
                Some(1 - s)
            } else {
                sender_at(at, Some(s))
            };
            chars.push(LineChar {
                at,
                from,
                to: Some(s),
                item,
                exact: true,
            });
        }
    }

    // One-sided traces: chunks from the partner, and writes nobody else saw.
    let mut partner = None;
    for e in entries {
        let Some(s) = index(&stations, &e.station) else {
            continue;
        };
        match &e.kind {
            TraceKind::RxChunk { bytes } => {
                let p = *partner.get_or_insert_with(|| {
                    stations.push(PARTNER.to_owned());
                    stations.len() - 1
                });
                // The last character arrived no later than `at`; the OS does not say when the
                // others did. Keep them in order, a microsecond apart, so they never overtake
                // an earlier write (on a pseudo-terminal the answer comes back at once).
                let n = bytes.len() as u64;
                for (k, &b) in bytes.iter().enumerate() {
                    let before = n - 1 - k as u64;
                    chars.push(LineChar {
                        at: Instant::from_micros(e.at.as_micros().saturating_sub(before)),
                        from: Some(p),
                        to: Some(s),
                        item: Ok(b),
                        exact: k == 0,
                    });
                }
            }
            TraceKind::Tx { bytes } if exact_rx.is_empty() => {
                let to = *partner.get_or_insert_with(|| {
                    stations.push(PARTNER.to_owned());
                    stations.len() - 1
                });
                // The write began at `at`; when each character left the UART is unknown.
                for (k, &b) in bytes.iter().enumerate() {
                    chars.push(LineChar {
                        at: e.at + Duration::from_micros(k as u64),
                        from: Some(s),
                        to: Some(to),
                        item: Ok(b),
                        exact: k == 0,
                    });
                }
            }
            _ => {}
        }
    }
    chars.sort_by_key(|c| c.at);

    Line { stations, chars }
}

/// The silence between `prev` and `c`, for timers measured between characters; `None` when
/// `c`'s time is an estimate (the later characters of a chunk a real port delivered at once).
pub fn gap(prev: Option<&LineChar>, c: &LineChar) -> Option<Duration> {
    let p = prev?;
    c.exact.then(|| c.at.saturating_since(p.at))
}

/// The characters of a chunk a real port delivered at once, `at` the instant it was read: the
/// last character arrived at `at`, the ones before it one character time apart (a UART delivers
/// them at that pace), never before a character already fed (`last`, which this advances).
/// Only the first is `exact`: the gaps inside a chunk are estimates and are not judged.
pub fn pace<'a>(
    bytes: &'a [u8],
    at: Instant,
    (from, to): (Option<usize>, Option<usize>),
    settings: SerialSettings,
    last: &'a mut Instant,
) -> impl Iterator<Item = LineChar> + 'a {
    let n = bytes.len();
    bytes.iter().enumerate().map(move |(k, &b)| {
        let before = settings.chars_time((n - 1 - k) as u64);
        let t = Instant::from_micros(at.as_micros().saturating_sub(before.as_micros())).max(*last);
        *last = t;
        LineChar {
            at: t,
            from,
            to,
            item: Ok(b),
            exact: k == 0,
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trace::{Trace, TraceEntry};
    use crate::tracefile::Header;

    fn entry(at: u64, station: &str, kind: TraceKind) -> TraceEntry {
        TraceEntry {
            at: Instant::from_micros(at),
            station: station.into(),
            kind,
        }
    }

    #[test]
    fn a_chunk_is_paced_back_from_its_read_instant_and_never_overtakes() {
        let settings = SerialSettings::default();
        let ct = settings.char_time().as_micros();
        let mut last = Instant::ZERO;
        let at = Instant::from_micros(10 * ct);
        let chars: Vec<LineChar> = pace(b"abc", at, (Some(0), None), settings, &mut last).collect();
        let times: Vec<u64> = chars.iter().map(|c| c.at.as_micros()).collect();
        assert_eq!(times, [8 * ct, 9 * ct, 10 * ct]);
        assert_eq!(chars.iter().filter(|c| c.exact).count(), 1);
        // A second chunk read a moment later cannot start before the first one ended.
        let chars: Vec<LineChar> = pace(
            b"de",
            at + Duration::from_micros(1),
            (Some(0), None),
            settings,
            &mut last,
        )
        .collect();
        assert!(chars.iter().all(|c| c.at >= at));
        assert_eq!(last, at + Duration::from_micros(1));
    }

    #[test]
    fn point_to_point_rx_at_b_was_sent_by_a() {
        let file = TraceFile {
            header: Some(Header::new("sim").stations(&["A", "B"])),
            trace: Trace {
                entries: vec![
                    entry(0, "A", TraceKind::Tx { bytes: vec![2] }),
                    entry(1146, "B", TraceKind::Rx { byte: 2 }),
                    entry(1146, "B", TraceKind::Tx { bytes: vec![0x10] }),
                    entry(2292, "A", TraceKind::Rx { byte: 0x10 }),
                ],
            },
        };
        let line = from_trace(&file, SerialSettings::default());
        assert_eq!(line.chars.len(), 2);
        assert_eq!((line.chars[0].from, line.chars[0].to), (Some(0), Some(1)));
        assert_eq!((line.chars[1].from, line.chars[1].to), (Some(1), Some(0)));
    }

    #[test]
    fn a_one_sided_port_trace_gets_a_partner() {
        let file = TraceFile {
            header: None,
            trace: Trace {
                entries: vec![
                    entry(0, "si", TraceKind::Tx { bytes: vec![2] }),
                    entry(
                        5000,
                        "si",
                        TraceKind::RxChunk {
                            bytes: vec![0x10, 0x15],
                        },
                    ),
                ],
            },
        };
        let line = from_trace(&file, SerialSettings::default());
        assert_eq!(line.stations, vec!["si", PARTNER]);
        let from: Vec<_> = line.chars.iter().map(|c| c.from).collect();
        assert_eq!(from, vec![Some(0), Some(1), Some(1)]);
        assert!(line.chars[1].at < line.chars[2].at);
        let exact: Vec<_> = line.chars.iter().map(|c| c.exact).collect();
        assert_eq!(
            exact,
            vec![true, true, false],
            "only a chunk's first time is judged"
        );
    }
}
