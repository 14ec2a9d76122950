//! Decoded frames in the logs: a [`Transport`](crate::driver::Transport) wrapper that shows
//! each frame sent and received as text through `tracing`, at INFO (the level `si -v` shows).
//!
//! The driver cannot name a frame: it moves bytes for any [`Engine`](crate::Engine). The
//! protocol crates' passive monitors can ([`crate::monitor`]: `si_modbus::monitor`,
//! `si_3964r::monitor`, …), so [`Frames`] watches a transport through a [`Tap`], feeds one of
//! them everything written and read, and logs every [`Record`] the monitor completes: frames,
//! control characters and the monitor's notes (a timer that ran out, a bad check sum). Any
//! handle takes the tapped transport ([`FrameLog`]) as its transport, so a program gets the
//! same lines as `si -v` through its own subscriber:
//!
//! ```no_run
//! # async fn demo(port: tokio::io::DuplexStream) {
//! use si_core::frame_log::Frames;
//! use si_core::tap::Tap;
//! use si_core::monitor::{Counters, Decoder, LineChar, Record};
//! # #[derive(Default)] struct MyMonitor(Counters);
//! # impl Decoder for MyMonitor {
//! #     fn push(&mut self, _: &LineChar, _: &mut Vec<Record>) {}
//! #     fn idle(&mut self, _: si_core::Instant, _: &mut Vec<Record>) {}
//! #     fn counters(&self) -> &Counters { &self.0 }
//! # }
//! let settings = si_core::SerialSettings::default();
//! // A protocol crate's monitor, e.g. si_modbus::monitor::Monitor::new(params, false).
//! let logged = Tap::new(port, Frames::new(Box::new(MyMonitor::default()), settings));
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

use crate::linemark::Marked;
use crate::monitor::{line, Decoder, Kind, LineChar, Record};
use crate::serial::SerialSettings;
use crate::tap::{Tap, Watch};
use crate::time::{Duration, Instant};
use std::future::Future;
use std::pin::Pin;
use std::task::Context;

/// The monitor's station index for this side of the line (what is written).
pub const SENT: usize = 0;
/// The monitor's station index for the partner (what is read).
pub const RECEIVED: usize = 1;

/// Silence after the last character before the monitor is asked what is overdue (a frame that
/// ends by a gap, Modbus's 3.5 characters or the ASCII character delay): the live monitor's
/// tick, or eight characters on a slow line.
const IDLE_TICK: Duration = Duration::from_millis(50);

/// A transport whose frames are logged (module docs).
pub type FrameLog<T> = Tap<T, Frames>;

/// Logs the frames on a tapped line (module docs).
pub struct Frames {
    decoder: Box<dyn Decoder + Send>,
    settings: SerialSettings,
    /// The monitor's clock: microseconds since the watcher was made.
    origin: tokio::time::Instant,
    /// The last character's time (characters are fed in time order).
    last: Instant,
    /// Who sent the last character.
    last_from: Option<usize>,
    /// Wakes the reading task when the line has been quiet for [`IDLE_TICK`] after characters
    /// were fed, so a frame ended by silence is logged without waiting for the next byte.
    idle: Option<Pin<Box<tokio::time::Sleep>>>,
    records: Vec<Record>,
}

impl core::fmt::Debug for Frames {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Frames")
            .field("settings", &self.settings)
            .finish_non_exhaustive()
    }
}

impl Frames {
    /// Log with `decoder`, a protocol's passive monitor, on a line with `settings` (the
    /// character time places the characters of a chunk).
    pub fn new(decoder: Box<dyn Decoder + Send>, settings: SerialSettings) -> Self {
        Frames {
            decoder,
            settings,
            origin: tokio::time::Instant::now(),
            last: Instant::ZERO,
            last_from: None,
            idle: None,
            records: Vec::new(),
        }
    }

    fn now(&self) -> Instant {
        Instant::from_micros(self.origin.elapsed().as_micros() as u64)
    }

    /// Feed characters whose last one ends at `at` from `from` to the other side.
    ///
    /// The silence before the first character after the other side's is not judged (it is
    /// not `exact`): what was written is placed at its character times from the write on, but a
    /// port without wire time (a pseudo-terminal, a device server) delivers the answer sooner,
    /// and the monitor would flag a turnaround that never happened on the line.
    fn feed(&mut self, bytes: &[u8], at: Instant, from: usize) {
        let to = Some(SENT + RECEIVED - from);
        let turned = self.last_from.replace(from) != Some(from);
        for (k, mut c) in
            line::pace(bytes, at, (Some(from), to), self.settings, &mut self.last).enumerate()
        {
            c.exact &= !(turned && k == 0);
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
        self.last_from = Some(RECEIVED);
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

    fn flush(&mut self) {
        for r in self.records.drain(..) {
            log(&r);
        }
    }
}

impl Watch for Frames {
    fn written(&mut self, bytes: &[u8]) {
        if tracing::enabled!(tracing::Level::INFO) {
            // The characters leave one after another from now on.
            let ends = self.now() + self.settings.chars_time(bytes.len() as u64);
            self.feed(bytes, ends, SENT);
        }
    }

    fn read(&mut self, piece: Marked<'_>) {
        if tracing::enabled!(tracing::Level::INFO) {
            let now = self.now();
            match piece {
                Marked::Data(run) => self.feed(run, now, RECEIVED),
                Marked::Error(error) => self.feed_error(error, now),
            }
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
    let flags: String = r.flags.iter().map(|f| format!(" [{f}]")).collect();
    match r.kind {
        Kind::Note => tracing::info!("{side}: !! {}", r.label),
        _ => tracing::info!("{side} {text}{flags}"),
    }
}

impl Drop for Frames {
    fn drop(&mut self) {
        let now = self.now();
        self.decoder.finish(now, &mut self.records);
        self.flush();
    }
}
