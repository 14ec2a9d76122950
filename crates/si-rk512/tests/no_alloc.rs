//! Zero heap allocations per job in steady state (the si-core contract, ARCHITECTURE.md): an
//! active and a serving RK 512 station, back to back on an instant line, run SEND and FETCH
//! jobs of 200 bytes (two telegrams each) under a counting global allocator. Telegrams and
//! FETCH data are cut from buffers the stations keep, and come back to them once the link,
//! the driver and the application drop them.
//!
//! Runs without libtest's harness, whose own threads would allocate while we count.

use bytes::Bytes;
use si_3964r::Priority;
use si_core::memory::Area;
use si_core::{Duration, SerialSettings};
use si_rk512::frame::{Address, Coordination};
use si_rk512::passive::ServerConfig;
use si_rk512::{Command, Config, Event, Station};
use si_sim::Pair;
use si_testkit::alloc::assert_no_alloc;

fn main() {
    steady_state_send_and_fetch_do_not_allocate();
    println!("no_alloc: 1000 SEND and 1000 FETCH jobs allocate nothing: ok");
}

fn steady_state_send_and_fetch_do_not_allocate() {
    let line = SerialSettings::default();
    let mut active = Config::default();
    active.link.priority = Priority::High;
    let mut serve = ServerConfig::default();
    serve.memory.dbs.insert(10, 512);
    let a = Station::new(active.with_settings(line)).unwrap();
    let b = Station::serving(Config::default().with_settings(line), &serve).unwrap();
    let mut pair = Pair::new(a, b);
    // 200 bytes with DLEs in them, so doubling is exercised; two telegrams per job.
    let payload: Bytes = (0..200u8)
        .map(|i| i.wrapping_mul(7))
        .collect::<Vec<u8>>()
        .into();
    let address = Address::Db { db: 10, dw: 0 };
    let cycle = |pair: &mut Pair<Station, Station>| {
        let now = pair.now;
        let job = pair
            .a
            .send(now, address, Coordination::NONE, payload.clone())
            .unwrap();
        pair.run_until(now + Duration::from_millis(2_000));
        match pair.last.0.take() {
            Some(Event::Done { job: done, data }) => {
                assert_eq!(done, job);
                assert!(data.is_empty());
            }
            other => panic!("SEND did not end with Done: {other:?}"),
        }
        match pair.last.1.take() {
            Some(Event::Served { command, len, .. }) => {
                assert_eq!((command, len), (Command::Send, 200));
            }
            other => panic!("B did not serve the SEND: {other:?}"),
        }
        let now = pair.now;
        let job = pair.a.fetch(now, address, Coordination::NONE, 200).unwrap();
        pair.run_until(now + Duration::from_millis(2_000));
        match pair.last.0.take() {
            Some(Event::Done { job: done, data }) => {
                assert_eq!(done, job);
                assert_eq!(data, payload);
            }
            other => panic!("FETCH did not end with Done: {other:?}"),
        }
        match pair.last.1.take() {
            Some(Event::Served { command, len, .. }) => {
                assert_eq!((command, len), (Command::Fetch, 200));
            }
            other => panic!("B did not serve the FETCH: {other:?}"),
        }
    };
    for _ in 0..20 {
        cycle(&mut pair); // warm up: queues reach their working size
    }
    let before = (
        pair.events,
        pair.a.link().counters(),
        pair.b.link().counters(),
    );
    assert_no_alloc("1000 SEND and 1000 FETCH jobs", || {
        for _ in 0..1_000 {
            cycle(&mut pair);
        }
    });
    let after = (
        pair.events,
        pair.a.link().counters(),
        pair.b.link().counters(),
    );
    // One Done per job on A, one Served per job on B.
    assert_eq!(after.0 .0 - before.0 .0, 2_000);
    assert_eq!(after.0 .1 - before.0 .1, 2_000);
    // Two command telegrams per job from A, two reactions per job from B, none repeated.
    assert_eq!(after.1.blocks_sent - before.1.blocks_sent, 4_000);
    assert_eq!(after.2.blocks_sent - before.2.blocks_sent, 4_000);
    assert_eq!(after.1.repetitions, before.1.repetitions);
    assert_eq!(after.2.repetitions, before.2.repetitions);
    assert_eq!(
        pair.b.server().memory().word(Area::Db(10), 0).unwrap(),
        u16::from_be_bytes([payload[0], payload[1]])
    );
}
