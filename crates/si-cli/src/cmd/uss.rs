//! `si uss`: the USS master on a line (poll drives, read and write parameters), a simulated drive,
//! offline telegrams and the USS simulator scenarios (et200s-si-modbus-uss.md §6, public-facts.md §3).

use crate::conn::Connection;
use crate::error::CliError;
use crate::output::Output;
use crate::scenario::{print_trace, Scenario, SimOptions};
use clap::{Args, Subcommand};
use serde_json::json;
use si_core::driver::{spawn, DriverOptions};
use si_core::sim::Simulator;
use si_core::{Duration, Instant, SerialSettings, Status};
use si_uss::config::{MasterConfig, PollEntry};
use si_uss::drive::{stw, Drive, DriveConfig, DriveEvent};
use si_uss::frame::{self, pkw_error_text, Adr, NetData, ParamAddress, PkwWords, MAX_TELEGRAM};
use si_uss::master::{Event, Master, ParamRequest};
use si_uss::tokio::{Error as UssError, Handle};

/// The protocol's subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Poll drives cyclically; prints status word and actual value per slave per cycle.
    Poll(PollArgs),
    /// Read a parameter value (PKW task 1, or 6 for an array element with --array).
    ReadParam(ReadArgs),
    /// Write a parameter value (PKW task 2, or 3 with --dword).
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
    response_timeout: u64,
    /// WDH: PKW repetitions without a matching response before the job fails.
    #[arg(long, default_value_t = 20)]
    retries: u16,
}

impl Structure {
    fn config(&self, settings: SerialSettings, slaves: &[u8]) -> Result<MasterConfig, CliError> {
        let pkw = PkwWords::from_count(self.pkw_words).ok_or_else(|| {
            CliError::new(format!(
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
        c.response_timeout = Duration::from_millis(self.response_timeout);
        c.pkw_retries = self.retries;
        c.validate()?;
        Ok(c)
    }
}

/// `si uss poll`.
#[derive(Debug, Args)]
pub struct PollArgs {
    /// Node numbers in polling order, e.g. 1,2,5 (a node may appear twice).
    #[arg(long, value_delimiter = ',', required = true)]
    slaves: Vec<u8>,
    /// Control word STW (PZD1) in hex, sent to every slave, e.g. 047F.
    #[arg(long)]
    stw: Option<String>,
    /// Main setpoint HSW (PZD2) in hex, e.g. 4000.
    #[arg(long)]
    hsw: Option<String>,
    /// Stop after this many cycles (default: until interrupted).
    #[arg(long)]
    cycles: Option<u64>,
    #[command(flatten)]
    structure: Structure,
}

/// `si uss read-param`.
#[derive(Debug, Args)]
pub struct ReadArgs {
    /// Node number.
    #[arg(long)]
    slave: u8,
    /// Parameter number, optionally with sub-index: 700 or 2010:1.
    param: String,
    /// Read an array element (task 6) instead of a value (task 1).
    #[arg(long)]
    array: bool,
    #[command(flatten)]
    structure: Structure,
}

/// `si uss write-param`.
#[derive(Debug, Args)]
pub struct WriteArgs {
    /// Node number.
    #[arg(long)]
    slave: u8,
    /// Parameter number, optionally with sub-index: 1082 or 2010:1.
    param: String,
    /// The value (decimal, or hex with 0x).
    value: String,
    /// Write a double word (task 3) instead of a word (task 2).
    #[arg(long)]
    dword: bool,
    #[command(flatten)]
    structure: Structure,
}

/// `si uss sim-slave`.
#[derive(Debug, Args)]
pub struct SimSlaveArgs {
    /// Bus address 0…31.
    #[arg(long)]
    address: u8,
    /// PKW words: 0, 3 or 4.
    #[arg(long, default_value_t = 4)]
    pkw_words: u8,
    /// PZD words: 0…16.
    #[arg(long, default_value_t = 2)]
    pzd_words: u8,
}

fn parse_word(what: &str, text: &str) -> Result<u16, CliError> {
    let t = text.trim_start_matches("0x").trim_start_matches("16#");
    u16::from_str_radix(t, 16)
        .map_err(|_| CliError::new(format!("{what} {text:?} is not a hex word (0000…FFFF)")))
}

fn parse_value(text: &str) -> Result<u32, CliError> {
    let r = match text.strip_prefix("0x") {
        Some(h) => u32::from_str_radix(h, 16),
        None => text.parse(),
    };
    r.map_err(|_| CliError::new(format!("value {text:?} is not a number 0…4294967295")))
}

fn parse_param(text: &str) -> Result<ParamAddress, CliError> {
    let bad = || {
        CliError::new(format!(
            "parameter {text:?} is not PNU[:IND] with PNU 0…{} and IND 0…255",
            ParamAddress::MAX_NUMBER
        ))
    };
    let (n, i) = text.split_once(':').unwrap_or((text, "0"));
    let number: u16 = n.parse().map_err(|_| bad())?;
    let index: u8 = i.parse().map_err(|_| bad())?;
    if number > ParamAddress::MAX_NUMBER {
        return Err(bad());
    }
    Ok(ParamAddress { number, index })
}

fn status_text(status: Status) -> String {
    if status.info().is_some() {
        status.to_string()
    } else {
        Status::lookup(status.code(), &[si_uss::status::CATALOG]).to_string()
    }
}

fn uss_error(e: UssError) -> CliError {
    match e {
        UssError::Failed {
            status,
            error_number,
        } => CliError::new(match error_number {
            Some(n) => format!(
                "{}: error number {n} ({})",
                status_text(status),
                pkw_error_text(n)
            ),
            None => status_text(status),
        }),
        other => CliError::new(other.to_string()),
    }
}

async fn open_master(conn: &Connection, config: MasterConfig) -> Result<Handle, CliError> {
    let transport = conn.open_with(&config.settings).await?;
    Ok(Handle::spawn(config, transport)?)
}

impl Command {
    /// Run it on the line.
    pub async fn run(self, conn: &Connection, out: &Output) -> Result<(), CliError> {
        match self {
            Command::Poll(a) => poll(a, conn, out).await,
            Command::ReadParam(a) => {
                let param = parse_param(&a.param)?;
                let config = a.structure.config(
                    conn.settings_for(&si_uss::config::USS_BAUD_RATES)?,
                    &[a.slave],
                )?;
                let m = open_master(conn, config).await?;
                let request = if a.array {
                    ParamRequest::read_array(param.number, param.index)
                } else {
                    ParamRequest::read(param.number, param.index)
                };
                let r = m.parameter(a.slave, request).await.map_err(uss_error)?;
                out.line(
                    &format!(
                        "slave {} {param} = {} (response ID {})",
                        a.slave,
                        r.value(),
                        r.pke.ak()
                    ),
                    json!({"slave": a.slave, "pnu": param.number, "index": param.index,
                           "value": r.value(), "response_id": r.pke.ak()}),
                );
                Ok(())
            }
            Command::WriteParam(a) => {
                let param = parse_param(&a.param)?;
                let value = parse_value(&a.value)?;
                if !a.dword && value > u32::from(u16::MAX) {
                    return Err(CliError::new(format!(
                        "value {value} does not fit a word; add --dword"
                    )));
                }
                let config = a.structure.config(
                    conn.settings_for(&si_uss::config::USS_BAUD_RATES)?,
                    &[a.slave],
                )?;
                let m = open_master(conn, config).await?;
                let request = ParamRequest::write(param.number, param.index, value, a.dword);
                let r = m.parameter(a.slave, request).await.map_err(uss_error)?;
                out.line(
                    &format!("slave {} {param} := {} done", a.slave, r.value()),
                    json!({"slave": a.slave, "pnu": param.number, "index": param.index,
                           "value": r.value(), "response_id": r.pke.ak()}),
                );
                Ok(())
            }
            Command::SimSlave(a) => sim_slave(a, conn, out).await,
        }
    }
}

async fn poll(a: PollArgs, conn: &Connection, out: &Output) -> Result<(), CliError> {
    let config = a.structure.config(
        conn.settings_for(&si_uss::config::USS_BAUD_RATES)?,
        &a.slaves,
    )?;
    let mut words = Vec::new();
    if a.stw.is_some() || a.hsw.is_some() {
        words.push(a.stw.as_deref().map_or(Ok(0), |t| parse_word("--stw", t))?);
    }
    if let Some(h) = &a.hsw {
        words.push(parse_word("--hsw", h)?);
    }
    if words.len() > usize::from(a.structure.pzd_words) {
        return Err(CliError::new(format!(
            "--stw/--hsw need {} PZD words, --pzd-words is {}",
            words.len(),
            a.structure.pzd_words
        )));
    }
    let mut m = open_master(conn, config).await?;
    if !words.is_empty() {
        let mut seen = Vec::new();
        for &s in &a.slaves {
            if !seen.contains(&s) {
                seen.push(s);
                m.set_control(s, words.clone()).await.map_err(uss_error)?;
            }
        }
    }
    let mut failures = 0u64;
    while let Some(event) = m.next_event().await {
        match event {
            Event::Response {
                cycle,
                address,
                net,
            } => {
                let zsw = net.pzd.first();
                let hiw = net.pzd.second();
                let show = |w: Option<u16>| w.map_or("-".to_owned(), |w| format!("16#{w:04X}"));
                out.line(
                    &format!(
                        "cycle {cycle} slave {address}: ZSW {} HIW {}",
                        show(zsw),
                        hiw.map_or("-".to_owned(), |w| w.to_string())
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
                return Ok(());
            }
            _ => {}
        }
    }
    Err(CliError::new("the line was closed"))
}

async fn sim_slave(a: SimSlaveArgs, conn: &Connection, out: &Output) -> Result<(), CliError> {
    let settings = conn.settings_for(&si_uss::config::USS_BAUD_RATES)?;
    let pkw = PkwWords::from_count(a.pkw_words)
        .filter(|p| *p != PkwWords::Variable)
        .ok_or_else(|| {
            CliError::new(format!(
                "--pkw-words {} is out of range: 0, 3 or 4",
                a.pkw_words
            ))
        })?;
    let drive = Drive::new(DriveConfig {
        pkw,
        pzd_words: a.pzd_words,
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
                    &format!("control word 16#{stw:04X}, setpoint {setpoint}"),
                    json!({"stw": stw, "setpoint": setpoint}),
                );
            }
            DriveEvent::Written { param, value } => out.line(
                &format!("{param} := {value}"),
                json!({"pnu": param.number, "index": param.index, "value": value}),
            ),
            DriveEvent::Discarded { reason } => out.line(
                &format!("discarded: {reason}"),
                json!({"discarded": reason}),
            ),
            _ => {}
        }
    }
    Ok(())
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
) -> Result<si_core::sim::StationId<Master>, CliError> {
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
        for a in [1, 3] {
            let _ = m.set_control(a, &[stw::RUN, 1000]);
        }
    });
    while sim.engine(m).cycle() < 3 && sim.step() {}
    print_trace(sim.trace(), out);
    let master = sim.engine(m);
    for s in master.slaves() {
        out.line(
            &format!(
                "slave {}: ZSW {} HIW {} comm status 16#{:04X} comm error 16#{:04X} last {}",
                s.address,
                s.status_word()
                    .map_or("-".into(), |w| format!("16#{w:04X}")),
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
        ParamRequest::write(1082, 0, 120, false),
        ParamRequest::read(1082, 0),
        ParamRequest::write(1082, 0, 1000, false),
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
