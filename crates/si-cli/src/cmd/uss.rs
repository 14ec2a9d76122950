//! `si uss`: the USS master on a line (poll drives, read and write parameters), a simulated drive,
//! offline telegrams and the USS simulator scenarios ([Modbus/USS] §3.7, [USS spec]).
//!
//! Numbers follow `crate::radix`: decimal by default, `0x…` or `16#…` for hex, `-` where a value
//! may be negative; output is decimal unless `--hex` is given. STATUS codes always print as
//! `16#…` (the manuals' notation for them), telegram bytes as hex.

mod scan;

use crate::conn::Connection;
use crate::error::CliError;
use crate::output::Output;
use crate::radix;
use crate::scenario::{print_trace, Scenario, SimOptions};
use clap::{Args, Subcommand};
use serde_json::json;
use si_core::driver::{spawn, DriverOptions};
use si_core::{Duration, Instant, SerialSettings, Status};
use si_sim::Simulator;
use si_uss::config::{MasterConfig, PkwAfterJob, PollEntry};
use si_uss::drive::{stw, Drive, DriveConfig, DriveEvent};
use si_uss::frame::{
    self, pkw_error_text, Adr, NetData, ParamAddress, Pkw, PkwWords, MAX_TELEGRAM,
};
use si_uss::master::{Event, Master, ParamRequest, Width};
use si_uss::tokio::Handle;

/// The protocol's subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Find which nodes (0–31) answer, at which line settings: one read of parameter 0 per
    /// node and setting, one telegram each; the total time is printed before it starts,
    /// Ctrl-C stops with what was found.
    Scan(scan::ScanArgs),
    /// Poll drives cyclically; prints status word and actual value per slave per cycle. Exits
    /// with 1 when a node never answered during a run of --cycles.
    Poll(PollArgs),
    /// Read a parameter value (PKW task 1, or 6 for an array element with --array).
    ReadParam(ReadArgs),
    /// Write a parameter value (PKW task 2 or 3 with --dword; 7 or 8 for an array element with
    /// --array).
    WriteParam(WriteArgs),
    /// Answer as a simulated drive (status word follows the control word, actual value ramps).
    SimSlave(SimSlaveArgs),
}

/// The net-data structure and timing every master command shares.
#[derive(Debug, Args)]
pub struct Structure {
    /// PKW words: 0, 3 or 4 (127 = variable).
    #[arg(long, default_value_t = 4)]
    pkw_words: u8,
    /// PZD words: 0…16.
    #[arg(long, default_value_t = 2)]
    pzd_words: u8,
    /// Response timeout in ms (the USS spec's 20 ms; more for converters and device servers).
    #[arg(long, default_value_t = 20)]
    response_timeout_ms: u64,
    /// WDH: PKW repetitions after the first telegram (0…32767). A job goes out at most 1 + N
    /// times; then it fails with 16#1408 if the node never answered, 16#1505 if it answered
    /// without a matching response.
    #[arg(long, default_value_t = 20)]
    retries: u16,
    /// After a parameter job, send its PKW task again in every poll until the next job, as the
    /// module's FCs do ([Modbus/USS] §3.7.7). Default: PKW task 0 "no task" after a job (the USS
    /// rule), so a drive does not execute a write again and again.
    #[arg(long)]
    pkw_repeat: bool,
}

impl Structure {
    fn config(&self, settings: SerialSettings, slaves: &[u8]) -> Result<MasterConfig, CliError> {
        let pkw = PkwWords::from_count(self.pkw_words).ok_or_else(|| {
            CliError::usage(format!(
                "--pkw-words {} is out of range: 0, 3, 4 or 127 (variable)",
                self.pkw_words
            ))
        })?;
        let mut c = MasterConfig::new(
            slaves
                .iter()
                .map(|&a| PollEntry::new(a, pkw, self.pzd_words))
                .collect(),
        );
        c.settings = settings;
        c.response_timeout = Duration::from_millis(self.response_timeout_ms);
        c.retries = self.retries;
        c.pkw_after_job = if self.pkw_repeat {
            PkwAfterJob::RepeatLast
        } else {
            PkwAfterJob::TaskZero
        };
        c.validate().map_err(CliError::bad_argument)?;
        Ok(c)
    }
}

/// `si uss poll`.
#[derive(Debug, Args)]
pub struct PollArgs {
    /// Node numbers in polling order, e.g. 1,2,5 (a node may appear twice).
    #[arg(long, value_delimiter = ',', required = true, value_parser = radix::u8_arg)]
    slaves: Vec<u8>,
    /// Control word STW (PZD1) sent to every slave: decimal, or hex with 0x or 16#, e.g. 0x047F.
    #[arg(long, value_parser = radix::u16_arg)]
    stw: Option<u16>,
    /// Main setpoint HSW (PZD2): decimal (negative allowed, sent as 16-bit two's complement),
    /// or hex with 0x or 16#, e.g. 0x4000.
    #[arg(long, value_parser = radix::word_arg, allow_hyphen_values = true)]
    hsw: Option<u16>,
    /// Stop after this many cycles (default: until interrupted); no telegram leaves after them.
    #[arg(long)]
    cycles: Option<u64>,
    /// Read this parameter (PNU or PNU:IND) from every node in the first polls (PKW task 1); the
    /// results are printed. With --pkw-repeat the read then stays in every poll's PKW area.
    #[arg(long, value_name = "PARAM")]
    read_param: Option<String>,
    /// Print ZSW and HIW in hex (16#…) instead of decimal.
    #[arg(long)]
    hex: bool,
    #[command(flatten)]
    structure: Structure,
}

/// `si uss read-param`.
#[derive(Debug, Args)]
pub struct ReadArgs {
    /// Node number.
    #[arg(long, value_parser = radix::u8_arg)]
    slave: u8,
    /// Parameter number 0…61999 (above 1999 through the page index), optionally with
    /// sub-index: 700, 2010:1, 20001.
    param: String,
    /// Read an array element (task 6) instead of a value (task 1).
    #[arg(long)]
    array: bool,
    /// Sub-index 0…255 (instead of PNU:IND).
    #[arg(long, value_parser = radix::u8_arg)]
    index: Option<u8>,
    /// Show the value as signed: 16-bit for a word response (ID 1, 4), 32-bit for a double word.
    #[arg(long)]
    signed: bool,
    /// Print the value in hex (16#…) instead of decimal.
    #[arg(long)]
    hex: bool,
    #[command(flatten)]
    structure: Structure,
}

/// `si uss write-param`.
#[derive(Debug, Args)]
pub struct WriteArgs {
    /// Node number.
    #[arg(long, value_parser = radix::u8_arg)]
    slave: u8,
    /// Parameter number 0…61999 (above 1999 through the page index), optionally with
    /// sub-index: 1082, 2010:1, 20001.
    param: String,
    /// The value: decimal (negative allowed: -5), or hex with 0x or 16#. A word takes
    /// -32768…65535, a double word -2147483648…4294967295 (two's complement when negative).
    #[arg(allow_hyphen_values = true)]
    value: String,
    /// Write a double word (task 3, or 8 with --array) instead of a word (task 2, or 7).
    #[arg(long)]
    dword: bool,
    /// Write an array element (task 7 or 8) instead of a value (task 2 or 3).
    #[arg(long)]
    array: bool,
    /// Sub-index 0…255 (instead of PNU:IND).
    #[arg(long, value_parser = radix::u8_arg)]
    index: Option<u8>,
    /// Print the value the drive reports back in hex (16#…) instead of decimal.
    #[arg(long)]
    hex: bool,
    #[command(flatten)]
    structure: Structure,
}

/// `si uss sim-slave`.
impl WriteArgs {
    /// The value's width (`--dword`).
    fn width(&self) -> Width {
        if self.dword {
            Width::DoubleWord
        } else {
            Width::Word
        }
    }
}

#[derive(Debug, Args)]
pub struct SimSlaveArgs {
    /// Bus address 0…31.
    #[arg(long, value_parser = radix::u8_arg)]
    address: u8,
    /// PKW words: 0, 3 or 4.
    #[arg(long, default_value_t = 4)]
    pkw_words: u8,
    /// PZD words: 0…16.
    #[arg(long, default_value_t = 2)]
    pzd_words: u8,
    /// Answer every PKW task with response ID 8, "no master control / no PKW rights".
    #[arg(long)]
    no_pkw_rights: bool,
    /// Print control words and values in hex (16#…) instead of decimal.
    #[arg(long)]
    hex: bool,
}

/// `PNU` or `PNU:IND` with `--index`: the parameter's number and sub-index, checked against the page
/// index's range (si_uss::param).
fn parse_param(text: &str, index: Option<u8>) -> Result<ParamAddress, CliError> {
    let bad = |why: String| CliError::usage(format!("parameter {text:?}: {why}"));
    let (n, i) = match text.split_once(':') {
        Some((n, i)) => (n, Some(i)),
        None => (text, None),
    };
    let number = radix::bounded(n, u16::MAX.into()).map_err(bad)? as u16;
    let index = match (i, index) {
        (Some(_), Some(_)) => {
            return Err(bad(
                "give the sub-index as PNU:IND or --index, not both".into()
            ))
        }
        (Some(i), None) => radix::u8_arg(i).map_err(bad)?,
        (None, i) => i.unwrap_or(0),
    };
    ParamAddress::new(number, index).map_err(|e| CliError::usage(e.to_string()))
}

/// The value to write as the bit pattern of a word or double word; negative values are
/// two's complement.
fn parse_value(text: &str, dword: bool) -> Result<u32, CliError> {
    let (min, max) = if dword {
        (i64::from(i32::MIN), i64::from(u32::MAX))
    } else {
        (i64::from(i16::MIN), i64::from(u16::MAX))
    };
    let v = radix::signed(text, min, max).map_err(|e| {
        CliError::usage(format!(
            "value {e}{}",
            if dword { "" } else { " (a word; add --dword)" }
        ))
    })?;
    Ok(if dword { v as u32 } else { u32::from(v as u16) })
}

/// A PKW response's value as the user asked to see it.
fn show_value(r: &Pkw, signed: bool, hex: bool) -> (String, i64) {
    let v = if signed {
        i64::from(r.signed_value())
    } else {
        i64::from(r.value())
    };
    (radix::show(v, hex), v)
}

fn status_text(status: Status) -> String {
    let catalog = |code| Status::lookup(code, &[si_uss::status::CATALOG]);
    status.described_by(catalog).to_string()
}

/// A failed job's line: the node, the STATUS and, for response ID 7, the drive's error number.
fn failure_text(address: u8, status: Status, error_number: Option<u16>) -> String {
    let number = error_number
        .map(|n| format!(": error number {n} ({})", pkw_error_text(n)))
        .unwrap_or_default();
    format!("node {address}: {}{number}", status_text(status))
}

impl Command {
    /// Run it on the line.
    pub async fn run(self, conn: &Connection, out: &Output) -> Result<(), CliError> {
        match self {
            Command::Scan(a) => a.run(conn, out).await,
            Command::Poll(a) => poll(a, conn, out).await,
            Command::ReadParam(a) => {
                let param = parse_param(&a.param, a.index)?;
                let request = if a.array {
                    ParamRequest::read_array(param.number, param.index)
                } else {
                    ParamRequest::read(param.number, param.index)
                };
                let r = last_job(conn, &a.structure, a.slave, request).await?;
                let (text, value) = show_value(&r, a.signed, a.hex);
                out.line(
                    &format!(
                        "slave {} {param} = {text} (response ID {})",
                        a.slave,
                        r.pke.ak()
                    ),
                    json!({"slave": a.slave, "pnu": param.number, "index": param.index,
                           "value": value, "response_id": r.pke.ak()}),
                );
                Ok(())
            }
            Command::WriteParam(a) => {
                let param = parse_param(&a.param, a.index)?;
                let value = parse_value(&a.value, a.dword)?;
                let request = if a.array {
                    ParamRequest::write_array(param.number, param.index, value, a.width())
                } else {
                    ParamRequest::write(param.number, param.index, value, a.width())
                };
                let r = last_job(conn, &a.structure, a.slave, request).await?;
                let signed = a.value.trim_start().starts_with('-');
                let (text, value) = show_value(&r, signed, a.hex);
                out.line(
                    &format!("slave {} {param} := {text} done", a.slave),
                    json!({"slave": a.slave, "pnu": param.number, "index": param.index,
                           "value": value, "response_id": r.pke.ak(), "task": request.task}),
                );
                Ok(())
            }
            Command::SimSlave(a) => sim_slave(a, conn, out).await,
        }
    }
}

/// Run one parameter job on a master that polls only `slave`, as the only job on the line
/// (`si_uss::tokio::Handle::only_job`).
async fn last_job(
    conn: &Connection,
    structure: &Structure,
    slave: u8,
    request: ParamRequest,
) -> Result<Pkw, CliError> {
    let config = structure.config(
        conn.settings_for(&si_uss::config::USS_BAUD_RATES)?,
        &[slave],
    )?;
    let transport = conn.open_with(&config.settings).await?;
    Handle::only_job(config, transport, slave, request)
        .await
        .map_err(|e| match e {
            si_uss::tokio::Error::Failed {
                status,
                error_number,
                ..
            } => CliError::new(failure_text(slave, status, error_number)),
            si_uss::tokio::Error::Stopped => conn.closed(),
            e => CliError::new(e.to_string()),
        })
}

async fn poll(a: PollArgs, conn: &Connection, out: &Output) -> Result<(), CliError> {
    let config = a.structure.config(
        conn.settings_for(&si_uss::config::USS_BAUD_RATES)?,
        &a.slaves,
    )?;
    let mut words = Vec::new();
    if a.stw.is_some() || a.hsw.is_some() {
        words.push(a.stw.unwrap_or(0));
    }
    words.extend(a.hsw);
    if words.len() > usize::from(a.structure.pzd_words) {
        return Err(CliError::new(format!(
            "--stw/--hsw need {} PZD words, --pzd-words is {}",
            words.len(),
            a.structure.pzd_words
        )));
    }
    let read = a
        .read_param
        .as_deref()
        .map(|p| parse_param(p, None))
        .transpose()?;
    // Control words, the end of the run and the first jobs are set before the master starts:
    // the first telegram carries them and none follows the last cycle.
    let settings = config.settings;
    let mut master = Master::new(config)?;
    let mut nodes: Vec<u8> = Vec::new();
    for &s in &a.slaves {
        if !nodes.contains(&s) {
            nodes.push(s);
        }
    }
    for &s in &nodes {
        if !words.is_empty() {
            master.set_control(s, &words)?;
        }
        if let Some(p) = read {
            master.request_parameter(Instant::ZERO, s, ParamRequest::read(p.number, p.index))?;
        }
    }
    if let Some(n) = a.cycles {
        master.stop_after_cycles(n);
    }
    let transport = conn.open_with(&settings).await?;
    let mut m = Handle::spawn_engine(master, transport);
    let mut failures = 0u64;
    let mut answered: Vec<u8> = Vec::new();
    let word = |w: Option<u16>| w.map_or("-".to_owned(), |w| radix::show(w, a.hex));
    while let Some(event) = m.next_event().await {
        match event {
            Event::Response {
                cycle,
                address,
                net,
            } => {
                if !answered.contains(&address) {
                    answered.push(address);
                }
                let zsw = net.pzd.first();
                let hiw = net.pzd.second();
                out.line(
                    &format!(
                        "cycle {cycle} slave {address}: ZSW {} HIW {}",
                        word(zsw),
                        word(hiw)
                    ),
                    json!({"cycle": cycle, "slave": address, "zsw": zsw, "hiw": hiw,
                           "pzd": net.pzd.words()}),
                );
            }
            Event::NoAnswer { cycle, address } => {
                failures += 1;
                out.line(
                    &format!(
                        "cycle {cycle} slave {address}: node {address} does not answer ({})",
                        status_text(si_uss::status::NO_ANSWER)
                    ),
                    json!({"cycle": cycle, "slave": address, "status": si_uss::status::NO_ANSWER.code()}),
                );
            }
            Event::Rejected {
                cycle,
                address,
                status,
                error,
            } => {
                failures += 1;
                let detail = error.map(|e| format!(": {e}")).unwrap_or_default();
                out.line(
                    &format!(
                        "cycle {cycle} slave {address}: response rejected ({}){detail}",
                        status_text(status)
                    ),
                    json!({"cycle": cycle, "slave": address, "status": status.code()}),
                );
            }
            Event::ParameterDone {
                address, response, ..
            } => {
                let param = ParamAddress::join(response.pke.pnu(), response.ind);
                let (text, value) = show_value(&response, false, a.hex);
                out.line(
                    &format!(
                        "slave {address} {param} = {text} (response ID {})",
                        response.pke.ak()
                    ),
                    json!({"slave": address, "pnu": param.number, "index": param.index,
                           "value": value, "response_id": response.pke.ak()}),
                );
            }
            Event::ParameterFailed {
                address,
                status,
                error_number,
                ..
            } => out.line(
                &failure_text(address, status, error_number),
                json!({"slave": address, "status": status.code(), "error_number": error_number}),
            ),
            Event::CycleDone { cycle } if a.cycles.is_some_and(|n| cycle + 1 >= n) => {
                let counters = m
                    .call(|m, _| *m.counters())
                    .await
                    .map_err(|e| CliError::new(e.to_string()))?;
                out.line(
                    &format!(
                        "{} cycles: {} responses, {} failures",
                        cycle + 1,
                        counters.ok,
                        failures
                    ),
                    json!({"cycles": cycle + 1, "counters": counters}),
                );
                return never_answered(&nodes, &answered, cycle + 1);
            }
            _ => {}
        }
    }
    Err(conn.closed())
}

/// Exit status of a run: an error naming the nodes that never gave a valid response, if any.
fn never_answered(nodes: &[u8], answered: &[u8], cycles: u64) -> Result<(), CliError> {
    let silent: Vec<String> = nodes
        .iter()
        .filter(|n| !answered.contains(n))
        .map(u8::to_string)
        .collect();
    if silent.is_empty() {
        return Ok(());
    }
    Err(CliError::new(format!(
        "node{} {} never answered (no valid response in {cycles} cycles): {}",
        if silent.len() > 1 { "s" } else { "" },
        silent.join(", "),
        status_text(si_uss::status::NO_ANSWER),
    )))
}

async fn sim_slave(a: SimSlaveArgs, conn: &Connection, out: &Output) -> Result<(), CliError> {
    let settings = conn.settings_for(&si_uss::config::USS_BAUD_RATES)?;
    let pkw = PkwWords::from_count(a.pkw_words)
        .filter(|p| *p != PkwWords::Variable)
        .ok_or_else(|| {
            CliError::usage(format!(
                "--pkw-words {} is out of range: 0, 3 or 4",
                a.pkw_words
            ))
        })?;
    let drive = Drive::new(DriveConfig {
        pkw,
        pzd_words: a.pzd_words,
        no_pkw_rights: a.no_pkw_rights,
        ..DriveConfig::new(settings, a.address)
    })?;
    let transport = conn.open_with(&settings).await?;
    let options = DriverOptions {
        settings: Some(settings),
        ..DriverOptions::default()
    };
    let (mut handle, _task) = spawn(drive, transport, options);
    out.line(
        &format!(
            "drive {} answering at {settings} (PKW {}, PZD {})",
            a.address, a.pkw_words, a.pzd_words
        ),
        json!({"drive": a.address, "settings": settings.to_string()}),
    );
    let mut last = None;
    while let Some(e) = handle.next_event().await {
        match e {
            DriveEvent::Polled { stw, setpoint, .. } if last != Some((stw, setpoint)) => {
                last = Some((stw, setpoint));
                out.line(
                    &format!(
                        "control word {}, setpoint {}",
                        radix::show(stw, a.hex),
                        radix::show(setpoint, a.hex)
                    ),
                    json!({"stw": stw, "setpoint": setpoint}),
                );
            }
            DriveEvent::Written { param, value } => out.line(
                &format!("{param} := {}", radix::show(value, a.hex)),
                json!({"pnu": param.number, "index": param.index, "value": value}),
            ),
            DriveEvent::Discarded { reason } => out.line(
                &format!("discarded: {reason}"),
                json!({"discarded": reason}),
            ),
            _ => {}
        }
    }
    // The drive answers until Ctrl-C (the default SIGINT exit, 130); its events ending means
    // the driver stopped: the line closed under it.
    Err(conn.closed())
}

/// `si frame encode uss`.
#[derive(Debug, Args)]
pub struct EncodeArgs {
    /// ADR then the net data, in hex: `01 12 BC 00 00 00 00 00 00 04 7E 00 00`.
    #[arg(required = true, num_args = 1.., value_name = "HEX")]
    hex: Vec<String>,
}

impl EncodeArgs {
    /// Run it.
    pub fn run(&self, out: &Output) -> Result<(), CliError> {
        let bytes = crate::hex::parse_hex_args(&self.hex)?;
        let (&adr, net) = bytes
            .split_first()
            .ok_or_else(|| CliError::new("give at least the ADR byte"))?;
        let mut buf = [0u8; MAX_TELEGRAM];
        let n = frame::encode(Adr(adr), net, &mut buf)?;
        let hex = si_core::hex::format(&buf[..n]);
        out.line(
            &hex,
            json!({"telegram": hex, "lge": buf[1], "bcc": buf[n - 1]}),
        );
        Ok(())
    }
}

/// `si frame decode uss`.
#[derive(Debug, Args)]
pub struct DecodeArgs {
    /// PKW words to split the net data into PKW and PZD: 0, 3, 4 or 127 (variable).
    #[arg(long)]
    pkw_words: Option<u8>,
    /// PZD words (with --pkw-words; default: all words after the PKW area).
    #[arg(long)]
    pzd_words: Option<u8>,
    /// Telegram in hex, STX to BCC.
    #[arg(required = true, num_args = 1.., value_name = "HEX")]
    hex: Vec<String>,
}

impl DecodeArgs {
    /// Run it.
    pub fn run(&self, out: &Output) -> Result<(), CliError> {
        let bytes = crate::hex::parse_hex_args(&self.hex)?;
        let t = frame::decode(&bytes)?;
        let mut text = format!(
            "ADR {:02X}H (slave {}{}), LGE {}, {} net bytes: {}",
            t.adr.0,
            t.adr.address(),
            match t.adr.0 & 0xE0 {
                0 => "",
                0x20 => ", broadcast",
                0x40 => ", mirror",
                0x80 => ", special",
                _ => ", undefined type",
            },
            bytes[1],
            t.net.len(),
            si_core::hex::format(t.net)
        );
        let mut value = json!({"adr": t.adr.0, "address": t.adr.address(),
            "broadcast": t.adr.is_broadcast(), "mirror": t.adr.is_mirror(),
            "special": t.adr.is_special(), "lge": bytes[1], "net": si_core::hex::format(t.net)});
        if let Some(words) = self.pkw_words {
            let pkw = PkwWords::from_count(words).ok_or_else(|| {
                CliError::new(format!(
                    "--pkw-words {words} is out of range: 0, 3, 4 or 127"
                ))
            })?;
            let pzd = match self.pzd_words {
                Some(p) => usize::from(p),
                None => (t.net.len() / 2).saturating_sub(pkw.fixed().unwrap_or(3)),
            };
            let d = NetData::parse(t.net, pkw, pzd)?;
            if let Some(p) = d.pkw {
                let param = ParamAddress::join(p.pke.pnu(), p.ind);
                text.push_str(&format!(
                    "\nPKW: AK {} SPM {} PNU {} IND {:04X}H ({param}) PWE {:04X?}",
                    p.pke.ak(),
                    u8::from(p.pke.spm()),
                    p.pke.pnu(),
                    p.ind,
                    p.pwe()
                ));
                value["pkw"] = json!({"ak": p.pke.ak(), "spm": p.pke.spm(), "pnu": p.pke.pnu(),
                    "ind": p.ind, "parameter": param.number, "index": param.index, "pwe": p.pwe()});
            }
            text.push_str(&format!("\nPZD: {:04X?}", d.pzd.words()));
            value["pzd"] = json!(d.pzd.words());
        }
        out.line(&text, value);
        Ok(())
    }
}

/// Scenarios for `si sim`.
pub const SCENARIOS: &[Scenario] = &[
    Scenario {
        name: "uss-cycle",
        about: "USS master polls three drives on RS-485, drive 2 silent: the cycle goes on",
        run: uss_cycle,
    },
    Scenario {
        name: "uss-param",
        about: "USS master reads and writes drive parameters, one write refused with AK 7",
        run: uss_param,
    },
];

fn sim_master(
    sim: &mut Simulator,
    settings: SerialSettings,
    slaves: &[u8],
) -> Result<si_sim::StationId<Master>, CliError> {
    let mut config = MasterConfig::new(
        slaves
            .iter()
            .map(|&a| PollEntry::new(a, PkwWords::Four, 2))
            .collect(),
    );
    config.settings = settings;
    config.local_echo = true;
    Ok(sim.add_station("master", settings, Master::new(config)?))
}

fn uss_cycle(o: &SimOptions, out: &Output) -> Result<(), CliError> {
    let mut sim = Simulator::new(o.seed);
    let m = sim_master(&mut sim, o.settings, &[1, 2, 3])?;
    let mut members = vec![m.index()];
    let mut drives = Vec::new();
    for a in [1u8, 2, 3] {
        let cfg = DriveConfig {
            local_echo: true,
            ..DriveConfig::new(o.settings, a)
        };
        let d = sim.add_station(&format!("drive{a}"), o.settings, Drive::new(cfg)?);
        members.push(d.index());
        drives.push(d);
    }
    sim.bus(&members);
    sim.silence(drives[1], Instant::ZERO);
    sim.with(m, |m, now| {
        m.start(now);
        m.stop_after_cycles(3);
        for a in [1, 3] {
            let _ = m.set_control(a, &[stw::RUN, 1000]);
        }
    });
    // The master stops itself after the third cycle: the line goes quiet.
    while sim.step() {}
    print_trace(sim.trace(), out);
    let master = sim.engine(m);
    for s in master.slaves() {
        out.line(
            &format!(
                "slave {}: ZSW {} HIW {} comm status {} comm error {} last {}",
                s.address,
                s.status_word().map_or("-".into(), |w| w.to_string()),
                s.actual_value().map_or("-".into(), |w| w.to_string()),
                s.comm_status,
                s.comm_error,
                status_text(s.last_status)
            ),
            json!({"slave": s.address, "zsw": s.status_word(), "hiw": s.actual_value(),
                   "comm_status": s.comm_status, "comm_error": s.comm_error,
                   "status": s.last_status.code()}),
        );
    }
    let c = master.counters();
    out.line(
        &format!(
            "{} cycles: {} telegrams sent, {} answered, {} not answered",
            c.cycles, c.sent, c.ok, c.no_answer
        ),
        json!({"counters": c}),
    );
    Ok(())
}

fn uss_param(o: &SimOptions, out: &Output) -> Result<(), CliError> {
    let mut sim = Simulator::new(o.seed);
    let m = sim_master(&mut sim, o.settings, &[1])?;
    let cfg = DriveConfig {
        local_echo: true,
        ..DriveConfig::new(o.settings, 1)
    };
    let d = sim.add_station("drive1", o.settings, Drive::new(cfg)?);
    sim.bus(&[m.index(), d.index()]);
    sim.with(m, |m, now| m.start(now));
    let jobs = [
        ParamRequest::read(1082, 0),
        ParamRequest::write(1082, 0, 120, Width::Word),
        ParamRequest::read(1082, 0),
        ParamRequest::write(1082, 0, 1000, Width::Word),
    ];
    let mut results = Vec::new();
    for job in jobs {
        sim.with(m, |m, now| m.request_parameter(now, 1, job))?;
        let limit = sim.now() + Duration::from_secs(5);
        let outcome = loop {
            if sim.now() > limit || !sim.step() {
                return Err(CliError::new("the simulated job did not end"));
            }
            let found = sim.take_events(m).into_iter().find(|e| {
                matches!(
                    e,
                    Event::ParameterDone { .. } | Event::ParameterFailed { .. }
                )
            });
            if let Some(e) = found {
                break e;
            }
        };
        results.push((job, outcome));
    }
    print_trace(sim.trace(), out);
    for (job, outcome) in results {
        let what = format!(
            "task {} {}{}",
            job.task,
            job.param,
            if job.task == frame::task::READ {
                String::new()
            } else {
                format!(" := {}", job.value)
            }
        );
        match outcome {
            Event::ParameterDone { response, .. } => out.line(
                &format!(
                    "{what}: done, response ID {} value {}",
                    response.pke.ak(),
                    response.value()
                ),
                json!({"task": job.task, "pnu": job.param.number, "done": true,
                       "response_id": response.pke.ak(), "value": response.value()}),
            ),
            Event::ParameterFailed {
                status,
                error_number,
                ..
            } => out.line(
                &format!(
                    "{what}: failed {}{}",
                    status_text(status),
                    error_number
                        .map(|n| format!(", error number {n} ({})", pkw_error_text(n)))
                        .unwrap_or_default()
                ),
                json!({"task": job.task, "pnu": job.param.number, "done": false,
                       "status": status.code(), "error_number": error_number}),
            ),
            _ => {}
        }
    }
    Ok(())
}
