//! `si gateway`: Modbus TCP clients served by Modbus RTU and Modbus TCP lines, as mbusd does,
//! several lines in one process, and by USS, RK 512 and 3964(R) lines. The gateway is the
//! si-gateway library; this command turns flags and the `--config` file into its
//! configuration, prints what it reports, reloads on SIGHUP and raises the open-file limit
//! ([`limits`]).

mod limits;

use crate::conn::Connection;
use crate::error::CliError;
use crate::output::Output;
use clap::Args;
use si_gateway::config::{self, Config, File, LineFile};
use si_gateway::open::Opening;
use si_gateway::rtu_config::RtuFile;
use si_gateway::{report, Event, Gateway, Options};
use std::path::PathBuf;
use std::sync::Arc;
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
        conflicts_with_all = [
            "line", "units", "retries", "response_timeout_ms", "pause_ms", "queue", "broadcast"
        ]
    )]
    config: Option<PathBuf>,
    /// Check the TOML configuration FILE and exit: 0 and a summary if it is valid, 2 and the
    /// error (file, line, key) if not. Nothing is opened or bound.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["config", "line"])]
    check: Option<PathBuf>,
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
    response_timeout_ms: Option<u32>,
    /// Pause after each request before the next, 0–10000 ms (default 100, mbusd's).
    #[arg(long, value_name = "MS")]
    pause_ms: Option<u64>,
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
    fn gateway(&self, conn: &Connection) -> Result<Config, CliError> {
        match &self.config {
            Some(path) => {
                let text = crate::config_file::read(path)?;
                let file = File::parse(path, &text)?;
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
                    lines: vec![LineFile::ModbusRtu(self.flag_line(conn)?)],
                    ..File::default()
                };
                self.over(file)
                    .map_err(|e| CliError::new(config::cut(&e.to_string())))
            }
        }
    }

    /// `file` with the top-level flags over it, checked.
    fn over(&self, mut file: File) -> Result<Config, config::ConfigError> {
        file.listen = self.listen.clone().or(file.listen);
        file.max_connections = self.max_connections.or(file.max_connections);
        file.diagnostic_unit = self.diagnostic_unit.or(file.diagnostic_unit);
        file.reply_on_broadcast |= self.reply_on_broadcast;
        file.allow_down_at_start |= self.allow_down_at_start;
        file.check()
    }

    /// The line of the flag form, with the global serial flags.
    fn flag_line(&self, conn: &Connection) -> Result<RtuFile, CliError> {
        let device = self
            .line
            .clone()
            .or_else(|| conn.port.clone())
            .or_else(|| conn.tcp.as_ref().map(|t| format!("tcp:{t}")))
            .ok_or_else(|| {
                CliError::new("no line: use --config FILE, or --line DEVICE --units LIST")
            })?;
        Ok(RtuFile {
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
            pause_ms: self.pause_ms,
            response_timeout_ms: self.response_timeout_ms,
            broadcast: self.broadcast,
            queue: self.queue,
            ..RtuFile::default()
        })
    }

    /// `--check FILE`: the file checked as `--config` would read it, with nothing opened.
    fn check_file(&self, path: &std::path::Path, out: &Output) -> Result<(), CliError> {
        let text = crate::config_file::read(path).map_err(|e| CliError::usage(e.text()))?;
        let gw = File::parse(path, &text)
            .map_err(|e| CliError::usage(e.text()))
            .and_then(|file| {
                self.over(file).map_err(|e| {
                    CliError::usage(format!(
                        "{}: {}",
                        path.display(),
                        config::cut(&e.to_string())
                    ))
                })
            })?;
        let names: Vec<_> = gw.lines.iter().map(|l| l.name.as_str()).collect();
        out.line(
            &format!(
                "{}: valid, {} line(s): {}",
                path.display(),
                names.len(),
                names.join(", ")
            ),
            serde_json::json!({"event": "checked", "file": path.display().to_string(),
                "lines": names}),
        );
        Ok(())
    }

    /// Open every line, listen, and serve until Ctrl-C.
    pub async fn run(self, conn: &Connection, out: &Output) -> Result<(), CliError> {
        if let Some(path) = &self.check {
            return self.check_file(path, out);
        }
        let gw = self.gateway(conn)?;
        crate::output::outlive_stdout();
        limits::raise_open_files(si_gateway::limits::descriptors_needed(&gw))?;
        let options = Options {
            opening: Opening {
                no_line_errors: conn.no_line_errors,
                tap: Some(tap(conn)),
                ..Opening::default()
            },
            on_event: Some(events(*out)),
        };
        let gateway = Gateway::start_with(gw, options).await?;
        let gw = gateway.config().await;
        let listeners = gateway.listeners();
        out.line(
            &report::listening_text(&gw, listeners),
            report::listening_json(&gw, listeners),
        );
        for e in gateway.extra_listeners() {
            out.line(&report::extra_text(e), report::extra_json(e));
        }
        let server = gateway.run();
        tokio::pin!(server);
        let every = self
            .status_every
            .filter(|&s| s > 0)
            .map(Duration::from_secs);
        #[cfg(unix)]
        let (mut terminate, mut hangup) = {
            use tokio::signal::unix::SignalKind;
            (
                Watched::new(SignalKind::terminate())?,
                Watched::new(SignalKind::hangup())?,
            )
        };
        #[cfg(not(unix))]
        let (mut terminate, mut hangup) = (Watched(), Watched());
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
                () = hangup.recv() => self.reload(conn, &gateway, out).await,
                ended = &mut server => break match ended {
                    Err(e) => Err(e.into()),
                    Ok(()) => Ok(()),
                },
                () = tick => print_status(&gateway, out).await,
            }
        };
        print_status(&gateway, out).await;
        result
    }

    /// SIGHUP: the file read and checked again and the gateway changed to it
    /// ([`Gateway::reload`]); a file that does not check is refused with the error it would
    /// give at start, and the running configuration stays.
    async fn reload(&self, conn: &Connection, gateway: &Gateway, out: &Output) {
        let reloaded = match self.config {
            Some(_) => match self.gateway(conn) {
                Ok(config) => gateway.reload(config).await.map_err(CliError::from),
                Err(e) => Err(e),
            },
            None => Err(CliError::new("no --config file to read again")),
        };
        match reloaded {
            Ok(r) => out.line(
                &format!(
                    "reloaded: {} kept, {} restarted, {} added, {} removed",
                    r.kept.len(),
                    r.restarted.len(),
                    r.added.len(),
                    r.removed.len()
                ),
                serde_json::json!({"event": "reloaded", "kept": r.kept,
                    "restarted": r.restarted, "added": r.added, "removed": r.removed}),
            ),
            Err(e) => eprintln!(
                "si: reload refused, the running configuration stays: {}",
                e.text()
            ),
        }
    }
}

/// A signal the gateway watches besides SIGINT: SIGTERM, what a service manager stops it
/// with, ends it as SIGINT does (with the final counters and exit code 130; without a handler
/// the process would die silently); SIGHUP reads the configuration file again.
struct Watched(#[cfg(unix)] tokio::signal::unix::Signal);

impl Watched {
    /// Watch signal `kind` from now on.
    #[cfg(unix)]
    fn new(kind: tokio::signal::unix::SignalKind) -> Result<Self, CliError> {
        let n = kind.as_raw_value();
        let signal = tokio::signal::unix::signal(kind)
            .map_err(|e| CliError::new(format!("cannot watch signal {n}: {e}")))?;
        Ok(Watched(signal))
    }

    /// The next delivery (never, where there are no such signals).
    async fn recv(&mut self) {
        #[cfg(unix)]
        self.0.recv().await;
        #[cfg(not(unix))]
        std::future::pending::<()>().await
    }
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
    Arc::new(move |event: &Event| out.line(&event.to_string(), report::event_json(event)))
}

/// One status line: every line's and every client's counters.
async fn print_status(gateway: &Gateway, out: &Output) {
    let (gw, stats) = (gateway.config().await, gateway.stats());
    out.line(
        &report::status_text(&gw, &stats),
        report::status_json(&gw, &stats),
    );
}
