//! `si rk512 send|fetch|serve`, `si frame decode rk512`, and the RK 512 scenarios of `si sim`
//! ([CP 341] §2.2.3, §2.3.2, [Public RK 512]).

use crate::conn::Connection;
use crate::error::CliError;
use crate::output::Output;
use crate::scenario::{print_trace, Scenario, SimOptions};
use clap::{Args, Subcommand, ValueEnum};
use serde::Deserialize;
use serde_json::json;
use si_3964r::Priority;
use si_core::memory::{Area, MemorySizes};
use si_core::{Duration, Instant, Status};
use si_rk512::frame::{Address, Coordination, Telegram};
use si_rk512::passive::ServerConfig;
use si_rk512::status;
use si_rk512::tokio::{Error as StationError, Handle};
use si_rk512::{Config, CounterLetter, DwUnit, Event, Station};
use si_sim::{Simulator, StationId};
use std::collections::BTreeMap;
use std::path::PathBuf;

/// The protocol's subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// SEND data to the partner's DB (or DX) and wait for its reaction; exits non-zero with the
    /// STATUS when the job fails.
    Send(SendArgs),
    /// FETCH data from the partner's memory and print them in hex.
    Fetch(FetchArgs),
    /// Be the passive partner: serve SEND and FETCH jobs from a simulated CPU memory.
    Serve(ServeArgs),
}

/// Which memory area a job addresses (the header's data type letter).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum AreaArg {
    /// Data block 'D' (--db, --dw; counts words).
    Db,
    /// Extended data block 'X' (--db, --dw; counts words).
    Dx,
    /// Input bytes 'E' (--start; counts bytes).
    I,
    /// Output bytes 'A' (--start; counts bytes).
    Q,
    /// Flag bytes 'M' (--start; counts bytes).
    M,
    /// Timer cells 'T' (--start; counts words).
    T,
    /// Counter cells 'Z' (--start; counts words).
    C,
}

/// Where a job's data live at the partner, and its coordination flag.
#[derive(Debug, Clone, Args)]
pub struct Target {
    /// Memory area.
    #[arg(long, value_enum, default_value = "db")]
    area: AreaArg,
    /// DB (or DX) number, 0 … 255; required with --area db (the default) and dx, so a job
    /// never lands in a DB the user did not name.
    #[arg(long)]
    db: Option<u8>,
    /// Start data word of the DB/DX, 0 … 255 (header byte 6).
    #[arg(long, default_value_t = 0)]
    dw: u8,
    /// Start byte (I, Q, M) or cell number (T, C), 0 … 65535.
    #[arg(long, default_value_t = 0)]
    start: u16,
    /// Coordination flag at the partner, as BYTE.BIT (e.g. 20.3); a SEND or FETCH is refused
    /// while it is set (16#0909) and sets it when served ([CP 341] §2.2.3).
    #[arg(long, value_name = "BYTE.BIT")]
    flag: Option<String>,
    /// CPU number 1 … 4 in header byte 10 (multi-CPU partners).
    #[arg(long)]
    cpu: Option<u8>,
}

impl Target {
    /// The partner address, or a usage error when a DB or DX job names no --db.
    fn address(&self) -> Result<Address, CliError> {
        let db = || {
            self.db.ok_or_else(|| {
                CliError::usage("--db N is required with --area db or dx (the data block to use)")
            })
        };
        Ok(match self.area {
            AreaArg::Db => Address::Db {
                db: db()?,
                dw: self.dw,
            },
            AreaArg::Dx => Address::Dx {
                db: db()?,
                dw: self.dw,
            },
            AreaArg::I => Address::Inputs(self.start),
            AreaArg::Q => Address::Outputs(self.start),
            AreaArg::M => Address::Flags(self.start),
            AreaArg::T => Address::Timers(self.start),
            AreaArg::C => Address::Counters(self.start),
        })
    }

    fn coordination(&self) -> Result<Coordination, CliError> {
        Coordination::parse(self.flag.as_deref(), self.cpu)
            .map_err(|e| CliError::usage(format!("--{e}")))
    }
}

/// Priority in a 3964(R) initialization conflict.
#[derive(Debug, Clone, Copy, ValueEnum)]
enum PriorityArg {
    /// Yield to the partner's STX.
    Low,
    /// Keep waiting for the partner's DLE.
    High,
}

/// The RK 512 and 3964(R) parameters; anything not given keeps the manual's default.
#[derive(Debug, Clone, Args)]
pub struct LinkArgs {
    /// 3964(R) priority; the two partners must differ. Default: high for send/fetch, low for
    /// serve.
    #[arg(long, value_enum)]
    priority: Option<PriorityArg>,
    /// Plain 3964: no block check character.
    #[arg(long)]
    no_bcc: bool,
    /// Response monitoring time TRES in ms (10 … 655350, default 10000).
    #[arg(long, value_name = "MS")]
    response_timeout_ms: Option<u32>,
    /// Acknowledgement delay time QVZ in ms (3964(R); default 2000, 550 with --no-bcc).
    #[arg(long, value_name = "MS")]
    ack_delay_ms: Option<u32>,
    /// Header byte 6 is a byte offset rather than a data-word number (some non-Siemens
    /// partners; [Public RK 512]).
    #[arg(long)]
    dw_bytes: bool,
    /// Letter for counters in our telegrams: z (5AH, default) or c (43H) ([CP 341] `[derived]`).
    #[arg(long, value_enum, default_value = "z")]
    counter_letter: CounterArg,
}

/// The counter letter ([CP 341] `[derived]`).
#[derive(Debug, Clone, Copy, ValueEnum)]
enum CounterArg {
    /// 'Z' (5AH).
    Z,
    /// 'C' (43H).
    C,
}

impl LinkArgs {
    fn config(&self, default_priority: Priority) -> Result<Config, CliError> {
        let mut c = Config::default();
        if self.no_bcc {
            c.link = si_3964r::Config::without_block_check();
        }
        c.link.priority = match self.priority {
            None => default_priority,
            Some(PriorityArg::Low) => Priority::Low,
            Some(PriorityArg::High) => Priority::High,
        };
        if let Some(q) = self.ack_delay_ms {
            c.link.ack_delay = si_core::Duration::from_millis(q.into());
        }
        if let Some(t) = self.response_timeout_ms {
            c.response_timeout = si_core::Duration::from_millis(t.into());
        }
        if self.dw_bytes {
            c.dw_unit = DwUnit::Bytes;
        }
        c.counter_letter = match self.counter_letter {
            CounterArg::Z => CounterLetter::Z,
            CounterArg::C => CounterLetter::C,
        };
        c.validate().map_err(CliError::bad_argument)?;
        Ok(c)
    }
}

/// `si rk512 send`.
#[derive(Debug, Args)]
pub struct SendArgs {
    #[command(flatten)]
    target: Target,
    #[command(flatten)]
    link: LinkArgs,
    /// The data (an even number of bytes: SEND counts data words).
    #[arg(required = true, num_args = 1.., value_name = "HEX")]
    hex: Vec<String>,
}

/// `si rk512 fetch`.
#[derive(Debug, Args)]
pub struct FetchArgs {
    #[command(flatten)]
    target: Target,
    #[command(flatten)]
    link: LinkArgs,
    /// How much to fetch, in the area's unit: data words for DB/DX/T/C, bytes for I/Q/M.
    #[arg(long)]
    count: usize,
}

/// `si rk512 serve`.
#[derive(Debug, Args)]
pub struct ServeArgs {
    /// TOML file with memory sizes (see `ServeFile`); default: I, Q 128 bytes, M 2048, T and C
    /// 256 cells, DB1 … DB16 of 512 bytes each.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Stop after this many jobs, served or refused (default: run until interrupted).
    #[arg(long)]
    count: Option<u64>,
    #[command(flatten)]
    link: LinkArgs,
}

/// How long a command lets the line settle after opening it (the partner's startup NAK).
const SETTLE: std::time::Duration = std::time::Duration::from_millis(100);

impl Command {
    /// Run it on the line.
    pub async fn run(self, conn: &Connection, out: &Output) -> Result<(), CliError> {
        match self {
            Command::Send(args) => args.run(conn, out).await,
            Command::Fetch(args) => args.run(conn, out).await,
            Command::Serve(args) => args.run(conn, out).await,
        }
    }
}

/// Start the job on an offline station first: what the station refuses before sending
/// (1E41H for a length outside 1 … `max_job_len` or odd for a word type, 0515H, 0516H) is a
/// usage error naming the limit and the value, and no port is opened (1E41 names
/// the limit it broke).
fn refused_offline(
    config: Config,
    settings: si_core::SerialSettings,
    start: impl FnOnce(&mut Station) -> Result<si_rk512::JobId, si_rk512::RequestError>,
) -> Result<(), CliError> {
    let mut probe = Station::new(config.with_settings(settings))?;
    match start(&mut probe) {
        Ok(_) => Ok(()),
        Err(e) => Err(CliError::usage(format!(
            "{}: {e}",
            status::lookup(e.status().code())
        ))),
    }
}

/// The job's STATUS; a 051A names the 3964(R) error reported just before it
/// ([CP 341 Diag] "chained reports"), on the same line.
async fn failed(station: &Handle, what: &str, e: StationError) -> CliError {
    let Some(s) = e.status() else {
        return CliError::new(format!("{what} failed: {e}"));
    };
    let s = status::lookup(s.code());
    let cause = if s == status::COMMAND_NOT_SENT {
        station.call(|st, _| st.last_cause()).await.ok().flatten()
    } else {
        None
    };
    match cause {
        Some(c) => CliError::new(format!(
            "{what} failed: {}, then {s}",
            status::lookup(c.code())
        )),
        None => CliError::new(format!("{what} failed: {s}")),
    }
}

impl SendArgs {
    async fn run(self, conn: &Connection, out: &Output) -> Result<(), CliError> {
        let data = crate::hex::parse_hex_args(&self.hex)?;
        let address = self.target.address()?;
        let coordination = self.target.coordination()?;
        let config = self.link.config(Priority::High)?;
        let settings = conn.settings()?;
        refused_offline(config, settings, |s| {
            s.send(Instant::ZERO, address, coordination, data.clone())
        })?;
        let transport = conn.open().await?;
        let mut config = config;
        config.link.settings = settings;
        let station = Handle::spawn(config, transport)?;
        tokio::time::sleep(SETTLE).await;
        let len = data.len();
        if let Err(e) = station.send(address, coordination, data).await {
            return Err(failed(&station, "SEND", e).await);
        }
        out.line(
            &format!("SEND {len} bytes to {address}: {}", Status::OK),
            json!({"sent": len, "address": address.to_string(), "status": 0}),
        );
        // Our DLE for the reaction is written; let the port drain it.
        tokio::time::sleep(SETTLE).await;
        Ok(())
    }
}

impl FetchArgs {
    async fn run(self, conn: &Connection, out: &Output) -> Result<(), CliError> {
        let address = self.target.address()?;
        let coordination = self.target.coordination()?;
        let len = if address.data_type().counts_words() {
            self.count.saturating_mul(2)
        } else {
            self.count
        };
        let config = self.link.config(Priority::High)?;
        let settings = conn.settings()?;
        refused_offline(config, settings, |s| {
            s.fetch(Instant::ZERO, address, coordination, len)
        })?;
        let transport = conn.open().await?;
        let mut config = config;
        config.link.settings = settings;
        let station = Handle::spawn(config, transport)?;
        tokio::time::sleep(SETTLE).await;
        let data = match station.fetch(address, coordination, len).await {
            Ok(data) => data,
            Err(e) => return Err(failed(&station, "FETCH", e).await),
        };
        let hex = si_core::hex::format(&data);
        out.line(
            &hex,
            json!({"address": address.to_string(), "len": data.len(), "hex": hex}),
        );
        tokio::time::sleep(SETTLE).await;
        Ok(())
    }
}

/// The `si rk512 serve --config` file.
///
/// ```toml
/// accept_send = true
/// accept_fetch = true
/// [memory]          # I, Q, M in bytes; T, C in cells
/// flags = 2048
/// [[db]]
/// number = 10
/// length = 512
/// [[dx]]
/// number = 3
/// length = 64
/// ```
#[derive(Debug, Deserialize)]
#[serde(default, deny_unknown_fields)]
struct ServeFile {
    accept_send: bool,
    accept_fetch: bool,
    memory: AreaSizes,
    db: Vec<BlockFile>,
    dx: Vec<BlockFile>,
}

impl Default for ServeFile {
    fn default() -> Self {
        ServeFile {
            accept_send: true,
            accept_fetch: true,
            memory: AreaSizes::default(),
            db: (1..=16)
                .map(|number| BlockFile {
                    number,
                    length: 512,
                })
                .collect(),
            dx: Vec::new(),
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(default, deny_unknown_fields)]
struct AreaSizes {
    inputs: u32,
    outputs: u32,
    flags: u32,
    timers: u32,
    counters: u32,
}

impl Default for AreaSizes {
    fn default() -> Self {
        let d = MemorySizes::default();
        AreaSizes {
            inputs: d.inputs,
            outputs: d.outputs,
            flags: d.flags,
            timers: d.timers,
            counters: d.counters,
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct BlockFile {
    number: u16,
    length: u32,
}

/// Largest area a config file may ask for, so a typo cannot exhaust memory.
const MAX_AREA: u32 = 1 << 20;

impl ServeFile {
    fn server_config(&self) -> Result<ServerConfig, CliError> {
        let m = &self.memory;
        for (name, v) in [
            ("memory.inputs", m.inputs),
            ("memory.outputs", m.outputs),
            ("memory.flags", m.flags),
            ("memory.timers", m.timers),
            ("memory.counters", m.counters),
        ]
        .into_iter()
        .chain(self.db.iter().map(|b| ("db length", b.length)))
        .chain(self.dx.iter().map(|b| ("dx length", b.length)))
        {
            if v > MAX_AREA {
                return Err(CliError::new(format!(
                    "{name} must be 0 … {MAX_AREA}, got {v}"
                )));
            }
        }
        let blocks = |v: &[BlockFile]| -> BTreeMap<u16, u32> {
            v.iter().map(|b| (b.number, b.length)).collect()
        };
        let memory = MemorySizes {
            inputs: m.inputs,
            outputs: m.outputs,
            flags: m.flags,
            timers: m.timers,
            counters: m.counters,
            dbs: blocks(&self.db),
        };
        // Each area is capped above, and all of them together (DX blocks included) at the
        // SIMATIC memory's host limit, so many blocks cannot add up to gigabytes either.
        let dx_bytes: u64 = self.dx.iter().map(|b| u64::from(b.length)).sum();
        si_core::RangeError::check(
            "memory in all areas",
            (0, si_core::memory::MAX_TOTAL_BYTES),
            " bytes",
            memory.total_bytes() + dx_bytes,
        )?;
        Ok(ServerConfig {
            memory,
            dx: blocks(&self.dx),
            accept_send: self.accept_send,
            accept_fetch: self.accept_fetch,
        })
    }
}

impl ServeArgs {
    async fn run(self, conn: &Connection, out: &Output) -> Result<(), CliError> {
        let file = match &self.config {
            None => ServeFile::default(),
            Some(path) => crate::config_file::read_toml(path)?,
        };
        let server = file.server_config()?;
        let config = self.link.config(Priority::Low)?;
        let settings = conn.settings()?;
        let transport = conn.open().await?;
        let station = Station::serving(config.with_settings(settings), &server)?;
        let mut station = Handle::spawn_engine(station, transport);
        let mut served = 0u64;
        while self.count.is_none_or(|n| served < n) {
            match station.next_event().await {
                Some(Event::Served {
                    command,
                    address,
                    len,
                }) => {
                    served += 1;
                    let what = if command.is_send() { "SEND" } else { "FETCH" };
                    out.line(
                        &format!("served {what} {address}, {len} bytes"),
                        json!({"served": what, "address": address.to_string(), "len": len}),
                    );
                }
                Some(Event::Refused { error }) => {
                    served += 1;
                    let s = error.status();
                    let number = error.error_number().code();
                    out.line(
                        &format!("refused with error number {number:02X}H: {s}"),
                        json!({"refused": number, "status": s.code()}),
                    );
                }
                Some(
                    Event::ServeAborted(s) | Event::ReceiveError(s) | Event::ProcedureError(s),
                ) => {
                    eprintln!("si: {}", status::lookup(s.code()));
                }
                Some(Event::Done { .. } | Event::Failed { .. }) => {}
                None => return Err(conn.closed()),
            }
        }
        // Our last reaction is queued; give it time to go out and be acknowledged.
        tokio::time::sleep(SETTLE * 5).await;
        Ok(())
    }
}

/// `si frame decode rk512`.
#[derive(Debug, Args)]
pub struct DecodeArgs {
    /// A command, continuation or reaction telegram in hex (the 3964(R) payload), with or
    /// without its data.
    #[arg(required = true, num_args = 1.., value_name = "HEX")]
    hex: Vec<String>,
}

impl DecodeArgs {
    /// Print the header fields (and the data, if any); fail naming offset, expected and found.
    pub fn run(&self, out: &Output) -> Result<(), CliError> {
        let bytes = crate::hex::parse_hex_args(&self.hex)?;
        let telegram = Telegram::decode(&bytes).map_err(|e| CliError::new(e.to_string()))?;
        let (text, value, data) = match telegram {
            Telegram::Command(h, data) => {
                let letter = h.command.letter() as char;
                let unit = if h.address.data_type().counts_words() {
                    "words"
                } else {
                    "bytes"
                };
                let c = h.coordination;
                let flag = match c.flag_address() {
                    Some((b, bit)) => format!("flag M{b}.{bit}"),
                    None => "no coordination flag".to_owned(),
                };
                let cpu = match c.cpu {
                    1..=4 => format!("CPU {}", c.cpu),
                    _ => "no CPU number".to_owned(),
                };
                (
                    format!(
                        "command telegram: {} ('{letter}') {} {} ('{}'), {} {unit} ({} bytes), {flag}, {cpu}",
                        h.command.name(),
                        h.address,
                        h.address.data_type().name(),
                        h.address.data_type().letter() as char,
                        h.length,
                        h.data_len(),
                    ),
                    json!({
                        "telegram": "command",
                        "job": h.command.name(),
                        "command": letter.to_string(),
                        "data_type": (h.address.data_type().letter() as char).to_string(),
                        "address": h.address.to_string(),
                        "length": h.length,
                        "bytes": h.data_len(),
                        "flag_byte": c.flag_byte,
                        "flag_bit": c.flag_bit,
                        "cpu": c.cpu,
                    }),
                    data,
                )
            }
            Telegram::Continuation(h, data) => (
                format!(
                    "continuation command telegram: {} ('{}') {} ('{}')",
                    h.command.name(),
                    h.command.letter() as char,
                    h.data_type.name(),
                    h.data_type.letter() as char,
                ),
                json!({
                    "telegram": "continuation",
                    "job": h.command.name(),
                    "command": (h.command.letter() as char).to_string(),
                    "data_type": (h.data_type.letter() as char).to_string(),
                }),
                data,
            ),
            Telegram::Reaction(h, data) => {
                let kind = if h.continuation {
                    "continuation reaction telegram"
                } else {
                    "reaction telegram"
                };
                let meaning = match status::for_error_byte(h.error) {
                    None => "no error".to_owned(),
                    Some(s) => status::lookup(s.code()).to_string(),
                };
                (
                    format!("{kind}: error number {:02X}H ({meaning})", h.error),
                    json!({
                        "telegram": if h.continuation { "continuation_reaction" } else { "reaction" },
                        "error": h.error,
                        "status": status::for_error_byte(h.error).map(Status::code),
                    }),
                    data,
                )
            }
        };
        let mut value = value;
        value["data"] = json!(si_core::hex::format(data));
        value["data_len"] = json!(data.len());
        let text = if data.is_empty() {
            text
        } else {
            format!(
                "{text}; {} data bytes: {}",
                data.len(),
                si_core::hex::format(data)
            )
        };
        out.line(&text, value);
        Ok(())
    }
}

// --- simulator scenarios ---------------------------------------------------------------------

/// Scenarios for `si sim`.
pub const SCENARIOS: &[Scenario] = &[
    Scenario {
        name: "rk512",
        about: "RK 512: a host SENDs 300 bytes to DB10 of a PLC, then FETCHes them back",
        run: send_then_fetch,
    },
    Scenario {
        name: "rk512-locked",
        about: "RK 512: a SEND with coordination flag M20.3; the second SEND is refused (16#0909)",
        run: locked,
    },
];

type St = StationId<Station>;

fn stations(o: &SimOptions) -> Result<(Simulator, St, St), CliError> {
    let line = o.settings;
    let mut host = Config::default();
    host.link.priority = Priority::High;
    let mut memory = ServerConfig::default();
    memory.memory.dbs.insert(10, 512);
    let mut sim = Simulator::new(o.seed);
    let a = sim.add_station("host", line, Station::new(host.with_settings(line))?);
    let b = sim.add_station(
        "PLC",
        line,
        Station::serving(Config::default().with_settings(line), &memory)?,
    );
    sim.connect(a, b);
    Ok((sim, a, b))
}

/// Run until the host's job has ended and the line is idle (not until stale timers of ended
/// jobs would fire, which only stretches the trace).
fn settle(sim: &mut Simulator, host: St) {
    for _ in 0..2400 {
        if !sim.engine(host).is_busy() {
            break;
        }
        sim.run_for(Duration::from_millis(50));
    }
    sim.run_for(Duration::from_millis(50));
}

fn report(out: &Output, name: &str, events: Vec<Event>) {
    for e in events {
        let (text, value) = match e {
            Event::Done { job, data } if data.is_empty() => (
                format!("{name}: {job} done: {}", Status::OK),
                json!({"station": name, "job": job.0, "status": 0}),
            ),
            Event::Done { job, data } => (
                format!(
                    "{name}: {job} done: {} bytes {}",
                    data.len(),
                    si_core::hex::format(&data)
                ),
                json!({"station": name, "job": job.0, "status": 0, "data": si_core::hex::format(&data)}),
            ),
            Event::Failed { job, status: s } => (
                format!("{name}: {job} failed: {}", status::lookup(s.code())),
                json!({"station": name, "job": job.0, "status": s.code()}),
            ),
            Event::Served {
                command,
                address,
                len,
            } => (
                format!("{name}: served {} {address}, {len} bytes", command.name()),
                json!({"station": name, "served": command.name(), "address": address.to_string(), "len": len}),
            ),
            Event::Refused { error } => (
                format!(
                    "{name}: refused with error number {:02X}H ({})",
                    error.error_number().code(),
                    error.status()
                ),
                json!({"station": name, "refused": error.error_number().code(), "status": error.status().code()}),
            ),
            Event::ServeAborted(s) | Event::ReceiveError(s) | Event::ProcedureError(s) => (
                format!("{name}: {}", status::lookup(s.code())),
                json!({"station": name, "error": s.code()}),
            ),
        };
        out.line(&text, value);
    }
}

fn send_then_fetch(o: &SimOptions, out: &Output) -> Result<(), CliError> {
    let (mut sim, host, plc) = stations(o)?;
    let data: Vec<u8> = (0..300u16).map(|i| (i % 251) as u8).collect();
    let at = Address::Db { db: 10, dw: 0 };
    sim.with(host, |s, now| s.send(now, at, Coordination::NONE, data))?;
    settle(&mut sim, host);
    sim.with(host, |s, now| s.fetch(now, at, Coordination::NONE, 300))?;
    settle(&mut sim, host);
    print_trace(sim.trace(), out);
    report(out, "host", sim.take_events(host));
    report(out, "PLC", sim.take_events(plc));
    Ok(())
}

fn locked(o: &SimOptions, out: &Output) -> Result<(), CliError> {
    let (mut sim, host, plc) = stations(o)?;
    let at = Address::Db { db: 10, dw: 0 };
    let km = Coordination::flag(20, 3);
    sim.with(host, |s, now| s.send(now, at, km, vec![0x12, 0x34]))?;
    settle(&mut sim, host);
    sim.with(host, |s, now| s.send(now, at, km, vec![0x56, 0x78]))?;
    settle(&mut sim, host);
    print_trace(sim.trace(), out);
    report(out, "host", sim.take_events(host));
    report(out, "PLC", sim.take_events(plc));
    let flag = sim
        .engine(plc)
        .server()
        .memory()
        .bit(Area::Flags, 20, 3)
        .unwrap_or(false);
    out.line(
        &format!("PLC: M20.3 = {}", u8::from(flag)),
        json!({"station": "PLC", "flag": "M20.3", "value": flag}),
    );
    Ok(())
}
