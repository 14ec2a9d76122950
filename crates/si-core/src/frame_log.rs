//! Decoded frames in the logs: a [`Transport`] wrapper that shows each frame sent and received
//! as text through `tracing`, at INFO (the level `si -v` shows).
//!
//! The driver cannot name a frame: it moves bytes for any [`Engine`](crate::Engine). The
//! protocol crates' passive monitors can ([`crate::monitor`]: `si_modbus::monitor`,
//! `si_3964r::monitor`, …), so [`FrameLog`] feeds one of them everything written to and read
//! from the transport it wraps and logs every [`Record`] the monitor completes: frames, control
//! characters and the monitor's notes (a timer that ran out, a bad check sum). Any handle takes
//! it as its transport, so a program gets the same lines as `si -v` through its own subscriber:
//!
//! ```no_run
//! # async fn demo(port: tokio::io::DuplexStream) {
//! use si_core::frame_log::FrameLog;
//! use si_core::monitor::{Counters, Decoder, LineChar, Record};
//! # #[derive(Default)] struct MyMonitor(Counters);
//! # impl Decoder for MyMonitor {
//! #     fn push(&mut self, _: &LineChar, _: &mut Vec<Record>) {}
//! #     fn idle(&mut self, _: si_core::Instant, _: &mut Vec<Record>) {}
//! #     fn counters(&self) -> &Counters { &self.0 }
//! # }
//! let settings = si_core::SerialSettings::default();
//! // A protocol crate's monitor, e.g. si_modbus::monitor::Monitor::new(params, false).
//! let logged = FrameLog::new(port, Box::new(MyMonitor::default()), settings);
//! // Hand `logged` to a handle's `spawn` in place of the port.
//! # let _ = logged;
//! # }
//! ```
//!
//! What the line carried is logged, as a monitor cable would see it: on a port that hears its
//! own transmission (`PortFacts::local_echo`) a frame sent is also logged as received. Times
//! come from the log's timestamps (wall clock, when the monitor completed the record: a frame
//! ended by silence is logged once the silence has passed). The raw bytes, the engine's events
//! and its timers are the driver's DEBUG and TRACE lines ([`crate::driver`], "Logs").

use crate::driver::{PortFacts, Transport};
use crate::linemark::{MarkDecoder, Marked};
use crate::monitor::{line, Decoder, Kind, LineChar, Record, Severity};
use crate::sansio::{ModemSignals, SignalUpdate};
use crate::serial::SerialSettings;
use crate::time::{Duration, Instant};
use std::future::Future;
use std::io;
use std::pin::Pin;
use std::task::{Context, Poll};
use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};

/// The monitor's station index for this side of the line (what is written).
pub const SENT: usize = 0;
/// The monitor's station index for the partner (what is read).
pub const RECEIVED: usize = 1;

/// Silence after the last character before the monitor is asked what is overdue (a frame that
/// ends by a gap, Modbus's 3.5 characters or the ASCII character delay): the live monitor's
/// tick, or eight characters on a slow line.
const IDLE_TICK: Duration = Duration::from_millis(50);

/// A transport that logs the frames passing through it (module docs).
pub struct FrameLog<T> {
    inner: T,
    decoder: Box<dyn Decoder + Send>,
    settings: SerialSettings,
    /// The monitor's clock: microseconds since the wrapper was made.
    origin: tokio::time::Instant,
    /// The last character's time (characters are fed in time order).
    last: Instant,
    /// Once a driver attached to a port that marks line errors: reads are marked.
    marks: Option<MarkDecoder>,
    /// Wakes the reading task when the line has been quiet for [`IDLE_TICK`] after characters
    /// were fed, so a frame ended by silence is logged without waiting for the next byte.
    idle: Option<Pin<Box<tokio::time::Sleep>>>,
    records: Vec<Record>,
}

impl<T> core::fmt::Debug for FrameLog<T> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("FrameLog")
            .field("settings", &self.settings)
            .finish_non_exhaustive()
    }
}

impl<T> FrameLog<T> {
    /// Log what passes through `inner` with `decoder`, a protocol's passive monitor, on a line
    /// with `settings` (the character time places the characters of a chunk).
    pub fn new(inner: T, decoder: Box<dyn Decoder + Send>, settings: SerialSettings) -> Self {
        FrameLog {
            inner,
            decoder,
            settings,
            origin: tokio::time::Instant::now(),
            last: Instant::ZERO,
            marks: None,
            idle: None,
            records: Vec::new(),
        }
    }

    fn now(&self) -> Instant {
        Instant::from_micros(self.origin.elapsed().as_micros() as u64)
    }

    /// Feed characters whose last one ends at `at` from `from` to the other side.
    fn feed(&mut self, bytes: &[u8], at: Instant, from: usize) {
        let to = Some(SENT + RECEIVED - from);
        for c in line::pace(bytes, at, (Some(from), to), self.settings, &mut self.last) {
            self.decoder.push(&c, &mut self.records);
        }
        self.fed();
    }

    /// A line error where a character would have been.
    fn feed_error(&mut self, error: crate::LineError, at: Instant) {
        let c = LineChar {
            at: at.max(self.last),
            from: Some(RECEIVED),
            to: Some(SENT),
            item: Err(error),
            exact: true,
        };
        self.last = c.at;
        self.decoder.push(&c, &mut self.records);
        self.fed();
    }

    /// Characters went in: log what they completed, ask again after a silence.
    fn fed(&mut self) {
        self.flush();
        let tick = IDLE_TICK.max(self.settings.chars_time(8));
        let at = tokio::time::Instant::now() + std::time::Duration::from(tick);
        match &mut self.idle {
            Some(sleep) => sleep.as_mut().reset(at),
            None => self.idle = Some(Box::pin(tokio::time::sleep_until(at))),
        }
    }

    /// The silence has passed: ask the monitor what is overdue.
    fn poll_idle(&mut self, cx: &mut Context<'_>) {
        if let Some(sleep) = &mut self.idle {
            if sleep.as_mut().poll(cx).is_ready() {
                self.idle = None;
                let now = self.now();
                self.decoder.idle(now, &mut self.records);
                self.flush();
            }
        }
    }

    fn flush(&mut self) {
        for r in self.records.drain(..) {
            log(&r);
        }
    }
}

/// One record as one INFO line: direction, label, meaning, flags.
fn log(r: &Record) {
    let side = match r.from {
        Some(SENT) => "sent",
        Some(_) => "received",
        None => "line",
    };
    let text = if r.text.is_empty() || r.text == r.label {
        r.label.clone()
    } else {
        format!("{}: {}", r.label, r.text)
    };
    let flags: String = r
        .flags
        .iter()
        .map(|f| match f.severity {
            Severity::Error => format!(" [!! {}]", f.text),
            Severity::Note => format!(" [{}]", f.text),
        })
        .collect();
    match r.kind {
        Kind::Note => tracing::info!("{side}: !! {}", r.label),
        _ => tracing::info!("{side} {text}{flags}"),
    }
}

impl<T> Drop for FrameLog<T> {
    fn drop(&mut self) {
        let now = self.now();
        self.decoder.finish(now, &mut self.records);
        self.flush();
    }
}

impl<T: Transport> AsyncRead for FrameLog<T> {
    fn poll_read(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<io::Result<()>> {
        let this = &mut *self;
        let before = buf.filled().len();
        let poll = Pin::new(&mut this.inner).poll_read(cx, buf);
        if let Poll::Ready(Ok(())) = &poll {
            let new = &buf.filled()[before..];
            if !new.is_empty() && tracing::enabled!(tracing::Level::INFO) {
                let now = this.now();
                match this.marks.take() {
                    None => this.feed(new, now, RECEIVED),
                    Some(mut marks) => {
                        marks.feed(new, |piece| match piece {
                            Marked::Data(run) => this.feed(run, now, RECEIVED),
                            Marked::Error(error) => this.feed_error(error, now),
                        });
                        this.marks = Some(marks);
                    }
                }
            }
        }
        this.poll_idle(cx);
        poll
    }
}

impl<T: Transport> AsyncWrite for FrameLog<T> {
    fn poll_write(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<io::Result<usize>> {
        let this = &mut *self;
        let poll = Pin::new(&mut this.inner).poll_write(cx, buf);
        if let Poll::Ready(Ok(n)) = &poll {
            if *n > 0 && tracing::enabled!(tracing::Level::INFO) {
                // The characters leave one after another from now on.
                let ends = this.now() + this.settings.chars_time(*n as u64);
                this.feed(&buf[..*n], ends, SENT);
            }
        }
        poll
    }
    fn poll_flush(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.inner).poll_flush(cx)
    }
    fn poll_shutdown(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.inner).poll_shutdown(cx)
    }
}

impl<T: Transport> Transport for FrameLog<T> {
    fn set_signals(&mut self, update: SignalUpdate) -> io::Result<()> {
        self.inner.set_signals(update)
    }
    fn read_signals(&mut self) -> io::Result<Option<ModemSignals>> {
        self.inner.read_signals()
    }
    fn attach(&mut self) -> PortFacts {
        let facts = self.inner.attach();
        self.marks = facts.marked_errors.map(MarkDecoder::new);
        facts
    }
}
