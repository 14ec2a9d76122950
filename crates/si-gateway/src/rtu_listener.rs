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

use si_modbus::frame::crc16;
use si_modbus::mbap::TcpAdu;
use si_modbus::rtu_stream::{Cut, RtuStream};
use si_modbus::rx::Expect;
use si_modbus::tokio::tcp::{Handler, Peer};
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

/// Pause after a failed accept (out of file descriptors and the like) before the next, as the
/// Modbus TCP server does: one failing connection attempt must not end the listener, and
/// retrying at once would spin.
pub const ACCEPT_RETRY: Duration = Duration::from_millis(100);

/// Accept connections on `listener` for ever (a failed accept is retried after
/// [`ACCEPT_RETRY`]); each is served by `handler`. Connection ids given to the handler are
/// `id_base` + the connection's number from 1.
pub async fn run<H: Handler>(
    listener: TcpListener,
    handler: Arc<H>,
    counters: Arc<RtuCounters>,
    id_base: u64,
) -> std::convert::Infallible {
    let mut next = 0u64;
    loop {
        let (stream, addr) = match listener.accept().await {
            Ok(accepted) => accepted,
            Err(_) => {
                tokio::time::sleep(ACCEPT_RETRY).await;
                continue;
            }
        };
        next += 1;
        let peer = Peer {
            id: id_base | next,
            addr,
        };
        let (h, c) = (Arc::clone(&handler), Arc::clone(&counters));
        tokio::spawn(async move {
            h.connected(&peer);
            let _ = connection(stream, &*h, &peer, &c).await;
            h.disconnected(&peer);
        });
    }
}

/// Serve one connection until it closes.
async fn connection<H: Handler>(
    mut stream: TcpStream,
    handler: &H,
    peer: &Peer,
    counters: &RtuCounters,
) -> std::io::Result<()> {
    let _ = stream.set_nodelay(true);
    let mut rtu = RtuStream::new(Expect::Request);
    let mut buf = [0u8; 512];
    loop {
        let read = if rtu.pending() > 0 {
            tokio::time::timeout(GAP, stream.read(&mut buf)).await
        } else {
            Ok(stream.read(&mut buf).await)
        };
        match read {
            Err(_silence) => {
                while let Some(cut) = rtu.gap() {
                    answer(&mut stream, handler, peer, counters, cut).await?;
                }
            }
            Ok(Ok(0)) => return Ok(()),
            Ok(Ok(n)) => {
                let mut input = &buf[..n];
                while let Some(cut) = rtu.push(&mut input) {
                    answer(&mut stream, handler, peer, counters, cut).await?;
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
        tokio::spawn(run(listener, Arc::new(Echo), Arc::clone(&counters), 0));
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
}
