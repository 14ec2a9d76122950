//! `si 3964r send|recv`, `si frame encode|decode 3964r`, and the 3964(R) scenarios of `si sim`
//! ([ET200S SI] §2.7, [CP 341] §2.2.2, §2.3.1).

mod probe;

use crate::conn::Connection;
use crate::error::CliError;
use crate::output::Output;
use crate::scenario::{print_trace, Scenario, SimOptions};
use clap::{Args, Subcommand, ValueEnum};
use serde_json::json;
use si_3964r::frame::{self, FrameError, Mode};
use si_3964r::tokio::{Error as LinkError, Handle};
use si_3964r::{status, Config, Event, Link, Priority};
use si_core::{Duration, Instant, Status};
use si_sim::{Simulator, StationId};

/// The protocol's subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Does a partner answer STX with DLE at each line setting, and does it insist on sending
    /// (high priority)? One STX per setting; the total time is printed first.
    Probe(probe::ProbeArgs),
    /// Send one block and wait for the partner's acknowledgement (DLE); exits non-zero with the
    /// STATUS when the procedure gives up.
    Send(SendArgs),
    /// Receive blocks and print one per line (hex, or JSON with --json).
    Recv(RecvArgs),
}

/// `si 3964r send`.
#[derive(Debug, Args)]
pub struct SendArgs {
    /// The block, e.g. 41 42 10 43.
    #[arg(required_unless_present = "text", conflicts_with = "text", num_args = 1.., value_name = "HEX")]
    hex: Vec<String>,
    /// The block as text (its UTF-8 bytes) instead of hex.
    #[arg(long)]
    text: Option<String>,
    #[command(flatten)]
    link: LinkArgs,
}

/// `si 3964r recv`.
#[derive(Debug, Args)]
pub struct RecvArgs {
    /// Stop after this many blocks (default: run until interrupted).
    #[arg(long)]
    count: Option<u64>,
    #[command(flatten)]
    link: LinkArgs,
}

/// Priority in an initialization conflict.
#[derive(Debug, Clone, Copy, ValueEnum)]
enum PriorityArg {
    /// Yield: answer the partner's STX with DLE and receive first (the manual's default).
    Low,
    /// Keep waiting for the partner's DLE.
    High,
}

/// The 3964(R) parameters of Table 2-11; anything not given keeps the manual's default.
#[derive(Debug, Clone, Args)]
pub struct LinkArgs {
    /// Priority in an initialization conflict; the two partners must differ.
    #[arg(long, value_enum, default_value = "low")]
    priority: PriorityArg,
    /// Plain 3964: no block check character (QVZ default becomes 550 ms).
    #[arg(long)]
    no_bcc: bool,
    /// Character delay time ZVZ in ms (20 … 655350, default 220).
    #[arg(long, value_name = "MS")]
    char_delay_ms: Option<u64>,
    /// Acknowledgement delay time QVZ in ms (10 … 655350, default 2000, 550 with --no-bcc).
    #[arg(long, value_name = "MS")]
    ack_delay_ms: Option<u64>,
    /// Connection attempts (1 … 255, default 6).
    #[arg(long, value_name = "N")]
    connection_attempts: Option<u64>,
    /// Transmission attempts (1 … 255, default 6).
    #[arg(long, value_name = "N")]
    transmission_attempts: Option<u64>,
}

impl LinkArgs {
    /// The validated configuration; an out-of-range value names parameter, range and value.
    fn config(&self) -> Result<Config, CliError> {
        let mut raw = json!({
            "block_check": !self.no_bcc,
            "priority": match self.priority {
                PriorityArg::Low => "low",
                PriorityArg::High => "high",
            },
        });
        for (key, value) in [
            ("char_delay_ms", self.char_delay_ms),
            ("ack_delay_ms", self.ack_delay_ms),
            ("connection_attempts", self.connection_attempts),
            ("transmission_attempts", self.transmission_attempts),
        ] {
            if let Some(v) = value {
                raw[key] = json!(v);
            }
        }
        serde_json::from_value(raw).map_err(CliError::bad_argument)
    }
}

/// How long a command lets the line settle after opening it: the partner's startup NAK or
/// stale bytes arrive while the link is idle, where they are harmless ([ET200S SI] §2.7, receiving:
/// idle and startup NAK).
const SETTLE: std::time::Duration = std::time::Duration::from_millis(100);

impl Command {
    /// Run it on the line.
    pub async fn run(self, conn: &Connection, out: &Output) -> Result<(), CliError> {
        match self {
            Command::Probe(args) => args.run(conn, out).await,
            Command::Send(args) => args.run(conn, out).await,
            Command::Recv(args) => args.run(conn, out).await,
        }
    }
}

impl SendArgs {
    async fn run(self, conn: &Connection, out: &Output) -> Result<(), CliError> {
        let data = match (&self.hex, &self.text) {
            (_, Some(text)) => text.as_bytes().to_vec(),
            (hex, None) if !hex.is_empty() => crate::hex::parse_hex_args(hex)?,
            _ => return Err(CliError::usage("give the block as HEX or --text")),
        };
        let config = si_3964r::Config {
            settings: conn.settings()?,
            ..self.link.config()?
        };
        let transport = conn.open().await?;
        let link = Handle::spawn(config, transport)?;
        tokio::time::sleep(SETTLE).await;
        let len = data.len();
        match link.send(data).await {
            Ok(()) => {
                out.line(
                    &format!("sent {len} bytes: {}", Status::OK),
                    json!({"sent": len, "status": 0}),
                );
                Ok(())
            }
            Err(LinkError::Failed { status }) => {
                Err(CliError::new(format!("send failed: {}", described(status))))
            }
            Err(e) => Err(e.into()),
        }
    }
}

impl RecvArgs {
    async fn run(self, conn: &Connection, out: &Output) -> Result<(), CliError> {
        let config = si_3964r::Config {
            settings: conn.settings()?,
            ..self.link.config()?
        };
        let transport = conn.open().await?;
        let mut link = Handle::spawn(config, transport)?;
        let mut received = 0u64;
        while self.count.is_none_or(|n| received < n) {
            match link.recv().await {
                Ok(block) => {
                    received += 1;
                    out.line(
                        &si_core::hex::format(&block),
                        json!({
                            "len": block.len(),
                            "hex": si_core::hex::format(&block),
                            "text": String::from_utf8_lossy(&block),
                        }),
                    );
                }
                Err(LinkError::Failed { status }) => {
                    eprintln!("si: receive error {}", described(status));
                }
                Err(LinkError::Stopped) => return Err(conn.closed()),
                Err(e) => return Err(e.into()),
            }
        }
        // Our DLE for the last block is already written; give the port a moment to drain it.
        tokio::time::sleep(SETTLE).await;
        Ok(())
    }
}

/// A STATUS with the manual's text, whichever catalog it comes from.
fn described(status: Status) -> Status {
    if status.is_ok() {
        Status::OK
    } else {
        status::lookup(status.code())
    }
}

/// `si frame encode 3964r`.
#[derive(Debug, Args)]
pub struct EncodeArgs {
    /// Plain 3964: no block check character.
    #[arg(long)]
    no_bcc: bool,
    /// Payload in hex.
    #[arg(required = true, num_args = 1.., value_name = "HEX")]
    hex: Vec<String>,
}

impl EncodeArgs {
    /// Print the block that follows the partner's DLE: stuffed data, DLE ETX, BCC.
    pub fn run(&self, out: &Output) -> Result<(), CliError> {
        let payload = crate::hex::parse_hex_args(&self.hex)?;
        let mode = mode(self.no_bcc);
        let block = frame::encode(&payload, mode);
        let text = si_core::hex::format(&block);
        let bcc = mode.has_bcc().then(|| block[block.len() - 1]);
        out.line(
            &text,
            json!({"block": text, "len": block.len(), "bcc": bcc}),
        );
        Ok(())
    }
}

/// `si frame decode 3964r`.
#[derive(Debug, Args)]
pub struct DecodeArgs {
    /// Plain 3964: no block check character.
    #[arg(long)]
    no_bcc: bool,
    /// Longest payload accepted (the ET 200S limit is 200).
    #[arg(long, default_value_t = 1024)]
    max_len: usize,
    /// The block after the receiver's DLE: data, DLE ETX and (3964R) BCC, in hex.
    #[arg(required = true, num_args = 1.., value_name = "HEX")]
    hex: Vec<String>,
}

impl DecodeArgs {
    /// Print the payload, or fail naming what is wrong (and its STATUS).
    pub fn run(&self, out: &Output) -> Result<(), CliError> {
        let block = crate::hex::parse_hex_args(&self.hex)?;
        match frame::decode(&block, mode(self.no_bcc), self.max_len) {
            Ok(payload) => {
                let text = si_core::hex::format(&payload);
                out.line(&text, json!({"payload": text, "len": payload.len()}));
                Ok(())
            }
            Err(e) => {
                let status = match e {
                    FrameError::OddDle { .. } => Some(status::ODD_DLE),
                    FrameError::Bcc { .. } => Some(status::BCC_ERROR),
                    FrameError::TooLong { .. } => Some(status::BLOCK_TOO_LONG),
                    _ => None,
                };
                Err(CliError::new(match status {
                    Some(s) => format!("{e} (STATUS 16#{:04X})", s.code()),
                    None => e.to_string(),
                }))
            }
        }
    }
}

fn mode(no_bcc: bool) -> Mode {
    if no_bcc {
        Mode::NoBlockCheck
    } else {
        Mode::BlockCheck
    }
}

// --- simulator scenarios ---------------------------------------------------------------------

/// Scenarios for `si sim`.
pub const SCENARIOS: &[Scenario] = &[
    Scenario {
        name: "3964r",
        about: "3964(R): two stations exchange blocks both ways (high and low priority)",
        run: exchange,
    },
    Scenario {
        name: "3964r-conflict",
        about: "3964(R): both send STX at once; the low-priority side yields, then sends",
        run: conflict,
    },
    Scenario {
        name: "3964r-nak-retry",
        about:
            "3964(R): receive buffer full, the partner NAKs after 400 ms, the sender repeats STX",
        run: nak_retry,
    },
    Scenario {
        name: "3964r-bcc-error",
        about: "3964(R): a flipped bit, BCC error, NAK, the block is repeated and accepted",
        run: bcc_error,
    },
    Scenario {
        name: "3964r-timeout",
        about: "3964(R): the partner never answers; six STX, QVZ each, STATUS 16#0703",
        run: timeout,
    },
];

type Station = StationId<Link>;

fn two_links(
    o: &SimOptions,
    a: Config,
    b: Config,
) -> Result<(Simulator, Station, Station), CliError> {
    let line = o.settings;
    let mut sim = Simulator::new(o.seed);
    let sa = sim.add_station("A", line, Link::new(a.with_settings(line))?);
    let sb = sim.add_station("B", line, Link::new(b.with_settings(line))?);
    sim.connect(sa, sb);
    Ok((sim, sa, sb))
}

fn high() -> Config {
    Config {
        priority: Priority::High,
        ..Config::default()
    }
}

fn settle(sim: &mut Simulator) {
    let limit = sim.now() + Duration::from_secs(120);
    sim.run_until_quiet(limit);
}

/// The outcome of the send job in `events`, as a STATUS.
fn send_status(events: &[Event]) -> Option<Status> {
    events.iter().find_map(|e| match e {
        Event::Sent { .. } => Some(Status::OK),
        Event::SendFailed { status, .. } => Some(*status),
        _ => None,
    })
}

fn send(sim: &mut Simulator, s: Station, data: &[u8]) -> Result<(), CliError> {
    let data = bytes::Bytes::copy_from_slice(data);
    sim.with(s, |l, now| l.send(now, data))?;
    Ok(())
}

fn take(sim: &mut Simulator, s: Station) -> Vec<u8> {
    sim.with(s, |l, now| l.take_block(now))
        .map(|b| b.to_vec())
        .unwrap_or_default()
}

/// Print one station's result: what its send job ended with and what it received.
fn result_line(out: &Output, name: &str, events: &[Event], received: &[Vec<u8>]) {
    let status = send_status(events);
    // Repeated errors are shown once with their count.
    let mut errors: Vec<(Status, usize)> = Vec::new();
    for e in events {
        if let Event::ReceiveError(s) = e {
            match errors.iter_mut().find(|(x, _)| x == s) {
                Some((_, n)) => *n += 1,
                None => errors.push((*s, 1)),
            }
        }
    }
    let errors: Vec<String> = errors
        .into_iter()
        .map(|(s, n)| match n {
            1 => described(s).to_string(),
            n => format!("{n} × {}", described(s)),
        })
        .collect();
    let received_text: Vec<String> = received
        .iter()
        .map(|b| format!("{:?}", String::from_utf8_lossy(b)))
        .collect();
    let mut text = format!("{name}: ");
    match status {
        Some(s) => text.push_str(&format!("send {}", described(s))),
        None => text.push_str("no send job"),
    }
    if !received_text.is_empty() {
        text.push_str(&format!("; received {}", received_text.join(", ")));
    }
    if !errors.is_empty() {
        text.push_str(&format!("; receive errors {}", errors.join(", ")));
    }
    out.line(
        &text,
        json!({
            "station": name,
            "status": status.map(Status::code),
            "received": received.iter().map(|b| si_core::hex::format(b)).collect::<Vec<_>>(),
            "receive_errors": events.iter().filter_map(|e| match e {
                Event::ReceiveError(s) => Some(s.code()),
                _ => None,
            }).collect::<Vec<_>>(),
        }),
    );
}

fn finish(sim: &mut Simulator, a: Station, b: Station, out: &Output) {
    print_trace(sim.trace(), out);
    for (name, s) in [("A", a), ("B", b)] {
        let events = sim.take_events(s);
        let mut received = Vec::new();
        while let Some(block) = sim.with(s, |l, now| l.take_block(now)) {
            received.push(block.to_vec());
        }
        result_line(out, name, &events, &received);
    }
}

fn exchange(o: &SimOptions, out: &Output) -> Result<(), CliError> {
    let (mut sim, a, b) = two_links(o, high(), Config::default())?;
    send(&mut sim, a, b"temperature?\x10")?;
    sim.run_for(Duration::from_millis(100));
    send(&mut sim, b, b"21.5 C")?;
    settle(&mut sim);
    finish(&mut sim, a, b, out);
    Ok(())
}

fn conflict(o: &SimOptions, out: &Output) -> Result<(), CliError> {
    let (mut sim, a, b) = two_links(o, high(), Config::default())?;
    send(&mut sim, a, b"from A (high)")?;
    send(&mut sim, b, b"from B (low)")?;
    settle(&mut sim);
    finish(&mut sim, a, b, out);
    Ok(())
}

fn nak_retry(o: &SimOptions, out: &Output) -> Result<(), CliError> {
    let b_config = Config {
        receive_buffer_blocks: 1,
        ..Config::default()
    };
    let (mut sim, a, b) = two_links(o, high(), b_config)?;
    // B's application does not take the first block: its one-block buffer is full.
    send(&mut sim, a, b"first")?;
    sim.run_for(Duration::from_millis(100));
    let _first_job = sim.take_events(a);
    send(&mut sim, a, b"second")?;
    // B waits 400 ms for a free buffer, then NAKs (080A); A repeats its STX (0702).
    sim.run_for(Duration::from_millis(600));
    let first = take(&mut sim, b); // now B's application takes the first block
    settle(&mut sim);
    print_trace(sim.trace(), out);
    let a_events = sim.take_events(a);
    let b_events = sim.take_events(b);
    result_line(out, "A", &a_events, &[]);
    let mut received = vec![first];
    received.push(take(&mut sim, b));
    result_line(out, "B", &b_events, &received);
    Ok(())
}

fn bcc_error(o: &SimOptions, out: &Output) -> Result<(), CliError> {
    let (mut sim, a, b) = two_links(o, high(), Config::default())?;
    // B receives A's startup NAK (0), STX (1), then the block: flip a bit of its 3rd byte.
    sim.corrupt_received(b, 4, 0x08);
    send(&mut sim, a, b"setpoint=42")?;
    settle(&mut sim);
    finish(&mut sim, a, b, out);
    Ok(())
}

fn timeout(o: &SimOptions, out: &Output) -> Result<(), CliError> {
    let (mut sim, a, b) = two_links(o, high(), Config::default())?;
    sim.silence(b, Instant::ZERO);
    send(&mut sim, a, b"anyone there?")?;
    settle(&mut sim);
    finish(&mut sim, a, b, out);
    Ok(())
}
