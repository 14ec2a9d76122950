//! `si monitor`: watch a line without ever transmitting, or read a recorded trace, and decode
//! the frames with their timing.
//!
//! The input is either a port (`--port`/`--tcp`; the monitor only reads) or a trace file
//! (`--trace FILE`, see `si_core::tracefile`) written by `si sim --record`, by `si --record` on
//! any command, or by the tokio driver. The characters go to the protocol crate's passive
//! monitor (`si_3964r::monitor`, `si_rk512::monitor`, `si_modbus::monitor`, `si_uss::monitor`,
//! `si_ascii::monitor`), which cuts frames the way the module's receiver does, checks BCC/CRC,
//! judges the manuals' timers with the engine's own timing functions (ZVZ, QVZ, Modbus
//! end-of-frame gap and response timeout, USS start interval, residual run time and response
//! delay) and keeps counters. A trace of DP windows (`--protocol dp-coord`,
//! `si_dp_coord::monitor`) is read window by window with its coordination bytes. This command
//! only chooses the monitor, feeds it and prints: every record as it is decoded, the counters
//! at the end; `--svg` draws the sequence diagram ([`crate::svg`]).

mod line_errors;

use crate::conn::Connection;
use crate::error::CliError;
use crate::output::Output;
use clap::{Args, ValueEnum};
use si_core::monitor::{decode_all, line, Analysis, Decoder, Kind, LineChar, Record};
use si_core::tracefile::{self, TraceFile};
use si_core::{Duration, Instant, SerialSettings};
use std::path::PathBuf;

/// The protocols the monitor decodes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Protocol {
    /// 3964(R) with block check (BCC).
    #[value(name = "3964r")]
    P3964r,
    /// Plain 3964 (no block check, QVZ 550 ms).
    #[value(name = "3964")]
    P3964,
    /// RK 512 telegrams in 3964(R) blocks.
    Rk512,
    /// ASCII driver frames.
    Ascii,
    /// Modbus RTU.
    Modbus,
    /// USS.
    Uss,
    /// The window protocol's DP windows (a recorded window trace, not a serial line).
    #[value(name = "dp-coord")]
    DpCoord,
    /// The trace header's protocol, else the decoder that explains the line best.
    Auto,
}

impl Protocol {
    fn name(self) -> &'static str {
        match self {
            Protocol::P3964r => "3964r",
            Protocol::P3964 => "3964",
            Protocol::Rk512 => "rk512",
            Protocol::Ascii => "ascii",
            Protocol::Modbus => "modbus",
            Protocol::Uss => "uss",
            Protocol::DpCoord => "dp-coord",
            Protocol::Auto => "auto",
        }
    }

    fn from_name(name: &str) -> Option<Protocol> {
        Some(match name {
            "3964r" | "3964R" => Protocol::P3964r,
            "3964" => Protocol::P3964,
            "rk512" => Protocol::Rk512,
            "ascii" => Protocol::Ascii,
            "modbus" => Protocol::Modbus,
            "uss" => Protocol::Uss,
            "dp-coord" => Protocol::DpCoord,
            _ => return None,
        })
    }
}

/// `si monitor`.
#[derive(Debug, Args)]
pub struct MonitorArgs {
    /// Protocol to decode.
    #[arg(long, value_enum, default_value_t = Protocol::Auto)]
    pub protocol: Protocol,
    /// Read this recorded trace instead of a port.
    #[arg(long, value_name = "FILE")]
    pub trace: Option<PathBuf>,
    /// Also draw the exchange as an SVG sequence diagram.
    #[arg(long, value_name = "FILE")]
    pub svg: Option<PathBuf>,
    /// Second port of a monitor cable on a point-to-point line: it hears the other direction
    /// (`--port` hears station A, `--tap` station B). Both are only read.
    #[arg(long, value_name = "PATH")]
    pub tap: Option<String>,
    /// Stop watching a port after this many seconds (default: until Ctrl-C).
    #[arg(long, value_name = "SECONDS")]
    pub duration: Option<f64>,
    /// 3964(R) character delay time ZVZ in ms (default 220).
    #[arg(long, value_name = "MS")]
    pub zvz: Option<u64>,
    /// 3964(R) acknowledgement delay time QVZ in ms (default 2000, 550 for plain 3964).
    #[arg(long, value_name = "MS")]
    pub qvz: Option<u64>,
    /// Modbus response timeout in ms (default 2000, the master's default).
    #[arg(long, value_name = "MS")]
    pub timeout: Option<u64>,
    /// ASCII character delay time in ms (default: 4 ms or the baud rate's minimum, whichever is longer).
    #[arg(long, value_name = "MS")]
    pub char_delay: Option<u64>,
    /// ASCII: frames end with these one or two end-of-text characters (hex, e.g. 03 or 0D0A)
    /// instead of at the character delay time.
    #[arg(long, value_name = "HEX", conflicts_with = "fixed_length")]
    pub end_char: Option<String>,
    /// ASCII: frames have this fixed length instead of ending at the delay.
    #[arg(long, value_name = "N")]
    pub fixed_length: Option<u16>,
    /// Also show what the stations' own engines reported (the trace's `event` entries).
    #[arg(long)]
    pub events: bool,
    /// ASCII: treat 11H and 13H as data, not as XON/XOFF flow-control characters.
    #[arg(long)]
    pub no_xon_xoff: bool,
}

impl MonitorArgs {
    /// Run it: decode a trace, or watch the port.
    pub async fn run(&self, conn: &Connection, out: &Output) -> Result<(), CliError> {
        match &self.trace {
            Some(path) => self.run_trace(path, conn, out),
            None => self.run_live(conn, out).await,
        }
    }

    /// The protocol crate's monitor for `protocol`, with the engine's own timers unless the
    /// command line overrides them.
    fn decoder(
        &self,
        protocol: Protocol,
        settings: SerialSettings,
        one_sided: bool,
    ) -> Box<dyn Decoder + Send> {
        let ms = Duration::from_millis;
        match protocol {
            Protocol::P3964r | Protocol::P3964 | Protocol::Rk512 | Protocol::Auto => {
                let link = if protocol == Protocol::P3964 {
                    si_3964r::Config::without_block_check()
                } else {
                    si_3964r::Config::default()
                };
                // ZVZ is silence between characters: the monitor needs the character time.
                let mut p = if protocol == Protocol::Rk512 {
                    si_rk512::monitor::params(&link, settings)
                } else {
                    si_3964r::monitor::Params::from_config(&link, settings)
                };
                p.zvz = self.zvz.map_or(p.zvz, ms);
                p.qvz = self.qvz.map_or(p.qvz, ms);
                Box::new(si_3964r::monitor::Monitor::new(p))
            }
            Protocol::Modbus => {
                let mut master = si_modbus::config::MasterConfig::default();
                master.line.settings = settings;
                let mut p = si_modbus::monitor::Params::from_config(&master);
                p.timeout = self.timeout.map_or(p.timeout, ms);
                Box::new(si_modbus::monitor::Monitor::new(p, one_sided))
            }
            Protocol::Uss => Box::new(si_uss::monitor::Monitor::new(settings, one_sided)),
            Protocol::DpCoord => Box::new(si_dp_coord::monitor::Monitor::new(1)),
            Protocol::Ascii => {
                use si_ascii::config::{EndCriterion, FlowControl};
                let end = match (&self.end_char, self.fixed_length) {
                    (Some(hex), _) => {
                        let chars = si_core::hex::parse(hex).unwrap_or_default();
                        EndCriterion::EndChars {
                            first: chars.first().copied().unwrap_or(0x03),
                            second: chars.get(1).copied().unwrap_or(0),
                        }
                    }
                    (None, Some(len)) => EndCriterion::FixedLength { len },
                    (None, None) => EndCriterion::CharDelay,
                };
                let link = si_ascii::Config {
                    settings,
                    end,
                    // The smallest delay the link accepts at this rate (Table 2-9, 4 ms floor).
                    char_delay_ms: si_ascii::config::min_char_delay_ms(settings.baud()),
                    flow_control: if self.no_xon_xoff {
                        FlowControl::None
                    } else {
                        FlowControl::XonXoff
                    },
                    ..si_ascii::Config::default()
                };
                let mut p = si_ascii::monitor::Params::from_config(&link);
                p.char_delay = self.char_delay.map_or(p.char_delay, ms);
                Box::new(si_ascii::monitor::Monitor::new(p))
            }
        }
    }

    fn run_trace(
        &self,
        path: &std::path::Path,
        conn: &Connection,
        out: &Output,
    ) -> Result<(), CliError> {
        let file = std::fs::File::open(path)
            .map_err(|e| CliError::new(format!("cannot open {}: {e}", path.display())))?;
        let file = tracefile::read(std::io::BufReader::new(file))
            .map_err(|e| CliError::new(format!("{}: {e}", path.display())))?;
        let settings = file
            .header
            .as_ref()
            .and_then(|h| h.settings)
            .and_then(|f| f.settings())
            .map_or_else(|| conn.settings_for(&TRACE_RATES), Ok)?;
        let analysis = self.analyse(&file, settings)?;
        // Record times count from the recording's start; say when that was. Text only: a JSON
        // reader has the header itself, and every JSON line stays a record.
        if let Some(start) = file.header.as_ref().and_then(|h| h.start.as_deref()) {
            if !out.json {
                crate::output::write_stdout(format_args!("recorded from {start}\n"));
            }
        }
        for r in &analysis.records {
            print_record(r, &analysis.stations, out);
        }
        print_counters(&analysis, out);
        if let Some(svg) = &self.svg {
            write_svg(svg, &analysis)?;
        }
        Ok(())
    }

    /// Decode a trace file.
    pub fn analyse(
        &self,
        file: &TraceFile,
        settings: SerialSettings,
    ) -> Result<Analysis, CliError> {
        let named = file
            .header
            .as_ref()
            .and_then(|h| h.protocol.as_deref())
            .and_then(Protocol::from_name);
        let windows = match (self.protocol, named) {
            (Protocol::Auto, named) => named == Some(Protocol::DpCoord),
            (p, _) => p == Protocol::DpCoord,
        };
        let line = if windows {
            si_dp_coord::monitor::line(file)
        } else {
            line::from_trace(file, settings)
        };
        let one_sided = line.stations.len() < 2;
        let end = file
            .trace
            .entries
            .last()
            .map(|e| e.at)
            .unwrap_or_default()
            .max(line.chars.last().map(|c| c.at).unwrap_or_default());
        let protocol = match (self.protocol, named) {
            (Protocol::Auto, Some(p)) => p,
            (Protocol::Auto, None) => {
                guess(&line.chars, |p| self.decoder(p, settings, one_sided), end)
            }
            (p, _) => p,
        };
        let mut decoder: Box<dyn Decoder + Send> = if windows {
            Box::new(si_dp_coord::monitor::Monitor::new(
                si_dp_coord::monitor::module_index(&line.stations),
            ))
        } else {
            self.decoder(protocol, settings, one_sided)
        };
        let mut records = decode_all(decoder.as_mut(), &line.chars, end);
        if self.events {
            for e in &file.trace.entries {
                if let si_core::trace::TraceKind::Event { text } = &e.kind {
                    let from = line.stations.iter().position(|s| s == &e.station);
                    let mut r = Record::new(Kind::Event, e.at, e.at, from);
                    r.label = text.clone();
                    records.push(r);
                }
            }
            // Stable: at equal times the line comes before what the engine made of it.
            records.sort_by_key(|r| r.start);
        }
        Ok(Analysis {
            protocol: protocol.name().to_owned(),
            stations: line.stations,
            records,
            counters: decoder.counters().clone(),
            span: (line.chars.first().map(|c| c.at).unwrap_or_default(), end),
        })
    }

    async fn run_live(&self, conn: &Connection, out: &Output) -> Result<(), CliError> {
        use tokio::io::AsyncReadExt;
        let settings = conn.settings_for(&TRACE_RATES)?;
        let protocol = if self.protocol == Protocol::Auto {
            return Err(CliError::new(
                "on a live port, name the protocol: --protocol 3964r|3964|rk512|ascii|modbus|uss",
            ));
        } else if self.protocol == Protocol::DpCoord {
            return Err(CliError::new(
                "DP windows are not on a serial port: record them (si sim dp-coord-send --record FILE) and read them with --trace FILE",
            ));
        } else {
            self.protocol
        };
        let mut port = conn.open_with(&settings).await?;
        // A monitor cable for a point-to-point line has two receive wires: with --tap the
        // second direction is read from a second port, and both stations get a lane.
        let tap_conn = self.tap.as_ref().map(|path| {
            let mut other = conn.clone();
            other.port = Some(path.clone());
            other.tcp = None;
            other
        });
        let mut tap = match &tap_conn {
            Some(other) => Some(other.open_with(&settings).await?),
            None => None,
        };
        let name = |p: Option<&String>, fallback: &str| {
            p.and_then(|p| p.rsplit('/').next().map(str::to_owned))
                .unwrap_or_else(|| fallback.to_owned())
        };
        let stations = match &self.tap {
            Some(t) => vec![name(conn.port.as_ref(), "A"), name(Some(t), "B")],
            None => vec!["line".to_owned()],
        };
        let (to_a, to_b) = if tap.is_some() {
            (Some(1), Some(0))
        } else {
            (None, None)
        };
        let mut decoder = self.decoder(protocol, settings, tap.is_none());
        // Line errors (parity, framing, BREAK, overrun) reach the decoders in place.
        let mut lines_a = line_errors::LineReader::attach(port.as_mut(), (Some(0), to_a));
        let mut lines_b = tap
            .as_mut()
            .map(|t| line_errors::LineReader::attach(t.as_mut(), (Some(1), to_b)));
        let origin = tokio::time::Instant::now();
        let now = || Instant::from_micros(origin.elapsed().as_micros() as u64);
        let stop = self
            .duration
            .map(|s| origin + std::time::Duration::from_secs_f64(s.max(0.0)));
        // The diagram summarises as the records arrive: a monitor left running for days, or
        // flooded, holds a bounded number of them (crate::svg::Diagram).
        let mut diagram = self.svg.as_ref().map(|_| crate::svg::Diagram::new());
        let mut buf = [0u8; 512];
        let mut buf2 = [0u8; 512];
        let mut last = Instant::ZERO;
        let mut tick = tokio::time::interval(std::time::Duration::from_millis(50));
        let ctrl_c = tokio::signal::ctrl_c();
        tokio::pin!(ctrl_c);
        out.line(
            &format!(
                "monitoring {} at {settings} (receive only); Ctrl-C ends",
                protocol.name()
            ),
            serde_json::json!({"monitor": protocol.name(), "settings": settings.to_string()}),
        );
        let read_error = |e: std::io::Error| CliError::new(format!("reading the line: {e}"));
        // How the watch ended when it was not its --duration: the counters and the diagram
        // are still written, then the exit code says it (a closed line 1, Ctrl-C 130).
        let mut ended: Option<CliError> = None;
        loop {
            let mut records = Vec::new();
            tokio::select! {
                read = port.read(&mut buf) => {
                    let n = read.map_err(read_error)?;
                    if n == 0 {
                        ended = Some(conn.closed());
                        break;
                    }
                    for c in lines_a.chars(port.as_mut(), &buf[..n], now(), settings, &mut last) {
                        decoder.push(&c, &mut records);
                    }
                }
                read = async { tap.as_mut().map(|t| t.read(&mut buf2)).expect("guarded").await }, if tap.is_some() => {
                    let n = read.map_err(read_error)?;
                    if n == 0 {
                        ended = tap_conn.as_ref().map(Connection::closed);
                        break;
                    }
                    let (Some(t), Some(lines)) = (tap.as_mut(), lines_b.as_mut()) else { break };
                    for c in lines.chars(t.as_mut(), &buf2[..n], now(), settings, &mut last) {
                        decoder.push(&c, &mut records);
                    }
                }
                _ = tick.tick() => decoder.idle(now(), &mut records),
                _ = &mut ctrl_c => {
                    ended = Some(CliError::interrupted());
                    break;
                }
                _ = tokio::time::sleep_until(stop.unwrap_or(origin)), if stop.is_some() => break,
            }
            for r in &records {
                print_record(r, &stations, out);
            }
            if let Some(d) = &mut diagram {
                records.into_iter().for_each(|r| d.push(r));
            }
        }
        let mut records = Vec::new();
        decoder.finish(now(), &mut records);
        for r in &records {
            print_record(r, &stations, out);
        }
        if let Some(d) = &mut diagram {
            records.into_iter().for_each(|r| d.push(r));
        }
        let first = diagram.as_ref().and_then(crate::svg::Diagram::first_start);
        let analysis = Analysis {
            protocol: protocol.name().to_owned(),
            stations,
            span: (first.unwrap_or_default(), now()),
            records: Vec::new(),
            counters: decoder.counters().clone(),
        };
        print_counters(&analysis, out);
        if let (Some(path), Some(d)) = (&self.svg, diagram) {
            write_file(path, d.render(&analysis))?;
        }
        ended.map_or(Ok(()), Err)
    }
}

/// The monitor for a command's own line, with the engines' default timers: what `si -v` logs
/// the frames with (`si_core::frame_log`). `None` for a protocol without a line monitor.
pub fn line_decoder(protocol: &str, settings: SerialSettings) -> Option<Box<dyn Decoder + Send>> {
    let protocol = Protocol::from_name(protocol).filter(|p| *p != Protocol::DpCoord)?;
    let defaults = MonitorArgs {
        protocol,
        trace: None,
        svg: None,
        tap: None,
        duration: None,
        zvz: None,
        qvz: None,
        timeout: None,
        char_delay: None,
        end_char: None,
        fixed_length: None,
        events: false,
        no_xon_xoff: false,
    };
    // Both directions are known: what we write and what we read.
    Some(defaults.decoder(protocol, settings, false))
}

/// Baud rates a trace or a monitored line may use: the manuals' twelve and USS's 187 500.
pub static TRACE_RATES: [u32; 13] = [
    110, 300, 600, 1_200, 2_400, 4_800, 9_600, 19_200, 38_400, 57_600, 76_800, 115_200, 187_500,
];

/// Pick the decoder that explains the characters best: most decoded frames without errors,
/// fewest errors.
fn guess(
    chars: &[LineChar],
    make: impl Fn(Protocol) -> Box<dyn Decoder>,
    end: Instant,
) -> Protocol {
    let mut best = (Protocol::Ascii, i64::MIN);
    for p in [
        Protocol::P3964r,
        Protocol::Modbus,
        Protocol::Uss,
        Protocol::Ascii,
    ] {
        let mut d = make(p);
        let records = decode_all(d.as_mut(), chars, end);
        let good = records
            .iter()
            .filter(|r| r.kind != Kind::Note && !r.has_error())
            .count() as i64;
        let bad = records.iter().filter(|r| r.has_error()).count() as i64;
        // ASCII explains everything trivially: it only wins when nothing else does.
        let score = if p == Protocol::Ascii {
            0
        } else {
            good * 2 - bad * 3
        };
        if score > best.1 {
            best = (p, score);
        }
    }
    best.0
}

fn station(stations: &[String], i: Option<usize>) -> &str {
    i.and_then(|i| stations.get(i)).map_or("?", String::as_str)
}

/// Print one record: time, direction, label, meaning, flags.
pub fn print_record(r: &Record, stations: &[String], out: &Output) {
    let from = station(stations, r.from);
    let to = match r.to {
        Some(_) => station(stations, r.to),
        None => "*",
    };
    let flags: Vec<String> = r.flags.iter().map(|f| format!("  {f}")).collect();
    let dir = if matches!(r.kind, Kind::Note | Kind::Event) {
        format!("{from:>8}   {:<8}", "")
    } else {
        format!("{from:>8} → {to:<8}")
    };
    let text = if r.text.is_empty() || r.text == r.label {
        r.label.clone()
    } else {
        format!("{:<14} {}", r.label, r.text)
    };
    let (text, flags) = match r.kind {
        Kind::Note => (format!("!! {}", r.label), Vec::new()),
        Kind::Event => (format!("event {}", r.label), Vec::new()),
        _ => (text, flags),
    };
    out.line(
        &format!(
            "{:>14}  {dir} {text}{}",
            r.start.to_string(),
            flags.join("")
        ),
        serde_json::json!({
            "at_us": r.start.as_micros(),
            "end_us": r.end.as_micros(),
            "from": r.from.map(|_| from),
            "to": r.to.map(|_| to),
            "kind": r.kind,
            "label": r.label,
            "text": r.text,
            "bytes": si_core::hex::format(&r.bytes),
            "flags": r.flags,
        }),
    );
}

/// Print the counters.
pub fn print_counters(a: &Analysis, out: &Output) {
    let text: Vec<String> = a
        .counters
        .0
        .iter()
        .map(|(k, v)| format!("  {k:<32} {v}"))
        .collect();
    out.line(
        &format!("{} counters:\n{}", a.protocol, text.join("\n")),
        serde_json::json!({"protocol": a.protocol, "counters": a.counters.0}),
    );
}

fn write_svg(path: &std::path::Path, a: &Analysis) -> Result<(), CliError> {
    write_file(path, crate::svg::render(a))
}

fn write_file(path: &std::path::Path, svg: String) -> Result<(), CliError> {
    std::fs::write(path, svg)
        .map_err(|e| CliError::new(format!("cannot write {}: {e}", path.display())))
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::FromArgMatches;
    use si_core::LineError;
    use si_sim::{SplitMix64, Trace, TraceEntry, TraceKind};

    fn args(extra: &[&str]) -> MonitorArgs {
        let cmd = <MonitorArgs as clap::Args>::augment_args(clap::Command::new("m"));
        let m = cmd.get_matches_from(std::iter::once("m").chain(extra.iter().copied()));
        MonitorArgs::from_arg_matches(&m).unwrap()
    }

    /// Characters that matter to the decoders, and any others.
    fn byte(rng: &mut SplitMix64) -> u8 {
        const SPECIAL: [u8; 8] = [0x02, 0x03, 0x10, 0x15, 0x11, 0x13, 0x0D, 0x0A];
        if rng.chance(0.5) {
            SPECIAL[rng.below(SPECIAL.len() as u64) as usize]
        } else {
            rng.next_u64() as u8
        }
    }

    fn chars(rng: &mut SplitMix64, n: usize, stations: usize) -> Vec<LineChar> {
        let mut at = 0u64;
        (0..n)
            .map(|_| {
                at += match rng.below(4) {
                    0 => 0,
                    1 => rng.below(2_000),
                    2 => rng.below(50_000),
                    _ => rng.below(3_000_000),
                };
                let who = |rng: &mut SplitMix64| {
                    let k = rng.below(stations as u64 + 1) as usize;
                    (k < stations).then_some(k)
                };
                LineChar {
                    at: Instant::from_micros(at),
                    from: who(rng),
                    to: who(rng),
                    item: if rng.chance(0.05) {
                        Err(LineError::Framing)
                    } else {
                        Ok(byte(rng))
                    },
                    exact: rng.chance(0.8),
                }
            })
            .collect()
    }

    #[test]
    fn every_decoder_survives_arbitrary_bytes_and_timing() {
        let settings = SerialSettings::default();
        let mut rng = SplitMix64::new(10);
        for round in 0..120 {
            let stations = 1 + round % 4;
            let n = 1 + rng.below(400) as usize;
            let input = chars(&mut rng, n, stations);
            let end = input.last().map(|c| c.at).unwrap_or_default();
            for protocol in [
                Protocol::P3964r,
                Protocol::P3964,
                Protocol::Rk512,
                Protocol::Ascii,
                Protocol::Modbus,
                Protocol::Uss,
                Protocol::DpCoord,
            ] {
                let a = args(&[]);
                let mut d = a.decoder(protocol, settings, stations == 1);
                let records = decode_all(d.as_mut(), &input, end);
                assert!(records.windows(2).all(|w| w[0].start <= w[1].start));
                assert!(records.iter().all(|r| r.start <= r.end));
                let analysis = Analysis {
                    protocol: protocol.name().into(),
                    stations: (0..stations).map(|i| format!("S{i}")).collect(),
                    records,
                    counters: d.counters().clone(),
                    span: (Instant::ZERO, end),
                };
                let svg = crate::svg::render(&analysis);
                assert!(svg.ends_with("</svg>\n"));
            }
        }
    }

    #[test]
    fn arbitrary_trace_entries_give_a_line_in_time_order() {
        let mut rng = SplitMix64::new(3);
        for _ in 0..300 {
            let names = ["A", "B", "C", "si"];
            let mut at = 0;
            let entries = (0..rng.below(200))
                .map(|_| {
                    at += rng.below(20_000);
                    let station = names[rng.below(4) as usize].to_owned();
                    let bytes: Vec<u8> = (0..rng.below(6)).map(|_| byte(&mut rng)).collect();
                    let kind = match rng.below(5) {
                        0 => TraceKind::Tx { bytes },
                        1 => TraceKind::Rx {
                            byte: byte(&mut rng),
                        },
                        2 => TraceKind::RxChunk { bytes },
                        3 => TraceKind::RxError {
                            error: LineError::Parity,
                        },
                        _ => TraceKind::Event { text: "x".into() },
                    };
                    TraceEntry {
                        at: Instant::from_micros(at),
                        station,
                        kind,
                    }
                })
                .collect();
            let file = TraceFile {
                header: None,
                trace: Trace { entries },
            };
            let line = line::from_trace(&file, SerialSettings::default());
            assert!(line.chars.windows(2).all(|w| w[0].at <= w[1].at));
            let n = line.stations.len();
            assert!(line
                .chars
                .iter()
                .all(|c| c.from.is_none_or(|f| f < n) && c.to.is_none_or(|t| t < n)));
            // And the whole analysis, with protocol guessing, never fails.
            assert!(args(&[]).analyse(&file, SerialSettings::default()).is_ok());
        }
    }

    #[test]
    fn ascii_options_set_the_end_criterion() {
        use si_ascii::config::EndCriterion;
        let settings = SerialSettings::default();
        let c = |b: u8, at: u64| LineChar {
            at: Instant::from_micros(at),
            from: Some(0),
            to: Some(1),
            item: Ok(b),
            exact: true,
        };
        let input: Vec<LineChar> = b"AB\r\nCD\r\n"
            .iter()
            .enumerate()
            .map(|(k, &b)| c(b, 1_146 * (k as u64 + 1)))
            .collect();
        let end = Instant::from_micros(100_000);
        let a = args(&["--end-char", "0D0A"]);
        let mut d = a.decoder(Protocol::Ascii, settings, false);
        assert_eq!(decode_all(d.as_mut(), &input, end).len(), 2);
        let a = args(&["--fixed-length", "2"]);
        let mut d = a.decoder(Protocol::Ascii, settings, false);
        assert_eq!(decode_all(d.as_mut(), &input, end).len(), 4);
        let a = args(&[]);
        let mut d = a.decoder(Protocol::Ascii, settings, false);
        assert_eq!(
            decode_all(d.as_mut(), &input, end).len(),
            1,
            "back to back, the character delay never expires: {:?}",
            EndCriterion::CharDelay
        );
    }
}
