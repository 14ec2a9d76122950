//! The Modbus TCP client: one request at a time on one connection.

use std::time::Duration;

use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpStream, ToSocketAddrs};

use crate::frame::{DecodeError, EncodeError, ExceptionCode, Request, Response};
use crate::mbap::{Decoder, HeaderError, TcpAdu};

/// How long [`Client::request`] waits for an answer unless told otherwise
/// ([`Client::with_timeout`]): the module's default Modbus "Response Time", 2 s
/// ([Modbus/USS] §3.4.3, Table 3-17, [`MasterConfig`](crate::MasterConfig)'s default; a test
/// keeps the two equal).
pub const DEFAULT_TIMEOUT: Duration = Duration::from_secs(2);

/// Bytes read from the socket at once.
const RX_CHUNK: usize = 512;

/// Why a Modbus TCP request failed.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The request cannot be encoded (a quantity out of range, or too long for TCP).
    #[error("{0}")]
    Encode(#[from] EncodeError),
    /// No answer with this request's transaction id within the timeout. An answer that comes
    /// later is discarded by its transaction id.
    #[error("no response within {0:?}")]
    Timeout(Duration),
    /// The connection failed.
    #[error("connection: {0}")]
    Io(#[from] std::io::Error),
    /// The server closed the connection.
    #[error("the server closed the connection")]
    Closed,
    /// The server sent a header that cannot be framed; the connection is unusable.
    #[error("{0}")]
    Header(#[from] HeaderError),
    /// The response PDU is malformed.
    #[error("{0}")]
    Decode(#[from] DecodeError),
    /// The response belongs to another unit or function than the request.
    #[error("response {field} expected {expected:02X}H, found {found:02X}H")]
    Mismatch {
        /// "unit id" or "function code".
        field: &'static str,
        /// The request's.
        expected: u8,
        /// The response's.
        found: u8,
    },
    /// The answer has the request's function code but does not fit the request (a wrong
    /// byte count, length or echo), with the RTU master's STATUS for it (0E52H–0E56H, [Modbus/USS]
    /// §3.4.5–§3.4.16).
    #[error("the answer does not fit the request: {0}")]
    Response(si_core::Status),
    /// The server answered with an exception, passed as it is.
    #[error("function {function:02X}H answered with exception {code:02X}H{}", exception_text(*.code))]
    Exception {
        /// The request's function code.
        function: u8,
        /// The exception code byte.
        code: u8,
    },
    /// An earlier failure left the stream without a frame boundary (a header error, or a
    /// timeout in the middle of sending a request): connect again.
    #[error("connection unusable after an earlier failure")]
    Broken,
}

fn exception_text(code: u8) -> String {
    match code {
        0x0A => " (gateway path unavailable)".into(),
        0x0B => " (gateway target device failed to respond)".into(),
        c => ExceptionCode::from_u8(c).map_or(String::new(), |e| format!(" ({e})")),
    }
}

impl Error {
    /// The exception code, for [`Error::Exception`].
    pub fn exception_code(&self) -> Option<u8> {
        match self {
            Error::Exception { code, .. } => Some(*code),
            _ => None,
        }
    }

    /// The module's master STATUS for the failures it has one for, so a TCP job reports like
    /// an RTU job: exceptions 01–07 as 0E61H–0E67H ([Modbus/USS] §3.3.6, Table 3-12), no answer as
    /// 0830H (§3.4.5–§3.4.16), a response for another function as 0E51H. Connection failures,
    /// header and PDU errors and gateway exceptions (0AH, 0BH) have none.
    pub fn status(&self) -> Option<si_core::Status> {
        match self {
            Error::Exception { code, .. } => {
                ExceptionCode::from_u8(*code).map(crate::status::for_exception)
            }
            Error::Timeout(_) => Some(crate::status::RESPONSE_TIMEOUT),
            Error::Response(s) => Some(*s),
            Error::Mismatch {
                field: "function code",
                ..
            } => Some(crate::status::WRONG_FUNCTION),
            _ => None,
        }
    }
}

/// A Modbus TCP client on one connection.
///
/// One request at a time (`&mut self`), each with the next transaction id; an answer whose
/// transaction id is not the current request's (a late answer to a request that timed out) is
/// discarded. Answers are also checked for the request's unit id and function code.
#[derive(Debug)]
pub struct Client {
    stream: TcpStream,
    decoder: Decoder,
    rx: [u8; RX_CHUNK],
    rx_pos: usize,
    rx_len: usize,
    next_transaction: u16,
    timeout: Duration,
    /// Set while a request is being written: a timeout then leaves half a frame on the wire.
    writing: bool,
    broken: bool,
}

impl Client {
    /// Connect to a Modbus TCP server (port 502 is the standard one).
    pub async fn connect(addr: impl ToSocketAddrs) -> std::io::Result<Self> {
        let stream = TcpStream::connect(addr).await?;
        // Requests are small and each waits for its answer: send at once.
        stream.set_nodelay(true)?;
        Ok(Client {
            stream,
            decoder: Decoder::new(),
            rx: [0; RX_CHUNK],
            rx_pos: 0,
            rx_len: 0,
            next_transaction: 1,
            timeout: DEFAULT_TIMEOUT,
            writing: false,
            broken: false,
        })
    }

    /// Wait this long for each answer.
    pub fn with_timeout(mut self, timeout: Duration) -> Self {
        self.timeout = timeout;
        self
    }

    /// Use `id` as the next transaction id (they count up from it, wrapping).
    pub fn with_transaction_id(mut self, id: u16) -> Self {
        self.next_transaction = id;
        self
    }

    /// The transaction id the next request will carry.
    pub fn next_transaction_id(&self) -> u16 {
        self.next_transaction
    }

    /// Send any request to `unit` and wait for its answer; an exception is
    /// [`Error::Exception`]. The answer is returned checked: same transaction id, unit id and
    /// function code, a PDU that decodes ([`TcpAdu::decode_response`]).
    pub async fn request(&mut self, unit: u8, request: &Request<'_>) -> Result<TcpAdu, Error> {
        if self.broken {
            return Err(Error::Broken);
        }
        let transaction = self.next_transaction;
        self.next_transaction = transaction.wrapping_add(1);
        let adu = TcpAdu::request(transaction, unit, request)?;
        let timeout = self.timeout;
        let result = tokio::time::timeout(timeout, self.exchange(&adu)).await;
        match result {
            Ok(Ok(reply)) => check(reply, &adu),
            Ok(Err(e)) => {
                if matches!(e, Error::Io(_) | Error::Closed | Error::Header(_)) {
                    self.broken = true;
                }
                Err(e)
            }
            Err(_) => {
                if self.writing {
                    self.broken = true;
                }
                Err(Error::Timeout(timeout))
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
                return Err(Error::Closed);
            }
            self.rx_pos = 0;
            self.rx_len = n;
        }
    }

    /// Send `request` and pick the typed result out of its response.
    async fn exchange_typed<T>(
        &mut self,
        unit: u8,
        request: Request<'_>,
        pick: impl FnOnce(Response<'_>) -> Option<T>,
    ) -> Result<T, Error> {
        let reply = self.request(unit, &request).await?;
        let (_, response) = reply.decode_response()?;
        pick(response).ok_or(Error::Mismatch {
            field: "function code",
            expected: request.function(),
            found: response.function(),
        })
    }

    crate::tokio::typed::typed_requests!(Error);
}

/// Check an answer against its request: unit id, function code (an exception is returned as
/// [`Error::Exception`]), its structure as the RTU master checks it (byte count, length, echo:
/// [`Error::Response`]), and a PDU that decodes.
fn check(reply: TcpAdu, request: &TcpAdu) -> Result<TcpAdu, Error> {
    if reply.unit() != request.unit() {
        return Err(Error::Mismatch {
            field: "unit id",
            expected: request.unit(),
            found: reply.unit(),
        });
    }
    let function = request.function();
    let pdu = &reply.unit_pdu()[1..];
    if pdu.len() == 2 && pdu[0] == function | 0x80 {
        return Err(Error::Exception {
            function,
            code: pdu[1],
        });
    }
    if reply.function() != function {
        return Err(Error::Mismatch {
            field: "function code",
            expected: function,
            found: reply.function(),
        });
    }
    crate::master::check_structure(request.unit_pdu(), reply.unit_pdu())
        .map_err(Error::Response)?;
    reply.decode_response()?;
    Ok(reply)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn statuses_are_the_rtu_masters() {
        let e = Error::Exception {
            function: 3,
            code: 2,
        };
        assert_eq!(e.status().map(|s| s.code()), Some(0x0E62));
        let gateway = Error::Exception {
            function: 3,
            code: 0x0B,
        };
        assert_eq!(gateway.status(), None);
        let timeout = Error::Timeout(DEFAULT_TIMEOUT).status();
        assert_eq!(timeout.map(|s| s.code()), Some(0x0830));
    }

    #[test]
    fn default_timeout_is_the_masters_default_response_time() {
        assert_eq!(
            DEFAULT_TIMEOUT.as_millis(),
            u128::from(crate::MasterConfig::default().response_timeout_ms)
        );
    }
}
