//! A late host ("A late host" in si_core::driver): when the driver runs again only after an
//! engine's deadline has passed, bytes already waiting in the port reach the engine before
//! that deadline fires, and only a silence that really happened ends a frame.
//!
//! Deterministic: tokio's paused clock on the test's one thread. The test writes the peer's
//! bytes and moves the clock past the deadline without letting the driver task run in between
//! (`tokio::time::advance` yields only after moving the clock), which is exactly what a host
//! that was off the CPU for longer than the gap sees when it wakes.

use si_core::driver::{spawn, DriverOptions};
use si_core::{Duration, Engine, Instant, Output};
use std::collections::VecDeque;
use tokio::io::AsyncWriteExt;

/// The end-of-frame silence of the test engine: long enough that the driver waits for it on
/// tokio's wheel, so under the paused clock nothing but the test moves time past it.
const GAP: Duration = Duration::from_millis(10);

/// Ends a frame by silence, as a Modbus RTU receiver does: a frame ends when `GAP` has passed
/// since its last byte, told by a timeout or by bytes that come after the gap.
#[derive(Default)]
struct Framer {
    frame: Vec<u8>,
    last: Option<Instant>,
    frames: VecDeque<Vec<u8>>,
}

impl Framer {
    fn end_if_silent(&mut self, now: Instant) {
        if self.last.is_some_and(|last| now >= last + GAP) {
            self.last = None;
            self.frames.push_back(std::mem::take(&mut self.frame));
        }
    }
}

impl Engine for Framer {
    type Event = Vec<u8>;
    fn handle_rx(&mut self, now: Instant, bytes: &[u8]) {
        self.end_if_silent(now);
        self.frame.extend_from_slice(bytes);
        self.last = Some(now);
    }
    fn handle_timeout(&mut self, now: Instant) {
        self.end_if_silent(now);
    }
    fn poll_output(&mut self) -> Output<Vec<u8>> {
        match self.frames.pop_front() {
            Some(frame) => Output::Event(frame),
            None => Output::Wait(self.last.map(|last| last + GAP)),
        }
    }
}

/// Write `bytes` as the peer and wait until the driver has handed them to the engine, the
/// clock standing still (the driver task runs as soon as the test task waits).
async fn arrive(
    theirs: &mut tokio::io::DuplexStream,
    handle: &si_core::driver::Handle<Framer>,
    bytes: &[u8],
) {
    let want = handle.call(|f, _| f.frame.len()).await.unwrap() + bytes.len();
    theirs.write_all(bytes).await.unwrap();
    while handle.call(|f, _| f.frame.len()).await.unwrap() < want {}
}

#[tokio::test(start_paused = true)]
async fn a_frame_whose_rest_waits_when_the_late_driver_wakes_arrives_whole() {
    let (ours, mut theirs) = tokio::io::duplex(64);
    let (mut handle, _task) = spawn(Framer::default(), ours, DriverOptions::default());
    arrive(&mut theirs, &handle, &[0x01, 0x03]).await;
    // The rest of the frame reaches the port while the driver is off the CPU; it runs again
    // only when the gap has long passed, with the gap's deadline and the bytes both ready.
    theirs.write_all(&[0x02, 0x00, 0x2A]).await.unwrap();
    tokio::time::advance((GAP + GAP + GAP).into()).await;
    assert_eq!(
        handle.next_event().await,
        Some(vec![0x01, 0x03, 0x02, 0x00, 0x2A]),
        "the line was never silent for the gap: one frame"
    );
}

#[tokio::test(start_paused = true)]
async fn a_silence_that_really_happened_still_ends_the_frame() {
    let (ours, mut theirs) = tokio::io::duplex(64);
    let (mut handle, _task) = spawn(Framer::default(), ours, DriverOptions::default());
    arrive(&mut theirs, &handle, &[0x01, 0x03]).await;
    // The driver is late, but nothing waits: the gap fires when it runs.
    tokio::time::advance((GAP + GAP + GAP).into()).await;
    assert_eq!(handle.next_event().await, Some(vec![0x01, 0x03]));
    theirs.write_all(&[0x02, 0x00]).await.unwrap();
    assert_eq!(handle.next_event().await, Some(vec![0x02, 0x00]));
}

/// A deadline that bytes do not move (a response timeout), armed by command; counts the bytes
/// received before it fires.
#[derive(Default)]
struct Timeout {
    deadline: Option<Instant>,
    received: usize,
    fired: Option<(Instant, usize)>,
}

impl Engine for Timeout {
    type Event = (Instant, usize);
    fn handle_rx(&mut self, _: Instant, bytes: &[u8]) {
        self.received += bytes.len();
    }
    fn handle_timeout(&mut self, now: Instant) {
        if self.deadline.is_some_and(|d| now >= d) {
            self.deadline = None;
            self.fired = Some((now, self.received));
        }
    }
    fn poll_output(&mut self) -> Output<(Instant, usize)> {
        match self.fired.take() {
            Some(fired) => Output::Event(fired),
            None => Output::Wait(self.deadline),
        }
    }
}

#[tokio::test(start_paused = true)]
async fn a_deadline_bytes_do_not_move_gets_the_waiting_bytes_first_and_then_fires() {
    let (ours, mut theirs) = tokio::io::duplex(64);
    let (mut handle, _task) = spawn(Timeout::default(), ours, DriverOptions::default());
    let deadline = handle
        .call(|t, now| *t.deadline.insert(now + GAP))
        .await
        .unwrap();
    theirs.write_all(&[0x01, 0x03, 0x02]).await.unwrap();
    tokio::time::advance((GAP + GAP).into()).await;
    let (at, received) = handle.next_event().await.unwrap();
    assert_eq!(received, 3, "the answer waiting in the port came first");
    assert!(at >= deadline, "fired early: {at} < {deadline}");
}

/// A port that hands over at most two bytes per read: what waited behind an expired deadline
/// takes the driver several reads to take.
struct TwoAtATime(tokio::io::DuplexStream);

impl tokio::io::AsyncRead for TwoAtATime {
    fn poll_read(
        mut self: std::pin::Pin<&mut Self>,
        cx: &mut std::task::Context<'_>,
        buf: &mut tokio::io::ReadBuf<'_>,
    ) -> std::task::Poll<std::io::Result<()>> {
        let mut two = [0u8; 2];
        let mut small = tokio::io::ReadBuf::new(&mut two);
        let polled = std::pin::Pin::new(&mut self.0).poll_read(cx, &mut small);
        buf.put_slice(small.filled());
        polled
    }
}

impl tokio::io::AsyncWrite for TwoAtATime {
    fn poll_write(
        mut self: std::pin::Pin<&mut Self>,
        cx: &mut std::task::Context<'_>,
        buf: &[u8],
    ) -> std::task::Poll<std::io::Result<usize>> {
        std::pin::Pin::new(&mut self.0).poll_write(cx, buf)
    }
    fn poll_flush(
        mut self: std::pin::Pin<&mut Self>,
        cx: &mut std::task::Context<'_>,
    ) -> std::task::Poll<std::io::Result<()>> {
        std::pin::Pin::new(&mut self.0).poll_flush(cx)
    }
    fn poll_shutdown(
        mut self: std::pin::Pin<&mut Self>,
        cx: &mut std::task::Context<'_>,
    ) -> std::task::Poll<std::io::Result<()>> {
        std::pin::Pin::new(&mut self.0).poll_shutdown(cx)
    }
}

impl si_core::driver::Transport for TwoAtATime {}

/// Each chunk taken late is stamped before the deadline the engine named after the last one,
/// whichever way the driver came to take the first (its read or its look at the clock): a
/// look at the clock that fired nothing does not count as telling the engine the time. The
/// driver picks between a ready read and a ready timer at random, so the scenario is run
/// several times (the old reading failed it unless the timer won every time).
#[tokio::test(start_paused = true)]
async fn a_rest_taken_in_several_reads_still_arrives_whole() {
    let (ours, mut theirs) = tokio::io::duplex(64);
    let (mut handle, _task) = spawn(
        Framer::default(),
        TwoAtATime(ours),
        DriverOptions::default(),
    );
    for round in 0..8u8 {
        arrive(&mut theirs, &handle, &[round, 0x03]).await;
        theirs
            .write_all(&[0x06, 0x00, 0x2A, 0x00, 0x01, round])
            .await
            .unwrap();
        tokio::time::advance((GAP + GAP + GAP).into()).await;
        assert_eq!(
            handle.next_event().await,
            Some(vec![round, 0x03, 0x06, 0x00, 0x2A, 0x00, 0x01, round]),
            "round {round}: the line was never silent for the gap: one frame"
        );
    }
}
