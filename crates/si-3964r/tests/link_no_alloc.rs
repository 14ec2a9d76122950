//! Zero heap allocations per block in steady state (the si-core contract, ARCHITECTURE.md):
//! two 3964(R) links exchange blocks both ways under a counting global allocator. Transmitted
//! blocks and received blocks are cut from buffers the links keep, and come back to them once
//! the driver and the application drop them.
//!
//! Runs without libtest's harness, whose own threads would allocate while we count.

use bytes::Bytes;
use si_3964r::{Config, Link, Priority};
use si_core::{Duration, Engine, Instant, Output, SerialSettings};
use stats_alloc::{Region, StatsAlloc, INSTRUMENTED_SYSTEM};
use std::alloc::System;

#[global_allocator]
static GLOBAL: &StatsAlloc<System> = &INSTRUMENTED_SYSTEM;

fn main() {
    steady_state_block_exchange_does_not_allocate();
    println!("link_no_alloc: 1000 blocks each way allocate nothing: ok");
}

fn steady_state_block_exchange_does_not_allocate() {
    let settings = SerialSettings::default();
    let high = Config {
        priority: Priority::High,
        ..Config::default()
    };
    let a = Link::new(high, settings).unwrap();
    let b = Link::new(Config::default(), settings).unwrap();
    let mut pair = Pair::new(a, b);
    // 200 bytes with DLEs in them, so doubling is exercised.
    let payload: Bytes = (0..200u8)
        .map(|i| i.wrapping_mul(7))
        .collect::<Vec<u8>>()
        .into();
    let cycle = |pair: &mut Pair<Link, Link>| {
        let now = pair.now;
        pair.a.send(now, payload.clone()).unwrap();
        pair.run_until(now + Duration::from_millis(500));
        let block = pair.b.take_block(pair.now).expect("a block arrived at B");
        assert_eq!(block.len(), 200);
        drop(block);
        let now = pair.now;
        pair.b.send(now, payload.clone()).unwrap();
        pair.run_until(now + Duration::from_millis(500));
        assert_eq!(pair.a.take_block(pair.now).map(|b| b.len()), Some(200));
    };
    for _ in 0..20 {
        cycle(&mut pair); // warm up: queues reach their working size
    }
    let before = (pair.a.counters(), pair.b.counters());
    let region = Region::new(GLOBAL);
    for _ in 0..1_000 {
        cycle(&mut pair);
    }
    let stats = region.change();
    assert_eq!(
        (stats.allocations, stats.reallocations),
        (0, 0),
        "allocations in 1000 blocks each way: {stats:?}"
    );
    let after = (pair.a.counters(), pair.b.counters());
    assert_eq!(after.1.blocks_received - before.1.blocks_received, 1_000);
    assert_eq!(after.0.blocks_received - before.0.blocks_received, 1_000);
    assert_eq!(after.0.repetitions, before.0.repetitions);
    assert_eq!(after.1.repetitions, before.1.repetitions);
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
