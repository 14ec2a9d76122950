//! A Modbus RTU master on a host that runs late (si_core::driver, "A late host"): when the
//! master's task runs again only after the end-of-frame gap ([Modbus/USS] §3.3.5, Table 3-11)
//! has passed, with the rest of the answer already waiting in the port, the answer is read
//! whole, not cut at a silence the line never had (0E52H/0E57H).
//!
//! Deterministic: tokio's paused clock on the test's one thread. The test writes the slave's
//! bytes and moves the clock past the gap without letting the master's driver run in between;
//! the port logs each read (bytes and instant on that clock), so the test asserts that the
//! driver did take the first half before the gap and the rest only after it: the late-host
//! path, not an answer read in one piece.
#![cfg(feature = "tokio")]

use si_core::driver::{PortFacts, Transport, WithFacts};
use si_modbus::frame::crc16;
use si_modbus::tokio::{Client as _, Master};
use si_modbus::MasterConfig;
use std::pin::Pin;
use std::sync::{Arc, Mutex};
use std::task::{Context, Poll};
use tokio::io::{AsyncRead, AsyncReadExt, AsyncWrite, AsyncWriteExt, DuplexStream, ReadBuf};
use tokio::time::Instant;

/// Each read the driver made: its bytes and when.
type ReadLog = Arc<Mutex<Vec<(Instant, usize)>>>;

/// The master's end of the line, logging its reads.
struct Logged {
    inner: DuplexStream,
    log: ReadLog,
}

impl AsyncRead for Logged {
    fn poll_read(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<std::io::Result<()>> {
        let before = buf.filled().len();
        let polled = Pin::new(&mut self.inner).poll_read(cx, buf);
        let n = buf.filled().len() - before;
        if n > 0 {
            self.log.lock().unwrap().push((Instant::now(), n));
        }
        polled
    }
}

impl AsyncWrite for Logged {
    fn poll_write(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<std::io::Result<usize>> {
        Pin::new(&mut self.inner).poll_write(cx, buf)
    }

    fn poll_flush(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<std::io::Result<()>> {
        Pin::new(&mut self.inner).poll_flush(cx)
    }

    fn poll_shutdown(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<std::io::Result<()>> {
        Pin::new(&mut self.inner).poll_shutdown(cx)
    }
}

impl Transport for Logged {}

#[tokio::test(start_paused = true)]
async fn an_answer_whose_rest_waits_when_the_late_master_wakes_is_read_whole() {
    let (ours, mut slave) = tokio::io::duplex(256);
    let log = ReadLog::default();
    let ours = Logged {
        inner: ours,
        log: log.clone(),
    };
    // A port that delivers byte by byte (declared): the manual's gap, 4 ms at 19 200 bit/s,
    // with no allowance for a packetising adapter.
    let port = WithFacts {
        inner: ours,
        facts: PortFacts {
            rx_latency: Some(si_core::Duration::ZERO),
            ..PortFacts::default()
        },
    };
    let master = Master::spawn(MasterConfig::default(), port).unwrap();
    let reading = tokio::spawn(async move { master.read_holding_registers(1, 0, 2).await });
    let mut request = [0u8; 8];
    slave.read_exact(&mut request).await.unwrap();
    assert_eq!(&request[..6], &[0x01, 0x03, 0x00, 0x00, 0x00, 0x02]);
    // The request has left the wire (its tx-done), the slave has turned round.
    tokio::time::sleep(std::time::Duration::from_millis(10)).await;
    let mut answer = vec![0x01, 0x03, 0x04, 0x00, 0x2A, 0x00, 0x2B];
    let crc = crc16(&answer);
    answer.extend(crc.to_le_bytes());
    slave.write_all(&answer[..4]).await.unwrap();
    // The master's driver takes the first half; the clock stands still while tasks are ready.
    for _ in 0..10 {
        tokio::task::yield_now().await;
    }
    let first_half = Instant::now();
    let taken: usize = log.lock().unwrap().iter().map(|(_, n)| n).sum();
    assert_eq!(taken, 4, "the driver took the first half before the gap");
    // The rest arrives while the master's process is off the CPU; it runs again only well
    // after the gap, with the gap's deadline and the bytes both ready.
    slave.write_all(&answer[4..]).await.unwrap();
    tokio::time::advance(std::time::Duration::from_millis(50)).await;
    assert_eq!(reading.await.unwrap().unwrap(), [0x2A, 0x2B]);
    // The answer came in two parts: the first half before the gap, the rest once the late
    // master woke, after the gap (4 ms at 19 200 bit/s) had passed on the clock.
    let log = log.lock().unwrap();
    let (early, late): (Vec<_>, Vec<_>) = log.iter().partition(|(at, _)| *at <= first_half);
    assert_eq!(early.iter().map(|(_, n)| n).sum::<usize>(), 4, "{log:?}");
    assert_eq!(late.iter().map(|(_, n)| n).sum::<usize>(), 5, "{log:?}");
    let gap = std::time::Duration::from_millis(4);
    assert!(
        late.iter().all(|(at, _)| *at >= first_half + gap),
        "the rest was read before the gap passed: {log:?}"
    );
}
