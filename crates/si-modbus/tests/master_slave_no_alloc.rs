//! Zero heap allocations per frame in steady state (the si-core contract, ARCHITECTURE.md):
//! a master polls a slave under a counting global allocator. Requests and responses are cut
//! from transmit buffers the engines keep (`split().freeze()`), and `reserve` reclaims the same
//! allocation once the driver drops the previous frame.
//!
//! Runs without libtest's harness, whose own threads would allocate while we count.

use si_core::{Duration, Engine, Instant, Output};
use si_modbus::frame::{Registers, Request};
use si_modbus::{Master, MasterConfig, MasterEvent, SimaticStore, Slave, SlaveConfig};
use stats_alloc::{Region, StatsAlloc, INSTRUMENTED_SYSTEM};
use std::alloc::System;

#[global_allocator]
static GLOBAL: &StatsAlloc<System> = &INSTRUMENTED_SYSTEM;

fn main() {
    steady_state_polling_does_not_allocate();
    println!("master_slave_no_alloc: 1000 request/response cycles allocate nothing: ok");
}

fn steady_state_polling_does_not_allocate() {
    let master = Master::new(MasterConfig::default()).unwrap();
    let config = SlaveConfig {
        address: 1,
        ..SlaveConfig::default()
    };
    let slave = Slave::new(config, SimaticStore::example()).unwrap();
    let mut pair = Pair::new(master, slave);
    let read = Request::ReadHoldingRegisters {
        address: 0,
        quantity: 10,
    };
    let words = [0x1234u16; 10];
    let write = Request::WriteMultipleRegisters {
        address: 0,
        values: Registers::Words(&words),
    };
    let cycle = |pair: &mut Pair<Master, Slave<SimaticStore>>| {
        for request in [&read, &write] {
            let now = pair.now;
            pair.a.request(now, 1, request).unwrap();
            pair.run_until(now + Duration::from_millis(100));
            assert!(!pair.a.is_busy());
            assert!(
                matches!(pair.last.0, Some(MasterEvent::Completed(_))),
                "{:?}",
                pair.last.0
            );
        }
    };
    for _ in 0..20 {
        cycle(&mut pair); // warm up: queues reach their working size
    }
    let events = pair.events;
    let region = Region::new(GLOBAL);
    for _ in 0..1_000 {
        cycle(&mut pair);
    }
    let stats = region.change();
    assert_eq!(
        (stats.allocations, stats.reallocations),
        (0, 0),
        "allocations in 1000 cycles: {stats:?}"
    );
    // Every request ended in a master event (done), so the frames really went both ways.
    assert!(pair.events.0 - events.0 >= 2_000, "{:?}", pair.events);
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
