//! `si modbus`: Modbus RTU master jobs, a slave serving simulated SIMATIC memory, offline
//! frames, and simulator scenarios ([Modbus/USS] §3.3–§3.5).
//!
//! The master's jobs run on the serial line or to a Modbus TCP server (`--modbus-tcp`,
//! [`tcp`]), once or as a poll over one or several units ([`poll`]), with
//! addresses in the user's numbering ([`address`]), registers shown in the user's format
//! ([`format`](mod@format)) and one stamped line per outcome ([`report`](mod@report)).

mod address;
mod explain;
mod format;
mod poll;
mod report;
mod scan;
mod tcp;

use address::{parse_u16, parse_unit, AddressArgs};
use clap::builder::{PossibleValuesParser, TypedValueParser};
use explain::{failure, status_text};
use poll::PollArgs;
use report::Report;
use si_modbus::values::{ValueFormat, WordOrder};

mod serve_map;

use crate::conn::Connection;
use crate::error::CliError;
use crate::output::Output;
use crate::scenario::{print_trace, Scenario, SimOptions};
use clap::{Args, Subcommand, ValueEnum};
use serde::Deserialize;
use serde_json::json;
use si_core::memory::{Memory, MemorySizes};
use si_core::v24::AutoV24Times;
use si_core::{Duration, Instant, SerialSettings};
use si_modbus::frame::{self, Request};
use si_modbus::master::{Master, MasterEvent};
use si_modbus::slave::{Slave, SlaveEvent};
use si_modbus::tokio as handle;
use si_modbus::{ConversionDb, FrameEnd, MasterConfig, Mode, SimaticStore, SlaveConfig};
use si_sim::Simulator;

/// Master parameters every job shares (Table 3-17).
#[derive(Debug, Clone, Args)]
pub struct MasterOptions {
    /// Slave address 1–255, 0 = broadcast (FC05/06/15/16 only); several as `1,2,5` or
    /// repeated `--unit`, asked in turn, each line labelled with its unit ([Modbus/USS] §3.3.2).
    #[arg(long = "unit", short = 'u', required = true, value_delimiter = ',',
          value_name = "UNIT", value_parser = parse_unit)]
    units: Vec<u8>,
    /// Response time in ms (50–655000): the wait for the start of the response (the
    /// config's `response_timeout`, `response_timeout_ms` in files).
    #[arg(
        long = "response-timeout-ms",
        value_name = "MS",
        default_value_t = 2000
    )]
    timeout: u32,
    /// Extension: send again this many times after a timeout or CRC error.
    #[arg(long, default_value_t = 0)]
    retries: u8,
    #[command(flatten)]
    framing: FramingOptions,
    #[command(flatten)]
    modbus_tcp: tcp::ModbusTcp,
    /// Start each text line with the wall-clock time (RFC 3339, UTC, milliseconds); JSON
    /// lines always carry it as `timestamp`.
    #[arg(long)]
    timestamps: bool,
}

/// How received frames are recognised ([Modbus/USS] §3.3.5, Table 3-11, §3.4.3, §3.5.4): the same
/// flags on the master's jobs and on `serve`, so whatever framing `si modbus read` can use, the
/// slave side can too.
#[derive(Debug, Clone, Args)]
pub struct FramingOptions {
    /// Operating mode (`serve`: overridden by the config file's `mode`): normal reports
    /// transmission errors, interference-suppression ignores corrupt frames and skips garbage
    /// before the address.
    #[arg(long, default_value = "normal", value_parser = PossibleValuesParser::new(Mode::NAMES.map(|(n, _)| n))
        .try_map(|s| s.parse::<Mode>()))]
    mode: Mode,
    /// Character delay multiplier 1–10: end-of-frame gap = table value × this (`serve`:
    /// overridden by the config file's `char_delay_multiplier`).
    #[arg(long, default_value_t = 1)]
    char_delay_multiplier: u8,
    /// How a received frame ends: at the end-of-frame gap as the module does, or (host
    /// extension) also as soon as it has its predicted length and a good CRC, so the master
    /// completes (and the slave answers) without waiting for the gap (`serve`: overridden by
    /// the config file's `frame_end`): gap ([Modbus/USS] §3.3.5, Table 3-11) or length.
    #[arg(long, default_value = "gap", value_parser = PossibleValuesParser::new(FrameEnd::NAMES)
        .try_map(|s| s.parse::<FrameEnd>()))]
    frame_end: FrameEnd,
    /// Data flow control "automatic use of the V.24 signals" ([Modbus/USS] §3.2.2; RS-232C only):
    /// RTS on before each frame, send once CTS is on, RTS off after it. Default: none.
    #[arg(long)]
    auto_v24: bool,
    /// With --auto-v24: time from the last byte sent until RTS off, 0–655350 ms in 10 ms steps
    /// (default 10).
    #[arg(long, value_name = "MS", requires = "auto_v24")]
    rts_off_ms: Option<u32>,
    /// With --auto-v24: the wait for CTS on after RTS on, 0–655350 ms in 10 ms steps
    /// (default 10).
    #[arg(long, value_name = "MS", requires = "auto_v24")]
    data_wait_ms: Option<u32>,
}

impl FramingOptions {
    /// The automatic V.24 times, when `--auto-v24` is given (ranges checked with the config).
    /// RS-485 has no V.24 signals ([Modbus/USS] §3.2.2: "none possible on RS-485"): a usage error.
    fn auto_v24(&self, conn: &Connection) -> Result<Option<AutoV24Times>, CliError> {
        if !self.auto_v24 {
            return Ok(None);
        }
        if conn.rs485.is_some() {
            return Err(CliError::usage(
                "--auto-v24 needs RS-232C: RS-485 has no V.24 signals ([Modbus/USS] §3.2.2); leave out --rs485",
            ));
        }
        let d = AutoV24Times::default();
        Ok(Some(AutoV24Times {
            time_rts_off: self
                .rts_off_ms
                .map_or(d.time_rts_off, |ms| Duration::from_millis(ms.into())),
            data_wait_time: self
                .data_wait_ms
                .map_or(d.data_wait_time, |ms| Duration::from_millis(ms.into())),
        }))
    }
}

/// What `read` reads.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum ReadKind {
    /// FC01 read coils.
    Coils,
    /// FC02 read discrete inputs.
    Discrete,
    /// FC03 read holding registers.
    Holding,
    /// FC04 read input registers.
    Input,
}

/// What `write` writes.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum WriteKind {
    /// FC05 write single coil (one value: 1/0, on/off).
    Coil,
    /// FC15 write multiple coils.
    Coils,
    /// FC06 write single register (one value, decimal or 0x hex).
    Register,
    /// FC16 write multiple registers.
    Registers,
}

/// The protocol's subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Find which units answer, at which line settings: one FC03 read of register 0 per unit
    /// and setting, one try each; the total time is printed before it starts, Ctrl-C stops
    /// with what was found.
    Scan(scan::ScanArgs),
    /// Read coils, discrete inputs, holding or input registers (FC01–04).
    Read {
        /// What to read.
        #[arg(value_enum)]
        kind: ReadKind,
        #[command(flatten)]
        master: MasterOptions,
        #[command(flatten)]
        at: AddressArgs,
        /// How many (bits 1–2040, registers 1–127).
        #[arg(long, default_value_t = 1)]
        count: u16,
        #[command(flatten)]
        polling: PollArgs,
        /// How registers are shown (holding and input registers only) [default: u16]: hex, u16
        /// or i16 per register, u32, i32 or f32 per pair (see --word-order), ascii two
        /// characters per register.
        #[arg(long, value_parser = PossibleValuesParser::new(ValueFormat::NAMES)
            .try_map(|s| s.parse::<ValueFormat>()))]
        format: Option<ValueFormat>,
        /// For u32/i32/f32: `big` = high word first (Modicon default), `swapped` = low word
        /// first.
        #[arg(long, default_value = "big", value_parser = PossibleValuesParser::new(WordOrder::NAMES)
            .try_map(|s| s.parse::<WordOrder>()))]
        word_order: WordOrder,
    },
    /// Write coils or registers (FC05, 06, 15, 16).
    Write {
        /// What to write.
        #[arg(value_enum)]
        kind: WriteKind,
        #[command(flatten)]
        master: MasterOptions,
        #[command(flatten)]
        at: AddressArgs,
        /// The values: coils 1/0/on/off/true/false, registers decimal, 0x or 16# hex.
        #[arg(required = true, num_args = 1..)]
        values: Vec<String>,
    },
    /// FC08 diagnostics, sub-function 0000: the slave echoes the test value.
    Diag {
        #[command(flatten)]
        master: MasterOptions,
        /// Test value (decimal, 0x or 16# hex).
        #[arg(long, default_value = "0xA537")]
        data: String,
        #[command(flatten)]
        polling: PollArgs,
    },
    /// FC11 get comm event counter.
    EventCounter {
        #[command(flatten)]
        master: MasterOptions,
    },
    /// FC12 get comm event log.
    EventLog {
        #[command(flatten)]
        master: MasterOptions,
    },
    /// FC07 read exception status.
    ExceptionStatus {
        #[command(flatten)]
        master: MasterOptions,
    },
    /// Be a slave serving simulated SIMATIC memory through S_MODB's conversion DB.
    Serve {
        /// Slave address 1–255.
        #[arg(long, short = 'u')]
        unit: u8,
        /// TOML file with `mode`, `char_delay_multiplier`, `frame_end` ("gap" or "length"),
        /// `[conversion]` (the 26 fields of Table 3-19) and `[memory]` (inputs, outputs,
        /// flags up to 65536 bytes, timers and counters up to 65536, dbs of up to 65536 bytes,
        /// 16 MiB in all); without it, the manual's example conversion DB of Table 3-20.
        #[arg(long)]
        config: Option<std::path::PathBuf>,
        #[command(flatten)]
        framing: FramingOptions,
    },
}

fn line_config(
    conn: &Connection,
    mode: Mode,
    mul: u8,
    framing: &FramingOptions,
) -> Result<si_modbus::config::LineConfig, CliError> {
    Ok(si_modbus::config::LineConfig {
        settings: conn.settings()?,
        mode,
        char_delay_multiplier: mul,
        local_echo: false,
        auto_v24: framing.auto_v24(conn)?,
    })
}

fn master_config(conn: &Connection, o: &MasterOptions) -> Result<MasterConfig, CliError> {
    let config = MasterConfig {
        line: line_config(
            conn,
            o.framing.mode,
            o.framing.char_delay_multiplier,
            &o.framing,
        )?,
        response_timeout: si_core::Duration::from_millis(o.timeout.into()),
        retries: o.retries,
        ..MasterConfig::default()
    };
    config.validate().map_err(CliError::bad_argument)?;
    Ok(config)
}

fn parse_bool(text: &str) -> Result<bool, CliError> {
    match text.to_ascii_lowercase().as_str() {
        "1" | "on" | "true" => Ok(true),
        "0" | "off" | "false" => Ok(false),
        _ => Err(CliError::usage(format!(
            "bad coil value {text:?}: use 1/0, on/off or true/false"
        ))),
    }
}

impl Command {
    /// Run it on the line.
    pub async fn run(self, conn: &Connection, out: &Output) -> Result<(), CliError> {
        match self {
            Command::Scan(a) => a.run(conn, out).await,
            Command::Serve {
                unit,
                config,
                framing,
            } => serve(conn, out, unit, config, &framing).await,
            Command::Read {
                kind,
                master,
                at,
                count,
                polling,
                format,
                word_order,
            } => {
                let address = at.pdu(count)?;
                let request = match kind {
                    ReadKind::Coils => Request::ReadCoils {
                        address,
                        quantity: count,
                    },
                    ReadKind::Discrete => Request::ReadDiscreteInputs {
                        address,
                        quantity: count,
                    },
                    ReadKind::Holding => Request::ReadHoldingRegisters {
                        address,
                        quantity: count,
                    },
                    ReadKind::Input => Request::ReadInputRegisters {
                        address,
                        quantity: count,
                    },
                };
                if let Some(f) = format {
                    if matches!(kind, ReadKind::Coils | ReadKind::Discrete) {
                        return Err(CliError::usage(format!(
                            "--format {} shows registers: coils and discrete inputs are bits",
                            f.name()
                        )));
                    }
                    format::check_count(f, count).map_err(CliError::usage)?;
                }
                let report = Report {
                    format: format.unwrap_or_default(),
                    order: word_order,
                    ..reporter(out, &master, at.base())
                };
                jobs(conn, &master, &request, &polling, &report).await
            }
            Command::Write {
                kind,
                master,
                at,
                values,
            } => {
                let single = matches!(kind, WriteKind::Coil | WriteKind::Register);
                if single && values.len() != 1 {
                    return Err(CliError::usage(format!(
                        "write {} takes exactly one value, got {}",
                        match kind {
                            WriteKind::Coil => "coil",
                            _ => "register",
                        },
                        values.len()
                    )));
                }
                let address = at.pdu(u16::try_from(values.len()).unwrap_or(u16::MAX))?;
                let report = reporter(out, &master, at.base());
                let once = PollArgs::default();
                match kind {
                    WriteKind::Coil | WriteKind::Coils => {
                        let bits = values
                            .iter()
                            .map(|v| parse_bool(v))
                            .collect::<Result<Vec<_>, _>>()?;
                        let r = if single {
                            Request::WriteSingleCoil {
                                address,
                                value: bits[0],
                            }
                        } else {
                            Request::WriteMultipleCoils {
                                address,
                                values: frame::Bits::Bools(&bits),
                            }
                        };
                        jobs(conn, &master, &r, &once, &report).await
                    }
                    WriteKind::Register | WriteKind::Registers => {
                        let regs = values
                            .iter()
                            .map(|v| parse_u16(v))
                            .collect::<Result<Vec<_>, _>>()?;
                        let r = if single {
                            Request::WriteSingleRegister {
                                address,
                                value: regs[0],
                            }
                        } else {
                            Request::WriteMultipleRegisters {
                                address,
                                values: frame::Registers::Words(&regs),
                            }
                        };
                        jobs(conn, &master, &r, &once, &report).await
                    }
                }
            }
            Command::Diag {
                master,
                data,
                polling,
            } => {
                let request = Request::Diagnostics {
                    data: parse_u16(&data)?,
                };
                let report = reporter(out, &master, 0);
                jobs(conn, &master, &request, &polling, &report).await
            }
            Command::EventCounter { master } => {
                job(conn, out, &master, Request::GetCommEventCounter).await
            }
            Command::EventLog { master } => job(conn, out, &master, Request::GetCommEventLog).await,
            Command::ExceptionStatus { master } => {
                job(conn, out, &master, Request::ReadExceptionStatus).await
            }
        }
    }
}

/// How a master job's outcomes are printed, registers as u16 until `--format` says otherwise.
fn reporter<'a>(out: &'a Output, o: &MasterOptions, base: u8) -> Report<'a> {
    Report {
        out,
        timestamps: o.timestamps,
        base,
        format: ValueFormat::default(),
        order: WordOrder::default(),
    }
}

async fn open_master(conn: &Connection, o: &MasterOptions) -> Result<handle::Master, CliError> {
    let config = master_config(conn, o)?;
    // On RS-485 a response is recognised by its address, skipping a turnaround glitch ([Modbus/USS]
    // §3.4.1, §3.4.3).
    let interface = if conn.rs485.is_some() {
        si_core::Interface::Rs485
    } else {
        si_core::Interface::Rs232
    };
    let master = Master::new(config)
        .map_err(|e| failure(e.into()))?
        .with_frame_end(o.framing.frame_end)
        .with_interface(interface);
    let port = conn.open().await?;
    Ok(handle::Master::spawn_engine(master, port))
}

/// `request` on every `--unit`, once or as a poll ([`poll::run`]), on the serial line or to
/// the `--modbus-tcp` server.
async fn jobs(
    conn: &Connection,
    o: &MasterOptions,
    request: &Request<'_>,
    polling: &PollArgs,
    report: &Report<'_>,
) -> Result<(), CliError> {
    let mut units = o.units.clone();
    // Each unit once, in the order given.
    let mut seen = std::collections::BTreeSet::new();
    units.retain(|u| seen.insert(*u));
    // --response-timeout-ms and --retries in the module's ranges, whichever way the jobs go.
    master_config(conn, o)?;
    if let Some(mut server) = o
        .modbus_tcp
        .connect(conn, o.timeout, o.retries, polling.is_polling())
        .await?
    {
        return poll::run(&mut server, &units, request, polling, report).await;
    }
    let mut m = open_master(conn, o).await?;
    poll::run(&mut m, &units, request, polling, report).await
}

/// A job without an address: once on every `--unit`.
async fn job(
    conn: &Connection,
    out: &Output,
    o: &MasterOptions,
    request: Request<'static>,
) -> Result<(), CliError> {
    let report = reporter(out, o, 0);
    jobs(conn, o, &request, &PollArgs::default(), &report).await
}

/// The `serve --config` file.
#[derive(Debug, Default, Deserialize)]
#[serde(default, deny_unknown_fields)]
struct ServeFile {
    mode: Option<Mode>,
    char_delay_multiplier: Option<u8>,
    frame_end: Option<FrameEnd>,
    conversion: Option<ConversionDb>,
    memory: Option<MemoryFile>,
}

#[derive(Debug, Deserialize)]
#[serde(default, deny_unknown_fields)]
struct MemoryFile {
    inputs: u32,
    outputs: u32,
    flags: u32,
    timers: u32,
    counters: u32,
    dbs: Vec<DbFile>,
}

impl Default for MemoryFile {
    fn default() -> Self {
        MemoryFile {
            inputs: 128,
            outputs: 128,
            flags: 1256,
            timers: 256,
            counters: 256,
            dbs: (1..=6)
                .map(|number| DbFile {
                    number,
                    length: 1024,
                })
                .collect(),
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct DbFile {
    number: u16,
    length: u32,
}

async fn serve(
    conn: &Connection,
    out: &Output,
    unit: u8,
    path: Option<std::path::PathBuf>,
    framing: &FramingOptions,
) -> Result<(), CliError> {
    let text = path.as_deref().map(crate::config_file::read).transpose()?;
    let file: ServeFile = match (&path, &text) {
        (Some(p), Some(text)) => crate::config_file::parse_toml(p, text)?,
        _ => ServeFile::default(),
    };
    let memory = file.memory.unwrap_or_default();
    let sizes = MemorySizes {
        inputs: memory.inputs,
        outputs: memory.outputs,
        flags: memory.flags,
        timers: memory.timers,
        counters: memory.counters,
        dbs: memory.dbs.iter().map(|d| (d.number, d.length)).collect(),
    };
    let conversion = file.conversion.unwrap_or(ConversionDb::EXAMPLE);
    let map = si_modbus::serve_map::ServeMap::new(&conversion, &sizes);
    // Every size is checked against its maximum before anything is allocated
    // (si_core::memory::MAX_AREA_BYTES and the others).
    let memory = Memory::checked(&sizes).map_err(|e| match (&path, &text) {
        (Some(p), Some(text)) => match crate::config_file::key_span(text, e.parameter) {
            Some(span) => crate::config_file::placed(p, text, span, Some(e.parameter), &e),
            None => CliError::new(format!("{}: {e}", p.display())),
        },
        _ => e.into(),
    })?;
    let out_copy = *out;
    let store = si_modbus::serve_map::Explaining::new(
        SimaticStore::new(memory, conversion),
        map.clone(),
        move |r: &si_modbus::serve_map::Refusal| serve_map::print_refusal(r, &out_copy),
    );
    let config = SlaveConfig {
        line: line_config(
            conn,
            file.mode.unwrap_or(framing.mode),
            file.char_delay_multiplier
                .unwrap_or(framing.char_delay_multiplier),
            framing,
        )?,
        address: unit,
    };
    config.validate()?;
    let frame_end = file.frame_end.unwrap_or(framing.frame_end);
    let slave = Slave::new(config, store)
        .map_err(|e| failure(e.into()))?
        .with_frame_end(frame_end);
    let port = conn.open().await?;
    let mut server = handle::Slave::spawn_engine(slave, port);
    let ends = match frame_end {
        FrameEnd::Gap => "",
        FrameEnd::Length => ", or at the predicted length (host extension)",
    };
    out.line(
        &format!(
            "serving as slave {unit} ({}), end-of-frame gap {}{ends}",
            config.line.settings,
            config.line.gap()
        ),
        json!({"serving": unit, "settings": config.line.settings.to_string(),
               "gap_us": config.line.gap().as_micros(),
               "frame_end": match frame_end { FrameEnd::Gap => "gap", FrameEnd::Length => "length" }}),
    );
    serve_map::print(&map, unit, out);
    // Serves until Ctrl-C (exit 130, main's runtime) or until the line closes (exit 1).
    while let Some(e) = server.next_event().await {
        print_slave_event(&e, out);
    }
    Err(conn.closed())
}

fn print_slave_event(e: &SlaveEvent, out: &Output) {
    match *e {
        SlaveEvent::Served {
            function,
            address,
            quantity,
        } => out.line(
            &format!("served FC{function:02} address {address} quantity {quantity}"),
            json!({"served": function, "address": address, "quantity": quantity}),
        ),
        SlaveEvent::Broadcast {
            function,
            address,
            quantity,
        } => out.line(
            &format!("broadcast FC{function:02} address {address} quantity {quantity} executed"),
            json!({"broadcast": function, "address": address, "quantity": quantity}),
        ),
        SlaveEvent::Exception {
            function,
            code,
            status,
            error,
        } => {
            let why = match (status, error) {
                (Some(s), _) => status_text(s),
                (None, Some(e)) => format!("S_MODB ERROR_NR {} ERROR_INFO {}", e.error_nr, e.info),
                // SlaveEvent::Exception: no STATUS and no store error is a request of the
                // wrong length for its function ([Modbus/USS] §3.5.6–§3.5.14 lists no event for
                // it).
                (None, None) => format!(
                    "the request is too short or too long for FC{function:02} (no STATUS: \
                     [Modbus/USS] §3.5.6–§3.5.14 lists none)"
                ),
            };
            out.line(
                &format!("answered FC{function:02} with {code}: {why}"),
                json!({"exception": code.code(), "function": function,
                       "status": status.map(|s| s.code()),
                       "error_nr": error.map(|e| e.error_nr), "text": why}),
            )
        }
        SlaveEvent::Error(s) => out.line(
            &format!("request not answered: {}", status_text(s)),
            json!({"error": s.code(), "text": status_text(s)}),
        ),
    }
}

/// `si frame encode modbus`.
#[derive(Debug, Args)]
pub struct EncodeArgs {
    /// Slave address and PDU in hex, e.g. "01 03 00 00 00 0A".
    #[arg(required = true, num_args = 1.., value_name = "HEX")]
    hex: Vec<String>,
}

impl EncodeArgs {
    /// Append the CRC (low byte first) and say how the frame reads.
    pub fn run(&self, out: &Output) -> Result<(), CliError> {
        let body = crate::hex::parse_hex_args(&self.hex)?;
        let adu = frame::seal(&body).map_err(CliError::new)?;
        let crc = frame::crc16(&body);
        let reading = frame::reading(&adu);
        out.line(
            &si_core::hex::format(&adu),
            json!({"adu": si_core::hex::format(&adu), "crc": format!("{crc:04X}"),
                   "reading": reading.map(|r| r.0)}),
        );
        Ok(())
    }
}

/// `si frame decode modbus`.
#[derive(Debug, Args)]
pub struct DecodeArgs {
    /// ADU in hex with the CRC, e.g. "01 03 00 00 00 0A C5 CD".
    #[arg(required = true, num_args = 1.., value_name = "HEX")]
    hex: Vec<String>,
}

impl DecodeArgs {
    /// Check the CRC, then read the frame as a request, else as a response.
    pub fn run(&self, out: &Output) -> Result<(), CliError> {
        let adu = crate::hex::parse_hex_args(&self.hex)?;
        let as_request = frame::decode_request(&adu);
        let as_response = frame::decode_response(&adu);
        match (&as_request, &as_response) {
            (Err(e), Err(_)) if e.kind == frame::DecodeErrorKind::Crc => {
                return Err(CliError::new(e.to_string()))
            }
            (Err(e), Err(f)) => {
                return Err(CliError::new(format!(
                    "neither a request ({e}) nor a response ({f})"
                )))
            }
            _ => {}
        }
        let (reading, text) = frame::reading(&adu).unwrap_or(("?", String::new()));
        let crc = u16::from_le_bytes([adu[adu.len() - 2], adu[adu.len() - 1]]);
        out.line(
            &format!("{reading}: {text}, CRC {crc:04X} ok"),
            // The PDU's fields as read each way (null where that reading fails).
            json!({"reading": reading, "unit": adu[0], "function": adu[1],
                   "request": as_request.as_ref().ok().map(|(_, r)| r),
                   "response": as_response.as_ref().ok().map(|(_, p)| p),
                   "crc": format!("{crc:04X}")}),
        );
        Ok(())
    }
}

/// Scenarios for `si sim`.
pub const SCENARIOS: &[Scenario] = &[
    Scenario {
        name: "modbus",
        about: "a Modbus master polls slave 1 (Table 3-20's conversion DB): write, read back, exception",
        run: scenario_poll,
    },
    Scenario {
        name: "modbus-timeout",
        about: "the slave is silent: the master's job fails with 16#0830 after the response time",
        run: scenario_timeout,
    },
    Scenario {
        name: "modbus-crc-error",
        about: "one bit of the response flips on the line: the master's job fails with 16#0E57",
        run: scenario_crc,
    },
];

type Rig = (
    Simulator,
    si_sim::StationId<Master>,
    si_sim::StationId<Slave<SimaticStore>>,
);

fn rig(o: &SimOptions, timeout_ms: u32) -> Result<Rig, CliError> {
    let line = si_modbus::config::LineConfig {
        settings: o.settings,
        ..Default::default()
    };
    let mut sim = Simulator::new(o.seed);
    let master = Master::new(MasterConfig {
        line,
        response_timeout: si_core::Duration::from_millis(timeout_ms.into()),
        ..MasterConfig::default()
    })?;
    let slave = Slave::new(SlaveConfig { line, address: 1 }, SimaticStore::example())?;
    let m = sim.add_station("master", o.settings, master);
    let s = sim.add_station("slave", o.settings, slave);
    sim.connect(m, s);
    Ok((sim, m, s))
}

fn run_job(
    sim: &mut Simulator,
    m: si_sim::StationId<Master>,
    request: &Request<'_>,
) -> Result<(MasterEvent, Instant), CliError> {
    sim.with(m, |e, now| e.request(now, 1, request))
        .map_err(|e| CliError::new(status_text(e.status())))?;
    // Step until the job's completion event, so its time is the time it happened.
    while sim.step() {
        let done = sim
            .take_events(m)
            .into_iter()
            .find(|e| !matches!(e, MasterEvent::Diagnostic(_)));
        if let Some(e) = done {
            return Ok((e, sim.now()));
        }
    }
    Err(CliError::new("the job did not complete"))
}

fn report(event: &MasterEvent, at: Instant, out: &Output) {
    match event {
        MasterEvent::Completed(c) => {
            let text = format!("{:?}", c.response());
            out.line(
                &format!("{at}: job done: {text}"),
                json!({"at_us": at.as_micros(), "done": text}),
            )
        }
        MasterEvent::Failed { status, .. } => out.line(
            &format!("{at}: job failed: {}", status_text(*status)),
            json!({"at_us": at.as_micros(), "status": status.code()}),
        ),
        MasterEvent::Diagnostic(s) => out.line(
            &format!("{at}: {}", status_text(*s)),
            json!({"at_us": at.as_micros(), "diagnostic": s.code()}),
        ),
    }
}

fn check_settings(s: SerialSettings) -> Result<(), CliError> {
    si_modbus::config::LineConfig {
        settings: s,
        ..Default::default()
    }
    .validate()?;
    Ok(())
}

fn scenario_poll(o: &SimOptions, out: &Output) -> Result<(), CliError> {
    check_settings(o.settings)?;
    let (mut sim, m, _) = rig(o, 2000)?;
    let jobs = [
        Request::WriteMultipleRegisters {
            address: 0,
            values: frame::Registers::Words(&[0x1234, 0x5678]),
        },
        Request::ReadHoldingRegisters {
            address: 0,
            quantity: 2,
        },
        Request::WriteSingleCoil {
            address: 3,
            value: true,
        },
        Request::ReadCoils {
            address: 0,
            quantity: 8,
        },
        // R = 512 → DB7: above DB_Max = 6, exception 02.
        Request::WriteSingleRegister {
            address: 512,
            value: 1,
        },
    ];
    let mut results = Vec::new();
    for job in &jobs {
        results.push(run_job(&mut sim, m, job)?);
        sim.run_for(Duration::from_millis(10));
    }
    print_trace(sim.trace(), out);
    for (e, at) in &results {
        report(e, *at, out);
    }
    Ok(())
}

fn scenario_timeout(o: &SimOptions, out: &Output) -> Result<(), CliError> {
    check_settings(o.settings)?;
    let (mut sim, m, s) = rig(o, 2000)?;
    sim.silence(s, Instant::ZERO);
    let (e, at) = run_job(
        &mut sim,
        m,
        &Request::ReadHoldingRegisters {
            address: 0,
            quantity: 10,
        },
    )?;
    print_trace(sim.trace(), out);
    report(&e, at, out);
    Ok(())
}

fn scenario_crc(o: &SimOptions, out: &Output) -> Result<(), CliError> {
    check_settings(o.settings)?;
    let (mut sim, m, _) = rig(o, 2000)?;
    sim.corrupt_received(m, 3, 0x10);
    let (e, at) = run_job(
        &mut sim,
        m,
        &Request::ReadHoldingRegisters {
            address: 0,
            quantity: 2,
        },
    )?;
    print_trace(sim.trace(), out);
    report(&e, at, out);
    Ok(())
}
