//! The Modbus TCP client: one request at a time on one connection.

use serde::{Deserialize, Serialize};
use si_core::Duration;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpStream, ToSocketAddrs};
use tokio::sync::Mutex;

use crate::frame::{EncodeError, Request, Response};
use crate::mbap::{Decoder, TcpAdu};
use crate::tokio::client::{unexpected, Client as ModbusClient};
use crate::tokio::error::{Error, Job};

/// How long a request waits for its answer unless configured otherwise
/// ([`ClientConfig::response_timeout`]): the module's default Modbus "Response Time", 2 s
/// ([Modbus/USS] §3.4.3, Table 3-17, [`MasterConfig`](crate::MasterConfig)'s default; a test keeps the two
/// equal).
pub const DEFAULT_RESPONSE_TIMEOUT: Duration = Duration::from_secs(2);

/// Bytes read from the socket at once.
const RX_CHUNK: usize = 512;

/// The Modbus TCP client's parameters, named as the RTU master's ([`MasterConfig`]).
///
/// In files the time is an integer of milliseconds: `response_timeout_ms`.
///
/// [`MasterConfig`]: crate::MasterConfig
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ClientConfig {
    /// How long to wait for each answer (default 2 s, as the RTU master's Response Time).
    #[serde(rename = "response_timeout_ms", with = "crate::config::millis")]
    pub response_timeout: Duration,
    /// Repetitions after the first try of a request that got no answer in time (default 0).
    /// Each repetition carries a new transaction id; a late answer to an earlier one is
    /// discarded by its id.
    pub retries: u8,
}

impl Default for ClientConfig {
    fn default() -> Self {
        ClientConfig {
            response_timeout: DEFAULT_RESPONSE_TIMEOUT,
            retries: 0,
        }
    }
}

/// A Modbus TCP client on one connection.
///
/// One request at a time (concurrent calls on `&self` wait for each other), each with the next
/// transaction id; an answer whose transaction id is not the current request's (a late answer
/// to a request that timed out) is discarded. Answers are also checked for the request's unit
/// id and function code. The function codes are the [`Client`](ModbusClient) trait's.
#[derive(Debug)]
pub struct Client {
    inner: Mutex<Connection>,
}

#[derive(Debug)]
struct Connection {
    stream: TcpStream,
    decoder: Decoder,
    rx: [u8; RX_CHUNK],
    rx_pos: usize,
    rx_len: usize,
    next_transaction: u16,
    config: ClientConfig,
    /// Set while a request is being written: a timeout then leaves half a frame on the wire.
    writing: bool,
    broken: bool,
}

impl Client {
    /// Connect to a Modbus TCP server (port 502 is the standard one) with the default
    /// [`ClientConfig`].
    pub async fn connect(addr: impl ToSocketAddrs) -> Result<Self, Error> {
        Self::connect_with(ClientConfig::default(), addr).await
    }

    /// Connect to a Modbus TCP server with `config`.
    pub async fn connect_with(
        config: ClientConfig,
        addr: impl ToSocketAddrs,
    ) -> Result<Self, Error> {
        Ok(Self::new(config, TcpStream::connect(addr).await?)?)
    }

    /// A client on a connection the caller made.
    pub fn new(config: ClientConfig, stream: TcpStream) -> std::io::Result<Self> {
        // Requests are small and each waits for its answer: send at once.
        stream.set_nodelay(true)?;
        Ok(Client {
            inner: Mutex::new(Connection {
                stream,
                decoder: Decoder::new(),
                rx: [0; RX_CHUNK],
                rx_pos: 0,
                rx_len: 0,
                next_transaction: 1,
                config,
                writing: false,
                broken: false,
            }),
        })
    }

    /// Wait this long for each answer (a `std::time::Duration` converts).
    pub fn with_response_timeout(mut self, timeout: impl Into<Duration>) -> Self {
        self.inner.get_mut().config.response_timeout = timeout.into();
        self
    }

    /// Repeat a request that got no answer in time this often ([`ClientConfig::retries`]).
    pub fn with_retries(mut self, retries: u8) -> Self {
        self.inner.get_mut().config.retries = retries;
        self
    }

    /// Use `id` as the next transaction id (they count up from it, wrapping).
    pub fn with_transaction_id(mut self, id: u16) -> Self {
        self.inner.get_mut().next_transaction = id;
        self
    }

    /// The transaction id the next request will carry.
    pub async fn next_transaction_id(&self) -> u16 {
        self.inner.lock().await.next_transaction
    }

    /// Send any request to `unit` and wait for its answer; an exception is
    /// [`Error::Failed`] with its [`exception_code`](Error::exception_code). The answer is
    /// returned checked: same transaction id, unit id and function code, a PDU that decodes
    /// ([`TcpAdu::decode_response`]).
    pub async fn request_adu(&self, unit: u8, request: &Request<'_>) -> Result<TcpAdu, Error> {
        self.inner.lock().await.request(unit, request).await
    }

    /// Close the connection; it is shut down when this returns.
    pub async fn close(self) -> Result<(), Error> {
        self.inner.into_inner().stream.shutdown().await?;
        Ok(())
    }
}

impl Connection {
    async fn request(&mut self, unit: u8, request: &Request<'_>) -> Result<TcpAdu, Error> {
        let job = Job::of(unit, request);
        for _ in 0..self.config.retries {
            match self.attempt(job, unit, request).await {
                Err(Error::Failed { status, .. })
                    if status == crate::status::RESPONSE_TIMEOUT && !self.broken => {}
                other => return other,
            }
        }
        self.attempt(job, unit, request).await
    }

    async fn attempt(
        &mut self,
        job: Job,
        unit: u8,
        request: &Request<'_>,
    ) -> Result<TcpAdu, Error> {
        if self.broken {
            return Err(Error::Broken);
        }
        let transaction = self.next_transaction;
        self.next_transaction = transaction.wrapping_add(1);
        let adu = TcpAdu::request(transaction, unit, request).map_err(|e| refused(job, e))?;
        let timeout = self.config.response_timeout;
        let result = tokio::time::timeout(timeout.into(), self.exchange(&adu)).await;
        match result {
            Ok(Ok(reply)) => check(reply, &adu, job),
            Ok(Err(e)) => {
                if matches!(e, Error::Io(_) | Error::Stopped | Error::Header(_)) {
                    self.broken = true;
                }
                Err(e)
            }
            Err(_) => {
                if self.writing {
                    self.broken = true;
                }
                Err(Error::failed(job, crate::status::RESPONSE_TIMEOUT))
            }
        }
    }

    /// Write `adu` and read until the answer with its transaction id.
    async fn exchange(&mut self, adu: &TcpAdu) -> Result<TcpAdu, Error> {
        self.writing = true;
        self.stream.write_all(adu.as_bytes()).await?;
        self.writing = false;
        loop {
            let reply = self.next_adu().await?;
            if reply.transaction() == adu.transaction() {
                return Ok(reply);
            }
        }
    }

    /// The next complete ADU from the connection.
    async fn next_adu(&mut self) -> Result<TcpAdu, Error> {
        loop {
            let mut input = &self.rx[self.rx_pos..self.rx_len];
            let before = input.len();
            let got = self.decoder.decode(&mut input)?.copied();
            self.rx_pos += before - input.len();
            if let Some(adu) = got {
                return Ok(adu);
            }
            let n = self.stream.read(&mut self.rx).await?;
            if n == 0 {
                return Err(Error::Stopped);
            }
            self.rx_pos = 0;
            self.rx_len = n;
        }
    }
}

/// A request that cannot be encoded: refused with the module's STATUS for its count
/// (0E44H–0E46H), as the RTU master refuses it.
fn refused(job: Job, _: EncodeError) -> Error {
    crate::tokio::error::refused_count(job)
}

impl ModbusClient for Client {
    async fn exchange<T: Send>(
        &self,
        unit: u8,
        request: &Request<'_>,
        pick: impl FnOnce(Option<Response<'_>>) -> Option<T> + Send,
    ) -> Result<T, Error> {
        let reply = self.request_adu(unit, request).await?;
        let response = reply.decode_response().ok().map(|(_, r)| r);
        pick(response).ok_or_else(|| unexpected(unit, request))
    }
}

/// Check an answer against its request: unit id, function code (an exception is returned as
/// [`Error::Failed`] with its code), its structure as the RTU master checks it (byte count,
/// length, echo, [Modbus/USS] §3.4.5–§3.4.16), and a PDU that decodes.
fn check(reply: TcpAdu, request: &TcpAdu, job: Job) -> Result<TcpAdu, Error> {
    if reply.unit() != request.unit() {
        return Err(Error::failed(job, crate::status::WRONG_SLAVE_ADDRESS));
    }
    let function = request.function();
    let pdu = &reply.unit_pdu()[1..];
    if pdu.len() == 2 && pdu[0] == function | 0x80 {
        return Err(Error::exception(job, pdu[1]));
    }
    if reply.function() != function {
        return Err(Error::failed(job, crate::status::WRONG_FUNCTION));
    }
    crate::master::check_structure(request.unit_pdu(), reply.unit_pdu())
        .map_err(|status| Error::failed(job, status))?;
    reply
        .decode_response()
        .map_err(|source| Error::Decode { job, source })?;
    Ok(reply)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn statuses_are_the_rtu_masters() {
        let job = Job::of(
            1,
            &Request::ReadHoldingRegisters {
                address: 0,
                quantity: 1,
            },
        );
        let e = Error::exception(job, 2);
        assert_eq!(e.status().map(|s| s.code()), Some(0x0E62));
        let gateway = Error::exception(job, 0x0B);
        assert_eq!(gateway.exception_code(), Some(0x0B));
    }

    #[test]
    fn default_timeout_is_the_masters_default_response_time() {
        assert_eq!(
            DEFAULT_RESPONSE_TIMEOUT,
            crate::MasterConfig::default().response_timeout
        );
    }
}
