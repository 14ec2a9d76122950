//! The tokio driver's deadlines ("Timing, honestly" in si_core::driver): short ones are fired by
//! the precise helper thread, long ones by tokio's wheel handing over to it; none fires early,
//! a deadline moved later fires once at its last value, and the helper thread ends with the
//! driver.
//!
//! Real time cannot be asserted tightly on a shared CI machine, so the lateness bound is
//! generous; the lateness seen is printed (`--nocapture`) for the record.
#![cfg(feature = "tokio")]

use si_core::driver::{spawn, DriverOptions};
use si_core::{Duration, Engine, Instant, Output};
use std::collections::VecDeque;
use tokio::io::AsyncWriteExt;

/// Arms a deadline on command or `after` every received chunk; reports when it fired.
#[derive(Default)]
struct Timer {
    out: VecDeque<Output<Fired>>,
    deadline: Option<Instant>,
    after_rx: Option<Duration>,
}

#[derive(Debug, PartialEq)]
struct Fired {
    deadline: Instant,
    at: Instant,
}

impl Engine for Timer {
    type Event = Fired;
    fn handle_rx(&mut self, now: Instant, _: &[u8]) {
        if let Some(d) = self.after_rx {
            self.deadline = Some(now + d);
        }
    }
    fn handle_timeout(&mut self, now: Instant) {
        if let Some(deadline) = self.deadline.filter(|d| now >= *d) {
            self.deadline = None;
            self.out
                .push_back(Output::Event(Fired { deadline, at: now }));
        }
    }
    fn poll_output(&mut self) -> Output<Fired> {
        self.out.pop_front().unwrap_or(Output::Wait(self.deadline))
    }
}

const LATE_TOLERANCE: Duration = Duration::from_millis(100);

fn check(f: &Fired, what: &str) {
    assert!(f.at >= f.deadline, "{what}: fired early: {f:?}");
    let late = f.at - f.deadline;
    assert!(late < LATE_TOLERANCE, "{what}: {late} late");
    eprintln!("{what}: fired {late} after the deadline");
}

#[tokio::test]
async fn short_and_long_deadlines_fire_never_early() {
    let (ours, _theirs) = tokio::io::duplex(64);
    let (mut handle, _task) = spawn(Timer::default(), ours, DriverOptions::default());
    // 300 µs (the precise thread alone), 1 ms (Modbus's gap above 38 400 bit/s), 4 ms (the
    // gap at 9600 bit/s) and 20 ms (the wheel, then the thread for the last 3 ms).
    for (us, what) in [
        (300, "300 µs"),
        (1_000, "1 ms"),
        (4_000, "4 ms"),
        (20_000, "20 ms"),
    ] {
        for _ in 0..5 {
            handle
                .call(move |t, now| t.deadline = Some(now + Duration::from_micros(us)))
                .await
                .unwrap();
            let fired = handle.next_event().await.unwrap();
            check(&fired, what);
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_deadline_moved_later_by_every_byte_fires_once_at_its_last_value() {
    let (ours, mut theirs) = tokio::io::duplex(64);
    let engine = Timer {
        after_rx: Some(Duration::from_millis(20)),
        ..Timer::default()
    };
    let (mut handle, _task) = spawn(engine, ours, DriverOptions::default());
    // Bytes about 500 µs apart: the deadline moves later with each (the wheel's deadline and
    // the helper thread's are both re-armed), well before it could fire even on a busy machine.
    for _ in 0..10 {
        theirs.write_all(&[0x55]).await.unwrap();
        std::thread::sleep(std::time::Duration::from_micros(500));
    }
    let fired = handle.next_event().await.unwrap();
    check(&fired, "20 ms after the last of 10 bytes");
    // Exactly once: nothing else within the next 50 ms.
    let more =
        tokio::time::timeout(std::time::Duration::from_millis(50), handle.next_event()).await;
    assert!(more.is_err(), "a second event: {more:?}");
}

/// Records the order of tx-done and received bytes; transmits on command.
#[derive(Default)]
struct Order {
    out: VecDeque<Output<&'static str>>,
}

impl Engine for Order {
    type Event = &'static str;
    fn handle_rx(&mut self, _: Instant, _: &[u8]) {
        self.out.push_back(Output::Event("rx"));
    }
    fn handle_timeout(&mut self, _: Instant) {}
    fn handle_tx_done(&mut self, _: Instant) {
        self.out.push_back(Output::Event("tx-done"));
    }
    fn poll_output(&mut self) -> Output<&'static str> {
        self.out.pop_front().unwrap_or(Output::Wait(None))
    }
}

/// Without wire time (no `settings`), tx-done is due the moment the write returns: it reaches
/// the engine before any answer to the bytes written, even one already waiting (a slave must
/// know its response has left before it judges the next request, or it reports a sequence
/// error). Tokio's wheel alone would round that deadline up to its next millisecond.
#[tokio::test]
async fn tx_done_without_wire_time_comes_before_the_answer() {
    use tokio::io::AsyncReadExt;
    let (ours, mut theirs) = tokio::io::duplex(64);
    let (mut handle, _task) = spawn(Order::default(), ours, DriverOptions::default());
    for _ in 0..20 {
        handle
            .call(|o, _| {
                o.out
                    .push_back(Output::Transmit(bytes::Bytes::from_static(b"\x01\x03")))
            })
            .await
            .unwrap();
        let mut got = [0u8; 2];
        theirs.read_exact(&mut got).await.unwrap();
        theirs.write_all(&[0x01]).await.unwrap();
        assert_eq!(handle.next_event().await, Some("tx-done"));
        assert_eq!(handle.next_event().await, Some("rx"));
    }
}

/// Under tokio's paused test clock (time moves only when the runtime idles) a deadline between
/// two millisecond ticks still fires: the driver's short yield loop gives way to the wheel.
#[tokio::test(start_paused = true)]
async fn deadlines_between_ticks_fire_under_the_paused_clock() {
    let (ours, _theirs) = tokio::io::duplex(64);
    let (mut handle, _task) = spawn(Timer::default(), ours, DriverOptions::default());
    for us in [20, 1_020, 2_999, 3_001, 10_010] {
        handle
            .call(move |t, now| t.deadline = Some(now + Duration::from_micros(us)))
            .await
            .unwrap();
        let fired = handle.next_event().await.unwrap();
        assert!(fired.at >= fired.deadline, "{us} µs: {fired:?}");
    }
}
