//! The RTU-over-TCP listener (`rtu_over_tcp_listen`): raw RTU frames (address, PDU, CRC) over
//! TCP, as serial device servers in "raw" mode and some SCADA drivers send them, answered by any
//! Modbus TCP [`Handler`] (the gateway's router, so they are routed like MBAP requests).
//!
//! Each connection cuts frames with si-modbus's [`RtuStream`] (at their predicted length; an
//! unpredictable one at [`GAP`] of silence). A frame becomes an MBAP request with transaction
//! id 0 and the frame's address as unit id; the answer goes back as an RTU frame with its CRC.
//! Frames whose CRC does not check are dropped without an answer and counted, as a slave on a
//! line drops them ([Modbus serial] §2.5.1.2); so are bytes that make no frame. Requests on one
//! connection are answered one after the other.
//!
//! The listener keeps the Modbus TCP faces' limits, from the same configuration keys
//! (`max_connections`, `idle_timeout_ms`) and in the same way as si-modbus's TCP server: a
//! connection beyond [`Limits::max_connections`] is accepted and closed at once, as mbusd
//! does, and one that sends nothing for [`Limits::idle_timeout`] is closed.

use si_modbus::frame::crc16;
use si_modbus::mbap::TcpAdu;
use si_modbus::rtu_stream::{Cut, RtuStream};
use si_modbus::rx::Expect;
use si_modbus::tokio::tcp::{accept_limited, Handler, Peer};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Duration;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};

/// Silence that ends a frame whose length cannot be predicted (an unknown function code):
/// a device server forwards a frame in one burst, so 50 ms without a byte ends it. `[derived]`:
/// our choice, well above a TCP segment's spread and below a client's timeout.
pub const GAP: Duration = Duration::from_millis(50);

/// What the listener counted, shared with the metrics; never reset.
#[derive(Debug, Default)]
pub struct RtuCounters {
    /// Frames received with a valid CRC.
    pub frames: AtomicU64,
    /// Frames dropped for a wrong CRC.
    pub crc_errors: AtomicU64,
    /// Other bytes dropped as no frame (fragments at a gap, overflows, frames too long for
    /// an MBAP request), counted once per drop.
    pub dropped: AtomicU64,
}

/// The connections a listener serves: the gateway's `max_connections` and
/// `idle_timeout_ms`, as its Modbus TCP faces have them
/// (`si_modbus::tokio::tcp::ServerConfig`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Limits {
    /// Connections served at once; one more is accepted and closed at once.
    pub max_connections: usize,
    /// A connection that sends nothing for this long is closed (`None`: never).
    pub idle_timeout: Option<Duration>,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_connections: si_modbus::tokio::tcp::DEFAULT_MAX_CONNECTIONS,
            idle_timeout: Some(si_modbus::tokio::tcp::DEFAULT_IDLE_TIMEOUT),
        }
    }
}

/// Accept connections on `listener` for ever, up to `limits`, as the Modbus TCP server does
/// (`si_modbus::tokio::tcp::accept_limited`); each is served by `handler`. Connection ids
/// given to the handler are `id_base` + the connection's number from 1.
pub async fn run<H: Handler>(
    listener: TcpListener,
    handler: Arc<H>,
    counters: Arc<RtuCounters>,
    id_base: u64,
    limits: Limits,
) -> std::convert::Infallible {
    accept_limited(&listener, limits.max_connections, |stream, n, addr| {
        let peer = Peer {
            id: id_base | n,
            addr,
        };
        let (h, c) = (Arc::clone(&handler), Arc::clone(&counters));
        async move {
            let mut stream = stream;
            h.connected(&peer);
            let _ = connection(&mut stream, &*h, &peer, &c, limits.idle_timeout).await;
            h.disconnected(&peer);
            stream
        }
    })
    .await
}

/// Serve one connection until it closes, or is silent for `idle` between frames.
async fn connection<H: Handler>(
    stream: &mut TcpStream,
    handler: &H,
    peer: &Peer,
    counters: &RtuCounters,
    idle: Option<Duration>,
) -> std::io::Result<()> {
    let _ = stream.set_nodelay(true);
    let mut rtu = RtuStream::new(Expect::Request);
    let mut buf = [0u8; 512];
    loop {
        let read = if rtu.pending() > 0 {
            tokio::time::timeout(GAP, stream.read(&mut buf)).await
        } else if let Some(idle) = idle {
            match tokio::time::timeout(idle, stream.read(&mut buf)).await {
                Ok(read) => Ok(read),
                Err(_idle) => return Ok(()),
            }
        } else {
            Ok(stream.read(&mut buf).await)
        };
        match read {
            Err(_silence) => {
                while let Some(cut) = rtu.gap() {
                    answer(stream, handler, peer, counters, cut).await?;
                }
            }
            Ok(Ok(0)) => return Ok(()),
            Ok(Ok(n)) => {
                let mut input = &buf[..n];
                while let Some(cut) = rtu.push(&mut input) {
                    answer(stream, handler, peer, counters, cut).await?;
                }
            }
            Ok(Err(e)) => return Err(e),
        }
    }
}

/// Answer one cut: a frame is routed and its answer written back; anything else is counted.
async fn answer<H: Handler>(
    stream: &mut TcpStream,
    handler: &H,
    peer: &Peer,
    counters: &RtuCounters,
    cut: Cut,
) -> std::io::Result<()> {
    let adu = match cut {
        Cut::Frame(adu) => adu,
        Cut::BadCrc { .. } => {
            counters.crc_errors.fetch_add(1, Ordering::Relaxed);
            return Ok(());
        }
        Cut::Fragment { .. } | Cut::Overflow { .. } => {
            counters.dropped.fetch_add(1, Ordering::Relaxed);
            return Ok(());
        }
    };
    let bytes = adu.as_bytes();
    let Ok(request) = TcpAdu::from_unit_pdu(0, &bytes[..bytes.len() - 2]) else {
        counters.dropped.fetch_add(1, Ordering::Relaxed);
        return Ok(());
    };
    counters.frames.fetch_add(1, Ordering::Relaxed);
    let Some(response) = handler.answer_from(peer, request).await else {
        return Ok(());
    };
    let mut frame = response.unit_pdu().to_vec();
    frame.extend_from_slice(&crc16(&frame).to_le_bytes());
    stream.write_all(&frame).await
}

#[cfg(test)]
mod tests {
    use super::*;
    use si_modbus::frame::{Adu, Request};

    /// Answers FC03 with the register address as its one value; unit 9 gets no answer.
    struct Echo;

    impl Handler for Echo {
        async fn answer(&self, request: TcpAdu) -> Option<TcpAdu> {
            if request.unit() == 9 {
                return None;
            }
            let pdu = request.unit_pdu();
            let reply = [request.unit(), 0x03, 2, pdu[2], pdu[3]];
            TcpAdu::from_unit_pdu(request.transaction(), &reply).ok()
        }
    }

    fn fc03(unit: u8, address: u16) -> Vec<u8> {
        let r = Request::ReadHoldingRegisters {
            address,
            quantity: 1,
        };
        Adu::request(unit, &r).unwrap().as_bytes().to_vec()
    }

    #[tokio::test]
    async fn frames_are_answered_and_bad_crcs_dropped_and_counted() {
        let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
        let addr = listener.local_addr().unwrap();
        let counters = Arc::new(RtuCounters::default());
        let limits = Limits::default();
        tokio::spawn(run(
            listener,
            Arc::new(Echo),
            Arc::clone(&counters),
            0,
            limits,
        ));
        let mut client = TcpStream::connect(addr).await.unwrap();
        let mut bad = fc03(1, 0x0102);
        bad[7] ^= 0x55;
        // A bad frame, then two good ones in one write: the bad one gets no answer.
        let mut burst = bad.clone();
        burst.extend(fc03(2, 0x0304));
        burst.extend(fc03(9, 0));
        burst.extend(fc03(3, 0x0506));
        client.write_all(&burst).await.unwrap();
        let mut got = [0u8; 14];
        client.read_exact(&mut got).await.unwrap();
        let want = |unit: u8, hi: u8, lo: u8| {
            let mut f = vec![unit, 0x03, 2, hi, lo];
            f.extend_from_slice(&crc16(&f).to_le_bytes());
            f
        };
        assert_eq!(got[..7], want(2, 0x03, 0x04)[..]);
        assert_eq!(got[7..], want(3, 0x05, 0x06)[..]);
        assert_eq!(counters.crc_errors.load(Ordering::Relaxed), 1);
        assert_eq!(counters.frames.load(Ordering::Relaxed), 3);
    }

    /// A listener with `limits` on a free port, answering with [`Echo`].
    async fn listening(limits: Limits) -> std::net::SocketAddr {
        let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
        let addr = listener.local_addr().unwrap();
        let counters = Arc::new(RtuCounters::default());
        tokio::spawn(run(listener, Arc::new(Echo), counters, 0, limits));
        addr
    }

    /// Whether the listener closed `client`'s connection (end of stream or reset) rather than
    /// answering or keeping it open, waiting an hour at most (a bound only: on the paused
    /// clock it passes at once when nothing else would happen).
    async fn closed(client: &mut TcpStream) -> bool {
        let mut byte = [0u8; 1];
        let read = tokio::time::timeout(Duration::from_secs(3600), client.read(&mut byte));
        matches!(read.await, Ok(Ok(0) | Err(_)))
    }

    #[tokio::test]
    async fn a_connection_over_max_connections_is_closed_at_once() {
        let addr = listening(Limits {
            max_connections: 1,
            idle_timeout: None,
        })
        .await;
        let mut first = TcpStream::connect(addr).await.unwrap();
        first.write_all(&fc03(2, 0x0304)).await.unwrap();
        let mut got = [0u8; 7];
        first.read_exact(&mut got).await.unwrap();
        assert_eq!(got[..5], [2, 0x03, 2, 0x03, 0x04], "the first is served");
        let mut second = TcpStream::connect(addr).await.unwrap();
        // Its request is never answered: the connection is closed.
        let _ = second.write_all(&fc03(3, 0x0506)).await;
        assert!(closed(&mut second).await, "the second is refused");
        // The first is still served.
        first.write_all(&fc03(4, 0x0708)).await.unwrap();
        first.read_exact(&mut got).await.unwrap();
        assert_eq!(got[..5], [4, 0x03, 2, 0x07, 0x08]);
    }

    #[tokio::test(start_paused = true)]
    async fn a_silent_connection_is_closed_after_the_idle_timeout() {
        let idle = Duration::from_secs(60);
        let addr = listening(Limits {
            max_connections: 4,
            idle_timeout: Some(idle),
        })
        .await;
        let mut client = TcpStream::connect(addr).await.unwrap();
        client.write_all(&fc03(2, 0x0304)).await.unwrap();
        let mut got = [0u8; 7];
        client.read_exact(&mut got).await.unwrap();
        let answered = tokio::time::Instant::now();
        // Silent from here: the listener closes it once the idle time has passed (tokio's
        // paused clock runs on while every task waits), and not before.
        assert!(closed(&mut client).await);
        assert!(
            answered.elapsed() >= idle,
            "closed after {:?}",
            answered.elapsed()
        );
        // Without an idle timeout, the same silence keeps the connection.
        let addr = listening(Limits {
            max_connections: 4,
            idle_timeout: None,
        })
        .await;
        let mut kept = TcpStream::connect(addr).await.unwrap();
        let mut byte = [0u8; 1];
        let waited = tokio::time::timeout(idle * 2, kept.read(&mut byte)).await;
        assert!(
            waited.is_err(),
            "still open after twice the time: {waited:?}"
        );
    }
}
