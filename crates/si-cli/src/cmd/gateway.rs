//! `si gateway`: Modbus TCP clients served by Modbus RTU lines, as mbusd does, several lines
//! in one process, and by USS, RK 512 and 3964(R) lines.
//!
//! Requests are routed by unit id to a line ([`router`]); a Modbus RTU or RK 512 line has a
//! bounded queue served in round-robin order between clients ([`queue`]) by a task driving the
//! line's master ([`mod@line`]), USS and 3964(R) lines answer from their images at once;
//! counters per line and per client are printed as status lines and readable on a diagnostic
//! unit ([`counters`]). The configuration is a TOML file or flags ([`config`]); the RS-485
//! direction modes (`kernel`, `rts`, `rts-inverted`, `sysfs`, `sysfs-inverted`) apply to every
//! line kind. A line whose port closes is reopened while its requests get 0AH ([`reopen`]);
//! with `allow_down_at_start` a line whose port cannot be opened at start starts that way.
//! A `kind = "uss"` line serves USS drives instead: each drive is a unit id whose PZD and
//! parameter window are registers ([`uss`], keys in [`uss_config`]). A `kind = "rk512"` line
//! serves an RK 512 partner's S7 memory through S_MODB's conversion DB, or the gateway's own
//! memory as a passive partner ([`rk512`], [`rk512_own`], keys in [`rk512_config`], spans in
//! [`rk512_spans`]); a `kind = "3964r"` line shows a plain 3964(R) partner's latest block as
//! input registers and sends a block for a register write ([`r3964`], keys in
//! [`r3964_config`]). Every line kind is reopened the same way when its port closes. A line
//! may have its own listening address ([`faces`]), so that more than 255 lines fit in one
//! process; the open-file limit is raised for them ([`limits`]).

mod config;
mod counters;
mod demotion;
mod faces;
mod gateway_metrics;
mod limits;
mod line;
mod metrics;
mod metrics_http;
mod quantities;
mod queue;
mod r3964;
mod r3964_config;
mod reopen;
mod rk512;
mod rk512_config;
mod rk512_own;
mod rk512_spans;
mod router;
mod rtu_listener;
mod uss;
mod uss_config;

use crate::conn::Connection;
use crate::error::CliError;
use crate::output::Output;
use clap::Args;
use config::{Device, File, Gateway, Kind, LineFile};
use counters::Stats;
use si_modbus::config::LineConfig;
use si_modbus::{MasterConfig, Mode};
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// `si gateway`: a Modbus TCP server whose unit ids are slaves on Modbus RTU lines, USS
/// drives, RK 512 or 3964(R) partners (`kind` in the file).
///
/// Either `--config FILE` (TOML, any number of `[[line]]`s; see the README's "si gateway") or
/// one line from flags: `si gateway --listen 127.0.0.1:5020 --line /dev/ttyUSB0 --baud 19200
/// --units 1-10`. The serial settings and RS-485 options of a flag-configured line are the
/// global ones (`--baud`, `--parity`, `--rs485` …). A slave that does not answer gives
/// exception 0BH, a unit no line serves 0AH, a full queue 06H; slave exceptions pass unchanged.
#[derive(Debug, Clone, Args)]
#[command(next_help_heading = "Gateway options")]
pub struct GatewayArgs {
    /// The TOML configuration file (lines, routes, limits); its lines take their serial
    /// settings from the file, not from the global flags.
    #[arg(
        long,
        value_name = "FILE",
        conflicts_with_all = ["line", "units", "retries", "timeout", "pause", "queue", "broadcast"]
    )]
    config: Option<PathBuf>,
    /// TCP address to listen on (overrides the file's `listen`; default 127.0.0.1:502).
    #[arg(long, value_name = "HOST:PORT")]
    listen: Option<String>,
    /// The one line of the flag form: a serial port, or tcp:HOST:PORT for a device server.
    #[arg(long, value_name = "DEVICE", requires = "units")]
    line: Option<String>,
    /// Unit ids served by --line, e.g. 1-10,12.
    #[arg(long, value_name = "LIST")]
    units: Option<String>,
    /// Retries after a timeout or corrupt answer, 0–15 (default 2: mbusd's 3 tries).
    #[arg(long)]
    retries: Option<u8>,
    /// Response timeout, 50–655000 ms (default 500, mbusd's).
    #[arg(long, value_name = "MS")]
    timeout: Option<u32>,
    /// Pause after each request before the next, 0–10000 ms (default 100, mbusd's).
    #[arg(long, value_name = "MS")]
    pause: Option<u64>,
    /// Requests waiting per line, 1–1024 (default 32); one more is refused with 06H.
    #[arg(long)]
    queue: Option<usize>,
    /// Forward broadcasts (unit 0) to the line; without, unit 0 is refused with 0AH.
    #[arg(long)]
    broadcast: bool,
    /// Answer a broadcast with its echo once sent (mbusd's -b); default: no answer.
    #[arg(long)]
    reply_on_broadcast: bool,
    /// Connections served at once, 1–1024 (default 32, mbusd's).
    #[arg(long)]
    max_connections: Option<usize>,
    /// Unit id answering the counters as input registers (README "si gateway").
    #[arg(long, value_name = "UNIT")]
    diagnostic_unit: Option<u8>,
    /// Print the counters every S seconds (always once at exit, after SIGINT or SIGTERM alike).
    /// The gateway outlives its stdout: if stdout cannot be written (a closed pipe or FIFO),
    /// that is said once on stderr and it goes on serving.
    #[arg(long, value_name = "S")]
    status_every: Option<u64>,
    /// A line whose device cannot be opened at start starts down (0AH) and is reopened like
    /// a line whose port closed, instead of stopping the gateway.
    #[arg(long)]
    allow_down_at_start: bool,
}

impl GatewayArgs {
    /// The checked configuration: the file with the top-level flags over it, or the flag form.
    /// An error in the file names the file, then where in it (the TOML line and column, or the
    /// `[[line]]`) and the key, on a line of at most [`config::MAX_ERROR_LINE`] characters.
    fn gateway(&self, conn: &Connection) -> Result<Gateway, CliError> {
        match &self.config {
            Some(path) => {
                let file = crate::config_file::read_toml::<File>(path)?;
                self.over(file).map_err(|e| {
                    CliError::new(format!(
                        "{}: {}",
                        path.display(),
                        config::cut(&e.to_string())
                    ))
                })
            }
            None => {
                let file = File {
                    listen: None,
                    max_connections: None,
                    idle_timeout_s: None,
                    diagnostic_unit: None,
                    reply_on_broadcast: false,
                    allow_down_at_start: false,
                    metrics_listen: None,
                    rtu_over_tcp_listen: None,
                    lines: vec![self.flag_line(conn)?],
                };
                self.over(file)
                    .map_err(|e| CliError::new(config::cut(&e.to_string())))
            }
        }
    }

    /// `file` with the top-level flags over it, checked.
    fn over(&self, mut file: File) -> Result<Gateway, config::ConfigError> {
        file.listen = self.listen.clone().or(file.listen);
        file.max_connections = self.max_connections.or(file.max_connections);
        file.diagnostic_unit = self.diagnostic_unit.or(file.diagnostic_unit);
        file.reply_on_broadcast |= self.reply_on_broadcast;
        file.allow_down_at_start |= self.allow_down_at_start;
        file.check()
    }

    /// The line of the flag form, with the global serial flags.
    fn flag_line(&self, conn: &Connection) -> Result<LineFile, CliError> {
        let device = self
            .line
            .clone()
            .or_else(|| conn.port.clone())
            .or_else(|| conn.tcp.as_ref().map(|t| format!("tcp:{t}")))
            .ok_or_else(|| {
                CliError::new("no line: use --config FILE, or --line DEVICE --units LIST")
            })?;
        Ok(LineFile {
            device: Some(device),
            baud: Some(conn.baud),
            data_bits: Some(conn.data_bits),
            parity: Some(conn.parity.clone()),
            stop_bits: Some(conn.stop_bits),
            rs485: conn.rs485.map(|m| m.name().to_owned()),
            rs485_file: conn.rs485_file.clone(),
            rs485_delay_before_ms: Some(conn.rs485_delay_before),
            rs485_delay_after_ms: Some(conn.rs485_delay_after),
            local_echo: conn.local_echo,
            latency_timer_ms: conn.latency_timer,
            rx_latency_ms: conn.rx_latency,
            units: self.units.clone(),
            retries: self.retries,
            pause_ms: self.pause,
            response_timeout_ms: self.timeout,
            broadcast: self.broadcast,
            queue: self.queue,
            ..LineFile::default()
        })
    }

    /// Open every line, listen, and serve until Ctrl-C.
    pub async fn run(self, conn: &Connection, out: &Output) -> Result<(), CliError> {
        let gw = self.gateway(conn)?;
        crate::output::outlive_stdout();
        let listeners = faces::faces(&gw).len();
        limits::raise_open_files(limits::descriptors_needed(&gw, listeners))?;
        let stats = Arc::new(Mutex::new(Stats::new(gw.lines.len())));
        {
            let mut s = line::lock(&stats);
            s.metrics = gateway_metrics::GatewayMetrics::new(
                gw.lines.iter().map(|l| l.name.clone()).collect(),
            );
            s.health = gw
                .lines
                .iter()
                .map(|l| demotion::LineHealth::new(l.demotion))
                .collect();
        }
        let mut queues = Vec::with_capacity(gw.lines.len());
        for (i, l) in gw.lines.iter().enumerate() {
            let log = reopen::LineLog {
                index: i,
                name: l.name.clone(),
                stats: Arc::clone(&stats),
                out: *out,
            };
            let (conn, l) = (conn.clone(), l.clone());
            let handle = match &l.kind {
                Kind::ModbusRtu => {
                    let first = start(open_line(&conn, &l).await, &gw, &l)?;
                    let queue = Arc::new(line::LineQueue::new(l.queue));
                    let (q, pause) = (Arc::clone(&queue), l.pause);
                    let open = async move || Ok(open_line(&conn, &l).await?);
                    tokio::spawn(line::run(log, q, first, open, pause));
                    router::LineHandle::Rtu(queue)
                }
                Kind::Uss(u) => {
                    let u = u.clone();
                    let first = start(open_uss(&conn, &l, &u).await, &gw, &l)?;
                    let drives = uss::UssDrives::new(&u);
                    let open = async move || Ok(open_uss(&conn, &l, &u).await?);
                    tokio::spawn(drives.supervise(log, first, open));
                    router::LineHandle::Uss(drives)
                }
                Kind::Rk512(r) => {
                    let (r, pause) = (r.clone(), l.pause);
                    let queue = Arc::new(line::LineQueue::new(l.queue));
                    let q = Arc::clone(&queue);
                    match r.role {
                        rk512_config::Role::Active => {
                            let first = start(open_rk512(&conn, &l, &r, None).await, &gw, &l)?;
                            let partner = rk512::Partner::new(&r);
                            let open = async move || Ok(open_rk512(&conn, &l, &r, None).await?);
                            tokio::spawn(rk512::run(log, q, partner, first, open, pause));
                        }
                        rk512_config::Role::Passive => {
                            let own = rk512_own::OwnMemory::new(&r);
                            let kept = own.kept();
                            let first = start(open_rk512(&conn, &l, &r, None).await, &gw, &l)?;
                            let open =
                                async move || Ok(open_rk512(&conn, &l, &r, Some(&kept)).await?);
                            tokio::spawn(own.run(log, q, first, open));
                        }
                    }
                    router::LineHandle::Rk512(queue)
                }
                Kind::R3964(link) => {
                    let link = *link;
                    let first = start(open_3964r(&conn, &l, &link).await, &gw, &l)?;
                    let blocks = r3964::BlockLine::new(link.max_block_len.into());
                    let open = async move || Ok(open_3964r(&conn, &l, &link).await?);
                    tokio::spawn(blocks.supervise(log, first, open));
                    router::LineHandle::R3964(blocks)
                }
            };
            queues.push(handle);
        }
        let lines: Arc<[router::LineHandle]> = queues.into();
        let bound = faces::bind(&gw, Arc::clone(&lines), &stats).await?;
        out.line(
            &faces::listening_text(&gw, &bound),
            faces::listening_json(&gw, &bound),
        );
        let rtu = match &gw.rtu_over_tcp_listen {
            Some(addr) => {
                let face = &faces::faces(&gw)[0];
                let handler = faces::handler(&gw, bound.len() as u64, face, lines, &stats);
                let listener = listen(addr, "rtu_over_tcp_listening", out).await?;
                let counters = Arc::new(rtu_listener::RtuCounters::default());
                let run = rtu_listener::run(listener, Arc::new(handler), Arc::clone(&counters), 0);
                tokio::spawn(async move {
                    if let Err(e) = run.await {
                        tracing::error!("RTU-over-TCP listener stopped: {e}");
                    }
                });
                Some(counters)
            }
            None => None,
        };
        if let Some(addr) = &gw.metrics_listen {
            let listener = listen(addr, "metrics_listening", out).await?;
            let source = metrics_http::Source {
                stats: Arc::clone(&stats),
                rtu,
            };
            tokio::spawn(async move {
                if let Err(e) = metrics_http::run(listener, source).await {
                    tracing::error!("metrics listener stopped: {e}");
                }
            });
        }
        let mut server = tokio::spawn(faces::run(bound));
        let every = self
            .status_every
            .filter(|&s| s > 0)
            .map(Duration::from_secs);
        let mut terminate = terminate_signal()?;
        let result = loop {
            let tick = async {
                match every {
                    Some(d) => tokio::time::sleep(d).await,
                    None => std::future::pending().await,
                }
            };
            tokio::select! {
                _ = tokio::signal::ctrl_c() => break Err(CliError::interrupted()),
                () = terminate.recv() => break Err(CliError::interrupted()),
                ended = &mut server => break match ended {
                    Ok(Err(e)) => Err(CliError::new(format!("gateway stopped: {e}"))),
                    _ => Err(CliError::new("gateway stopped")),
                },
                () = tick => print_status(&gw, &stats, out),
            }
        };
        print_status(&gw, &stats, out);
        result
    }
}

/// Bind one of the extra listeners (metrics, RTU over TCP) and say where it listens with the
/// event `event` (its `addr`, the port resolved).
async fn listen(
    addr: &str,
    event: &str,
    out: &Output,
) -> Result<tokio::net::TcpListener, CliError> {
    let listener = tokio::net::TcpListener::bind(addr)
        .await
        .map_err(|e| CliError::new(format!("cannot listen on {addr}: {e}")))?;
    let at = listener.local_addr()?.to_string();
    out.line(
        &format!(
            "{}: listening on {at}",
            event.trim_end_matches("_listening").replace('_', "-")
        ),
        serde_json::json!({"event": event, "addr": at}),
    );
    Ok(listener)
}

/// SIGTERM, what a service manager stops the gateway with: it ends the gateway as SIGINT does,
/// with the final counters and exit code 130 (without a handler the process would die
/// silently).
struct Terminate {
    #[cfg(unix)]
    signal: tokio::signal::unix::Signal,
}

impl Terminate {
    /// The next SIGTERM (never, where there is none).
    async fn recv(&mut self) {
        #[cfg(unix)]
        {
            self.signal.recv().await;
        }
        #[cfg(not(unix))]
        std::future::pending::<()>().await
    }
}

/// Watch SIGTERM from now on.
fn terminate_signal() -> Result<Terminate, CliError> {
    Ok(Terminate {
        #[cfg(unix)]
        signal: tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate())
            .map_err(|e| CliError::new(format!("cannot watch SIGTERM: {e}")))?,
    })
}

/// The connection options of line `l`: the common ones (trace, monitor) with the line's port.
fn line_connection(conn: &Connection, l: &config::Line, protocol: &'static str) -> Connection {
    let mut c = conn.clone();
    (c.port, c.tcp) = match &l.device {
        Device::Port(p) => (Some(p.clone()), None),
        Device::Tcp(t) => (None, Some(t.clone())),
    };
    c.baud = l.baud;
    c.data_bits = l.data_bits;
    c.parity = l.parity.clone();
    c.stop_bits = l.stop_bits;
    // Names checked with the file (`LineFile::check_rs485`).
    c.rs485 = l.rs485.as_deref().and_then(|name| name.parse().ok());
    c.rs485_file = l.rs485_file.clone();
    (c.rs485_delay_before, c.rs485_delay_after) = l.rs485_delays_ms;
    c.local_echo = l.local_echo;
    c.latency_timer = l.latency_timer_ms;
    c.rx_latency = l.rx_latency_ms;
    c.protocol = Some(protocol);
    c
}

/// Why a line could not be opened: its configuration, which no retry can mend (the gateway
/// stops, naming it), or its port (a device missing or busy: with `allow_down_at_start` the
/// line starts down and is reopened).
enum OpenError {
    /// The line's settings or engine configuration were refused.
    Config(CliError),
    /// The port could not be opened.
    Port(CliError),
}

impl From<OpenError> for CliError {
    fn from(e: OpenError) -> CliError {
        match e {
            OpenError::Config(e) | OpenError::Port(e) => e,
        }
    }
}

/// How line `l` starts from its first opening: open, or (with `allow_down_at_start` and a port
/// that cannot be opened) down with the reason; otherwise the error stops the gateway.
fn start<L>(
    opened: Result<reopen::Opened<L>, OpenError>,
    gw: &Gateway,
    l: &config::Line,
) -> Result<reopen::First<L>, CliError> {
    match opened {
        Ok(o) => Ok(Ok(o)),
        Err(OpenError::Port(e)) if gw.allow_down_at_start => {
            let prefix = format!("line {}: ", l.name);
            Ok(Err(e.text().trim_start_matches(&prefix).to_owned()))
        }
        Err(e) => Err(e.into()),
    }
}

/// `line NAME: why`.
fn named(l: &config::Line) -> impl Fn(CliError) -> CliError + '_ {
    move |e| CliError::new(format!("line {}: {}", l.name, e.text()))
}

/// Open a USS line and start its master polling the drives.
async fn open_uss(
    conn: &Connection,
    l: &config::Line,
    u: &uss_config::UssLine,
) -> Result<reopen::Opened<si_uss::tokio::Handle>, OpenError> {
    let rates = Some(&si_uss::config::USS_BAUD_RATES[..]);
    open_engine(conn, l, "uss", rates, |settings| {
        let mut config = u.master.clone();
        config.settings = settings;
        si_uss::Master::new(config)
    })
    .await
    .map(|o| o.spawn(si_uss::tokio::Handle::spawn_engine))
}

/// Open an RK 512 line and start its station: active only, or serving the line's memory in
/// the passive role, from the memory `kept` before its port last closed, if any.
async fn open_rk512(
    conn: &Connection,
    l: &config::Line,
    r: &rk512_config::Rk512Line,
    kept: Option<&rk512_own::Kept>,
) -> Result<reopen::Opened<si_rk512::tokio::Handle>, OpenError> {
    open_engine(conn, l, "rk512", None, |settings| match r.role {
        rk512_config::Role::Active => si_rk512::Station::new(r.config, settings),
        rk512_config::Role::Passive => {
            let server = si_rk512::passive::ServerConfig {
                memory: r.memory.clone(),
                ..si_rk512::passive::ServerConfig::default()
            };
            let mut station = si_rk512::Station::serving(r.config, settings, &server)?;
            if let Some(kept) = kept {
                kept.restore(&mut station);
            }
            Ok(station)
        }
    })
    .await
    .map(|o| o.spawn(si_rk512::tokio::Handle::spawn_engine))
}

/// Open a plain 3964(R) line and start its link.
async fn open_3964r(
    conn: &Connection,
    l: &config::Line,
    link: &si_3964r::Config,
) -> Result<reopen::Opened<si_3964r::tokio::Handle>, OpenError> {
    open_engine(conn, l, "3964r", None, |settings| {
        si_3964r::Link::new(*link, settings)
    })
    .await
    .map(|o| o.spawn(si_3964r::tokio::Handle::spawn_engine))
}

/// Open a Modbus RTU line and start its master.
async fn open_line(
    conn: &Connection,
    l: &config::Line,
) -> Result<reopen::Opened<si_modbus::tokio::Master>, OpenError> {
    // On RS-485 a response is recognised by its address, skipping a turnaround glitch ([Modbus/USS]
    // §3.4.1, §3.4.3).
    let interface = if l.rs485.is_some() {
        si_core::Interface::Rs485
    } else {
        si_core::Interface::Rs232
    };
    open_engine(conn, l, "modbus", None, |settings| {
        let gap = spec_gap(&settings);
        let config = MasterConfig {
            line: LineConfig {
                settings,
                mode: Mode::Normal,
                char_delay_multiplier: l.rtu.char_delay_multiplier,
                local_echo: false,
                auto_v24: None,
            },
            response_timeout: si_core::Duration::from_millis(l.response_timeout_ms.into()),
            retries: l.retries,
            ..MasterConfig::default()
        };
        // A late answer never reaches the next request (si-modbus's quiet guard).
        let quiet = l
            .rtu
            .quiet_after_timeout_ms
            .unwrap_or(l.response_timeout_ms);
        si_modbus::Master::new(config).map(|m| {
            let m = m
                .with_interface(interface)
                .with_frame_end(l.rtu.frame_end)
                .with_quiet_after_timeout(Duration::from_millis(quiet.into()));
            if l.rtu.spec_gap {
                m.with_gap(gap)
            } else {
                m
            }
        })
    })
    .await
    .map(|o| o.spawn(si_modbus::tokio::Master::spawn_engine))
}

/// The Modbus specification's inter-frame silence t3.5 ([Modbus serial] §2.5.1.1): 3.5
/// character times below 19200 bit/s, a fixed 1.75 ms at and above, where the character time
/// would make it too short for a host to time.
fn spec_gap(settings: &si_core::SerialSettings) -> si_core::Duration {
    if settings.baud() >= 19_200 {
        si_core::Duration::from_micros(1_750)
    } else {
        let seven_halves = settings.chars_time(7).as_micros();
        si_core::Duration::from_micros(seven_halves.div_ceil(2))
    }
}

/// Build line `l`'s engine for its serial settings (the protocol's baud rates, `rates`, where
/// they differ from the manuals' twelve), checking its configuration before the port opens,
/// then open the port, watched for its closing ([`reopen::watch`]).
async fn open_engine<E, F: std::error::Error>(
    conn: &Connection,
    l: &config::Line,
    protocol: &'static str,
    rates: Option<&'static [u32]>,
    engine: impl FnOnce(si_core::SerialSettings) -> Result<E, F>,
) -> Result<reopen::Opened<(E, Box<dyn si_core::driver::Transport>)>, OpenError> {
    let c = line_connection(conn, l, protocol);
    let named = named(l);
    let settings = match rates {
        Some(rates) => c.settings_for(rates),
        None => c.settings(),
    }
    .map_err(|e| OpenError::Config(named(e)))?;
    let engine = engine(settings).map_err(|e| OpenError::Config(named(e.into())))?;
    let port = c.open_with(&settings).await;
    let (port, closed) = reopen::watch(port.map_err(|e| OpenError::Port(named(e)))?);
    Ok(reopen::Opened {
        link: (engine, port),
        closed,
    })
}

/// One status line: every line's and every client's counters.
fn print_status(gw: &Gateway, stats: &Mutex<Stats>, out: &Output) {
    let s = line::lock(stats);
    let lines: Vec<_> = gw
        .lines
        .iter()
        .zip(s.lines.iter().zip(&s.down))
        .map(|(l, (c, down))| {
            let mut v = serde_json::to_value(c).unwrap_or_default();
            v["name"] = l.name.clone().into();
            v["state"] = if down.is_some() { "down" } else { "up" }.into();
            if let Some(why) = down {
                v["down_reason"] = why.clone().into();
            }
            v
        })
        .collect();
    let clients: Vec<_> = s
        .clients
        .iter()
        .map(|(id, c)| {
            let mut v = serde_json::to_value(c).unwrap_or_default();
            v["id"] = (*id).into();
            v
        })
        .collect();
    let text = gw
        .lines
        .iter()
        .zip(s.lines.iter().zip(&s.down))
        .map(|(l, (c, down))| {
            let state = down.as_ref().map(|why| format!(" (down: {why})")).unwrap_or_default();
            format!(
                "{}{state}: {} requests, {} answers, {} exceptions, {} timeouts, {} CRC errors, {} busy, {} other, queue {}, {} reconnects",
                l.name, c.requests, c.answers, c.exceptions, c.timeouts, c.crc_errors, c.busy, c.other, c.queue_depth, c.reconnects
            )
        })
        .collect::<Vec<_>>()
        .join("; ");
    out.line(
        &format!("status: {text}; {} client(s)", clients.len()),
        serde_json::json!({"event": "status", "lines": lines, "clients": clients}),
    );
}

#[cfg(test)]
mod tests {
    use super::spec_gap;
    use si_core::{Parity, SerialSettings};

    #[test]
    fn the_spec_gap_is_t35_below_19200_and_1_75_ms_from_there() {
        let at = |baud| SerialSettings::new(baud, 8, Parity::Even, 1).unwrap();
        // 9600 8E1: 11 bits a character, 3.5 × 1145.8 µs.
        assert_eq!(spec_gap(&at(9600)).as_micros(), 4011);
        assert_eq!(spec_gap(&at(19_200)).as_micros(), 1750);
        assert_eq!(spec_gap(&at(115_200)).as_micros(), 1750);
    }
}
