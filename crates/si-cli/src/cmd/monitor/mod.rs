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
//! at the end; `--svg` draws the sequence diagram ([`si_core::diagram`]).
//!
//! A trace is read record by record (`si_core::monitor::streamed`): memory holds a minute of
//! line, not the file. `--pcap` also writes the records as a Wireshark capture
//! ([`pcap_out`]), `--from-pcap` reads one instead of a trace ([`pcap_in`]).

use crate::conn::Connection;
use crate::error::CliError;
use crate::output::Output;
use clap::{Args, ValueEnum};
use si_capture::{pcap_in, pcap_out};
use si_core::monitor::live::{self, Ended, WatchError};
use si_core::monitor::streamed::{Sink, StreamError, TraceStream};
use si_core::monitor::{self, line, Analysis, Decoder, Kind, LineChar, Record};
use si_core::tracefile::{self, Header, TraceFile, TRACE_RATES};
use si_core::{Duration, Instant, SerialSettings};
use std::path::PathBuf;

/// The protocols the monitor decodes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, ValueEnum)]
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
    #[default]
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

    /// The protocol a trace header or a capture names (`3964R` as `3964r`), not `auto`.
    fn from_name(name: &str) -> Option<Protocol> {
        let p = <Protocol as ValueEnum>::from_str(name, true).ok();
        p.filter(|p| *p != Protocol::Auto)
    }
}

/// `si monitor`.
#[derive(Debug, Default, Args)]
pub struct MonitorArgs {
    /// Protocol to decode.
    #[arg(long, value_enum, default_value_t = Protocol::Auto)]
    pub protocol: Protocol,
    /// Read this recorded trace instead of a port (record by record: any length).
    #[arg(long, value_name = "FILE", conflicts_with = "from_pcap")]
    pub trace: Option<PathBuf>,
    /// Read this capture instead of a port: one written by --pcap or `si trace export`, or an
    /// RTAC serial (link type 250) or USER0 (147) capture of Modbus RTU from another sniffer.
    #[arg(long, value_name = "FILE")]
    pub from_pcap: Option<PathBuf>,
    /// Also write the frames as a pcapng capture for Wireshark (exported PDUs naming the
    /// dissector; line errors and modem lines as RTAC serial records).
    #[arg(long, value_name = "FILE")]
    pub pcap: Option<PathBuf>,
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
    /// Character delay time in ms: 3964(R)'s ZVZ (default 220) or the ASCII driver's (default:
    /// 4 ms or the baud rate's minimum, whichever is longer).
    #[arg(long, value_name = "MS")]
    pub char_delay_ms: Option<u64>,
    /// 3964(R) acknowledgement delay time QVZ in ms (default 2000, 550 for plain 3964).
    #[arg(long, value_name = "MS")]
    pub ack_delay_ms: Option<u64>,
    /// Modbus response timeout in ms (default 2000, the master's default).
    #[arg(long, value_name = "MS")]
    pub response_timeout_ms: Option<u64>,
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
        match (&self.trace, &self.from_pcap) {
            (Some(path), _) => self.run_trace(path, conn, out),
            (None, Some(path)) => self.run_pcap(path, conn, out),
            (None, None) => self.run_live(conn, out).await,
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
                p.zvz = self.char_delay_ms.map_or(p.zvz, ms);
                p.qvz = self.ack_delay_ms.map_or(p.qvz, ms);
                Box::new(si_3964r::monitor::Monitor::new(p))
            }
            Protocol::Modbus => {
                let mut master = si_modbus::config::MasterConfig::default();
                master.line.settings = settings;
                let mut p = si_modbus::monitor::Params::from_config(&master);
                p.timeout = self.response_timeout_ms.map_or(p.timeout, ms);
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
                    char_delay: si_ascii::config::min_char_delay(settings.baud()),
                    flow_control: if self.no_xon_xoff {
                        FlowControl::None
                    } else {
                        FlowControl::XonXoff
                    },
                    ..si_ascii::Config::default()
                };
                let mut p = si_ascii::monitor::Params::from_config(&link);
                p.char_delay = self.char_delay_ms.map_or(p.char_delay, ms);
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
        let mut sinks = Sinks {
            out: Some(out),
            diagram: self.svg.as_ref().map(|_| si_core::diagram::Diagram::new()),
            pcap: None,
            pcap_path: self.pcap.clone(),
            kept: None,
        };
        let analysis = self.stream_trace(path, conn, &mut sinks)?;
        sinks.finish(&analysis, self.svg.as_deref())
    }

    /// Decode the trace at `path` record by record, handing every record to `sinks`: memory
    /// bounded by a minute of line (`si_core::monitor::ordered::HORIZON`) and the longest trace line, not by
    /// the file. The records come in the order [`analyse`](Self::analyse) gives them.
    pub fn stream_trace(
        &self,
        path: &std::path::Path,
        conn: &Connection,
        sinks: &mut Sinks<'_>,
    ) -> Result<Analysis, CliError> {
        let file = std::fs::File::open(path)
            .map_err(|e| CliError::new(format!("cannot open {}: {e}", path.display())))?;
        let bad = |e: tracefile::TraceFileError| CliError::new(format!("{}: {e}", path.display()));
        let input = TraceStream::open(std::io::BufReader::new(file)).map_err(bad)?;
        let header = input.header().cloned();
        let settings = header
            .as_ref()
            .and_then(|h| h.settings)
            .and_then(|f| f.settings())
            .map_or_else(|| conn.settings_for(&TRACE_RATES), Ok)?;
        let (named, windows) = self.named(header.as_ref());
        // The first entries decide the kind of line and, unnamed, the protocol.
        let probe = input.probe(settings, windows);
        let line = (&probe.chars[..], probe.end, &probe.stations[..]);
        let (protocol, decoder) = self.chosen(named, windows, line, settings);
        // Record times count from the recording's start; say when that was. Text only: a JSON
        // reader has the header itself, and every JSON line stays a record.
        if let (Some(start), Some(out)) =
            (header.as_ref().and_then(|h| h.start.as_ref()), sinks.out)
        {
            if !out.json {
                crate::output::write_stdout(format_args!("recorded from {start}\n"));
            }
        }
        let described = header
            .unwrap_or_else(|| Header::new("trace"))
            .protocol(protocol.name())
            .settings(settings)
            .stations(&probe.stations);
        drop(probe);
        sinks.open_pcap(protocol.name(), &described)?;
        let run = (settings, windows);
        input
            .run(run, decoder, (protocol.name(), self.events), sinks)
            .map_err(|e| match e {
                StreamError::Read(e) => bad(e),
                StreamError::Sink(e) => e,
            })
    }

    /// The protocol a trace header names, and whether the trace is one of DP windows.
    fn named(&self, header: Option<&Header>) -> (Option<Protocol>, bool) {
        let named = header
            .and_then(|h| h.protocol.as_deref())
            .and_then(Protocol::from_name);
        let windows = match (self.protocol, named) {
            (Protocol::Auto, named) => named == Some(Protocol::DpCoord),
            (p, _) => p == Protocol::DpCoord,
        };
        (named, windows)
    }

    /// The protocol (`--protocol`, else the one `named`, else the [`guess`](Self::guess) from
    /// the line's first characters up to `end`) and its decoder for a line of `stations`.
    fn chosen(
        &self,
        named: Option<Protocol>,
        windows: bool,
        (chars, end, stations): (&[LineChar], Instant, &[String]),
        settings: SerialSettings,
    ) -> (Protocol, Box<dyn Decoder + Send>) {
        let one_sided = stations.len() < 2;
        let protocol = match (self.protocol, named) {
            (Protocol::Auto, Some(p)) => p,
            (Protocol::Auto, None) => self.guess(chars, end, settings, one_sided),
            (p, _) => p,
        };
        let decoder: Box<dyn Decoder + Send> = if windows {
            let index = si_dp_coord::monitor::module_index(stations);
            Box::new(si_dp_coord::monitor::Monitor::new(index))
        } else {
            self.decoder(protocol, settings, one_sided)
        };
        (protocol, decoder)
    }

    /// Which protocol a line that names none looks like ([`monitor::best_fit`]): 3964(R),
    /// Modbus or USS, whichever explains it best; ASCII explains every line trivially, so only
    /// when nothing else does.
    fn guess(
        &self,
        chars: &[LineChar],
        end: Instant,
        settings: SerialSettings,
        one_sided: bool,
    ) -> Protocol {
        let candidates = [Protocol::P3964r, Protocol::Modbus, Protocol::Uss];
        monitor::best_fit(chars, end, &candidates, Protocol::Ascii, |p| {
            self.decoder(p, settings, one_sided)
        })
    }

    /// `--from-pcap`: decode a capture packet by packet.
    fn run_pcap(
        &self,
        path: &std::path::Path,
        conn: &Connection,
        out: &Output,
    ) -> Result<(), CliError> {
        let (mut input, first) = pcap_in::PcapIn::open(path).map_err(CliError::new)?;
        let header = input.header.clone();
        let settings = header
            .as_ref()
            .and_then(|h| h.settings)
            .and_then(|f| f.settings())
            .map_or_else(|| conn.settings_for(&TRACE_RATES), Ok)?;
        input.set_settings(settings);
        input.windows = header.as_ref().and_then(|h| h.protocol.as_deref()) == Some("dp-coord")
            || self.protocol == Protocol::DpCoord;
        let named = header
            .as_ref()
            .and_then(|h| h.protocol.as_deref())
            .or_else(|| input.dissector.as_deref().and_then(pcap_out::protocol_of))
            .and_then(Protocol::from_name);
        // Another sniffer's raw serial capture: Modbus RTU, unless --protocol says otherwise.
        let protocol = match (self.protocol, named) {
            (Protocol::Auto, Some(p)) => p,
            (Protocol::Auto, None) => Protocol::Modbus,
            (p, _) => p,
        };
        let one_sided = input.first_linktype() == Some(pcap_in::LINKTYPE_USER0)
            || header.as_ref().is_some_and(|h| h.stations.len() < 2);
        let decoder: Box<dyn Decoder + Send> = if protocol == Protocol::DpCoord {
            Box::new(si_dp_coord::monitor::Monitor::new(
                si_dp_coord::monitor::module_index(&input.stations),
            ))
        } else {
            self.decoder(protocol, settings, one_sided)
        };
        let mut sinks = Sinks {
            out: Some(out),
            diagram: self.svg.as_ref().map(|_| si_core::diagram::Diagram::new()),
            pcap: None,
            pcap_path: self.pcap.clone(),
            kept: None,
        };
        if let Some(start) = header.as_ref().and_then(|h| h.start.as_deref()) {
            if !out.json {
                crate::output::write_stdout(format_args!("recorded from {start}\n"));
            }
        }
        let described = header
            .clone()
            .unwrap_or_else(|| Header::new("pcap"))
            .protocol(protocol.name())
            .settings(settings);
        sinks.open_pcap(protocol.name(), &described)?;
        let analysis = input
            .run(first, decoder, protocol.name(), &mut sinks)
            .map_err(|e| match e {
                StreamError::Read(e) => CliError::new(format!("{}: {e}", path.display())),
                StreamError::Sink(e) => e,
            })?;
        sinks.finish(&analysis, self.svg.as_deref())
    }

    /// Decode a trace file.
    pub fn analyse(
        &self,
        file: &TraceFile,
        settings: SerialSettings,
    ) -> Result<Analysis, CliError> {
        let (named, windows) = self.named(file.header.as_ref());
        let line = if windows {
            si_dp_coord::monitor::line(file)
        } else {
            line::from_trace(file, settings)
        };
        let end = file
            .trace
            .entries
            .last()
            .map(|e| e.at)
            .unwrap_or_default()
            .max(line.chars.last().map(|c| c.at).unwrap_or_default());
        let seen = (&line.chars[..], end, &line.stations[..]);
        let (protocol, mut decoder) = self.chosen(named, windows, seen, settings);
        let events = self.events.then_some(&file.trace.entries[..]);
        let name = protocol.name();
        Ok(monitor::whole::analyse_line(
            line,
            end,
            decoder.as_mut(),
            name,
            events,
        ))
    }

    async fn run_live(&self, conn: &Connection, out: &Output) -> Result<(), CliError> {
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
        let mut decoder = self.decoder(protocol, settings, tap.is_none());
        // The diagram summarises as the records arrive: a monitor left running for days, or
        // flooded, holds a bounded number of them (si_core::diagram::Diagram).
        let mut diagram = self.svg.as_ref().map(|_| si_core::diagram::Diagram::new());
        // The capture's times are wall-clock: its start is the monitor's clock origin.
        let mut pcap = match &self.pcap {
            Some(path) => {
                let header = Header::new("port")
                    .protocol(protocol.name())
                    .settings(settings)
                    .stations(&stations)
                    .started(std::time::SystemTime::now());
                Some(
                    pcap_out::PcapOut::create(path, protocol.name(), &header).map_err(|e| {
                        CliError::new(format!("cannot write {}: {e}", path.display()))
                    })?,
                )
            }
            None => None,
        };
        let pcap_error = |p: &pcap_out::PcapOut, e: std::io::Error| {
            CliError::new(format!("cannot write {}: {e}", p.path().display()))
        };
        out.line(
            &format!(
                "monitoring {} at {settings} (receive only); Ctrl-C ends",
                protocol.name()
            ),
            serde_json::json!({"monitor": protocol.name(), "settings": settings.to_string()}),
        );
        // Ctrl-C (true) or the --duration (false) ends the watch.
        let duration = self
            .duration
            .map(|s| std::time::Duration::from_secs_f64(s.max(0.0)));
        let stop = async {
            tokio::select! {
                _ = tokio::signal::ctrl_c() => true,
                _ = tokio::time::sleep(duration.unwrap_or_default()), if duration.is_some() => false,
            }
        };
        let watched = live::watch(
            port.as_mut(),
            tap.as_mut()
                .map(|t| &mut **t as &mut dyn si_core::driver::Transport),
            settings,
            decoder.as_mut(),
            stop,
            |records| {
                for r in &records {
                    print_record(r, &stations, out);
                    if let Some(p) = &mut pcap {
                        p.record(r, &stations).map_err(|e| pcap_error(p, e))?;
                    }
                }
                if let Some(d) = &mut diagram {
                    records.into_iter().for_each(|r| d.push(r));
                }
                Ok(())
            },
        )
        .await;
        let (ended, end) = watched.map_err(|e| match e {
            WatchError::Read(e) => CliError::new(format!("reading the line: {e}")),
            WatchError::Records(e) => e,
        })?;
        // How the watch ended when it was not its --duration: the counters and the diagram
        // are still written, then the exit code says it (a closed line 1, Ctrl-C 130).
        let ended = match ended {
            Ended::Stopped(false) => None,
            Ended::Stopped(true) => Some(CliError::interrupted()),
            Ended::Closed { tap: false } => Some(conn.closed()),
            Ended::Closed { tap: true } => tap_conn.as_ref().map(Connection::closed),
        };
        if let Some(p) = pcap {
            let path = p.path().to_owned();
            p.finish(&stations, end)
                .map_err(|e| CliError::new(format!("cannot write {}: {e}", path.display())))?;
        }
        let first = diagram
            .as_ref()
            .and_then(si_core::diagram::Diagram::first_start);
        let analysis = Analysis {
            protocol: protocol.name().to_owned(),
            stations,
            span: (first.unwrap_or_default(), end),
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

/// Where a streamed analysis sends what it decoded: the printer, the diagram, the capture.
pub struct Sinks<'a> {
    /// Print each record (None: export only).
    pub out: Option<&'a Output>,
    /// The SVG diagram, summarised as records arrive.
    pub diagram: Option<si_core::diagram::Diagram>,
    /// The capture being written.
    pub pcap: Option<pcap_out::PcapOut>,
    /// Where to write the capture (opened once the protocol is known).
    pub pcap_path: Option<PathBuf>,
    /// Keep every record (tests compare the streamed analysis with the whole-trace one).
    pub kept: Option<Vec<Record>>,
}

impl Sinks<'_> {
    fn pcap_error(path: &std::path::Path, e: std::io::Error) -> CliError {
        CliError::new(format!("cannot write {}: {e}", path.display()))
    }

    /// Create the capture, if one was asked for, for a line described by `header`.
    pub fn open_pcap(&mut self, protocol: &str, header: &Header) -> Result<(), CliError> {
        if let Some(path) = &self.pcap_path {
            self.pcap = Some(
                pcap_out::PcapOut::create(path, protocol, header)
                    .map_err(|e| Self::pcap_error(path, e))?,
            );
        }
        Ok(())
    }
}

impl Sink for Sinks<'_> {
    type Error = CliError;

    fn char(&mut self, c: &LineChar) {
        if let Some(p) = &mut self.pcap {
            p.char(c);
        }
    }

    fn signals(
        &mut self,
        at: Instant,
        update: &si_core::SignalUpdate,
        station: &str,
    ) -> Result<(), CliError> {
        if let Some(p) = &mut self.pcap {
            p.signals(at, update, station)
                .map_err(|e| Self::pcap_error(p.path(), e))?;
        }
        Ok(())
    }

    fn record(&mut self, r: Record, stations: &[String]) -> Result<(), CliError> {
        if let Some(out) = self.out {
            print_record(&r, stations, out);
        }
        if let Some(p) = &mut self.pcap {
            p.record(&r, stations)
                .map_err(|e| Self::pcap_error(p.path(), e))?;
        }
        if let Some(kept) = &mut self.kept {
            kept.push(r.clone());
        }
        if let Some(d) = &mut self.diagram {
            d.push(r);
        }
        Ok(())
    }
}

impl Sinks<'_> {
    /// The end: counters printed, the diagram and the capture written.
    pub fn finish(
        self,
        analysis: &Analysis,
        svg: Option<&std::path::Path>,
    ) -> Result<(), CliError> {
        if let Some(out) = self.out {
            print_counters(analysis, out);
        }
        if let (Some(path), Some(d)) = (svg, self.diagram) {
            write_file(path, d.render(analysis))?;
        }
        if let Some(p) = self.pcap {
            let path = p.path().to_owned();
            p.finish(&analysis.stations, analysis.span.1)
                .map_err(|e| Self::pcap_error(&path, e))?;
        }
        Ok(())
    }
}

/// The monitor for a command's own line, with the engines' default timers: what `si -v` logs
/// the frames with (`si_core::frame_log`). `None` for a protocol without a line monitor.
pub fn line_decoder(protocol: &str, settings: SerialSettings) -> Option<Box<dyn Decoder + Send>> {
    let protocol = Protocol::from_name(protocol).filter(|p| *p != Protocol::DpCoord)?;
    let defaults = MonitorArgs::quiet(protocol);
    // Both directions are known: what we write and what we read.
    Some(defaults.decoder(protocol, settings, false))
}

impl MonitorArgs {
    /// The monitor of `protocol` with the engines' default timers and no output options.
    pub fn quiet(protocol: Protocol) -> MonitorArgs {
        MonitorArgs {
            protocol,
            ..MonitorArgs::default()
        }
    }
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

fn write_file(path: &std::path::Path, svg: String) -> Result<(), CliError> {
    std::fs::write(path, svg)
        .map_err(|e| CliError::new(format!("cannot write {}: {e}", path.display())))
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::FromArgMatches;
    use si_core::monitor::decode_all;
    use si_core::monitor::LineChar;
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
                let svg = si_core::diagram::render(&analysis);
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

    /// The streamed analysis (record by record) gives what the whole-trace one gives: the
    /// same records in the same order, the same counters, for traces of every kind of line.
    #[test]
    fn streaming_a_trace_gives_the_whole_trace_analysis() {
        let mut rng = SplitMix64::new(29);
        let dir = std::env::temp_dir().join(format!("si-stream-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let conn = {
            let cmd = <Connection as clap::Args>::augment_args(clap::Command::new("c"));
            Connection::from_arg_matches(&cmd.get_matches_from(["c"])).unwrap()
        };
        for round in 0..150 {
            let names = ["A", "B", "C", "si"];
            let stations = 1 + round % 4;
            let mut at = 0;
            let entries: Vec<TraceEntry> = (0..rng.below(300))
                .map(|_| {
                    at += rng.below(20_000);
                    let station = names[rng.below(stations as u64) as usize].to_owned();
                    let bytes: Vec<u8> = (0..1 + rng.below(6)).map(|_| byte(&mut rng)).collect();
                    let kind = match (round / 4) % 3 {
                        // A simulator's trace: writes and exact receptions.
                        0 => match rng.below(4) {
                            0 => TraceKind::Tx { bytes },
                            1 => TraceKind::RxError {
                                error: LineError::Parity,
                            },
                            2 => TraceKind::Event { text: "e".into() },
                            _ => TraceKind::Rx { byte: bytes[0] },
                        },
                        // A real port's: writes and chunks.
                        1 => match rng.below(2) {
                            0 => TraceKind::Tx { bytes },
                            _ => TraceKind::RxChunk { bytes },
                        },
                        _ => match rng.below(5) {
                            0 => TraceKind::Tx { bytes },
                            1 => TraceKind::Rx { byte: bytes[0] },
                            2 => TraceKind::RxChunk { bytes },
                            3 => TraceKind::RxError {
                                error: LineError::Framing,
                            },
                            _ => TraceKind::Event { text: "x".into() },
                        },
                    };
                    TraceEntry {
                        at: Instant::from_micros(at),
                        station,
                        kind,
                    }
                })
                .collect();
            let protocol = ["3964r", "modbus", "uss", "ascii", "dp-coord", "rk512"][round % 6];
            let header = tracefile::Header::new("sim")
                .protocol(protocol)
                .settings(SerialSettings::default())
                .stations(&names[..stations.min(2)]);
            let file = TraceFile {
                header: Some(header.clone()),
                trace: Trace { entries },
            };
            let path = dir.join("t.trace");
            tracefile::write(std::fs::File::create(&path).unwrap(), &header, &file.trace).unwrap();
            let a = args(&["--events"]);
            let whole = a.analyse(&file, SerialSettings::default()).unwrap();
            let mut sinks = Sinks {
                out: None,
                diagram: None,
                pcap: None,
                pcap_path: None,
                kept: Some(Vec::new()),
            };
            let streamed = a.stream_trace(&path, &conn, &mut sinks).unwrap();
            let kept = sinks.kept.unwrap();
            assert_eq!(kept, whole.records, "round {round} ({protocol})");
            assert_eq!(streamed.counters, whole.counters, "round {round}");
            assert_eq!(streamed.stations, whole.stations, "round {round}");
            assert_eq!(streamed.span, whole.span, "round {round}");
        }
        let _ = std::fs::remove_dir_all(&dir);
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

    #[test]
    fn timer_flags_are_named_by_the_time_rule_and_reach_the_decoders() {
        let settings = SerialSettings::default();
        let c = |b: u8, at: u64, from: usize| LineChar {
            at: Instant::from_micros(at),
            from: Some(from),
            to: Some(1 - from),
            item: Ok(b),
            exact: true,
        };
        let end = Instant::from_micros(5_000_000);
        // ASCII: "AB", 10 ms of silence, "CD": two frames at the default delay, one at 50 ms.
        let ascii = [
            c(b'A', 1_146, 0),
            c(b'B', 2_292, 0),
            c(b'C', 12_292, 0),
            c(b'D', 13_438, 0),
        ];
        let frames = |a: &MonitorArgs| {
            let mut d = a.decoder(Protocol::Ascii, settings, false);
            decode_all(d.as_mut(), &ascii, end).len()
        };
        assert_eq!(frames(&args(&[])), 2);
        assert_eq!(frames(&args(&["--char-delay-ms", "50"])), 1);
        // 3964(R): the partner's DLE 150 ms after our STX is late for a 100 ms QVZ only.
        let r3964 = [c(0x02, 1_146, 0), c(0x10, 151_146, 1)];
        let flagged = |a: &MonitorArgs| {
            let mut d = a.decoder(Protocol::P3964r, settings, false);
            let records = decode_all(d.as_mut(), &r3964, end);
            records.iter().map(|r| r.flags.len()).sum::<usize>()
        };
        assert!(flagged(&args(&["--ack-delay-ms", "100"])) > flagged(&args(&[])));
        let a = args(&["--response-timeout-ms", "300"]);
        assert_eq!(a.response_timeout_ms, Some(300));
        // The manual's abbreviations are not flags any more.
        for old in ["--zvz", "--qvz", "--timeout", "--char-delay"] {
            let cmd = <MonitorArgs as clap::Args>::augment_args(clap::Command::new("m"));
            assert!(cmd.try_get_matches_from(["m", old, "5"]).is_err(), "{old}");
        }
    }
}
