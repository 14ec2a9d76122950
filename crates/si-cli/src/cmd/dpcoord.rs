//! `si dp-coord`: the coordination-byte window protocol ([ET200S SI 2005] §2.12)
//! from the command line.
//!
//! * `si dp-coord host --window N JOB`: be the DP master's side of one job. The DP exchange is
//!   the caller's: each line read from standard input is the module's input window (hex), and
//!   each answer written to standard output is the host's output window for that cycle. When
//!   the job ends, a received frame is printed as `frame HEX` and read V.24 signals as
//!   `signals HEX` (the signal word as the window carries it), then `done STATUS=XXXX` (exit 0)
//!   or `error STATUS=XXXX` (exit 1). Standard output carries only these lines; logs go to
//!   standard error. A receive job that finds nothing buffered ends `done STATUS=0101` (the
//!   manual's "not an error", `[derived]`); the signal word is printed as bytes 1–2 of the window
//!   carry it (`[derived]`: byte 1 = 00H, byte 2 = `DCD CTS RTS DSR DTR` in bits 4…0). The host's
//!   clock is the time since the start, for its job watchdog (`--timeout-s`, STATUS 0502H).
//! * `si dp-coord module --window N --protocol ascii|3964r|modbus`: the mirror image — a
//!   simulated ET 200S SI module whose line is the serial port (`--port`/`--tcp`): each line read
//!   is the host's output window, each line written the module's input window. With `modbus` the
//!   module is a Modbus master ([`si_dp_coord::modbus`]): a send job carries the S_SEND source
//!   area (slave address, function code, address, quantity / data, [Modbus/USS]
//!   [Modbus/USS] §3.4.5–§3.4.16), and the next receive job brings the response in the S_RCV layout
//!   ([Modbus/USS] §3.4.5–§3.4.16) or the job's STATUS (0830H no response, 0E6xH exception). USS
//!   and Modbus slave mode are not offered: their window layout is not documented (`[derived]`).
//! * `--exec-after-7 1|0` (host and module): what follows execution number 7 (`[derived]`), 1 by
//!   default; both sides must agree ([`si_dp_coord::ExecWrap`]).
//! * `si dp-coord trace FILE`: annotates a recorded window trace cycle by cycle
//!   ([`si_dp_coord::frame::describe`]).
//!
//! A trace file holds one window per line: `<` (or `in`) for the module's input window, `>` (or
//! `out`) for the host's output window; lines without a prefix alternate input, output, as the
//! `host` command reads and writes them, so its transcript is a trace. `#` starts a comment;
//! the `frame`, `signals`, `done` and `error` lines of a transcript are shown as they are.

use crate::conn::Connection;
use crate::error::CliError;
use crate::hex::{parse_hex, parse_hex_args};
use crate::lines::{CappedLines, MAX_WINDOW_LINE};
use crate::output::Output;
use crate::preset::module_preset;
use crate::scenario::{print_trace, record_trace, Scenario, SimOptions};
use bytes::Bytes;
use clap::{Args, Subcommand, ValueEnum};
use serde_json::json;
use si_core::driver::{self, DriverOptions, Transport};
use si_core::{Duration, Engine, Instant, ModulePreset, SerialSettings, Status};
use si_dp_coord::engines;
use si_dp_coord::frame::{describe, Direction, V24Layout};
use si_dp_coord::line::EngineSerial;
use si_dp_coord::modbus;
use si_dp_coord::module::{LoopbackSerial, Module};
use si_dp_coord::user_program::{user_programs, ReceiveResult, SendResult};
use si_dp_coord::{
    ExecWrap, Host, HostConfig, HostEvent, Job, ModuleConfig, Outcome, ParamBlock, Window,
    WindowSize,
};
use si_sim::{Simulator, Trace, TraceEntry, TraceKind};
use std::sync::mpsc::RecvTimeoutError;

/// The protocol's subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Be the host (DP master side) of one job: input windows on stdin, output windows on stdout.
    Host(HostArgs),
    /// Be the module: output windows on stdin, input windows on stdout, the line on --port/--tcp.
    Module(ModuleArgs),
    /// Annotate a recorded window trace cycle by cycle.
    Trace(TraceArgs),
}

impl Command {
    /// Run it.
    pub async fn run(self, conn: &Connection, out: &Output) -> Result<(), CliError> {
        match self {
            Command::Host(a) => a.run(out),
            Command::Module(a) => a.run(conn, out).await,
            Command::Trace(a) => a.run(out),
        }
    }
}

/// The window size of the module variant: 4, 8 or 32 bytes ([ET200S SI 2005] §2.12.1, Fig. 2-23).
fn window_size(text: &str) -> Result<WindowSize, String> {
    text.parse::<usize>()
        .ok()
        .and_then(WindowSize::from_len)
        .ok_or_else(|| format!("{text:?} is not a window size: 4, 8 or 32"))
}

/// What follows execution number 7 (`[derived]`): `1` (the default) or `0`.
fn exec_after_7(text: &str) -> Result<ExecWrap, String> {
    match text {
        "1" => Ok(ExecWrap::ToOne),
        "0" => Ok(ExecWrap::ToZero),
        _ => Err(format!("{text:?}: 1 (7 → 1) or 0 (7 → 0)")),
    }
}

/// A signal state on the command line: 0 or 1.
fn bit(text: &str) -> Result<bool, String> {
    match text {
        "0" => Ok(false),
        "1" => Ok(true),
        _ => Err(format!("{text:?}: 0 or 1")),
    }
}

/// A byte given as hex (`11`, `0x11`).
fn hex_byte(text: &str) -> Result<u8, String> {
    u8::from_str_radix(text.trim_start_matches("0x"), 16)
        .map_err(|_| format!("{text:?}: a byte in hex"))
}

/// `si dp-coord host`.
#[derive(Debug, Args)]
pub struct HostArgs {
    /// Window size in bytes: 4, 8 or 32.
    #[arg(long, default_value = "8", value_parser = window_size)]
    window: WindowSize,
    /// Give up on the job after this many seconds without its end (STATUS 0502H).
    #[arg(long, default_value_t = 30)]
    timeout_s: u64,
    /// The execution number after 7: 1 or 0 (`[derived]`); the module must count the same way.
    #[arg(long, default_value = "1", value_parser = exec_after_7)]
    exec_after_7: ExecWrap,
    /// The module behind the window, whose maximum frame length applies: `et200s` (ET 200S 1SI,
    /// 200 bytes) or `2005` (the 2005 module, 224 bytes). The CP 341 has no DP window.
    #[arg(long, value_name = "TYPE", default_value = "2005", value_parser = module_preset)]
    module: ModulePreset,
    /// Maximum frame length in bytes (1 … 4096), instead of the module's: a longer send job is
    /// refused (1E41H), a longer received frame fails (0850H).
    #[arg(long, value_name = "N")]
    max_frame: Option<usize>,
    /// The job.
    #[command(subcommand)]
    job: JobArg,
}

/// The job for `si dp-coord host` (Table 2-22).
#[derive(Debug, Subcommand)]
pub enum JobArg {
    /// Job 1: send a frame (hex) to the module's serial partner.
    Send {
        /// The frame, e.g. `61 62 63` or `616263`.
        #[arg(required = true, num_args = 1.., value_name = "HEX")]
        hex: Vec<String>,
    },
    /// Job 2: fetch the oldest received frame.
    Receive,
    /// Job 3: read the V.24 signals.
    ReadV24,
    /// Job 4: set RTS and DTR.
    WriteV24 {
        /// RTS: 0 or 1.
        #[arg(long, value_parser = bit, action = clap::ArgAction::Set)]
        rts: bool,
        /// DTR: 0 or 1.
        #[arg(long, value_parser = bit, action = clap::ArgAction::Set)]
        dtr: bool,
    },
    /// Job 5: transfer a flow-control parameter block.
    #[command(subcommand)]
    Params(ParamsArg),
}

/// The parameter block of job 5 (Table 2-27); times in ms, sent in units of 10 ms.
#[derive(Debug, Subcommand)]
pub enum ParamsArg {
    /// Block 20H: XON, XOFF, wait for XON after XOFF.
    XonXoff {
        /// The XON character in hex.
        #[arg(long, default_value = "11", value_parser = hex_byte)]
        xon: u8,
        /// The XOFF character in hex.
        #[arg(long, default_value = "13", value_parser = hex_byte)]
        xoff: u8,
        /// Wait for XON after XOFF, 20 … 655 350 ms.
        #[arg(long, default_value_t = 2_000)]
        wait_ms: u32,
    },
    /// Block 21H: wait for CTS = ON.
    RtsCts {
        /// Wait for CTS = ON, 20 … 655 350 ms.
        #[arg(long, default_value_t = 2_000)]
        wait_ms: u32,
    },
    /// Block 22H: automatic V.24 control.
    AutoV24 {
        /// Time from the end of the transmission to RTS = OFF, 0 … 655 350 ms.
        #[arg(long, default_value_t = 10)]
        rts_off_ms: u32,
        /// Wait for CTS = ON after RTS = ON, 0 … 655 350 ms.
        #[arg(long, default_value_t = 10)]
        data_wait_ms: u32,
    },
}

/// A `--…-ms` flag as the window's count of 10 ms, through si-core's one conversion (range
/// `min` … 655 350 ms in 10 ms steps); the error names the flag, the range and the value.
fn ten_ms(name: &'static str, value: u32, min_ms: u64) -> Result<u16, CliError> {
    let time = si_core::Duration::from_millis(u64::from(value));
    si_core::param_block::ten_ms_count(name, time, si_core::Duration::from_millis(min_ms))
        .map_err(|e| CliError::new(e.to_string()))
}

impl JobArg {
    fn job(&self) -> Result<Job, CliError> {
        Ok(match self {
            JobArg::Send { hex } => Job::Send(Bytes::from(parse_hex_args(hex)?)),
            JobArg::Receive => Job::Receive,
            JobArg::ReadV24 => Job::ReadV24,
            JobArg::WriteV24 { rts, dtr } => Job::WriteV24 {
                rts: *rts,
                dtr: *dtr,
            },
            JobArg::Params(ParamsArg::XonXoff { xon, xoff, wait_ms }) => {
                Job::Parameters(ParamBlock::XonXoff {
                    xon: *xon,
                    xoff: *xoff,
                    xon_wait: ten_ms("--wait-ms", *wait_ms, 20)?,
                })
            }
            JobArg::Params(ParamsArg::RtsCts { wait_ms }) => Job::Parameters(ParamBlock::RtsCts {
                cts_wait: ten_ms("--wait-ms", *wait_ms, 20)?,
            }),
            JobArg::Params(ParamsArg::AutoV24 {
                rts_off_ms,
                data_wait_ms,
            }) => Job::Parameters(ParamBlock::AutoV24 {
                rts_off_delay: ten_ms("--rts-off-ms", *rts_off_ms, 0)?,
                cts_wait: ten_ms("--data-wait-ms", *data_wait_ms, 0)?,
            }),
        })
    }
}

/// Reads a window from one line of hex, checking its size.
fn read_window(line: &str, size: WindowSize, n: usize) -> Result<Vec<u8>, CliError> {
    let bytes = parse_hex(line)?;
    if bytes.len() != size.bytes() {
        return Err(CliError::new(format!(
            "line {n}: {} bytes, but the window has {}",
            bytes.len(),
            size.bytes()
        )));
    }
    Ok(bytes)
}

/// A line of stdin that carries no window.
fn skip(line: &str) -> bool {
    let t = line.trim();
    t.is_empty() || t.starts_with('#')
}

/// Prints the end of a job: `frame` / `signals` first, then `done` or `error`.
fn finish(result: Result<Outcome, Status>, out: &Output) -> Result<(), CliError> {
    let status = match &result {
        Ok(Outcome::Received(frame)) => {
            let hex = si_core::hex::format(frame);
            out.line(&format!("frame {hex}"), json!({"frame": hex}));
            Status::OK
        }
        Ok(Outcome::Signals(s)) => {
            let hex = si_core::hex::format(&V24Layout::default().encode(*s));
            out.line(
                &format!("signals {hex}"),
                json!({"signals": hex, "dtr": s.dtr, "dsr": s.dsr, "rts": s.rts, "cts": s.cts, "dcd": s.dcd}),
            );
            Status::OK
        }
        Ok(Outcome::NoMessage) => si_dp_coord::status::NO_MESSAGE,
        Ok(_) => Status::OK,
        Err(s) => *s,
    };
    let code = format!("{:04X}", status.code());
    match result {
        Ok(_) => {
            out.line(
                &format!("done STATUS={code}"),
                json!({"done": true, "status": code}),
            );
            Ok(())
        }
        Err(s) => {
            let text = described(s);
            out.line(
                &format!("error STATUS={code}"),
                json!({"done": false, "status": code, "text": text}),
            );
            Err(CliError::new(format!("the job failed: {text}")))
        }
    }
}

/// A window STATUS with its text: the window's own catalogs, then those of the drivers behind
/// the module (3964(R), ASCII); a code none of them has says so instead of standing bare
/// (a bare 16#49D1 tells the user nothing).
fn described(status: Status) -> String {
    match si_dp_coord::status::lookup_with_drivers(status) {
        Some(s) => s.to_string(),
        None => format!("{status} (not in the catalog)"),
    }
}

impl HostArgs {
    fn run(self, out: &Output) -> Result<(), CliError> {
        let mut cfg = HostConfig {
            job_timeout: Some(Duration::from_secs(self.timeout_s)),
            exec_wrap: self.exec_after_7,
            ..HostConfig::for_module(self.window, self.module)?
        };
        if let Some(n) = self.max_frame {
            cfg.max_frame_len = n;
        }
        let mut host = Host::new(cfg)?;
        let id = host
            .submit(self.job.job()?)
            .map_err(|e| CliError::new(e.to_string()))?;
        let start = std::time::Instant::now();
        // Stdin is read on its own thread, so the job's watchdog holds while no line comes
        // (`--timeout-s 2` waited until stdin closed). The host's own watchdog runs
        // in its cycles, and without one every 100 ms while stdin is silent; before the first
        // window (the job not started) the limit counts from here, with the same STATUS.
        let limit = std::time::Duration::from_secs(self.timeout_s);
        let (tx, lines) = std::sync::mpsc::sync_channel(16);
        std::thread::spawn(move || {
            for line in CappedLines::new(std::io::stdin().lock(), MAX_WINDOW_LINE) {
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        let mut n = 0;
        loop {
            match lines.recv_timeout(std::time::Duration::from_millis(100)) {
                Ok(line) => {
                    n += 1;
                    let line = line?;
                    if skip(&line) {
                        continue;
                    }
                    let input = read_window(&line, self.window, n)?;
                    let now = Instant::from_micros(
                        u64::try_from(start.elapsed().as_micros()).unwrap_or(u64::MAX),
                    );
                    let output = si_core::hex::format(host.cycle(now, &input));
                    out.line(&output, json!({"output": output}));
                }
                // No window yet: the job has not started, and its watchdog cannot run.
                Err(RecvTimeoutError::Timeout) if n == 0 && start.elapsed() >= limit => {
                    host.abort(id);
                    return finish(Err(host.config().watchdog_status), out);
                }
                // Windows came, then none: the host's own watchdog, counted from the job's
                // start, runs without a cycle (an input of the wrong length is "watchdog only").
                Err(RecvTimeoutError::Timeout) if n > 0 => {
                    let now = Instant::from_micros(
                        u64::try_from(start.elapsed().as_micros()).unwrap_or(u64::MAX),
                    );
                    host.cycle(now, &[]);
                }
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => {
                    return Err(CliError::new("standard input ended before the job did"))
                }
            }
            while let Some(event) = host.poll_event() {
                match event {
                    HostEvent::Completed {
                        id: done, result, ..
                    } if done == id => return finish(result, out),
                    other => tracing::info!("{other:?}"),
                }
            }
        }
    }
}

/// The line procedure of `si dp-coord module`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Protocol {
    /// 3964(R) with the manual's defaults.
    #[value(name = "3964r")]
    R3964r,
    /// The ASCII driver with the manual's defaults (end by character delay time).
    Ascii,
    /// Modbus master (the Modbus/USS module): send jobs carry the S_SEND source area of a
    /// master job, receive jobs bring the response.
    Modbus,
}

/// Priority of the 3964(R) side in an initialization conflict.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Priority {
    /// Yields to the partner (the default).
    Low,
    /// Keeps its job.
    High,
}

/// `si dp-coord module`.
#[derive(Debug, Args)]
pub struct ModuleArgs {
    /// Window size in bytes: 4, 8 or 32.
    #[arg(long, default_value = "8", value_parser = window_size)]
    window: WindowSize,
    /// The procedure on the line.
    #[arg(long, value_enum)]
    protocol: Protocol,
    /// 3964(R): priority in an initialization conflict (the partner must have the other one).
    #[arg(long, value_enum, default_value = "low")]
    priority: Priority,
    /// ASCII: the configured flow control, which decides the parameter block a params job may
    /// carry ([ET200S SI 2005] §2.12.2–§2.12.6 `[derived]`; any other block is refused with 0550H).
    #[arg(long, value_enum, default_value = "none")]
    flow_control: FlowControlArg,
    /// ASCII: character delay time in ms (the end of a frame; 4 … 65 535).
    #[arg(long, default_value_t = 4)]
    char_delay_ms: u32,
    /// Modbus: the response time in ms, 50 … 655 000 (STATUS 0830H when no response starts).
    #[arg(long, default_value_t = 2_000)]
    response_ms: u32,
    /// The execution number after 7: 1 or 0 (`[derived]`); the host must count the same way.
    #[arg(long, default_value = "1", value_parser = exec_after_7)]
    exec_after_7: ExecWrap,
}

/// The ASCII driver's flow control on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum FlowControlArg {
    /// None: every parameter job gets 0550H.
    None,
    /// XON/XOFF (block 20H).
    XonXoff,
    /// RTS/CTS (block 21H).
    RtsCts,
    /// Automatic V.24 control (block 22H).
    AutoV24,
}

impl ModuleArgs {
    async fn run(self, conn: &Connection, out: &Output) -> Result<(), CliError> {
        // The serial line speaks the procedure behind the window: its name goes into a
        // recording's header and picks the decoder of `-v`'s frame log.
        let mut line = conn.clone();
        line.protocol = Some(match self.protocol {
            Protocol::R3964r => "3964r",
            Protocol::Ascii => "ascii",
            Protocol::Modbus => "modbus",
        });
        let conn = &line;
        let settings = conn.settings()?;
        let transport = conn.open().await?;
        match self.protocol {
            Protocol::R3964r => {
                let config = si_3964r::Config {
                    priority: match self.priority {
                        Priority::Low => si_3964r::config::Priority::Low,
                        Priority::High => si_3964r::config::Priority::High,
                    },
                    ..si_3964r::Config::default()
                };
                let link = si_3964r::Link::new(config.with_settings(settings))?;
                let module =
                    engines::r3964r_module(self.window, link)?.with_exec_wrap(self.exec_after_7);
                serve(module, transport, settings, self.window, conn, out).await
            }
            Protocol::Ascii => {
                let config = si_ascii::Config {
                    settings,
                    flow_control: match self.flow_control {
                        FlowControlArg::None => si_ascii::FlowControl::None,
                        FlowControlArg::XonXoff => si_ascii::FlowControl::XonXoff,
                        FlowControlArg::RtsCts => si_ascii::FlowControl::RtsCts,
                        FlowControlArg::AutoV24 => si_ascii::FlowControl::AutoV24,
                    },
                    char_delay: si_core::Duration::from_millis(self.char_delay_ms.into()),
                    ..si_ascii::Config::default()
                };
                let link = si_ascii::Link::new(config)?;
                let module =
                    engines::ascii_module(self.window, link)?.with_exec_wrap(self.exec_after_7);
                serve(module, transport, settings, self.window, conn, out).await
            }
            Protocol::Modbus => {
                let config = si_modbus::MasterConfig {
                    line: si_modbus::config::LineConfig {
                        settings,
                        ..si_modbus::config::LineConfig::default()
                    },
                    response_timeout: si_core::Duration::from_millis(self.response_ms.into()),
                    ..si_modbus::MasterConfig::default()
                };
                let master = si_modbus::Master::new(config)?;
                let module =
                    modbus::master_module(self.window, master)?.with_exec_wrap(self.exec_after_7);
                serve(module, transport, settings, self.window, conn, out).await
            }
        }
    }
}

/// Runs the module over the transport; each stdin line is one DP cycle. The end of stdin ends
/// it (exit 0); the line closing first is an error naming it (exit 1).
async fn serve<E>(
    module: Module<EngineSerial<E>>,
    transport: Box<dyn Transport>,
    settings: SerialSettings,
    window: WindowSize,
    conn: &Connection,
    out: &Output,
) -> Result<(), CliError>
where
    E: Engine + Send + 'static,
    E::Event: Send + std::fmt::Debug + 'static,
{
    let options = DriverOptions {
        settings: Some(settings),
        ..DriverOptions::default()
    };
    let (mut handle, task) = driver::spawn(module, transport, options);
    let (tx, mut lines) = tokio::sync::mpsc::channel::<std::io::Result<String>>(16);
    // Standard input blocks: read it on its own thread, so the driver keeps serving the line.
    std::thread::spawn(move || {
        for line in CappedLines::new(std::io::stdin().lock(), MAX_WINDOW_LINE) {
            if tx.blocking_send(line).is_err() {
                break;
            }
        }
    });
    let mut n = 0;
    loop {
        tokio::select! {
            line = lines.recv() => {
                let Some(line) = line else { break };
                let line = line?;
                n += 1;
                if skip(&line) {
                    continue;
                }
                let output = read_window(&line, window, n)?;
                let input = handle
                    .call(move |m, now| m.cycle(now, &output).to_vec())
                    .await
                    .map_err(|_| CliError::new("the line driver stopped"))?;
                let hex = si_core::hex::format(&input);
                out.line(&hex, json!({"input": hex}));
            }
            event = handle.next_event() => match event {
                // The driver logs each event at DEBUG (-vv); -v shows the frames themselves.
                Some(_) => {}
                // The driver stopped while stdin still has cycles: the line closed
                // (a lost line is an error). Stdin's end is the module's normal end.
                None => return Err(conn.closed()),
            },
        }
    }
    drop(handle);
    match task.await {
        Ok(Err(e)) => Err(CliError::new(format!("line: {e}"))),
        _ => Ok(()),
    }
}

/// `si dp-coord trace`.
#[derive(Debug, Args)]
pub struct TraceArgs {
    /// The trace file (see `si dp-coord --help`): one window per line, `<` input, `>` output.
    file: std::path::PathBuf,
}

/// Prints one window of a trace with its reading.
fn print_window(out: &Output, cycle: usize, window: &Window, dir: Direction) {
    let arrow = match dir {
        Direction::ModuleToHost => "<",
        Direction::HostToModule => ">",
    };
    let hex = si_core::hex::format(window.as_bytes());
    let text = describe(window, dir, V24Layout::default());
    out.line(
        &format!("{cycle:>4} {arrow} {hex:<24} {text}"),
        json!({"cycle": cycle, "direction": arrow, "window": hex, "reading": text}),
    );
}

impl TraceArgs {
    fn run(self, out: &Output) -> Result<(), CliError> {
        let text = crate::config_file::read(&self.file)?;
        let mut cycle = 0;
        let mut next_in = true;
        let mut size = None;
        for (n, raw) in text.lines().enumerate() {
            let line = raw.trim();
            if skip(line) {
                continue;
            }
            let (dir, hex) = if let Some(rest) =
                line.strip_prefix('<').or_else(|| strip_word(line, "in"))
            {
                (Direction::ModuleToHost, rest)
            } else if let Some(rest) = line.strip_prefix('>').or_else(|| strip_word(line, "out")) {
                (Direction::HostToModule, rest)
            } else if ["frame", "signals", "done", "error"]
                .iter()
                .any(|w| line.starts_with(w))
            {
                out.line(&format!("       {line}"), json!({"result": line}));
                continue;
            } else if next_in {
                (Direction::ModuleToHost, line)
            } else {
                (Direction::HostToModule, line)
            };
            let bytes = si_core::hex::parse(hex)
                .map_err(|e| CliError::new(format!("line {}: bad hex: {e}", n + 1)))?;
            let window = Window::from_bytes(&bytes).ok_or_else(|| {
                CliError::new(format!(
                    "line {}: {} bytes is not a window of 4, 8 or 32",
                    n + 1,
                    bytes.len()
                ))
            })?;
            if *size.get_or_insert(window.size()) != window.size() {
                return Err(CliError::new(format!(
                    "line {}: {} bytes, but the trace started with {}-byte windows",
                    n + 1,
                    bytes.len(),
                    size.map_or(0, WindowSize::bytes)
                )));
            }
            if dir == Direction::ModuleToHost {
                cycle += 1;
            }
            next_in = dir == Direction::HostToModule;
            print_window(out, cycle.max(1), &window, dir);
        }
        Ok(())
    }
}

/// `rest` after a leading word `word` followed by `:` or whitespace.
fn strip_word<'a>(line: &'a str, word: &str) -> Option<&'a str> {
    let rest = line.strip_prefix(word)?;
    match rest.strip_prefix(':') {
        Some(after_colon) => Some(after_colon),
        None => rest.starts_with(char::is_whitespace).then_some(rest),
    }
}

/// Scenarios for `si sim`.
pub const SCENARIOS: &[Scenario] = &[
    Scenario {
        name: "dp-coord-send",
        about: "window protocol, Table 2-23: 22 characters sent through an 8-byte window, cycle by cycle",
        run: scenario_send,
    },
    Scenario {
        name: "dp-coord-e2e",
        about: "S_SEND via module A's window, 3964(R) on the line, module B, S_RCV via its window",
        run: scenario_e2e,
    },
    Scenario {
        name: "dp-coord-modbus",
        about: "module in Modbus master mode: FC03 job via S_SEND through the window, a Modbus slave on the line, the registers via S_RCV",
        run: scenario_modbus,
    },
];

/// Table 2-23 ([ET200S SI 2005] §2.12.2, Table 2-23, reconstructed, `[derived]`): 22 characters
/// through an 8-byte window, the module one DP cycle behind the host as in the manual's table.
///
/// The windows are also a trace for `--record`/`--svg` ([`record_trace`], protocol `dp-coord`):
/// per cycle the module's input window (station `module`) and, a millisecond later, the host's
/// answer (station `host`), each a `tx` entry.
fn scenario_send(_: &SimOptions, out: &Output) -> Result<(), CliError> {
    let mut host = Host::new(HostConfig::new(WindowSize::Eight))?;
    let mut serial = LoopbackSerial::new();
    serial.loopback = false;
    let mut module = Module::new(ModuleConfig::new(WindowSize::Eight), serial)?;
    let id = host
        .submit(Job::Send(Bytes::from_static(b"abcdefghijklmnopqrstuv")))
        .map_err(|e| CliError::new(e.to_string()))?;
    let mut input = module.input().to_vec();
    let mut previous = host.output().to_vec();
    let mut trace = Trace::default();
    let mut window = |at: Instant, station: &str, bytes: &[u8]| {
        trace.entries.push(TraceEntry {
            at,
            station: station.to_owned(),
            kind: TraceKind::Tx {
                bytes: bytes.to_vec(),
            },
        });
    };
    for cycle in 1..=40 {
        let now = Instant::from_micros(cycle as u64 * 10_000);
        let output = host.cycle(now, &input).to_vec();
        window(now, "module", &input);
        window(now + Duration::from_millis(1), "host", &output);
        if let Some(w) = Window::from_bytes(&input) {
            print_window(out, cycle, &w, Direction::ModuleToHost);
        }
        if let Some(w) = Window::from_bytes(&output) {
            print_window(out, cycle, &w, Direction::HostToModule);
        }
        // DP cycle ≈ CPU cycle: the module works on the window the host wrote one cycle
        // earlier, so each echo reaches the host two cycles after its segment (Table 2-23).
        input = module.cycle(now, &previous).to_vec();
        previous = output;
        while let Some(event) = host.poll_event() {
            if let HostEvent::Completed {
                id: done, result, ..
            } = event
            {
                if done == id {
                    record_trace(&trace, "dp-coord");
                    return finish(result, out);
                }
            }
        }
    }
    record_trace(&trace, "dp-coord");
    Err(CliError::new("the send job did not end in 40 cycles"))
}

/// A user program's S_SEND on module A, 3964(R) between the modules, S_RCV on module B.
fn scenario_e2e(o: &SimOptions, out: &Output) -> Result<(), CliError> {
    let high = si_3964r::Config {
        priority: si_3964r::config::Priority::High,
        ..si_3964r::Config::default()
    };
    let mut sim = Simulator::new(o.seed);
    let a = engines::r3964r_module(
        WindowSize::Eight,
        si_3964r::Link::new(high.with_settings(o.settings))?,
    )?;
    let b = engines::r3964r_module(
        WindowSize::Eight,
        si_3964r::Link::new(si_3964r::Config::default().with_settings(o.settings))?,
    )?;
    let (mut in_a, mut in_b) = (a.input().to_vec(), b.input().to_vec());
    let a = sim.add_station("A", o.settings, a);
    let b = sim.add_station("B", o.settings, b);
    sim.connect(a, b);
    let mut hosts = [
        Host::new(HostConfig::new(WindowSize::Eight))?,
        Host::new(HostConfig::new(WindowSize::Eight))?,
    ];
    let (sent, got) = user_programs(
        &mut sim,
        &mut hosts,
        1,
        b"temperature=21.5",
        |sim, hosts| {
            let out_a = hosts[0].cycle(sim.now(), &in_a).to_vec();
            in_a = sim.with(a, |m, now| m.cycle(now, &out_a).to_vec());
            let out_b = hosts[1].cycle(sim.now(), &in_b).to_vec();
            in_b = sim.with(b, |m, now| m.cycle(now, &out_b).to_vec());
        },
    );
    print_trace(sim.trace(), out);
    print_fb_results(sent, ("B", got), out)
}

/// Prints S_SEND's end (on station A) and S_RCV's (on `station`); an error if either is missing
/// or failed.
fn print_fb_results(
    sent: SendResult,
    (station, got): (&str, ReceiveResult),
    out: &Output,
) -> Result<(), CliError> {
    let Some((at, d)) = sent else {
        return Err(CliError::new("S_SEND did not end"));
    };
    out.line(
        &format!("{at} A S_SEND done={} error={} STATUS={:04X}", d.done, d.error, d.status.code()),
        json!({"at_us": at.as_micros(), "fb": "S_SEND", "done": d.done, "error": d.error, "status": format!("{:04X}", d.status.code())}),
    );
    let Some((at, r, bytes)) = got else {
        return Err(CliError::new("S_RCV got nothing"));
    };
    let hex = si_core::hex::format(&bytes);
    out.line(
        &format!("{at} {station} S_RCV ndr={} error={} STATUS={:04X} LEN={} {hex}", r.ndr, r.error, r.status.code(), r.len),
        json!({"at_us": at.as_micros(), "fb": "S_RCV", "ndr": r.ndr, "error": r.error, "status": format!("{:04X}", r.status.code()), "frame": hex}),
    );
    if d.error || r.error {
        return Err(CliError::new("the end-to-end job failed"));
    }
    Ok(())
}

/// The module in Modbus master mode ([Modbus/USS] §3.4.2, §3.4.5–§3.4.16): the user program's
/// S_SEND carries an FC03 job (slave 1, registers 0 and 1) through module A's window, the module's
/// master asks a Modbus slave on the simulated line, and S_RCV on the same module gets the two
/// registers (0x1234, 0x5678) in the S_RCV layout.
fn scenario_modbus(o: &SimOptions, out: &Output) -> Result<(), CliError> {
    let line = si_modbus::config::LineConfig {
        settings: o.settings,
        ..si_modbus::config::LineConfig::default()
    };
    let master = si_modbus::Master::new(si_modbus::MasterConfig {
        line,
        ..si_modbus::MasterConfig::default()
    })?;
    let mut sim = Simulator::new(o.seed);
    let module = modbus::master_module(WindowSize::Eight, master)?;
    let mut input = module.input().to_vec();
    let a = sim.add_station("A", o.settings, module);
    let mut tables = si_modbus::Tables::new(8, 8, 8, 8);
    tables.holding_registers[..2].copy_from_slice(&[0x1234, 0x5678]);
    let config = si_modbus::SlaveConfig { line, address: 1 };
    let slave = sim.add_station("slave", o.settings, si_modbus::Slave::new(config, tables)?);
    sim.connect(a, slave);
    let mut hosts = [Host::new(HostConfig {
        max_frame_len: modbus::MAX_FRAME_LEN,
        ..HostConfig::new(WindowSize::Eight)
    })?];
    let job = [0x01, 0x03, 0x00, 0x00, 0x00, 0x02];
    let (sent, got) = user_programs(&mut sim, &mut hosts, 0, &job, |sim, hosts| {
        let output = hosts[0].cycle(sim.now(), &input).to_vec();
        input = sim.with(a, |m, now| m.cycle(now, &output).to_vec());
    });
    print_trace(sim.trace(), out);
    print_fb_results(sent, ("A", got), out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_window_status_has_its_text_or_says_it_is_not_in_the_catalog() {
        assert_eq!(
            described(Status::from_code(0x49D1)),
            "16#49D1 (not in the catalog)"
        );
        let len = described(Status::from_code(0x1E41));
        assert!(len.starts_with("16#1E41 invalid number of bytes"), "{len}");
        // Codes of the drivers behind the module: 3964(R) 0703H, ASCII 0708H.
        let setup = described(Status::from_code(0x0703));
        assert_eq!(setup, si_3964r::status::SETUP_TIMEOUT.to_string());
        let xon = described(Status::from_code(0x0708));
        assert_eq!(xon, si_ascii::status::XON_CTS_TIMEOUT.to_string());
    }
}
