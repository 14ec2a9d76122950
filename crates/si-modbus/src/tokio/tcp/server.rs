//! The Modbus TCP server: requests from several clients at once, answered by a [`Handler`];
//! [`StoreHandler`] serves a [`Store`] with the RTU slave's code.

use std::future::Future;
use std::net::SocketAddr;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream, ToSocketAddrs};

use crate::frame::{ExceptionCode, Response};
use crate::mbap::{Decoder, TcpAdu};
use crate::serve::{self, Outcome, ResponseData};
use crate::slave::Store;

/// Connections served at once unless configured otherwise: mbusd's default (its `-C maxconn`,
/// `DEFAULT_MAXCONN` 32 in mbusd's `src/conn.h`), the gateway si is measured
/// against.
pub const DEFAULT_MAX_CONNECTIONS: usize = 32;

/// How long a connection may stay silent before the server closes it, unless configured
/// otherwise: mbusd's default (`-T`, `DEFAULT_CONNTIMEOUT` 60 s in
/// mbusd's `src/conn.h`), so idle clients cannot hold every slot for ever.
pub const DEFAULT_IDLE_TIMEOUT: Duration = Duration::from_secs(60);

/// Bytes read from a connection at once.
const RX_CHUNK: usize = 1024;

/// The unit ids a server answers.
#[derive(Clone, PartialEq, Eq)]
pub struct Units([bool; 256]);

impl Units {
    /// Every unit id, 0–255 (the default). Over TCP a server is addressed by its IP address
    /// and the unit id matters only behind a gateway (Implementation Guide, external, §3.1.3);
    /// clients send 0, 1 or 255 to a plain server, so it answers them all.
    pub const fn all() -> Self {
        Units([true; 256])
    }

    /// Only these unit ids.
    pub fn only(units: &[u8]) -> Self {
        let mut set = [false; 256];
        for &u in units {
            set[u as usize] = true;
        }
        Units(set)
    }

    /// Is `unit` answered?
    pub fn contains(&self, unit: u8) -> bool {
        self.0[unit as usize]
    }
}

impl Default for Units {
    fn default() -> Self {
        Units::all()
    }
}

impl std::fmt::Debug for Units {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let ids = (0..=255u8).filter(|&u| self.contains(u));
        if self.0.iter().all(|&b| b) {
            f.write_str("Units(all)")
        } else {
            f.debug_tuple("Units")
                .field(&ids.collect::<Vec<_>>())
                .finish()
        }
    }
}

/// Server options.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ServerConfig {
    /// Connections served at once; one more is accepted and closed at once, as mbusd does
    /// (`conn_open` in mbusd's `src/conn.c`), so a client sees a clear refusal
    /// instead of a hang.
    pub max_connections: usize,
    /// The unit ids answered. A request for any other unit id is not answered, as a serial
    /// slave does not answer another address ([Modbus/USS] §3.3.2); a gateway that
    /// should answer exception 0AH for it is `si gateway`, not this server.
    pub units: Units,
    /// A connection that sends nothing for this long is closed (`None`: never).
    pub idle_timeout: Option<Duration>,
}

impl Default for ServerConfig {
    fn default() -> Self {
        ServerConfig {
            max_connections: DEFAULT_MAX_CONNECTIONS,
            units: Units::all(),
            idle_timeout: Some(DEFAULT_IDLE_TIMEOUT),
        }
    }
}

/// What answers the requests a [`Server`] receives: a store ([`StoreHandler`]), or anything
/// else that can answer a Modbus TCP request, such as a gateway to serial lines.
pub trait Handler: Send + Sync + 'static {
    /// The answer to one request, with its transaction id and unit id (`None`: no answer).
    /// Requests on one connection are answered one after the other, in order.
    fn answer(&self, request: TcpAdu) -> impl Future<Output = Option<TcpAdu>> + Send;

    /// The answer to one request from the connection `peer` (a gateway counts and queues per
    /// client); by default the same as [`answer`](Self::answer).
    fn answer_from(
        &self,
        peer: &Peer,
        request: TcpAdu,
    ) -> impl Future<Output = Option<TcpAdu>> + Send {
        let _ = peer;
        self.answer(request)
    }

    /// A connection was accepted (called before its first request).
    fn connected(&self, peer: &Peer) {
        let _ = peer;
    }

    /// A connection ended (closed by either side, idle or a bad header).
    fn disconnected(&self, peer: &Peer) {
        let _ = peer;
    }
}

/// One accepted connection, as a [`Handler`] sees it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Peer {
    /// Numbered from 1 in the order of acceptance, unique for the server's life (addresses
    /// repeat when a client reconnects from the same port).
    pub id: u64,
    /// The client's address.
    pub addr: SocketAddr,
}

/// A [`Store`] behind a lock, answering requests as the RTU slave does ([`crate::serve`]).
///
/// A response too long for TCP (a read of 126 or 127 registers, or of over 2008 bits: the
/// manual's limits are above TCP's 253-byte PDU) is answered with exception 03.
pub struct StoreHandler<S> {
    store: Arc<Mutex<S>>,
}

impl<S: Store + Send + 'static> StoreHandler<S> {
    /// Serve `store`.
    pub fn new(store: S) -> Self {
        StoreHandler {
            store: Arc::new(Mutex::new(store)),
        }
    }

    /// The store, shared with the handler.
    pub fn store(&self) -> Arc<Mutex<S>> {
        Arc::clone(&self.store)
    }
}

impl<S: Store + Send + 'static> Handler for StoreHandler<S> {
    async fn answer(&self, request: TcpAdu) -> Option<TcpAdu> {
        Some(execute(&self.store, &request))
    }
}

/// A Modbus TCP server: accepts connections up to a limit and answers their requests with a
/// [`Handler`].
///
/// Each connection is a tokio task reading requests in any chunking (several in one segment
/// are answered in order, each with its own transaction id). Requests for a unit id not in
/// [`ServerConfig::units`] are not answered. A header that cannot be framed (protocol id ≠ 0,
/// length outside 2…254) closes that connection ([`crate::mbap`]), and so does silence past
/// [`ServerConfig::idle_timeout`].
pub struct Server<H> {
    listener: TcpListener,
    handler: Arc<H>,
    config: ServerConfig,
}

impl<S: Store + Send + 'static> Server<StoreHandler<S>> {
    /// Listen on `addr` (port 0: any free port, see [`Server::local_addr`]) and serve `store`.
    pub async fn bind(
        addr: impl ToSocketAddrs,
        config: ServerConfig,
        store: S,
    ) -> std::io::Result<Self> {
        Self::with_handler(addr, config, StoreHandler::new(store)).await
    }

    /// The store, shared with the server (to simulate a process or look at what was written).
    pub fn store(&self) -> Arc<Mutex<S>> {
        self.handler.store()
    }
}

impl<H: Handler> Server<H> {
    /// Listen on `addr` and answer with `handler`.
    pub async fn with_handler(
        addr: impl ToSocketAddrs,
        config: ServerConfig,
        handler: H,
    ) -> std::io::Result<Self> {
        Ok(Server {
            listener: TcpListener::bind(addr).await?,
            handler: Arc::new(handler),
            config,
        })
    }

    /// The address listened on.
    pub fn local_addr(&self) -> std::io::Result<SocketAddr> {
        self.listener.local_addr()
    }

    /// Accept and serve connections until the task is dropped or aborted
    /// ([`accept_limited`](super::accept_limited): at most `max_connections` at once).
    pub async fn run(self) -> std::io::Result<()> {
        let units = Arc::new(self.config.units);
        let idle = self.config.idle_timeout;
        let handler = self.handler;
        match super::accept_limited(
            &self.listener,
            self.config.max_connections,
            |stream, id, addr| {
                let peer = Peer { id, addr };
                let (handler, units) = (Arc::clone(&handler), Arc::clone(&units));
                async move {
                    let mut stream = stream;
                    handler.connected(&peer);
                    let _ = serve_connection(&mut stream, &*handler, &peer, &units, idle).await;
                    handler.disconnected(&peer);
                    stream
                }
            },
        )
        .await {}
    }
}

/// Answer the requests on one connection until it closes or sends a bad header.
async fn serve_connection<H: Handler>(
    stream: &mut TcpStream,
    handler: &H,
    peer: &Peer,
    units: &Units,
    idle: Option<Duration>,
) -> std::io::Result<()> {
    stream.set_nodelay(true)?;
    let mut decoder = Decoder::new();
    let mut rx = [0u8; RX_CHUNK];
    loop {
        let read = stream.read(&mut rx);
        let n = match idle {
            Some(limit) => match tokio::time::timeout(limit, read).await {
                Ok(n) => n?,
                Err(_) => return Ok(()),
            },
            None => read.await?,
        };
        if n == 0 {
            return Ok(());
        }
        let mut input = &rx[..n];
        let mut header_error = false;
        loop {
            match decoder.decode(&mut input) {
                Ok(Some(request)) => {
                    if !units.contains(request.unit()) {
                        continue;
                    }
                    let request = *request;
                    // Each answer goes as soon as it is ready: behind a slow handler (a
                    // gateway's serial line) a pipelined request must not hold back the
                    // answers to those before it.
                    if let Some(reply) = handler.answer_from(peer, request).await {
                        stream.write_all(reply.as_bytes()).await?;
                    }
                }
                Ok(None) => break,
                Err(_) => {
                    header_error = true;
                    break;
                }
            }
        }
        if header_error {
            return Ok(());
        }
    }
}

/// The answer of `store` to one request.
fn execute<S: Store>(store: &Mutex<S>, request: &TcpAdu) -> TcpAdu {
    let unit = request.unit();
    let transaction = request.transaction();
    let function = request.function() & 0x7F;
    let exception = |code| Response::Exception { function, code };
    let mut data: ResponseData = [0; 256];
    let response = match request.decode_request() {
        Ok((_, r)) => {
            let mut store = store
                .lock()
                .unwrap_or_else(|poisoned| poisoned.into_inner());
            match serve::execute(&mut *store, &r, &mut data) {
                Outcome::Answer { response, .. } => response,
                Outcome::Refused { code, .. } => exception(code),
            }
        }
        Err(e) => exception(serve::refusal(e.kind).0),
    };
    TcpAdu::response(transaction, unit, &response).unwrap_or_else(|_| {
        // Only a response too long for TCP fails to encode; an exception always fits.
        let refused = exception(ExceptionCode::IllegalDataValue);
        TcpAdu::response(transaction, unit, &refused).unwrap_or_default()
    })
}
