//! Zero heap allocations per block in steady state (the si-core contract, ARCHITECTURE.md):
//! two 3964(R) links exchange blocks both ways under a counting global allocator. Transmitted
//! blocks and received blocks are cut from buffers the links keep, and come back to them once
//! the driver and the application drop them.
//!
//! Runs without libtest's harness, whose own threads would allocate while we count.

use bytes::Bytes;
use si_3964r::fb::{SRcv, SSend};
use si_3964r::{Config, Link, Priority};
use si_core::{Duration, SerialSettings};
use si_sim::Pair;
use si_testkit::alloc::assert_no_alloc;

fn main() {
    steady_state_block_exchange_does_not_allocate();
    println!("no_alloc: 1000 blocks each way allocate nothing: ok");
    s_send_and_s_rcv_jobs_do_not_allocate();
    println!("no_alloc: 1000 S_SEND / S_RCV jobs allocate nothing: ok");
}

fn steady_state_block_exchange_does_not_allocate() {
    let settings = SerialSettings::default();
    let high = Config {
        priority: Priority::High,
        ..Config::default()
    };
    let a = Link::new(high.with_settings(settings)).unwrap();
    let b = Link::new(Config::default().with_settings(settings)).unwrap();
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
    assert_no_alloc("1000 blocks each way", || {
        for _ in 0..1_000 {
            cycle(&mut pair);
        }
    });
    let after = (pair.a.counters(), pair.b.counters());
    assert_eq!(after.1.blocks_received - before.1.blocks_received, 1_000);
    assert_eq!(after.0.blocks_received - before.0.blocks_received, 1_000);
    assert_eq!(after.0.repetitions, before.0.repetitions);
    assert_eq!(after.1.repetitions, before.1.repetitions);
}

/// si-core's S_SEND copies the source area into a buffer it keeps and S_RCV copies the block
/// into the destination area, so a job cycle through the FBs allocates nothing either.
fn s_send_and_s_rcv_jobs_do_not_allocate() {
    let settings = SerialSettings::default();
    let high = Config {
        priority: Priority::High,
        ..Config::default()
    };
    let a = Link::new(high.with_settings(settings)).unwrap();
    let b = Link::new(Config::default().with_settings(settings)).unwrap();
    let mut pair = Pair::new(a, b);
    let payload: Vec<u8> = (0..200u8).map(|i| i.wrapping_mul(7)).collect();
    let (mut s_send, mut s_rcv) = (SSend::default(), SRcv::default());
    let mut db = [0u8; 256];
    let mut job = |pair: &mut Pair<Link, Link>| {
        let now = pair.now;
        let started = s_send.call(&mut pair.a, now, true, false, &payload);
        assert!(!started.done && !started.error, "{started:?}");
        pair.run_until(now + Duration::from_millis(500));
        let now = pair.now;
        let done = s_send.call(&mut pair.a, now, false, false, &payload);
        assert!(done.done, "{done:?}");
        let r = s_rcv.call(&mut pair.b, now, true, false, &mut db);
        assert_eq!((r.ndr, r.len), (true, 200));
    };
    for _ in 0..20 {
        job(&mut pair); // warm up: the send buffer reaches its working size
    }
    assert_no_alloc("1000 S_SEND / S_RCV jobs", || {
        for _ in 0..1_000 {
            job(&mut pair);
        }
    });
}
