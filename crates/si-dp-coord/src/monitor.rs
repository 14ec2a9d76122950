//! The coordination-byte window protocol ([ET200S SI 2005] §2.12): not a serial
//! line but the DP process image the host and the module exchange every DP cycle.
//!
//! A window trace (`si sim dp-coord-send --record`, header protocol `dp-coord`) holds one `tx`
//! entry per station and cycle: the host's output window (station `host`) and the module's
//! input window (station `module`). [`line()`] turns each window into characters from its writer
//! to the other station (the first one exact, the rest a microsecond apart), and [`Monitor`]
//! cuts them back into windows and reads each one: the coordination byte with what the data
//! bytes mean for it (`10H send req, len 22`, `11H seg 1: abcde`, `71H done`). The error bit
//! (a segment out of order, [ET200S SI 2005] §2.12.7) and a STATUS other than 0000H (and 0101H,
//! "not an error") are errors.
//!
//! ```
//! use si_dp_coord::monitor::Monitor;
//! use si_core::monitor::{decode_all, LineChar};
//! use si_core::Instant;
//!
//! // The host (station 0) asks to send 22 bytes; the module (station 1) echoes the job code.
//! let mut chars = Vec::new();
//! for (k, (from, window)) in [(0, [0x10u8, 0, 0x16, 0, 0, 0, 0, 0]), (1, [0x10, 0, 0, 0, 0, 0, 0, 0])].iter().enumerate() {
//!     for (i, &b) in window.iter().enumerate() {
//!         let at = Instant::from_micros(k as u64 * 10_000 + i as u64);
//!         chars.push(LineChar { at, from: Some(*from), to: Some(1 - from), item: Ok(b), exact: i == 0 });
//!     }
//! }
//! let records = decode_all(&mut Monitor::new(1), &chars, Instant::from_micros(100_000));
//! assert_eq!(records[0].label, "10H send req");
//! assert_eq!(records[1].label, "10H accepted");
//! ```

use crate::coord::JobCode;
use crate::frame::{describe, Direction, V24Layout};
use crate::Window;
use si_core::monitor::line::Line;
use si_core::monitor::{Counters, Decoder, Flag, Kind, LineChar, Record};
use si_core::trace::TraceKind;
use si_core::tracefile::TraceFile;
use si_core::{Duration, Instant};
use std::collections::BTreeMap;

/// Index of the module's station: the one called `module`, else the second.
pub fn module_index(stations: &[String]) -> usize {
    stations.iter().position(|s| s == "module").unwrap_or(1)
}

/// The windows of `file` as characters: every `tx` entry from its station to the other one
/// (with more than two stations, to nobody in particular). Nothing else in the trace is a
/// window. The station `host` comes first (the left lane, as the manual's tables put it).
pub fn line(file: &TraceFile) -> Line {
    let mut stations = file.stations();
    if let Some(h) = stations.iter().position(|s| s == "host") {
        let host = stations.remove(h);
        stations.insert(0, host);
    }
    let mut chars = Vec::new();
    for e in &file.trace.entries {
        let TraceKind::Tx { bytes } = &e.kind else {
            continue;
        };
        let Some(from) = stations.iter().position(|s| s == &e.station) else {
            continue;
        };
        let to = (stations.len() == 2).then(|| 1 - from);
        for (k, &b) in bytes.iter().enumerate() {
            chars.push(LineChar {
                at: e.at + Duration::from_micros(k as u64),
                from: Some(from),
                to,
                item: Ok(b),
                exact: k == 0,
            });
        }
    }
    // Stable: two windows written at the same instant keep their characters' order per writer.
    chars.sort_by_key(|c| c.at);
    Line { stations, chars }
}

/// A window being collected from one writer.
struct Pending {
    start: Instant,
    end: Instant,
    to: Option<usize>,
    bytes: Vec<u8>,
}

/// The host's send or parameter job as its segments show it, to find the data in them.
#[derive(Clone, Copy)]
struct Transfer {
    /// Execution number of the latest segment.
    exec: u8,
    /// Segments so far (the execution number wraps after 7).
    segment: usize,
    /// Data bytes announced by the length word of segment 1.
    len: Option<usize>,
    /// The request was seen, so segments are counted from 1 (a trace that starts in the middle
    /// of a job does not say which segment holds the length word).
    from_request: bool,
}

/// Passive decoder of window traces: a window is a writer's exact character and the
/// estimated ones that follow it.
pub struct Monitor {
    module: usize,
    pending: BTreeMap<usize, Pending>,
    transfer: Option<Transfer>,
    counters: Counters,
}

impl Monitor {
    /// A decoder for which station `module` writes the input windows (all others the output).
    pub fn new(module: usize) -> Monitor {
        let mut counters = Counters::default();
        counters.declare(&[
            "output windows",
            "input windows",
            "jobs ok",
            "error bit",
            "STATUS errors",
            "not a window",
        ]);
        Monitor {
            module,
            pending: BTreeMap::new(),
            transfer: None,
            counters,
        }
    }

    fn flush(&mut self, from: usize, out: &mut Vec<Record>) {
        let Some(p) = self.pending.remove(&from) else {
            return;
        };
        let mut r = Record::new(Kind::Frame, p.start, p.end, Some(from));
        r.to = p.to;
        let Some(window) = Window::from_bytes(&p.bytes) else {
            self.counters.bump("not a window");
            r.flags.push(Flag::error(format!(
                "{} bytes is not a window of 4, 8 or 32",
                p.bytes.len()
            )));
            r.label = format!("{} bytes", p.bytes.len());
            r.bytes = p.bytes;
            out.push(r);
            return;
        };
        let dir = if from == self.module {
            self.counters.bump("input windows");
            Direction::ModuleToHost
        } else {
            self.counters.bump("output windows");
            Direction::HostToModule
        };
        r.label = self.label(&window, dir);
        r.text = describe(&window, dir, V24Layout::default());
        let c = window.coord();
        if c.error {
            self.counters.bump("error bit");
            r.flags.push(Flag::error(format!(
                "error bit: segment out of order, last valid {}",
                c.exec
            )));
        } else if let Some(word) = status_word(&window, dir) {
            match word {
                0 if c.job == JobCode::EndOfJob => self.counters.bump("jobs ok"),
                0 => {}
                0x0101 => r.flags.push(Flag::note(format!(
                    "STATUS {}",
                    crate::status::lookup(word)
                ))),
                _ => {
                    self.counters.bump("STATUS errors");
                    r.flags.push(Flag::error(format!(
                        "STATUS {}",
                        crate::status::lookup(word)
                    )));
                }
            }
        }
        r.bytes = p.bytes;
        out.push(r);
    }

    /// The short reading for the diagram.
    fn label(&mut self, window: &Window, dir: Direction) -> String {
        let c = window.coord();
        let byte = window.as_bytes()[0];
        let word = window.word();
        // The job's name as coord.rs writes it (Table 2-19).
        let job = c.job;
        if c.error {
            return format!("{byte:02X}H error, last {}", c.exec);
        }
        if let Some(word) = status_word(window, dir) {
            return match (c.job, word) {
                (JobCode::EndOfJob, 0) => format!("{byte:02X}H done"),
                (JobCode::Idle, 0) => format!("{byte:02X}H idle"),
                (JobCode::Idle, _) => format!("{byte:02X}H idle, rx {word:04X}H"),
                _ => format!("{byte:02X}H STATUS {word:04X}H"),
            };
        }
        let host = dir == Direction::HostToModule;
        let transfer = matches!(c.job, JobCode::Send | JobCode::Parameters);
        match (host, c.exec) {
            (_, _) if c.job == JobCode::Idle => format!("{byte:02X}H idle"),
            (true, 0) => {
                self.transfer = transfer.then_some(Transfer {
                    exec: 0,
                    segment: 0,
                    len: None,
                    from_request: true,
                });
                format!("{byte:02X}H {job} req")
            }
            (false, 0) if transfer => format!("{byte:02X}H accepted"),
            (true, exec) if transfer => {
                let t = self.transfer.get_or_insert(Transfer {
                    exec: 0,
                    segment: 0,
                    len: None,
                    from_request: false,
                });
                if t.exec != exec {
                    t.exec = exec;
                    t.segment += 1;
                }
                let d = window.data();
                let per = d.len();
                let (head, data) = if t.from_request && t.segment == 1 {
                    t.len = Some(usize::from(word));
                    (format!(", len {word}"), d.get(2..).unwrap_or_default())
                } else {
                    (String::new(), d)
                };
                // Segment k carries stream bytes (k-1)·per …; the stream is the length word
                // and the data, so the data left for it is what the length word announced.
                let data = match t.len {
                    Some(len) => {
                        let before = (t.segment.max(1) - 1) * per;
                        let left = (2 + len).saturating_sub(before.max(2));
                        &data[..left.min(data.len())]
                    }
                    None => data,
                };
                format!("{byte:02X}H seg {exec}{head}: {}", readable(data))
            }
            (false, exec) if transfer => format!("{byte:02X}H ack seg {exec}"),
            (false, exec) => format!("{byte:02X}H seg {exec}: {}", readable(window.data())),
            (true, exec) => format!("{byte:02X}H ack seg {exec}"),
        }
    }
}

/// The word in bytes 1–2 when the window carries a status there: the module's receive status
/// when idle, STATUS at the end of a job (and of a receive or write-V.24 request).
fn status_word(window: &Window, dir: Direction) -> Option<u16> {
    let c = window.coord();
    if dir != Direction::ModuleToHost || c.error {
        return None;
    }
    match (c.job, c.exec) {
        (JobCode::Idle | JobCode::EndOfJob, _) | (JobCode::Receive | JobCode::WriteV24, 0) => {
            Some(window.word())
        }
        _ => None,
    }
}

/// Data as text when it is printable ASCII, else as hex.
fn readable(data: &[u8]) -> String {
    if !data.is_empty() && data.iter().all(|b| b.is_ascii_graphic() || *b == b' ') {
        String::from_utf8_lossy(data).into_owned()
    } else {
        si_core::hex::format(data)
    }
}

impl Decoder for Monitor {
    fn push(&mut self, c: &LineChar, out: &mut Vec<Record>) {
        let Some(from) = c.from else {
            return;
        };
        let Ok(byte) = c.item else {
            return;
        };
        if c.exact {
            self.flush(from, out);
        }
        let p = self.pending.entry(from).or_insert(Pending {
            start: c.at,
            end: c.at,
            to: c.to,
            bytes: Vec::new(),
        });
        p.end = c.at;
        p.bytes.push(byte);
    }

    fn idle(&mut self, _now: Instant, _out: &mut Vec<Record>) {}

    fn finish(&mut self, _now: Instant, out: &mut Vec<Record>) {
        let writers: Vec<usize> = self.pending.keys().copied().collect();
        for from in writers {
            self.flush(from, out);
        }
    }

    fn counters(&self) -> &Counters {
        &self.counters
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn window(from: usize, at: u64, bytes: &[u8]) -> Vec<LineChar> {
        bytes
            .iter()
            .enumerate()
            .map(|(k, &b)| LineChar {
                at: Instant::from_micros(at + k as u64),
                from: Some(from),
                to: Some(1 - from),
                item: Ok(b),
                exact: k == 0,
            })
            .collect()
    }

    fn labels(windows: &[(usize, &[u8])]) -> Vec<Record> {
        let mut chars: Vec<LineChar> = windows
            .iter()
            .enumerate()
            .flat_map(|(k, (from, bytes))| window(*from, k as u64 * 10_000, bytes))
            .collect();
        chars.sort_by_key(|c| c.at);
        let mut d = Monitor::new(1);
        si_core::monitor::decode_all(&mut d, &chars, Instant::from_micros(1_000_000))
    }

    #[test]
    fn the_segments_of_table_2_23_read_as_the_data_they_carry() {
        let r = labels(&[
            (0, &[0x10, 0, 0x16, 0, 0, 0, 0, 0]),
            (1, &[0x10, 0, 0, 0, 0, 0, 0, 0]),
            (0, &[0x11, 0x00, 0x16, b'a', b'b', b'c', b'd', b'e']),
            (0, &[0x14, b't', b'u', b'v', 0, 0, 0, 0]),
            (1, &[0x71, 0, 0, 0, 0, 0, 0, 0]),
        ]);
        let l: Vec<&str> = r.iter().map(|r| r.label.as_str()).collect();
        assert_eq!(l[0], "10H send req");
        assert_eq!(l[1], "10H accepted");
        assert_eq!(l[2], "11H seg 1, len 22: abcde");
        assert_eq!(l[4], "71H done");
        assert!(r.iter().all(|r| !r.has_error()));
    }

    #[test]
    fn error_bit_and_status_are_errors_but_no_message_is_not() {
        let r = labels(&[
            (1, &[0x1A, 0, 0, 0, 0, 0, 0, 0]),
            (1, &[0x71, 0x05, 0x01, 0, 0, 0, 0, 0]),
            (1, &[0x20, 0x01, 0x01, 0, 0, 0, 0, 0]),
            (0, &[0x11, 0, 0]),
        ]);
        assert!(r[0].has_error() && r[0].label.contains("error"));
        assert!(r[1].has_error() && r[1].label == "71H STATUS 0501H");
        assert!(!r[2].has_error() && !r[2].flags.is_empty());
        assert!(r[3].has_error(), "3 bytes is not a window");
    }

    #[test]
    fn a_trace_that_starts_in_the_middle_of_a_job_claims_no_length_word() {
        let r = labels(&[(0, &[0x13, 0, 0x16, b'x', b'y', b'z', 0, 0])]);
        assert_eq!(r[0].label, "13H seg 3: 00 16 78 79 7A 00 00");
    }
}
