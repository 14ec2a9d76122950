//! `--modbus-tcp HOST:PORT`: the master's jobs (`read`, `write`, `diag`, …) to a Modbus TCP
//! server instead of an RTU slave, with the same output, formats, `--poll`, counters and
//! STATUS texts. Each `--unit` travels as the MBAP unit id; the PDU is the RTU
//! one ([`si_modbus::tokio::tcp::Client`]).
//!
//! What is the module's and what is not: a job is checked before sending as the module's
//! master checks it ([Modbus/USS] §3.4.5–§3.4.16, 0E43H–0E46H); a failure the module has a STATUS for reads as on a
//! serial line (exceptions 01–07 as 0E61H–0E67H, no answer within `--response-timeout-ms` as 0830H, an
//! answer for another function as 0E51H; see [`Error::status`]). Gateway exceptions 0AH and
//! 0BH have no STATUS: they are counted as exceptions and shown with the exception's name.
//! Reading chosen for unit 0: Modbus TCP has no broadcast (the MBAP unit id 0 addresses the
//! server itself), so a job to unit 0 waits for its answer like any other.

use super::explain::status_text;
use super::poll::{JobError, Kind, Line, LineFailure};
use super::report::Report;
use crate::conn::Connection;
use crate::error::CliError;
use clap::Args;
use si_modbus::frame::Request;
use si_modbus::master::Master;
use si_modbus::tokio::tcp::{Client, ClientConfig};
use si_modbus::tokio::Error;
use std::time::Duration;

/// `--modbus-tcp`.
#[derive(Debug, Clone, Default, Args)]
pub struct ModbusTcp {
    /// Modbus TCP server, e.g. 192.0.2.20:502: the jobs go in MBAP frames, each --unit as the
    /// unit id, instead of RTU over --port or --tcp (a raw serial device server; a port
    /// from SI_PORT or --profile is not used). --response-timeout-ms is the wait for each answer (and for the connection);
    /// --retries sends again after a timeout; the serial framing options do not apply. Unit 0
    /// addresses the server itself and is answered (no broadcast on TCP).
    #[arg(long = "modbus-tcp", value_name = "HOST:PORT",
          conflicts_with_all = ["tcp", "record"])]
    pub server: Option<String>,
}

impl ModbusTcp {
    /// Connect when `--modbus-tcp` is given (`None`: the jobs go to the serial line), waiting
    /// at most `timeout_ms` for the connection.
    pub async fn connect(
        &self,
        conn: &Connection,
        timeout_ms: u32,
        retries: u8,
        polling: bool,
    ) -> Result<Option<TcpLine>, CliError> {
        let Some(server) = &self.server else {
            return Ok(None);
        };
        refuse_serial_line(conn);
        let timeout = Duration::from_millis(u64::from(timeout_ms));
        let client = open(server, timeout, retries)
            .await
            .map_err(CliError::new)?;
        Ok(Some(TcpLine {
            client: Some(client),
            retries,
            server: server.clone(),
            timeout,
            reconnect: polling,
        }))
    }
}

/// Connect to `server` within `timeout`; the error says why, naming the server. Each answer is
/// waited for `timeout`, and a request without one is sent again `retries` times.
async fn open(server: &str, timeout: Duration, retries: u8) -> Result<Client, String> {
    let cannot = |why: String| format!("cannot connect to {server}: {why}");
    let config = ClientConfig {
        response_timeout: timeout.into(),
        retries,
    };
    tokio::time::timeout(timeout, Client::connect_with(config, server))
        .await
        .map_err(|_| cannot(format!("no connection within {timeout:?}")))?
        .map_err(|e| cannot(e.to_string()))
}

/// The usage error (exit 2) for `--modbus-tcp` with a serial line or a line recording. Clap's
/// `conflicts_with` sees `--tcp` and `--record` only when they follow the subcommand: given
/// before it (`si --tcp H:P modbus read …`) they reach the subcommand after its conflicts were
/// checked, so the same error is raised here. `--port` is checked here only: typed, it
/// conflicts; from `SI_PORT` or a profile it is simply not used (clap would count the
/// environment as given).
fn refuse_serial_line(conn: &Connection) {
    let given = [
        ("--port <PORT>", conn.port_on_command_line),
        ("--tcp <HOST:PORT>", conn.tcp.is_some()),
        ("--record <FILE>", conn.record.is_some()),
    ];
    if let Some((flag, _)) = given.iter().find(|(_, set)| *set) {
        clap::Error::raw(
            clap::error::ErrorKind::ArgumentConflict,
            format!("the argument '--modbus-tcp <HOST:PORT>' cannot be used with '{flag}'\n"),
        )
        .exit()
    }
}

/// A Modbus TCP connection running a poll's jobs.
///
/// A poll outlives its connection: a server that restarts, a gateway that drops idle
/// connections or a network that breaks for a moment costs the polls that fail meanwhile
/// (each counted as an error, "connection … lost"), and the next poll connects again. A single
/// job, or a first connection that fails, ends the run instead: there is nothing to go on with.
#[derive(Debug)]
pub struct TcpLine {
    /// `None` after the connection broke, until the next job connects again.
    client: Option<Client>,
    /// Sends again after a timeout, as the RTU master's `--retries`.
    retries: u8,
    /// HOST:PORT, for the error that ends a run.
    server: String,
    /// The wait for each answer and for a connection.
    timeout: Duration,
    /// Connect again after a broken connection (a poll) instead of ending the run.
    reconnect: bool,
}

impl Line for TcpLine {
    async fn job(
        &mut self,
        unit: u8,
        request: &Request<'_>,
        report: &Report<'_>,
    ) -> Result<(), JobError> {
        // The module's checks on counts ([Modbus/USS] §3.4.5–§3.4.16); unit 0 is not a broadcast on
        // TCP (see above).
        Master::check_job(unit.max(1), request)
            .map_err(|e| JobError::Fatal(CliError::new(status_text(e.status()))))?;
        let client = match &mut self.client {
            Some(client) => client,
            None => {
                let client = open(&self.server, self.timeout, self.retries)
                    .await
                    .map_err(|why| {
                        JobError::Line(LineFailure {
                            kind: Kind::Other,
                            status: None,
                            text: why,
                        })
                    })?;
                self.client.insert(client)
            }
        };
        let answer = client.request_adu(unit, request).await;
        let adu = answer.map_err(|e| self.failed(e))?;
        // `request_adu` checked that the answer decodes.
        let job = si_modbus::tokio::Job::of(unit, request);
        let (_, response) = adu
            .decode_response()
            .map_err(|source| self.failed(Error::Decode { job, source }))?;
        report.answer(unit, *request, Some(response));
        Ok(())
    }
}

impl TcpLine {
    /// How a failure is counted: an exception, a timeout or a malformed answer is on the line
    /// and the poll goes on; a broken connection ends the run, or in a poll is counted and
    /// the next job connects again.
    fn failed(&mut self, e: Error) -> JobError {
        let kind = match e {
            Error::Failed {
                exception: Some(_), ..
            } => Kind::Exception,
            Error::Failed { status, .. } if status == si_modbus::status::RESPONSE_TIMEOUT => {
                Kind::Timeout
            }
            Error::Failed { .. } | Error::Decode { .. } => Kind::Other,
            _ if self.reconnect => {
                self.client = None;
                return JobError::Line(LineFailure {
                    kind: Kind::Other,
                    status: None,
                    text: format!(
                        "connection to {} lost: {e}; connecting again for the next poll",
                        self.server
                    ),
                });
            }
            _ => return JobError::Fatal(CliError::new(format!("{}: {e}", self.server))),
        };
        // A gateway exception (0AH, 0BH) has no STATUS of the module's: shown by its name.
        let gateway = e
            .exception_code()
            .is_some_and(|c| si_modbus::ExceptionCode::from_u8(c).is_none());
        let status = e.status().filter(|_| !gateway);
        JobError::Line(LineFailure {
            kind,
            status,
            text: status.map_or_else(|| e.to_string(), status_text),
        })
    }
}
