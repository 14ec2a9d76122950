//! `si ascii`: the ASCII driver on a line (send, receive, monitor) and its simulator scenarios
//! ([ET200S SI] §2.8).
//!
//! The ASCII driver has no frame encoding of its own (the user data are the frame, [ET200S SI]
//! §2.8), so there is no `si frame encode|decode ascii`.

use crate::conn::Connection;
use crate::error::CliError;
use crate::hex::{parse_hex, parse_hex_args};
use crate::output::Output;
use crate::preset::module_preset;
use crate::scenario::{print_trace, Scenario, SimOptions};
use clap::{Args, Subcommand, ValueEnum};
use serde_json::json;
use si_ascii::config::min_char_delay_ms;
use si_ascii::tokio::{Error as AsciiError, Handle, Incoming};
use si_ascii::{Config, EndCriterion, Event, FlowControl, Interface, Link};
use si_core::{Duration, Instant, ModulePreset, Status};
use si_sim::{Simulator, StationId, Trace, TraceKind};

/// The protocol's subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Send one frame: the bytes exactly as given (include any end characters yourself).
    Send(SendArgs),
    /// Receive frames cut by the end criterion and print them.
    Recv(RecvArgs),
    /// Print every frame with its timestamp as it is cut; never transmits anything.
    Monitor(MonitorArgs),
}

/// `--flow`.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum Flow {
    /// No flow control.
    None,
    /// XON (11H) / XOFF (13H) characters.
    XonXoff,
    /// RTS/CTS handshake lines (RS-232C).
    RtsCts,
    /// Automatic V.24: RTS on before, off after each frame (RS-232C).
    AutoV24,
}

/// `--interface`.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum Iface {
    /// RS-232C.
    Rs232,
    /// RS-422 (full duplex).
    Rs422,
    /// RS-485 (two-wire, half duplex).
    Rs485,
}

/// The driver parameters every ASCII command shares (Table 2-10).
#[derive(Debug, Args)]
pub struct DriverArgs {
    /// End criterion: `delay` (character delay time), `chars HEX[,HEX]` (one or two end-of-text
    /// characters, e.g. `chars 0D,0A`), or `fixed N` (N characters, 1 … the maximum frame).
    #[arg(long, num_args = 1..=2, value_names = ["KIND", "ARG"], default_values = ["delay"])]
    end: Vec<String>,
    /// Character delay time in ms (default: the manual's minimum for the baud rate, ≥ 4 ms).
    #[arg(long, value_name = "MS")]
    char_delay_ms: Option<u32>,
    /// Flow control.
    #[arg(long, value_enum, default_value = "none")]
    flow: Flow,
    /// Interface type.
    #[arg(long, value_enum, default_value = "rs232")]
    interface: Iface,
    /// Wait time for XON or CTS = ON in ms (20 … 655350, 10 ms steps; default 2000).
    #[arg(long, value_name = "MS")]
    flow_wait_ms: Option<u32>,
    /// The module whose maximum frame length applies: `et200s` (ET 200S 1SI, 200 bytes),
    /// `2005` (the 2005 module, 224 bytes) or `cp341` (CP 341, 1024 bytes).
    #[arg(long, value_name = "TYPE", default_value = "et200s", value_parser = module_preset)]
    module: ModulePreset,
    /// Maximum frame length in bytes (1 … 1024), instead of the module's: longer frames are
    /// refused to send (050EH) and dropped on receipt (0850H).
    #[arg(long, value_name = "N")]
    max_frame: Option<u16>,
}

impl DriverArgs {
    fn config(&self, conn: &Connection) -> Result<Config, CliError> {
        let settings = conn.settings()?;
        // RTS/CTS and automatic V.24 drive RTS for flow control; RS-485 direction control
        // drives it (or its file) for the transmitter: the two cannot share it, and RS-485 has
        // no V.24 signals ([ET200S SI] §2.1, Table 2-1: RS-232C only).
        if conn.rs485.is_some() && matches!(self.flow, Flow::RtsCts | Flow::AutoV24) {
            return Err(CliError::usage(
                "--flow rts-cts and auto-v24 need RS-232C: RS-485 has no V.24 signals; leave out --rs485",
            ));
        }
        let end = parse_end(&self.end)?;
        let mut c = Config {
            settings,
            end,
            char_delay: si_core::Duration::from_millis(
                self.char_delay_ms
                    .unwrap_or_else(|| min_char_delay_ms(settings.baud()))
                    .into(),
            ),
            flow_control: match self.flow {
                Flow::None => FlowControl::None,
                Flow::XonXoff => FlowControl::XonXoff,
                Flow::RtsCts => FlowControl::RtsCts,
                Flow::AutoV24 => FlowControl::AutoV24,
            },
            interface: match self.interface {
                Iface::Rs232 => Interface::Rs232,
                Iface::Rs422 => Interface::Rs422,
                Iface::Rs485 => Interface::Rs485,
            },
            ..Config::for_module(self.module)
        };
        if let Some(n) = self.max_frame {
            c.max_frame_len = n;
        }
        if let Some(ms) = self.flow_wait_ms {
            c.xon_xoff.wait_for_xon = si_core::Duration::from_millis(ms.into());
            c.rts_cts.wait_for_cts = si_core::Duration::from_millis(ms.into());
        }
        c.validate().map_err(CliError::bad_argument)?;
        Ok(c)
    }
}

fn parse_end(words: &[String]) -> Result<EndCriterion, CliError> {
    let kind = words.first().map(String::as_str).unwrap_or("delay");
    let arg = words.get(1);
    match (kind, arg) {
        ("delay", None) => Ok(EndCriterion::CharDelay),
        ("chars", Some(hex)) => match parse_hex(hex)?[..] {
            [first] => Ok(EndCriterion::EndChars { first, second: 0 }),
            [first, second] => Ok(EndCriterion::EndChars { first, second }),
            _ => Err(CliError::new(format!(
                "--end chars {hex}: give one or two end-of-text characters, e.g. 03 or 0D,0A"
            ))),
        },
        ("fixed", Some(n)) => n
            .parse::<u16>()
            .map(|len| EndCriterion::FixedLength { len })
            .map_err(|_| CliError::new(format!("--end fixed {n}: not a number of characters"))),
        _ => Err(CliError::new(format!(
            "--end {}: use `delay`, `chars HEX[,HEX]` or `fixed N`",
            words.join(" ")
        ))),
    }
}

/// `si ascii send`.
#[derive(Debug, Args)]
pub struct SendArgs {
    /// The frame, e.g. 48 49 0D 0A.
    #[arg(required_unless_present = "text", conflicts_with = "text", num_args = 1.., value_name = "HEX")]
    hex: Vec<String>,
    /// The frame as text; \r \n \t \\ \0 and \xHH are understood.
    #[arg(long)]
    text: Option<String>,
    #[command(flatten)]
    driver: DriverArgs,
}

/// `si ascii recv`.
#[derive(Debug, Args)]
pub struct RecvArgs {
    /// Stop after this many frames (default: receive until Ctrl-C or the line closes, like
    /// `3964r recv`; a closed line is an error, exit 1).
    #[arg(long)]
    count: Option<u64>,
    /// With --count: give up after this many seconds without the frames, exit 1 (default: wait
    /// for ever).
    #[arg(long, value_name = "SECS", requires = "count")]
    timeout: Option<f64>,
    #[command(flatten)]
    driver: DriverArgs,
}

/// `si ascii monitor`.
#[derive(Debug, Args)]
pub struct MonitorArgs {
    /// Stop after this many frames (default: until interrupted).
    #[arg(long)]
    count: Option<u64>,
    #[command(flatten)]
    driver: DriverArgs,
}

impl Command {
    /// Run it on the line.
    pub async fn run(self, conn: &Connection, out: &Output) -> Result<(), CliError> {
        match self {
            Command::Send(a) => send(a, conn, out).await,
            Command::Recv(a) => recv(a, conn, out).await,
            Command::Monitor(a) => monitor(a, conn, out).await,
        }
    }
}

/// `\r`, `\n`, `\t`, `\\`, `\0` and `\xHH` in `--text`.
fn unescape(text: &str) -> Result<Vec<u8>, CliError> {
    let mut out = Vec::with_capacity(text.len());
    let mut chars = text.chars();
    while let Some(c) = chars.next() {
        if c != '\\' {
            let mut buf = [0u8; 4];
            out.extend_from_slice(c.encode_utf8(&mut buf).as_bytes());
            continue;
        }
        match chars.next() {
            Some('r') => out.push(b'\r'),
            Some('n') => out.push(b'\n'),
            Some('t') => out.push(b'\t'),
            Some('0') => out.push(0),
            Some('\\') => out.push(b'\\'),
            Some('x') => {
                let hex: String = chars.by_ref().take(2).collect();
                let b = u8::from_str_radix(&hex, 16).map_err(|_| {
                    CliError::new(format!("--text: \\x{hex} is not two hex digits"))
                })?;
                out.push(b);
            }
            other => {
                return Err(CliError::new(format!(
                    "--text: unknown escape \\{}; use \\r \\n \\t \\\\ \\0 or \\xHH",
                    other.map(String::from).unwrap_or_default()
                )))
            }
        }
    }
    Ok(out)
}

/// Printable text of a frame, escaped like `--text` takes it.
fn show(bytes: &[u8]) -> String {
    bytes
        .iter()
        .flat_map(|&b| std::ascii::escape_default(b))
        .map(char::from)
        .collect()
}

fn status_error(status: Status) -> CliError {
    CliError::new(si_ascii::status::lookup(status.code()).to_string())
}

fn ascii_error(e: AsciiError) -> CliError {
    match e {
        AsciiError::Failed { status } => status_error(status),
        // A refused send names the STATUS too (1E41H, 050EH, 0502H).
        AsciiError::Refused(e) => CliError::new(format!(
            "{e} ({})",
            si_ascii::status::lookup(e.status().code())
        )),
        other => CliError::new(other.to_string()),
    }
}

/// A receiver's error: the driver stopping is the line closing (named, exit 1), anything
/// else is [`ascii_error`].
fn received_error(e: AsciiError, conn: &Connection) -> CliError {
    match e {
        AsciiError::Stopped => conn.closed(),
        other => ascii_error(other),
    }
}

async fn send(a: SendArgs, conn: &Connection, out: &Output) -> Result<(), CliError> {
    let frame = match (&a.hex, &a.text) {
        (_, Some(text)) => unescape(text)?,
        (hex, None) if !hex.is_empty() => parse_hex_args(hex)?,
        _ => return Err(CliError::usage("give the frame as HEX or --text")),
    };
    let config = a.driver.config(conn)?;
    let port = Handle::spawn(config, conn.open().await?)?;
    port.send(frame.clone()).await.map_err(ascii_error)?;
    out.line(
        &format!(
            "sent {} bytes: {}",
            frame.len(),
            si_core::hex::format(&frame)
        ),
        json!({"sent": si_core::hex::format(&frame), "len": frame.len()}),
    );
    Ok(())
}

fn print_incoming(out: &Output, incoming: &Incoming, with_time: bool) {
    match incoming {
        Incoming::Frame { data, at } => {
            let time = if with_time {
                format!("{:>14}  ", at.to_string())
            } else {
                String::new()
            };
            out.line(
                &format!(
                    "{time}frame {} bytes: {}  \"{}\"",
                    data.len(),
                    si_core::hex::format(data),
                    show(data)
                ),
                json!({"frame": si_core::hex::format(data), "len": data.len(),
                       "text": show(data), "at_us": at.as_micros()}),
            );
        }
        Incoming::Error { status, at } => {
            let status = si_ascii::status::lookup(status.code());
            out.line(
                &format!("{:>14}  receive error {status}", at.to_string()),
                json!({"error": status.code(), "text": status.to_string(), "at_us": at.as_micros()}),
            );
        }
    }
}

async fn recv(a: RecvArgs, conn: &Connection, out: &Output) -> Result<(), CliError> {
    let config = a.driver.config(conn)?;
    let mut port = Handle::spawn(config, conn.open().await?)?;
    let frames = async {
        let mut got = 0;
        while a.count.is_none_or(|n| got < n) {
            let incoming = port
                .recv_timed()
                .await
                .map_err(|e| received_error(e, conn))?;
            print_incoming(out, &incoming, false);
            if matches!(incoming, Incoming::Frame { .. }) {
                got += 1;
            }
        }
        Ok::<_, CliError>(())
    };
    match a.timeout {
        None => frames.await,
        Some(secs) => {
            let limit = std::time::Duration::try_from_secs_f64(secs)
                .map_err(|_| CliError::usage(format!("--timeout {secs}: not a duration")))?;
            tokio::time::timeout(limit, frames).await.map_err(|_| {
                let n = a.count.unwrap_or_default();
                CliError::new(format!("no {n} frame(s) within {secs} s"))
            })?
        }
    }
}

async fn monitor(a: MonitorArgs, conn: &Connection, out: &Output) -> Result<(), CliError> {
    let mut config = a.driver.config(conn)?;
    // A monitor only listens: no XON at startup, no RTS/DTR changes.
    config.flow_control = FlowControl::None;
    let mut port = Handle::spawn(config, conn.open().await?)?;
    let mut got = 0;
    let limit = a.count.unwrap_or(u64::MAX);
    while got < limit {
        let incoming = port
            .recv_timed()
            .await
            .map_err(|e| received_error(e, conn))?;
        print_incoming(out, &incoming, true);
        if matches!(incoming, Incoming::Frame { .. }) {
            got += 1;
        }
    }
    Ok(())
}

/// Scenarios for `si sim`.
pub const SCENARIOS: &[Scenario] = &[
    Scenario {
        name: "ascii",
        about: "ASCII driver: two lines sent as one burst, cut by the end characters CR LF",
        run: scenario_end_chars,
    },
    Scenario {
        name: "ascii-xon-xoff",
        about: "ASCII driver: XOFF stops a fast sender before the receive buffer overflows, XON resumes it",
        run: scenario_xon_xoff,
    },
];

fn read_all(sim: &mut Simulator, b: StationId<Link>) -> Vec<Vec<u8>> {
    let mut frames = Vec::new();
    while let Some(f) = sim.with(b, |l, now| l.read_frame_vec(now)) {
        frames.push(f);
    }
    frames
}

fn scenario_end_chars(o: &SimOptions, out: &Output) -> Result<(), CliError> {
    let config = Config {
        settings: o.settings,
        end: EndCriterion::EndChars {
            first: 0x0D,
            second: 0x0A,
        },
        char_delay: si_ascii::config::min_char_delay(o.settings.baud()),
        ..Config::default()
    };
    let mut sim = Simulator::new(o.seed);
    let a = sim.add_station("A", o.settings, Link::new(config)?);
    let b = sim.add_station("B", o.settings, Link::new(config)?);
    sim.connect(a, b);
    // One burst holding two lines: B cuts after each CR LF.
    sim.with(a, |l, now| l.send(now, "HELLO\r\nSECOND LINE\r\n".into()))?;
    sim.run_until_quiet(Instant::from_micros(60_000_000));
    print_trace(sim.trace(), out);
    for f in read_all(&mut sim, b) {
        out.line(
            &format!("B received {} bytes: \"{}\"", f.len(), show(&f)),
            json!({"station": "B", "frame": si_core::hex::format(&f), "text": show(&f)}),
        );
    }
    Ok(())
}

fn scenario_xon_xoff(o: &SimOptions, out: &Output) -> Result<(), CliError> {
    const FRAMES: u8 = 12;
    let config = Config {
        settings: o.settings,
        end: EndCriterion::FixedLength { len: 100 },
        flow_control: FlowControl::XonXoff,
        char_delay: si_ascii::config::min_char_delay(o.settings.baud()),
        ..Config::default()
    };
    let (xon, xoff) = (config.xon_xoff.xon, config.xon_xoff.xoff);
    let mut sim = Simulator::new(o.seed);
    let a = sim.add_station("A", o.settings, Link::new(config)?);
    let b = sim.add_station("B", o.settings, Link::new(config)?);
    sim.connect(a, b);
    // B's program reads nothing until one second after its buffer came near full (well within
    // A's 2 s wait for XON)…
    let line_time = o.settings.chars_time(100 * u64::from(FRAMES));
    let limit = Instant::ZERO + line_time.saturating_mul(2) + Duration::from_secs(10);
    let mut read_at: Option<Instant> = None;
    let mut next = 0u8;
    let mut frames = Vec::new();
    let mut failures = Vec::new();
    while sim.now() < limit {
        if !sim.engine(a).is_sending() && next < FRAMES {
            let frame = vec![b'A' + next; 100];
            sim.with(a, |l, now| l.send(now, frame.into()))
                .map_err(|e| CliError::new(e.to_string()))?;
            next += 1;
        }
        for e in sim.take_events(a) {
            if let Event::SendFailed { status, .. } = e {
                failures.push(status);
            }
        }
        if read_at.is_none() && sim.engine(b).buffer().free() <= si_ascii::config::XOFF_MARGIN {
            read_at = Some(sim.now() + Duration::from_secs(1));
        }
        // … then everything at once.
        if read_at.is_some_and(|t| sim.now() >= t) {
            frames.extend(read_all(&mut sim, b));
        }
        if sim.is_quiet() && next == FRAMES {
            break;
        }
        sim.run_for(o.settings.char_time());
    }
    frames.extend(read_all(&mut sim, b));
    // The data characters would drown the story: keep flow-control characters and events.
    let flow = |bytes: &[u8]| bytes.len() == 1 && (bytes[0] == xon || bytes[0] == xoff);
    let story = Trace {
        entries: sim
            .trace()
            .entries
            .iter()
            .filter(|e| match &e.kind {
                TraceKind::Tx { bytes } => flow(bytes),
                TraceKind::Rx { byte } => flow(&[*byte]),
                _ => true,
            })
            .cloned()
            .collect(),
    };
    print_trace(&story, out);
    let sent: usize = usize::from(FRAMES) * 100;
    let received: usize = frames.iter().map(Vec::len).sum();
    let intact = frames
        .iter()
        .enumerate()
        .all(|(k, f)| f.len() == 100 && f.iter().all(|&x| usize::from(x) == usize::from(b'A') + k));
    out.line(
        &format!(
            "(data characters omitted) A sent {sent} bytes in {FRAMES} frames; B's program read \
             {} frames, {received} bytes, {} (XON {xon:02X}H, XOFF {xoff:02X}H)",
            frames.len(),
            if intact && received == sent {
                "nothing lost"
            } else {
                "BYTES LOST"
            }
        ),
        json!({"sent": sent, "received": received, "frames": frames.len(), "intact": intact,
               "send_failures": failures.iter().map(|s| s.code()).collect::<Vec<_>>()}),
    );
    if let Some(s) = failures.first() {
        return Err(status_error(*s));
    }
    Ok(())
}
