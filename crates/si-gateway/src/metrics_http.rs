//! `GET /metrics` over plain HTTP/1.1 on `metrics_listen`: the gateway's counters in the
//! Prometheus text exposition format ([`super::gateway_metrics`]).
//!
//! Enough HTTP for a Prometheus scraper or curl: one request per connection, its head read up to
//! [`MAX_HEAD`] bytes within [`HEAD_TIMEOUT`], answered with `Connection: close`. `GET
//! /metrics` (a query string is ignored) is 200, another path 404, another method 405.

use super::counters::Stats;
use super::gateway_metrics::RtuNow;
use super::line::lock;
use super::rtu_listener::RtuCounters;
use si_modbus::tokio::tcp::ACCEPT_RETRY;
use std::sync::atomic::Ordering;
use std::sync::{Arc, Mutex};
use std::time::Duration;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};

/// The longest request head read; a longer one is refused (431).
pub const MAX_HEAD: usize = 8192;
/// A client that has not sent its request head by then is dropped.
pub const HEAD_TIMEOUT: Duration = Duration::from_secs(10);

/// What a scrape reads.
#[derive(Clone)]
pub struct Source {
    /// The gateway's counters and metrics.
    pub stats: Arc<Mutex<Stats>>,
    /// The RTU-over-TCP listener's counters, if it runs.
    pub rtu: Option<Arc<RtuCounters>>,
}

impl Source {
    /// The exposition text now.
    pub fn render(&self) -> String {
        let rtu = self.rtu.as_ref().map(|c| RtuNow {
            frames: c.frames.load(Ordering::Relaxed),
            crc_errors: c.crc_errors.load(Ordering::Relaxed),
            dropped: c.dropped.load(Ordering::Relaxed),
        });
        let mut s = lock(&self.stats);
        let now = s.lines_now();
        s.metrics.render(&now, rtu)
    }
}

/// Serve scrapes on `listener` for ever (a failed accept is retried after
/// [`ACCEPT_RETRY`], as the Modbus TCP faces do).
pub async fn run(listener: TcpListener, source: Source) -> std::convert::Infallible {
    loop {
        let (stream, _) = match listener.accept().await {
            Ok(accepted) => accepted,
            Err(_) => {
                tokio::time::sleep(ACCEPT_RETRY).await;
                continue;
            }
        };
        let source = source.clone();
        tokio::spawn(async move {
            let _ = tokio::time::timeout(HEAD_TIMEOUT, scrape(stream, &source)).await;
        });
    }
}

/// Read one request head and answer it.
async fn scrape(mut stream: TcpStream, source: &Source) -> std::io::Result<()> {
    let mut head = Vec::with_capacity(512);
    let mut buf = [0u8; 512];
    while !head.windows(4).any(|w| w == b"\r\n\r\n") {
        if head.len() > MAX_HEAD {
            return respond(&mut stream, "431 Request Header Fields Too Large", "").await;
        }
        let n = stream.read(&mut buf).await?;
        if n == 0 {
            return Ok(());
        }
        head.extend_from_slice(&buf[..n]);
    }
    let line = head.split(|&b| b == b'\r').next().unwrap_or_default();
    let line = String::from_utf8_lossy(line);
    let mut parts = line.split(' ');
    let (method, target) = (parts.next().unwrap_or(""), parts.next().unwrap_or(""));
    let path = target.split('?').next().unwrap_or("");
    match (method, path) {
        ("GET", "/metrics") => respond(&mut stream, "200 OK", &source.render()).await,
        ("GET", _) => respond(&mut stream, "404 Not Found", "only /metrics here\n").await,
        _ => respond(&mut stream, "405 Method Not Allowed", "GET /metrics\n").await,
    }
}

async fn respond(stream: &mut TcpStream, status: &str, body: &str) -> std::io::Result<()> {
    let head = format!(
        "HTTP/1.1 {status}\r\nContent-Type: text/plain; version=0.0.4; charset=utf-8\r\n\
         Content-Length: {}\r\nConnection: close\r\n\r\n",
        body.len()
    );
    stream.write_all(head.as_bytes()).await?;
    stream.write_all(body.as_bytes()).await?;
    stream.shutdown().await
}

#[cfg(test)]
mod tests {
    use super::*;

    async fn get(addr: std::net::SocketAddr, request: &str) -> String {
        let mut s = TcpStream::connect(addr).await.unwrap();
        s.write_all(request.as_bytes()).await.unwrap();
        let mut out = String::new();
        s.read_to_string(&mut out).await.unwrap();
        out
    }

    #[tokio::test]
    async fn metrics_are_served_other_paths_are_not() {
        let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
        let addr = listener.local_addr().unwrap();
        let mut stats = Stats::new(1);
        stats.metrics = super::super::gateway_metrics::GatewayMetrics::new(vec!["l".into()]);
        let source = Source {
            stats: Arc::new(Mutex::new(stats)),
            rtu: None,
        };
        tokio::spawn(run(listener, source));
        let ok = get(addr, "GET /metrics HTTP/1.1\r\nHost: x\r\n\r\n").await;
        assert!(ok.starts_with("HTTP/1.1 200 OK\r\n"), "{ok}");
        assert!(
            ok.contains("\r\n\r\n# HELP si_gateway_requests_total "),
            "{ok}"
        );
        assert!(ok.contains("si_gateway_line_up{line=\"l\"} 1\n"), "{ok}");
        let missing = get(addr, "GET / HTTP/1.1\r\n\r\n").await;
        assert!(missing.starts_with("HTTP/1.1 404 "), "{missing}");
        let post = get(addr, "POST /metrics HTTP/1.1\r\n\r\n").await;
        assert!(post.starts_with("HTTP/1.1 405 "), "{post}");
    }
}
