//! What the driver and the frame log say through `tracing` (si_core::driver, "Logs";
//! si_core::frame_log): a library user's subscriber gets each frame decoded at INFO, the raw
//! bytes and the engine's events at DEBUG, the timers at TRACE; a frame that ends by silence is
//! logged once the silence has passed, without another byte.
//!
//! Alone in its test binary: tracing caches each call site's interest when the site is first
//! hit, and a test of another file hitting the driver's call sites on another thread while a
//! subscriber here is being set up could leave a site cached as disabled for it. The tests here
//! take turns.
#![cfg(feature = "tokio")]

use si_core::driver::{spawn, DriverOptions};
use si_core::frame_log::Frames;
use si_core::monitor::{Counters, Decoder, Kind, LineChar, Record};
use si_core::tap::Tap;
use si_core::{Duration, Engine, Instant, Output, SerialSettings};
use std::collections::VecDeque;
use std::sync::{Arc, Mutex};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tracing_subscriber::util::SubscriberInitExt;

/// A toy monitor: a frame is what one side sends until the other side starts or 10 ms pass.
#[derive(Default)]
struct UntilSilence {
    chars: Vec<u8>,
    from: Option<usize>,
    start: Instant,
    last: Instant,
    counters: Counters,
}

impl UntilSilence {
    fn end(&mut self, out: &mut Vec<Record>) {
        if self.chars.is_empty() {
            return;
        }
        let bytes = std::mem::take(&mut self.chars);
        let label = format!("{} B", bytes.len());
        let mut r = Record::new(Kind::Frame, self.start, self.last, self.from)
            .labelled(label, si_core::hex::format(&bytes));
        r.bytes = bytes;
        out.push(r);
    }
}

impl Decoder for UntilSilence {
    fn push(&mut self, c: &LineChar, out: &mut Vec<Record>) {
        if c.from != self.from {
            self.end(out);
            self.from = c.from;
            self.start = c.at;
        }
        if let Ok(b) = c.item {
            self.chars.push(b);
        }
        self.last = c.at;
    }
    fn idle(&mut self, now: Instant, out: &mut Vec<Record>) {
        if now.saturating_since(self.last) >= Duration::from_millis(10) {
            self.end(out);
        }
    }
    fn counters(&self) -> &Counters {
        &self.counters
    }
}

/// Answers every chunk with A0 and its length, and reports the answer.
#[derive(Default)]
struct Answerer(VecDeque<Output<usize>>);

impl Engine for Answerer {
    type Event = usize;
    fn handle_rx(&mut self, _: Instant, bytes: &[u8]) {
        let answer = vec![0xA0, bytes.len() as u8];
        self.0.push_back(Output::Transmit(answer.into()));
        self.0.push_back(Output::Event(bytes.len()));
    }
    fn handle_timeout(&mut self, _: Instant) {}
    fn poll_output(&mut self) -> Output<usize> {
        self.0.pop_front().unwrap_or(Output::Wait(None))
    }
}

/// The log text, as a subscriber writing into memory has it.
#[derive(Clone, Default)]
struct Captured(Arc<Mutex<Vec<u8>>>);

impl std::io::Write for Captured {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        self.0.lock().unwrap().extend_from_slice(b);
        Ok(b.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Captured {
    fn text(&self) -> String {
        String::from_utf8_lossy(&self.0.lock().unwrap()).into_owned()
    }
    /// The lines at `level` that contain `what`.
    fn lines(&self, level: &str, what: &str) -> usize {
        self.text()
            .lines()
            .filter(|l| l.contains(level) && l.contains(what))
            .count()
    }
}

/// One capture at a time: tracing caches each call site's interest and the global level hint
/// from the dispatchers alive when it looks, so two tests with subscribers of different levels
/// on two threads at once can leave a TRACE call site disabled for the TRACE one.
static ONE_SUBSCRIBER_AT_A_TIME: tokio::sync::Mutex<()> = tokio::sync::Mutex::const_new(());

async fn exchange(level: tracing::Level) -> Captured {
    let _alone = ONE_SUBSCRIBER_AT_A_TIME.lock().await;
    let captured = Captured::default();
    let writer = captured.clone();
    let _subscriber = tracing_subscriber::fmt()
        .with_writer(move || writer.clone())
        .with_max_level(level)
        .with_ansi(false)
        .set_default();
    let (ours, mut theirs) = tokio::io::duplex(64);
    let line = SerialSettings::default();
    let port = Tap::new(ours, Frames::new(Box::<UntilSilence>::default(), line));
    let (mut handle, _task) = spawn(Answerer::default(), port, DriverOptions::default());
    theirs.write_all(&[0x01, 0x02, 0x03]).await.unwrap();
    let mut answer = [0u8; 2];
    theirs.read_exact(&mut answer).await.unwrap();
    assert_eq!(answer, [0xA0, 3]);
    assert_eq!(handle.next_event().await, Some(3));
    // Our answer ends by silence: the frame log's idle tick logs it with no byte to follow.
    tokio::time::sleep(std::time::Duration::from_millis(200)).await;
    captured
}

#[tokio::test(start_paused = true)]
async fn info_gives_each_frame_decoded_and_nothing_raw() {
    let log = exchange(tracing::Level::INFO).await;
    assert_eq!(
        log.lines("INFO", "received 3 B: 01 02 03"),
        1,
        "{}",
        log.text()
    );
    assert_eq!(log.lines("INFO", "sent 2 B: A0 03"), 1, "{}", log.text());
    assert_eq!(log.lines("DEBUG", ""), 0, "{}", log.text());
}

#[tokio::test(start_paused = true)]
async fn debug_adds_the_raw_bytes_and_the_engines_events_trace_the_timers() {
    let log = exchange(tracing::Level::DEBUG).await;
    assert_eq!(log.lines("DEBUG", "rx 01 02 03"), 1, "{}", log.text());
    assert_eq!(log.lines("DEBUG", "tx A0 03"), 1, "{}", log.text());
    assert_eq!(log.lines("DEBUG", "event 3"), 1, "{}", log.text());
    assert_eq!(log.lines("TRACE", ""), 0, "{}", log.text());

    let log = exchange(tracing::Level::TRACE).await;
    assert_eq!(log.lines("TRACE", "tx done"), 1, "{}", log.text());
    assert_eq!(log.lines("INFO", "sent 2 B: A0 03"), 1, "{}", log.text());
}
