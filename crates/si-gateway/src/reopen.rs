//! Lines that die and come back: a USB adapter pulled and plugged in again, a device
//! server restarted, a pseudo-terminal closed and made again.
//!
//! Every line kind is served the same way by [`supervise`]: its link (an RTU master, a USS
//! master, …) serves until its port closes; the line is then **down** — the status lines say
//! so with the reason, and its requests are answered with 0AH, "gateway path unavailable" —
//! while the port is opened again by the line kind's own opener, after [`backoff`]; once open,
//! the line counts a reconnect and serves again.
//!
//! The port's closing is seen by wrapping it ([`watch`]): the protocol driver owns the port
//! and drops it when it stops (end of stream, an I/O error, its handle dropped), which tells
//! the line at once, idle or not, with no polling and no change to the protocol crates.
//!
//! A line that cannot be opened at **start** still stops `si gateway` with exit 1 naming it:
//! a wrong path or setting in the configuration is better reported at once than served as a
//! line that is down for ever — unless the gateway's `allow_down_at_start` is set and the
//! port (not the configuration) failed: the line then starts down, and [`supervise`] begins
//! with the reopening (its first opening is no reconnect).

use super::counters::Stats;
use super::line::lock;
use crate::event::{Event, Events};
use crate::Error;
use si_core::driver::{PortFacts, Transport};
use si_core::{ModemSignals, SignalUpdate};
use std::convert::Infallible;
use std::future::Future;
use std::io;
use std::pin::Pin;
use std::sync::{Arc, Mutex};
use std::task::{Context, Poll};
use std::time::Duration;
use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};
use tokio::sync::oneshot;

/// The wait before the first attempt to reopen: a replugged USB adapter's device node is back
/// within about a second (udev), and a restarted device server listens again in that time.
pub const FIRST_WAIT: Duration = Duration::from_secs(1);

/// The longest wait between two attempts: a device that stays away costs two failed opens a
/// minute (a refused TCP connect, a missing path) rather than a tight loop filling the log,
/// and one that comes back is served again within 30 s.
pub const MAX_WAIT: Duration = Duration::from_secs(30);

/// The wait before reopening attempt `attempt` (0 = the first): [`FIRST_WAIT`] doubling up to
/// [`MAX_WAIT`].
pub fn backoff(attempt: u32) -> Duration {
    let factor = 1u32.checked_shl(attempt).unwrap_or(u32::MAX);
    FIRST_WAIT.saturating_mul(factor).min(MAX_WAIT)
}

/// Why a port closed, when the driver did not say (it was dropped without an error seen).
const STOPPED: &str = "the line's driver stopped";

/// A line's port, reporting its closing to [`Closed`] when the driver drops it, with the first
/// I/O error or end of stream it saw as the reason.
pub struct Watched {
    inner: Box<dyn Transport>,
    why: Option<String>,
    closed: Option<oneshot::Sender<String>>,
}

/// Resolves with the reason once the port of a [`Watched`] has been dropped.
pub struct Closed(oneshot::Receiver<String>);

impl Future for Closed {
    type Output = String;

    fn poll(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<String> {
        Pin::new(&mut self.0)
            .poll(cx)
            .map(|r| r.unwrap_or_else(|_| STOPPED.to_owned()))
    }
}

/// Wrap `port` so that its closing can be awaited.
pub fn watch(port: Box<dyn Transport>) -> (Box<dyn Transport>, Closed) {
    let (tx, rx) = oneshot::channel();
    let watched = Watched {
        inner: port,
        why: None,
        closed: Some(tx),
    };
    (Box::new(watched), Closed(rx))
}

impl Watched {
    /// Keep the first failure as the reason.
    fn note<T>(&mut self, what: &str, r: &io::Result<T>) {
        if let (None, Err(e)) = (&self.why, r) {
            self.why = Some(format!("{what}: {e}"));
        }
    }
}

impl Drop for Watched {
    fn drop(&mut self) {
        if let Some(tx) = self.closed.take() {
            let why = self.why.take().unwrap_or_else(|| STOPPED.to_owned());
            // Nobody waits any more when the gateway is ending.
            let _ = tx.send(why);
        }
    }
}

impl AsyncRead for Watched {
    fn poll_read(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<io::Result<()>> {
        let before = buf.filled().len();
        let room = buf.remaining() > 0;
        let r = Pin::new(&mut self.inner).poll_read(cx, buf);
        if let Poll::Ready(result) = &r {
            self.note("read", result);
            if result.is_ok() && room && buf.filled().len() == before && self.why.is_none() {
                self.why = Some("end of stream".to_owned());
            }
        }
        r
    }
}

impl AsyncWrite for Watched {
    fn poll_write(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<io::Result<usize>> {
        let r = Pin::new(&mut self.inner).poll_write(cx, buf);
        if let Poll::Ready(result) = &r {
            self.note("write", result);
        }
        r
    }

    fn poll_flush(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        let r = Pin::new(&mut self.inner).poll_flush(cx);
        if let Poll::Ready(result) = &r {
            self.note("write", result);
        }
        r
    }

    fn poll_shutdown(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.inner).poll_shutdown(cx)
    }
}

impl Transport for Watched {
    fn set_signals(&mut self, update: SignalUpdate) -> io::Result<()> {
        let r = self.inner.set_signals(update);
        self.note("modem signals", &r);
        r
    }

    fn read_signals(&mut self) -> io::Result<Option<ModemSignals>> {
        let r = self.inner.read_signals();
        self.note("modem signals", &r);
        r
    }

    fn attach(&mut self) -> PortFacts {
        self.inner.attach()
    }

    fn new_overruns(&mut self) -> u64 {
        self.inner.new_overruns()
    }
}

/// A line's link to its devices, with the port's closing.
pub struct Opened<L> {
    /// The running protocol master.
    pub link: L,
    /// Resolves when its port has closed.
    pub closed: Closed,
}

impl<E> Opened<(E, Box<dyn Transport>)> {
    /// Start the engine on its port (e.g. `si_uss::tokio::Handle::spawn_engine`).
    pub fn spawn<L>(self, start: impl FnOnce(E, Box<dyn Transport>) -> L) -> Opened<L> {
        let (engine, port) = self.link;
        Opened {
            link: start(engine, port),
            closed: self.closed,
        }
    }
}

/// What a line reports about itself: its counters, state and log lines.
#[derive(Clone)]
pub struct LineLog {
    /// The line's index in the configuration (and in [`Stats::lines`]).
    pub index: usize,
    /// Its name.
    pub name: String,
    /// The gateway's counters.
    pub stats: Arc<Mutex<Stats>>,
    /// Where the line's events go.
    pub events: Events,
}

impl LineLog {
    /// The line's port closed (`was_open`), or could not be opened at start: down, and say so.
    fn down(&self, why: &str, was_open: bool) {
        lock(&self.stats).down[self.index] = Some(why.to_owned());
        (self.events)(&Event::LineDown {
            line: self.index,
            name: self.name.clone(),
            reason: why.to_owned(),
            at_start: !was_open,
        });
    }

    /// An attempt to reopen failed: keep the reason up to date (not logged: one a second
    /// at first, for as long as the device is away).
    fn still_down(&self, why: &str, error: &Error) {
        let reason = format!("{why}; reopening failed: {}", error.text());
        tracing::debug!("line {}: {reason}", self.name);
        lock(&self.stats).down[self.index] = Some(reason);
    }

    /// The line serves again (`was_open`: a reconnect), or for the first time.
    fn up(&self, was_open: bool) {
        let reconnects = {
            let mut s = lock(&self.stats);
            s.down[self.index] = None;
            let c = &mut s.lines[self.index];
            c.reconnects += u64::from(was_open);
            c.reconnects
        };
        (self.events)(&Event::LineUp {
            line: self.index,
            name: self.name.clone(),
            reconnects,
            reopened: was_open,
        });
    }
}

#[cfg(test)]
impl LineLog {
    /// Line 0 of `lines` fresh counters, its events dropped.
    pub fn test(lines: usize) -> LineLog {
        LineLog {
            index: 0,
            name: "test".into(),
            stats: Arc::new(Mutex::new(Stats::new(lines))),
            events: crate::event::ignore(),
        }
    }
}

/// How a line starts: open, or down with the reason its first opening failed (only with the
/// gateway's `allow_down_at_start`).
pub type First<L> = Result<Opened<L>, String>;

/// Serve a line for ever: `serve` runs the link until its port closes (returning why), then
/// the line is down until `open` succeeds, tried after [`backoff`]; `while_down` runs
/// meanwhile (answering what reaches the line with 0AH) and is dropped once it is back. A
/// line that starts down begins with the reopening.
pub async fn supervise<L>(
    log: LineLog,
    first: First<L>,
    mut open: impl AsyncFnMut() -> Result<Opened<L>, Error>,
    mut serve: impl AsyncFnMut(L, Closed) -> String,
    mut while_down: impl AsyncFnMut() -> Infallible,
) {
    // A line that started down was never open: its first opening is no reconnect.
    let mut was_open = first.is_ok();
    let mut state = first;
    loop {
        let why = match state {
            Ok(opened) => serve(opened.link, opened.closed).await,
            Err(why) => why,
        };
        log.down(&why, was_open);
        let reopen = async {
            let mut attempt = 0;
            loop {
                tokio::time::sleep(backoff(attempt)).await;
                match open().await {
                    Ok(o) => break o,
                    Err(e) => log.still_down(&why, &e),
                }
                attempt = attempt.saturating_add(1);
            }
        };
        state = Ok(tokio::select! {
            o = reopen => o,
            never = while_down() => match never {},
        });
        log.up(was_open);
        was_open = true;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_wait_doubles_from_one_second_and_stops_at_thirty() {
        let waits: Vec<u64> = (0..7).map(|n| backoff(n).as_secs()).collect();
        assert_eq!(waits, [1, 2, 4, 8, 16, 30, 30]);
        assert_eq!(backoff(31), MAX_WAIT);
        assert_eq!(
            backoff(u32::MAX),
            MAX_WAIT,
            "no overflow, however long it stays away"
        );
    }

    /// In virtual time: a line whose port closed at once is reopened on the fourth attempt,
    /// 1, 2 and 4 s apart after the first second, answers in the meantime, and counts one
    /// reconnect.
    #[tokio::test(start_paused = true)]
    async fn a_closed_line_is_reopened_after_the_backoff_and_counted() {
        use std::sync::atomic::{AtomicUsize, Ordering};
        let stats = Arc::new(Mutex::new(Stats::new(1)));
        let log = LineLog {
            index: 0,
            name: "l".into(),
            stats: Arc::clone(&stats),
            events: crate::event::ignore(),
        };
        let (a, _b) = tokio::io::duplex(8);
        let (port, closed) = watch(Box::new(a));
        drop(port);
        let first = Ok(Opened { link: 0, closed });
        let start = tokio::time::Instant::now();
        let (mut attempts, mut ports) = (Vec::new(), Vec::new());
        let open = async || {
            attempts.push(start.elapsed().as_secs());
            if attempts.len() < 4 {
                return Err(Error::new("away"));
            }
            let (a, _b) = tokio::io::duplex(8);
            let (port, closed) = watch(Box::new(a));
            ports.push(port);
            Ok(Opened { link: 1, closed })
        };
        let serve = async |link, closed: Closed| match link {
            0 => closed.await,
            _ => std::future::pending().await,
        };
        let down = AtomicUsize::new(0);
        let while_down = async || {
            down.fetch_add(1, Ordering::Relaxed);
            std::future::pending().await
        };
        let run = supervise(log, first, open, serve, while_down);
        let ended = tokio::time::timeout(Duration::from_secs(100), run).await;
        assert!(ended.is_err(), "a line is served for ever");
        assert_eq!(attempts, [1, 3, 7, 15]);
        assert_eq!(down.load(Ordering::Relaxed), 1);
        let s = lock(&stats);
        assert_eq!((s.lines[0].reconnects, s.down[0].clone()), (1, None));
    }

    #[tokio::test]
    async fn the_port_closing_is_seen_with_its_reason() {
        let (a, b) = tokio::io::duplex(64);
        let (mut port, closed) = watch(Box::new(a));
        drop(b);
        let mut buf = [0u8; 4];
        let n = tokio::io::AsyncReadExt::read(&mut port, &mut buf)
            .await
            .unwrap();
        assert_eq!(n, 0);
        drop(port);
        assert_eq!(closed.await, "end of stream");
    }

    #[tokio::test]
    async fn a_port_dropped_without_a_failure_says_the_driver_stopped() {
        let (a, _b) = tokio::io::duplex(64);
        let (port, closed) = watch(Box::new(a));
        drop(port);
        assert_eq!(closed.await, STOPPED);
    }
}
