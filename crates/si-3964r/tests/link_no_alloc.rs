//! Zero heap allocations per block in steady state (the si-core contract, ARCHITECTURE.md):
//! two 3964(R) links exchange blocks both ways under a counting global allocator. Transmitted
//! blocks and received blocks are cut from buffers the links keep, and come back to them once
//! the driver and the application drop them.
//!
//! Runs without libtest's harness, whose own threads would allocate while we count.

use bytes::Bytes;
use si_3964r::{Config, Link, Priority};
use si_core::sim::Pair;
use si_core::{Duration, SerialSettings};
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
