//! `si gateway`: Modbus TCP clients served by Modbus RTU lines, as mbusd does, several lines
//! in one process, and by USS, RK 512 and 3964(R) lines.
//!
//! Requests are routed by unit id to a line ([`router`](si_gateway::router)); a Modbus RTU or RK 512 line has a
//! bounded queue served in round-robin order between clients ([`queue`](si_gateway::queue)) by a task driving the
//! line's master ([`mod@line`]), USS and 3964(R) lines answer from their images at once;
//! counters per line and per client are printed as status lines and readable on a diagnostic
//! unit ([`counters`](si_gateway::counters)). The configuration is a TOML file or flags ([`config`]); the RS-485
//! direction modes (`kernel`, `rts`, `rts-inverted`, `sysfs`, `sysfs-inverted`) apply to every
//! line kind. A line whose port closes is reopened while its requests get 0AH ([`reopen`](si_gateway::reopen));
//! with `allow_down_at_start` a line whose port cannot be opened at start starts that way.
//! A `kind = "uss"` line serves USS drives instead: each drive is a unit id whose PZD and
//! parameter window are registers ([`uss`](si_gateway::uss), keys in [`uss_config`](si_gateway::uss_config)). A `kind = "rk512"` line
//! serves an RK 512 partner's S7 memory through S_MODB's conversion DB, or the gateway's own
//! memory as a passive partner ([`rk512`](si_gateway::rk512), [`rk512_own`](si_gateway::rk512_own), keys in [`rk512_config`](si_gateway::rk512_config), spans in
//! [`rk512_spans`](si_gateway::rk512_spans)); a `kind = "3964r"` line shows a plain 3964(R) partner's latest block as
//! input registers and sends a block for a register write ([`r3964`](si_gateway::r3964), keys in
//! [`r3964_config`](si_gateway::r3964_config)). Every line kind is reopened the same way when its port closes. A line
//! may have its own listening address ([`faces`]), so that more than 255 lines fit in one
//! process; the open-file limit is raised for them ([`limits`]).

mod limits;

use crate::conn::Connection;
use crate::error::CliError;
use crate::output::Output;
use clap::Args;
use si_gateway::config::{self, File, Gateway, LineFile};
use si_gateway::counters::Stats;
use si_gateway::open::Opening;
use si_gateway::{faces, line, Event};
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
        let opening = Opening {
            no_line_errors: conn.no_line_errors,
            tap: Some(tap(conn)),
        };
        let (stats, lines) = si_gateway::start::lines(&gw, &opening, &events(*out)).await?;
        let lines: Arc<[si_gateway::router::LineHandle]> = lines.into();
        let bound = faces::bind(&gw, Arc::clone(&lines), &stats).await?;
        out.line(
            &faces::listening_text(&gw, &bound),
            faces::listening_json(&gw, &bound),
        );
        for (event, addr) in si_gateway::listeners::start(&gw, bound.len(), lines, &stats).await? {
            let name = event.trim_end_matches("_listening").replace('_', "-");
            out.line(
                &format!("{name}: listening on {addr}"),
                serde_json::json!({"event": event, "addr": addr.to_string()}),
            );
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

/// The global flags' tap on every line's port: `--record`'s trace and -v's frame log, as on
/// any other command's port.
fn tap(conn: &Connection) -> si_gateway::open::Tap {
    let conn = conn.clone();
    Arc::new(move |protocol, settings, transport| {
        let mut c = conn.clone();
        c.protocol = Some(protocol);
        c.tap(transport, settings)
            .map_err(|e| si_gateway::Error::Port(e.text().to_owned()))
    })
}

/// The lines' events as log lines: text, or JSON with `--json`.
fn events(out: Output) -> si_gateway::Events {
    Arc::new(move |event: &Event| match event {
        Event::LineDown {
            name,
            reason,
            at_start,
            ..
        } => {
            let text = if *at_start {
                format!("line {name}: not opened at start ({reason}); trying again")
            } else {
                format!("line {name}: closed ({reason}); reopening")
            };
            out.line(
                &text,
                serde_json::json!({"event": "line_down", "line": name, "reason": reason,
                    "at_start": at_start}),
            );
        }
        Event::LineUp {
            name,
            reconnects,
            reopened,
            ..
        } => {
            let done = if *reopened { "reopened" } else { "opened" };
            out.line(
                &format!("line {name}: {done}"),
                serde_json::json!({"event": "line_up", "line": name, "reconnects": reconnects}),
            );
        }
        Event::UnitDemoted {
            name,
            unit,
            failures,
            for_ms,
            ..
        } => out.line(
            &format!(
                "line {name}: unit {unit} demoted for {for_ms} ms after {failures} failed requests"
            ),
            serde_json::json!({"event": "unit_demoted", "line": name, "unit": unit,
                "failures": failures, "for_ms": for_ms}),
        ),
        Event::UnitProbeFailed {
            name, unit, for_ms, ..
        } => out.line(
            &format!("line {name}: unit {unit} still not answering; demoted for {for_ms} ms more"),
            serde_json::json!({"event": "unit_probe_failed", "line": name, "unit": unit,
                "for_ms": for_ms}),
        ),
        Event::UnitRestored { name, unit, .. } => out.line(
            &format!("line {name}: unit {unit} answers again"),
            serde_json::json!({"event": "unit_restored", "line": name, "unit": unit}),
        ),
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
