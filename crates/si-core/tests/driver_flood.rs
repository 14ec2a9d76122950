//! A driver flooded with input (reads always ready) still fires the engine's
//! deadline. The engine arms a deadline at the first byte and the peer never stops sending;
//! the timeout must come while the flood goes on, within a generous bound (a bound, not a
//! timing claim: the driver checks the clock after every read, "Timing, honestly").
#![cfg(feature = "tokio")]

use si_core::driver::{spawn, DriverOptions};
use si_core::{Duration, Engine, Instant, Output};
use tokio::io::AsyncWriteExt;

/// What the engine saw when its deadline fired.
#[derive(Debug, Clone, Copy)]
struct Fired {
    at: Instant,
    deadline: Instant,
    bytes_before: u64,
}

/// Arms a deadline 20 ms after the first byte; counts bytes; reports the timeout once.
#[derive(Default)]
struct Flooded {
    deadline: Option<Instant>,
    received: u64,
    fired: Option<Fired>,
}

impl Engine for Flooded {
    type Event = Fired;
    fn handle_rx(&mut self, now: Instant, bytes: &[u8]) {
        if self.received == 0 {
            self.deadline = Some(now + Duration::from_millis(20));
        }
        self.received += bytes.len() as u64;
    }
    fn handle_timeout(&mut self, now: Instant) {
        if let Some(deadline) = self.deadline.filter(|&d| now >= d) {
            self.deadline = None;
            self.fired = Some(Fired {
                at: now,
                deadline,
                bytes_before: self.received,
            });
        }
    }
    fn poll_output(&mut self) -> Output<Fired> {
        match self.fired.take() {
            Some(f) => Output::Event(f),
            None => Output::Wait(self.deadline),
        }
    }
}

#[test]
fn a_flood_does_not_starve_the_engine_s_deadline() {
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .unwrap();
    rt.block_on(async {
        let (ours, mut theirs) = tokio::io::duplex(4096);
        let (mut handle, _task) = spawn(Flooded::default(), ours, DriverOptions::default());
        // The flood: as fast as the pipe takes it, until the test ends.
        let flood = tokio::spawn(async move {
            let chunk = [0x55u8; 256];
            while theirs.write_all(&chunk).await.is_ok() {}
        });
        let fired = tokio::time::timeout(std::time::Duration::from_secs(10), handle.next_event())
            .await
            .expect("the deadline fired under the flood within 10 s")
            .expect("the driver is running");
        flood.abort();
        // The engine records `at` only once `now >= deadline`, so only the lateness can be
        // wrong: a starved deadline fires late (or never). Half a second is a generous bound
        // for a 20 ms timer, not a timing claim.
        let late = fired.at.saturating_since(fired.deadline);
        assert!(
            late < Duration::from_millis(500),
            "fired {late:?} late: {fired:?}"
        );
        // The flood was on when the deadline came: reads kept coming before it fired.
        assert!(fired.bytes_before > 256, "{fired:?}");
    });
}
