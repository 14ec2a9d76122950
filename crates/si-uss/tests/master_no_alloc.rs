//! Zero heap allocations per telegram in steady state (the si-core contract, ARCHITECTURE.md):
//! the USS master polls a simulated drive under a counting global allocator. Telegrams are cut
//! from transmit buffers the engines keep (`split().freeze()`), reclaimed once dropped.
//!
//! Runs without libtest's harness, whose own threads would allocate while we count.

use si_core::{Duration, Engine, Instant, Output};
use si_uss::config::{uss_settings, MasterConfig, PollEntry};
use si_uss::drive::{Drive, DriveConfig};
use si_uss::frame::PkwWords;
use si_uss::Master;
use stats_alloc::{Region, StatsAlloc, INSTRUMENTED_SYSTEM};
use std::alloc::System;

#[global_allocator]
static GLOBAL: &StatsAlloc<System> = &INSTRUMENTED_SYSTEM;

fn main() {
    steady_state_polling_does_not_allocate();
    println!("master_no_alloc: 10 s of polling allocates nothing: ok");
}

fn steady_state_polling_does_not_allocate() {
    let settings = uss_settings(19_200).unwrap();
    let mut config = MasterConfig::new(vec![PollEntry::new(1, PkwWords::Four, 2)]);
    config.settings = settings;
    let master = Master::new(config).unwrap();
    let drive = Drive::new(DriveConfig::new(settings, 1)).unwrap();
    let mut pair = Pair::new(master, drive);
    let now = pair.now;
    pair.a.start(now);
    pair.run_until(Instant::from_micros(1_000_000)); // warm up
    let before = *pair.a.counters();
    let region = Region::new(GLOBAL);
    for _ in 0..10 {
        let now = pair.now;
        pair.a.set_control(1, &[0x047F, 0x2000]).unwrap();
        pair.run_until(now + Duration::from_secs(1));
    }
    let stats = region.change();
    assert_eq!(
        (stats.allocations, stats.reallocations),
        (0, 0),
        "allocations in 10 s of polling: {stats:?}"
    );
    let after = *pair.a.counters();
    let answered = after.ok - before.ok;
    assert!(answered > 500, "only {answered} telegrams answered");
    assert_eq!(after.rejected, before.rejected);
}

/// Two engines wired back to back with an instant line: everything one transmits is handed to
/// the other at the same instant, and its tx-done follows at once. Allocates nothing itself.
struct Pair<A: Engine, B: Engine> {
    a: A,
    b: B,
    now: Instant,
    /// Events reported by A and B.
    events: (u64, u64),
    /// The last event of A and of B.
    last: (Option<A::Event>, Option<B::Event>),
}

impl<A: Engine, B: Engine> Pair<A, B> {
    fn new(a: A, b: B) -> Self {
        Pair {
            a,
            b,
            now: Instant::ZERO,
            events: (0, 0),
            last: (None, None),
        }
    }

    /// Drain both engines until neither transmits; the earliest deadline of the two.
    fn settle(&mut self) -> Option<Instant> {
        for _ in 0..10_000 {
            let (moved_a, da) = drain_into(
                &mut self.a,
                &mut self.b,
                self.now,
                &mut self.events.0,
                &mut self.last.0,
            );
            let (moved_b, db) = drain_into(
                &mut self.b,
                &mut self.a,
                self.now,
                &mut self.events.1,
                &mut self.last.1,
            );
            if !moved_a && !moved_b {
                return Instant::earliest(da, db);
            }
        }
        panic!("the engines keep talking at one instant");
    }

    /// Run timers and traffic up to `until`.
    fn run_until(&mut self, until: Instant) {
        for _ in 0..100_000 {
            match self.settle() {
                Some(t) if t <= until => {
                    self.now = self.now.max(t);
                    self.a.handle_timeout(self.now);
                    self.b.handle_timeout(self.now);
                }
                _ => {
                    self.now = until;
                    self.a.handle_timeout(self.now);
                    self.b.handle_timeout(self.now);
                    self.settle();
                    return;
                }
            }
        }
        panic!("timers keep firing before {until:?}");
    }
}

fn drain_into<F: Engine, T: Engine>(
    from: &mut F,
    to: &mut T,
    now: Instant,
    events: &mut u64,
    last: &mut Option<F::Event>,
) -> (bool, Option<Instant>) {
    let mut moved = false;
    loop {
        match from.poll_output() {
            Output::Transmit(bytes) => {
                to.handle_rx(now, &bytes);
                drop(bytes);
                from.handle_tx_done(now);
                moved = true;
            }
            Output::Event(event) => {
                *events += 1;
                *last = Some(event);
            }
            Output::SetSignals(_) => {}
            Output::Wait(deadline) => return (moved, deadline),
        }
    }
}
