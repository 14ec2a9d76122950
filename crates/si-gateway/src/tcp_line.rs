//! A Modbus TCP slave behind the gateway (`kind = "modbus-tcp"`, keys in
//! [`crate::tcp_config`]): the line's task holds one connection to it, made with si-modbus's
//! TCP client, and serves the line's queue through it one request at a time, so that many
//! clients share a slave that accepts one connection (or few). Each request goes out with the
//! connection's own transaction id and its answer comes back with the client's.
//!
//! A connection that breaks under a request (closed, reset, a garbled header) takes the line
//! down: that request and those queued meanwhile get 0AH, and the connection is made again
//! ([`crate::reopen`]). A timeout is 0BH, the slave's exception passes unchanged.

use crate::counters::{Outcome, Stats};
use crate::line::{self, exception, LineQueue};
use crate::line::{GATEWAY_PATH_UNAVAILABLE, GATEWAY_TARGET_FAILED, ILLEGAL_DATA_VALUE};
use crate::line::{ILLEGAL_FUNCTION, SLAVE_DEVICE_FAILURE};
use crate::reopen::{self, Closed, LineLog, Opened};
use crate::tcp_config::TcpLine;
use crate::{quantities, Error};
use si_modbus::mbap::TcpAdu;
use si_modbus::tokio::tcp::Client;
use si_modbus::tokio::Error as ClientError;
use si_modbus::{serve, status};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use tokio::sync::oneshot;

/// The connection to the slave, while it lasts.
pub struct TcpSlave {
    client: Client,
    /// Held while the connection serves: its line is up.
    _up: oneshot::Sender<String>,
}

/// Connect to line `tcp`'s slave (keepalive, no Nagle delay, bounded connect time:
/// [`si_core::port::device_server`]).
pub async fn open(tcp: &TcpLine) -> Result<Opened<TcpSlave>, Error> {
    let stream = si_core::port::device_server(&tcp.address)
        .await
        .map_err(|e| Error::Port(e.to_string()))?;
    let client = Client::new(tcp.client, stream).map_err(|e| Error::Port(e.to_string()))?;
    let (up, closed) = reopen::closing();
    Ok(Opened {
        link: TcpSlave { client, _up: up },
        closed,
    })
}

/// Serve line `log.index` until the process ends; while its connection is down every
/// request is answered with 0AH and it is made again with `open`.
pub async fn run(
    log: LineLog,
    queue: Arc<LineQueue>,
    first: reopen::First<TcpSlave>,
    open: impl AsyncFnMut() -> Result<Opened<TcpSlave>, Error>,
    pause: Duration,
) {
    // The closures own what their futures use (see `line::run`).
    let (index, stats) = (log.index, Arc::clone(&log.stats));
    let (q, s) = (Arc::clone(&queue), Arc::clone(&stats));
    reopen::supervise(
        log,
        first,
        open,
        move |slave, closed| serve(index, Arc::clone(&q), slave, closed, pause, Arc::clone(&s)),
        move || line::refuse(index, Arc::clone(&queue), Arc::clone(&stats)),
    )
    .await;
}

/// Serve the queue through `slave` until its connection breaks: why.
async fn serve(
    index: usize,
    queue: Arc<LineQueue>,
    slave: TcpSlave,
    mut closed: Closed,
    pause: Duration,
    stats: Arc<Mutex<Stats>>,
) -> String {
    loop {
        let (client, job, depth) = tokio::select! {
            why = &mut closed => return why,
            next = queue.pop() => next,
        };
        line::taken(index, &stats, client, depth);
        let (answer, outcome, lost) = forward(&slave.client, &job.request).await;
        line::answered(index, &stats, client, job, Some(answer), outcome, 0);
        if let Some(why) = lost {
            return why;
        }
        if !pause.is_zero() {
            tokio::time::sleep(pause).await;
        }
    }
}

/// One request through the client: the answer with the request's transaction id, how it
/// counts, and why the connection was lost if it was.
async fn forward(client: &Client, request: &TcpAdu) -> (TcpAdu, Outcome, Option<String>) {
    let refused = |code| (exception(request, code), Outcome::Other, None);
    if quantities::out_of_range(request.unit_pdu()) {
        return refused(ILLEGAL_DATA_VALUE);
    }
    let (unit, r) = match request.decode_request() {
        Ok(decoded) => decoded,
        Err(e) => return refused(serve::refusal(e.kind).0.code()),
    };
    match client.request_adu(unit, &r).await {
        Ok(answer) => match TcpAdu::from_unit_pdu(request.transaction(), answer.unit_pdu()) {
            Ok(a) => (a, Outcome::Answer, None),
            Err(_) => refused(SLAVE_DEVICE_FAILURE),
        },
        Err(ClientError::Failed {
            exception: Some(code),
            ..
        }) => (exception(request, code), Outcome::Exception, None),
        Err(ClientError::Failed { status: s, .. }) if s == status::RESPONSE_TIMEOUT => (
            exception(request, GATEWAY_TARGET_FAILED),
            Outcome::Timeout,
            None,
        ),
        Err(ClientError::Refused { reason, .. }) => {
            let s = reason.status();
            let function =
                s == status::INVALID_FUNCTION || s == status::BROADCAST_NOT_ALLOWED_FOR_FC;
            refused(if function {
                ILLEGAL_FUNCTION
            } else {
                ILLEGAL_DATA_VALUE
            })
        }
        Err(
            e @ (ClientError::Broken
            | ClientError::Io(_)
            | ClientError::Stopped
            | ClientError::Header(_)),
        ) => (
            exception(request, GATEWAY_PATH_UNAVAILABLE),
            Outcome::Other,
            Some(format!("connection lost: {e}")),
        ),
        Err(_) => refused(SLAVE_DEVICE_FAILURE),
    }
}
