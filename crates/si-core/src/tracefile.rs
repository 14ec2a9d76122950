//! The trace file: one definition of a recorded line, written by the simulator (`si sim
//! --record`), by the tokio driver and by `si --record` on real ports, and read back by
//! `si monitor --trace` and the diagram writer.
//!
//! The header and the file's contents ([`Header`], [`TraceFile`]) are always here, for the
//! monitors; reading and writing the JSON lines (`read`, `write`, `Recorder`) need the
//! feature `tracefile` (serde_json), which `tokio` turns on.
//!
//! # Format
//!
//! JSON lines (UTF-8, one object per line, `\n`-separated), so a trace can be appended while the
//! line runs, cut with `head`, filtered with `grep` or `jq`, and read after a crash up to the
//! last complete line.
//!
//! 1. An optional **header**: `{"format":"si-trace","version":1,"source":"sim","protocol":"3964r",
//!    "settings":{"baud":9600,"data_bits":8,"parity":"even","stop_bits":1},"stations":["A","B"],
//!    "start":"2026-11-25T16:18:25.123456Z"}` ([`Header`]). A reader that finds no header
//!    assumes nothing about protocol or settings. `start` is the wall-clock time (RFC 3339,
//!    UTC) at which entry time 0 was; a [`Recorder`] (the driver, `si --record`) writes it, the
//!    simulator's traces, in virtual time, have none, nor do traces written before it existed.
//! 2. Any number of **entries**, exactly the simulator's [`crate::trace::TraceEntry`]: `at`
//!    (µs since the start of the recording), `station` (who transmitted or received), `kind`
//!    and its fields:
//!    - `{"at":0,"station":"A","kind":"tx","bytes":[2]}` — bytes the station queued for
//!      transmission (on a real port: the write began at `at`; the characters follow each other
//!      at the character time);
//!    - `{"at":1146,"station":"B","kind":"rx","byte":2}` — one character arrived completely
//!      (simulator: exact arrival time);
//!    - `{"at":5200,"station":"si","kind":"rx_chunk","bytes":[16,2]}` — the OS delivered several
//!      characters at once (real port: the last arrived no later than `at`, individual arrival
//!      times are unknown);
//!    - `rx_error` (`"error":"parity"|"framing"|"overrun"|"break"`), `signals`, `event` (`"text"`:
//!      the engine's event in its `Debug` form — the decoded meaning as the engine saw it).
//!
//! Entries are in time order. Unknown header fields are ignored, so later versions can add
//! fields; a line that is neither a header nor an entry is an error naming its line number.

use crate::range::RangeError;
use crate::serial::{Parity, SerialSettings, SettingsError, BAUD_RATES};
#[cfg(feature = "tracefile")]
use crate::time::Instant;
use crate::trace::Trace;
#[cfg(feature = "tracefile")]
use crate::trace::{TraceEntry, TraceKind};
use serde::{Deserialize, Serialize};
#[cfg(feature = "tracefile")]
use std::io::{self, BufRead, Write};
#[cfg(feature = "tracefile")]
use std::sync::{Arc, Mutex};

/// The value of [`Header::format`]: marks a JSON line as an `si` trace header.
pub const FORMAT: &str = "si-trace";

/// The format version this module writes ([`Header::version`]).
pub const VERSION: u32 = 1;

/// The baud rates a trace may name: the manuals' twelve plus USS's 187 500 bit/s, so a USS trace
/// reads back; also the rates a monitored line or a trace without a header may use.
pub const TRACE_RATES: [u32; 13] = {
    let mut r = [187_500; 13];
    let mut i = 0;
    while i < BAUD_RATES.len() {
        r[i] = BAUD_RATES[i];
        i += 1;
    }
    r
};

/// The line's character format as stored in a header (a plain record, so any baud rate of any
/// protocol round-trips; [`LineFormat::settings`] validates it).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct LineFormat {
    /// Bits per second.
    pub baud: u32,
    /// 7 or 8.
    pub data_bits: u8,
    /// Parity bit.
    pub parity: Parity,
    /// 1 or 2.
    pub stop_bits: u8,
}

impl LineFormat {
    /// The validated settings, `None` if the header names an impossible format.
    pub fn settings(&self) -> Option<SerialSettings> {
        self.check().ok()
    }

    /// The validated settings, or the field out of range (a header with `baud` 0, say: issue
    /// 21). The rates are the manuals' twelve and USS's 187 500 bit/s ([`BAUD_RATES`]).
    pub fn check(&self) -> Result<SerialSettings, RangeError> {
        SerialSettings::with_rates(
            self.baud,
            self.data_bits,
            self.parity,
            self.stop_bits,
            &TRACE_RATES,
        )
        .map_err(|e| match e {
            SettingsError::DataBits(v) => RangeError::new("data_bits", "7 or 8", "", v),
            SettingsError::StopBits(v) => RangeError::new("stop_bits", "1 or 2", "", v),
            // Baud is the only other check of `with_rates` (parity is already typed).
            _ => {
                let rates: Vec<String> = TRACE_RATES.iter().map(u32::to_string).collect();
                let range = format!("{} bit/s", rates.join(", "));
                RangeError::new("baud", range, " bit/s", self.baud)
            }
        })
    }
}

impl From<SerialSettings> for LineFormat {
    fn from(s: SerialSettings) -> Self {
        LineFormat {
            baud: s.baud(),
            data_bits: s.data_bits(),
            parity: s.parity(),
            stop_bits: s.stop_bits(),
        }
    }
}

/// The first line of a trace file: what the reader needs to decode the entries.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Header {
    /// Always [`FORMAT`]; tells a header from an entry.
    pub format: String,
    /// [`VERSION`] of the writer.
    pub version: u32,
    /// Who wrote it: `"sim"` (the simulator), `"driver"` (the tokio driver), `"port"` (the CLI's
    /// transport recorder).
    pub source: String,
    /// The protocol spoken on the line (`3964r`, `rk512`, `ascii`, `modbus`, `uss`, …) when the
    /// writer knows it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub protocol: Option<String>,
    /// The character format, when the writer knows it (needed to compute character times).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub settings: Option<LineFormat>,
    /// The stations named in the entries, in the order to draw them.
    #[serde(default)]
    pub stations: Vec<String>,
    /// The wall-clock time of entry time 0, RFC 3339 in UTC (`2026-11-25T16:18:25.123456Z`):
    /// what a reader needs to put a recorded line next to a PLC's or a SCADA tool's logs.
    /// `None` in simulated traces and in traces older than this field.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub start: Option<String>,
}

impl Header {
    /// A header for `source` with nothing else known yet.
    pub fn new(source: &str) -> Self {
        Header {
            format: FORMAT.to_owned(),
            version: VERSION,
            source: source.to_owned(),
            protocol: None,
            settings: None,
            stations: Vec::new(),
            start: None,
        }
    }

    /// With entry time 0 at the wall-clock time `start`.
    pub fn started(mut self, start: std::time::SystemTime) -> Self {
        self.start = Some(rfc3339(start));
        self
    }

    /// With the protocol name.
    pub fn protocol(mut self, protocol: &str) -> Self {
        self.protocol = Some(protocol.to_owned());
        self
    }

    /// With the character format.
    pub fn settings(mut self, settings: SerialSettings) -> Self {
        self.settings = Some(settings.into());
        self
    }

    /// With the station names.
    pub fn stations<S: AsRef<str>>(mut self, stations: &[S]) -> Self {
        self.stations = stations.iter().map(|s| s.as_ref().to_owned()).collect();
        self
    }
}

/// A trace read back from a file.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct TraceFile {
    /// The header, if the file has one.
    pub header: Option<Header>,
    /// The entries.
    pub trace: Trace,
}

impl TraceFile {
    /// Station names: the header's, then any others in order of first appearance.
    pub fn stations(&self) -> Vec<String> {
        let mut names: Vec<String> = self
            .header
            .as_ref()
            .map(|h| h.stations.clone())
            .unwrap_or_default();
        for e in &self.trace.entries {
            if !names.iter().any(|n| n == &e.station) {
                names.push(e.station.clone());
            }
        }
        names
    }
}

#[cfg(feature = "tracefile")]
#[cfg_attr(docsrs, doc(cfg(feature = "tracefile")))]
/// A trace file that cannot be read.
#[derive(Debug, thiserror::Error)]
pub enum TraceFileError {
    /// Reading failed.
    #[error("cannot read the trace: {0}")]
    Io(#[from] io::Error),
    /// A line is not a header or an entry.
    #[error("trace line {line}: {message}")]
    Syntax {
        /// 1-based line number.
        line: usize,
        /// What the JSON parser said.
        message: String,
    },
    /// A header whose line format is out of range.
    #[error("trace line {line}: {error}")]
    Range {
        /// 1-based line number of the header.
        line: usize,
        /// The field out of range.
        error: RangeError,
    },
    /// A header with a format version this reader does not know.
    #[error("trace format version {0} is newer than this reader (version {VERSION})")]
    Version(u32),
    /// A line longer than [`MAX_LINE`] (no recorder writes one: it would be a frame of
    /// over 200,000 bytes), or a file that is not lines at all, such as `/dev/zero`.
    #[error("trace line {line}: longer than {max} bytes")]
    TooLong {
        /// 1-based line number.
        line: usize,
        /// [`MAX_LINE`].
        max: usize,
    },
}

#[cfg(feature = "tracefile")]
#[cfg_attr(docsrs, doc(cfg(feature = "tracefile")))]
impl Header {
    /// The header as its JSON line (without the newline): what a trace file starts with, and
    /// what a capture's section comment carries (`si_capture::pcap_out`).
    pub fn to_line(&self) -> String {
        // Strings, numbers and options only: serialization cannot fail.
        serde_json::to_string(self).unwrap_or_default()
    }

    /// A header from its JSON line; `None` for text that is not a trace header of this format.
    pub fn from_line(text: &str) -> Option<Header> {
        serde_json::from_str::<Header>(text)
            .ok()
            .filter(|h| h.format == FORMAT)
    }
}

#[cfg(feature = "tracefile")]
#[cfg_attr(docsrs, doc(cfg(feature = "tracefile")))]
/// The longest trace line a reader accepts: 1 MiB, an entry of about 250,000 bytes written as
/// JSON numbers, far beyond any frame of the protocols (the longest, an RK 512 or 3964(R)
/// block, is 1 KiB). A streaming reader holds one line at a time, so this bounds its memory.
pub const MAX_LINE: usize = 1 << 20;

#[cfg(feature = "tracefile")]
#[cfg_attr(docsrs, doc(cfg(feature = "tracefile")))]
/// One line of a trace file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Item {
    /// A header line.
    Header(Header),
    /// An entry.
    Entry(TraceEntry),
}

#[cfg(feature = "tracefile")]
#[cfg_attr(docsrs, doc(cfg(feature = "tracefile")))]
/// Reads a trace file line by line, in memory bounded by [`MAX_LINE`], not by the file: what
/// `si monitor --trace` and `si trace export` use for recordings of days.
#[derive(Debug)]
pub struct Stream<R: BufRead> {
    input: R,
    line: Vec<u8>,
    number: usize,
}

#[cfg(feature = "tracefile")]
impl<R: BufRead> Stream<R> {
    /// A reader of `input`.
    pub fn new(input: R) -> Self {
        Stream {
            input,
            line: Vec::new(),
            number: 0,
        }
    }

    /// The 1-based number of the line last read.
    pub fn line_number(&self) -> usize {
        self.number
    }

    /// The next header or entry (blank lines skipped), `None` at the end.
    pub fn next_item(&mut self) -> Result<Option<Item>, TraceFileError> {
        loop {
            if !self.next_line()? {
                return Ok(None);
            }
            let line = self.number;
            let text = String::from_utf8_lossy(&self.line);
            let text = text.trim();
            if text.is_empty() {
                continue;
            }
            return parse_line(text, line).map(Some);
        }
    }

    /// Read one line into `self.line`, refusing it past [`MAX_LINE`] before holding more.
    fn next_line(&mut self) -> Result<bool, TraceFileError> {
        self.line.clear();
        self.number += 1;
        let mut any = false;
        loop {
            let buf = match self.input.fill_buf() {
                Ok(b) => b,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(e.into()),
            };
            if buf.is_empty() {
                return Ok(any);
            }
            any = true;
            let (take, done) = match buf.iter().position(|&b| b == b'\n') {
                Some(i) => (i, true),
                None => (buf.len(), false),
            };
            if self.line.len() + take > MAX_LINE {
                return Err(TraceFileError::TooLong {
                    line: self.number,
                    max: MAX_LINE,
                });
            }
            self.line.extend_from_slice(&buf[..take]);
            self.input.consume(take + usize::from(done));
            if done {
                return Ok(true);
            }
        }
    }
}

#[cfg(feature = "tracefile")]
/// A header or an entry from one non-blank line, `line` its number for errors.
fn parse_line(text: &str, line: usize) -> Result<Item, TraceFileError> {
    let syntax = |e: serde_json::Error| TraceFileError::Syntax {
        line,
        message: e.to_string(),
    };
    // Entries straight into their type (most lines, one parse); only a line that could be a
    // header goes through a JSON value first.
    if !text.contains("\"format\"") {
        return Ok(Item::Entry(serde_json::from_str(text).map_err(syntax)?));
    }
    let value: serde_json::Value = serde_json::from_str(text).map_err(syntax)?;
    if value.get("format").and_then(|f| f.as_str()) == Some(FORMAT) {
        let header: Header = serde_json::from_value(value).map_err(syntax)?;
        if header.version > VERSION {
            return Err(TraceFileError::Version(header.version));
        }
        if let Some(format) = &header.settings {
            format
                .check()
                .map_err(|error| TraceFileError::Range { line, error })?;
        }
        Ok(Item::Header(header))
    } else {
        Ok(Item::Entry(serde_json::from_value(value).map_err(syntax)?))
    }
}

#[cfg(feature = "tracefile")]
#[cfg_attr(docsrs, doc(cfg(feature = "tracefile")))]
/// Serialize one entry as its JSON line (without the newline).
pub fn entry_line(entry: &TraceEntry) -> String {
    // A TraceEntry holds only strings, numbers and enums: serialization cannot fail.
    serde_json::to_string(entry).unwrap_or_default()
}

#[cfg(feature = "tracefile")]
#[cfg_attr(docsrs, doc(cfg(feature = "tracefile")))]
/// Write a whole trace: the header, then every entry.
pub fn write<W: Write>(mut out: W, header: &Header, trace: &Trace) -> io::Result<()> {
    writeln!(out, "{}", serde_json::to_string(header).unwrap_or_default())?;
    for e in &trace.entries {
        writeln!(out, "{}", entry_line(e))?;
    }
    out.flush()
}

#[cfg(feature = "tracefile")]
#[cfg_attr(docsrs, doc(cfg(feature = "tracefile")))]
/// Read a trace file: an optional header line, then entries. Blank lines are skipped. This
/// holds the whole trace; [`Stream`] reads one line at a time.
pub fn read<R: BufRead>(input: R) -> Result<TraceFile, TraceFileError> {
    let mut file = TraceFile::default();
    let mut stream = Stream::new(input);
    while let Some(item) = stream.next_item()? {
        match item {
            Item::Header(h) => file.header = Some(h),
            Item::Entry(e) => file.trace.entries.push(e),
        }
    }
    Ok(file)
}

#[cfg(feature = "tracefile")]
#[cfg_attr(docsrs, doc(cfg(feature = "tracefile")))]
/// A live trace writer shared by everything that records one line: the driver, a transport
/// wrapper, a monitor. Cheap to clone; every clone appends to the same file, and each entry is
/// flushed as it is written so a trace survives Ctrl-C up to its last line.
///
/// Entry times are microseconds since the recorder was created (its own monotonic clock), so
/// several writers sharing one recorder agree on time.
#[derive(Clone)]
pub struct Recorder {
    inner: Arc<Mutex<Box<dyn Write + Send>>>,
    origin: std::time::Instant,
    station: Arc<str>,
}

#[cfg(feature = "tracefile")]
impl core::fmt::Debug for Recorder {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Recorder").finish_non_exhaustive()
    }
}

#[cfg(feature = "tracefile")]
impl Recorder {
    /// A recorder writing to `out`, starting with `header`; a header without a
    /// [`start`](Header::start) gets the wall-clock time of the recorder's clock origin.
    pub fn new(mut out: Box<dyn Write + Send>, header: &Header) -> io::Result<Self> {
        let origin = std::time::Instant::now();
        let mut header = header.clone();
        if header.start.is_none() {
            header = header.started(std::time::SystemTime::now());
        }
        writeln!(
            out,
            "{}",
            serde_json::to_string(&header).unwrap_or_default()
        )?;
        out.flush()?;
        Ok(Recorder {
            inner: Arc::new(Mutex::new(out)),
            origin,
            station: Arc::from("local"),
        })
    }

    /// A clone that writes its entries under another station name (same file, same clock):
    /// one per port when a program records several lines.
    pub fn for_station(&self, station: &str) -> Recorder {
        Recorder {
            station: Arc::from(station),
            ..self.clone()
        }
    }

    /// The station name entries are written under (`"local"` unless set with
    /// [`for_station`](Self::for_station)).
    pub fn station(&self) -> &str {
        &self.station
    }

    /// A recorder writing to a new file at `path` (replacing one that exists).
    pub fn create(path: &std::path::Path, header: &Header) -> io::Result<Self> {
        let file = std::fs::File::create(path)?;
        Recorder::new(Box::new(io::BufWriter::new(file)), header)
    }

    /// The recorder's clock: microseconds since it was created.
    pub fn now(&self) -> Instant {
        Instant::from_micros(u64::try_from(self.origin.elapsed().as_micros()).unwrap_or(u64::MAX))
    }

    /// Append one entry stamped with [`now`](Self::now). Callers on a live line log a write
    /// error and carry on: a full disk must not stop a PLC link.
    pub fn record(&self, kind: TraceKind) -> io::Result<()> {
        self.record_at(self.now(), kind)
    }

    /// Append one entry with an explicit time.
    pub fn record_at(&self, at: Instant, kind: TraceKind) -> io::Result<()> {
        let line = entry_line(&TraceEntry {
            at,
            station: self.station.to_string(),
            kind,
        });
        // A poisoned lock only means another writer panicked mid-line; keep recording.
        let mut out = self.inner.lock().unwrap_or_else(|p| p.into_inner());
        writeln!(out, "{line}")?;
        out.flush()
    }
}

/// `t` as RFC 3339 in UTC with microseconds (`2026-11-25T16:18:25.123456Z`); times before
/// 1970 are written as 1970-01-01T00:00:00Z (no clock of a recording machine is that wrong).
pub fn rfc3339(t: std::time::SystemTime) -> String {
    utc(t, 6)
}

/// `t` as RFC 3339 in UTC with milliseconds (`2026-11-25T16:43:59.123Z`), as log and poll
/// lines show it: UTC, so that lines of two machines and a trace line up without a time-zone
/// database.
pub fn rfc3339_millis(t: std::time::SystemTime) -> String {
    utc(t, 3)
}

/// `t` in UTC with `digits` (3 or 6) digits of the second's fraction.
fn utc(t: std::time::SystemTime, digits: usize) -> String {
    let since = t.duration_since(std::time::UNIX_EPOCH).unwrap_or_default();
    let secs = since.as_secs();
    let (days, rest) = (secs / 86_400, secs % 86_400);
    let (y, m, d) = civil_from_days(days);
    let fraction = if digits == 3 {
        since.subsec_millis()
    } else {
        since.subsec_micros()
    };
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}.{fraction:0digits$}Z",
        rest / 3600,
        rest / 60 % 60,
        rest % 60,
    )
}

/// Year, month, day of `days` since 1970-01-01 in the proleptic Gregorian calendar (Howard
/// Hinnant's `civil_from_days`, for days from the epoch on).
fn civil_from_days(days: u64) -> (u64, u64, u64) {
    let z = days + 719_468;
    let era = z / 146_097;
    let doe = z % 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + u64::from(m <= 2);
    (y, m, d)
}

#[cfg(test)]
mod tests {
    use super::*;
    #[cfg(feature = "tracefile")]
    use crate::sansio::LineError;

    #[test]
    fn rfc3339_writes_utc_with_microseconds() {
        let at = |s: u64, us: u32| std::time::UNIX_EPOCH + std::time::Duration::new(s, us * 1000);
        assert_eq!(rfc3339(at(0, 0)), "1970-01-01T00:00:00.000000Z");
        // 2000-02-29 (a leap day of a century leap year) 12:34:56.
        assert_eq!(rfc3339(at(951_827_696, 7)), "2000-02-29T12:34:56.000007Z");
        // 2026-11-25T16:18:25.123456Z, the last day of a month and of a year around it.
        assert_eq!(
            rfc3339(at(1_795_623_505, 123_456)),
            "2026-11-25T16:18:25.123456Z"
        );
        assert_eq!(rfc3339(at(1_798_761_599, 0)), "2026-12-31T23:59:59.000000Z");
    }

    #[test]
    fn rfc3339_millis_writes_utc_with_milliseconds() {
        let at = |s: u64, ms: u64| {
            std::time::UNIX_EPOCH
                + std::time::Duration::from_secs(s)
                + std::time::Duration::from_millis(ms)
        };
        assert_eq!(rfc3339_millis(at(0, 0)), "1970-01-01T00:00:00.000Z");
        assert_eq!(
            rfc3339_millis(at(951_827_696, 7)),
            "2000-02-29T12:34:56.007Z"
        );
        assert_eq!(
            rfc3339_millis(at(1_798_761_599, 999)),
            "2026-12-31T23:59:59.999Z"
        );
        let before_1970 = std::time::UNIX_EPOCH - std::time::Duration::from_secs(5);
        assert_eq!(rfc3339_millis(before_1970), "1970-01-01T00:00:00.000Z");
    }

    #[cfg(feature = "tracefile")]
    #[test]
    fn a_header_without_a_start_still_reads() {
        let old = concat!(
            r#"{"format":"si-trace","version":1,"source":"port","stations":["si"]}"#,
            "\n",
            r#"{"at":0,"station":"si","kind":"tx","bytes":[2]}"#,
        );
        let f = read(old.as_bytes()).unwrap();
        assert_eq!(f.header.unwrap().start, None);
        assert_eq!(f.trace.entries.len(), 1);
    }

    #[cfg(feature = "tracefile")]
    fn sample() -> Trace {
        let e = |at, station: &str, kind| TraceEntry {
            at: Instant::from_micros(at),
            station: station.to_owned(),
            kind,
        };
        Trace {
            entries: vec![
                e(0, "A", TraceKind::Tx { bytes: vec![0x02] }),
                e(1146, "B", TraceKind::Rx { byte: 0x02 }),
                e(
                    1200,
                    "B",
                    TraceKind::RxChunk {
                        bytes: vec![0x10, 0x10],
                    },
                ),
                e(
                    1300,
                    "B",
                    TraceKind::RxError {
                        error: LineError::Parity,
                    },
                ),
                e(
                    1400,
                    "A",
                    TraceKind::Event {
                        text: "Sent".into(),
                    },
                ),
            ],
        }
    }

    #[cfg(feature = "tracefile")]
    #[test]
    fn write_then_read_gives_the_same_trace() {
        let header = Header::new("sim")
            .protocol("3964r")
            .settings(SerialSettings::default())
            .stations(&["A", "B"]);
        let mut buf = Vec::new();
        write(&mut buf, &header, &sample()).unwrap();
        let back = read(&buf[..]).unwrap();
        assert_eq!(back.header, Some(header));
        assert_eq!(back.trace, sample());
        assert_eq!(back.stations(), vec!["A", "B"]);
    }

    #[cfg(feature = "tracefile")]
    #[test]
    fn the_documented_line_shapes_parse() {
        let text = r#"{"format":"si-trace","version":1,"source":"port","settings":{"baud":187500,"data_bits":8,"parity":"even","stop_bits":1}}
{"at":0,"station":"A","kind":"tx","bytes":[2]}

{"at":1146,"station":"B","kind":"rx","byte":2}
{"at":5200,"station":"si","kind":"rx_chunk","bytes":[16,2]}
"#;
        let f = read(text.as_bytes()).unwrap();
        assert_eq!(f.trace.entries.len(), 3);
        let s = f.header.unwrap().settings.unwrap().settings().unwrap();
        assert_eq!(s.baud(), 187_500, "USS's rate reads back");
        assert_eq!(
            f.trace.entries[2].kind,
            TraceKind::RxChunk { bytes: vec![16, 2] }
        );
    }

    #[cfg(feature = "tracefile")]
    /// A header with `baud` 0 is refused with a range error naming the field.
    #[test]
    fn a_header_out_of_range_is_refused() {
        let header = |baud: u32, data_bits: u8| {
            format!(
                r#"{{"format":"si-trace","version":1,"source":"port","settings":{{"baud":{baud},"data_bits":{data_bits},"parity":"even","stop_bits":1}}}}"#
            )
        };
        match read(header(0, 8).as_bytes()) {
            Err(e @ TraceFileError::Range { line: 1, .. }) => {
                let text = e.to_string();
                assert!(
                    text.starts_with("trace line 1: baud = 0 bit/s is out of range: 110, 300,"),
                    "{text}"
                );
                assert!(text.ends_with("115200, 187500 bit/s"), "{text}");
            }
            other => panic!("expected a range error, got {other:?}"),
        }
        let e = read(header(9600, 9).as_bytes()).unwrap_err();
        assert_eq!(
            e.to_string(),
            "trace line 1: data_bits = 9 is out of range: 7 or 8"
        );
        assert!(read(header(9600, 7).as_bytes()).is_ok());
    }

    #[cfg(feature = "tracefile")]
    #[test]
    fn a_line_past_the_limit_is_refused_with_its_number() {
        let mut text = String::from("{\"at\":0,\"station\":\"A\",\"kind\":\"tx\",\"bytes\":[2]}\n");
        text.push_str(&"0".repeat(MAX_LINE + 1));
        match read(text.as_bytes()) {
            Err(e @ TraceFileError::TooLong { line: 2, .. }) => {
                assert_eq!(e.to_string(), "trace line 2: longer than 1048576 bytes")
            }
            other => panic!("expected a line too long, got {other:?}"),
        }
        // Endless input without a newline: refused, not read into memory.
        let zero = io::BufReader::new(io::repeat(0));
        assert!(matches!(
            Stream::new(zero).next_item(),
            Err(TraceFileError::TooLong { line: 1, .. })
        ));
    }

    #[cfg(feature = "tracefile")]
    #[test]
    fn a_bad_line_is_named() {
        let text = "{\"at\":0,\"station\":\"A\",\"kind\":\"tx\",\"bytes\":[2]}\nnot json\n";
        match read(text.as_bytes()) {
            Err(TraceFileError::Syntax { line, .. }) => assert_eq!(line, 2),
            other => panic!("expected a syntax error, got {other:?}"),
        }
        let newer = r#"{"format":"si-trace","version":99,"source":"x"}"#;
        assert!(matches!(
            read(newer.as_bytes()),
            Err(TraceFileError::Version(99))
        ));
    }

    #[cfg(feature = "tracefile")]
    #[test]
    fn recorder_appends_lines_a_reader_understands() {
        #[derive(Clone, Default)]
        struct Shared(Arc<Mutex<Vec<u8>>>);
        impl Write for Shared {
            fn write(&mut self, b: &[u8]) -> io::Result<usize> {
                self.0.lock().unwrap().extend_from_slice(b);
                Ok(b.len())
            }
            fn flush(&mut self) -> io::Result<()> {
                Ok(())
            }
        }
        let buf = Shared::default();
        let before = rfc3339(std::time::SystemTime::now());
        let rec = Recorder::new(Box::new(buf.clone()), &Header::new("driver")).unwrap();
        let after = rfc3339(std::time::SystemTime::now());
        let rec2 = rec.for_station("si");
        rec.record_at(Instant::from_micros(5), TraceKind::Tx { bytes: vec![1] })
            .unwrap();
        rec2.record(TraceKind::RxChunk { bytes: vec![2, 3] })
            .unwrap();
        let bytes = buf.0.lock().unwrap().clone();
        let f = read(&bytes[..]).unwrap();
        let header = f.header.unwrap();
        assert_eq!(header.source, "driver");
        // The recorder stamps its wall-clock start (same width: text order is time order).
        let start = header.start.unwrap();
        assert!(
            before <= start && start <= after,
            "{before} {start} {after}"
        );
        assert_eq!(f.trace.entries.len(), 2);
        assert_eq!(f.trace.entries[0].at, Instant::from_micros(5));
        assert_eq!(f.trace.entries[0].station, "local");
        assert_eq!(f.trace.entries[1].station, "si");
    }

    #[cfg(feature = "tracefile")]
    proptest::proptest! {
        #[test]
        fn read_never_panics_on_arbitrary_text(text in "(\\PC|\n|\\{|\\}|\"|:|,|[0-9])*") {
            let _ = read(text.as_bytes());
        }

        #[test]
        fn any_entry_round_trips(
            at in 0u64..u64::MAX / 2,
            station in "[A-Za-z0-9 _-]{0,12}",
            bytes in proptest::collection::vec(proptest::num::u8::ANY, 0..40),
            kind in 0u8..4,
        ) {
            let kind = match kind {
                0 => TraceKind::Tx { bytes },
                1 => TraceKind::Rx { byte: bytes.first().copied().unwrap_or(0) },
                2 => TraceKind::RxChunk { bytes },
                _ => TraceKind::Event { text: String::from_utf8_lossy(&bytes).into_owned() },
            };
            let trace = Trace { entries: vec![TraceEntry { at: Instant::from_micros(at), station, kind }] };
            let mut buf = Vec::new();
            write(&mut buf, &Header::new("sim"), &trace).unwrap();
            proptest::prop_assert_eq!(read(&buf[..]).unwrap().trace, trace);
        }
    }
}
