//! No allocation per frame in steady state beyond the `Bytes` each `Transmit` carries (the
//! Sans-IO contract, ARCHITECTURE.md): a counting global allocator watches 100 request/response
//! cycles between a master and a slave fed by hand.

use si_core::{Engine, Instant, Output};
use si_modbus::frame::Request;
use si_modbus::{Master, MasterConfig, SimaticStore, Slave, SlaveConfig};
use stats_alloc::{Region, StatsAlloc, INSTRUMENTED_SYSTEM};
use std::alloc::System;

#[global_allocator]
static GLOBAL: &StatsAlloc<System> = &INSTRUMENTED_SYSTEM;

/// Drain an engine; returns the length of its last Transmit (copied into `wire`).
fn drain<E: Engine>(e: &mut E, wire: &mut [u8; 300]) -> usize {
    let mut n = 0;
    loop {
        match e.poll_output() {
            Output::Transmit(b) => {
                wire[..b.len()].copy_from_slice(&b);
                n = b.len();
            }
            Output::Wait(_) => return n,
            _ => {}
        }
    }
}

#[test]
fn one_allocation_per_transmitted_frame_and_nothing_else() {
    let mut master = Master::new(MasterConfig::default()).unwrap();
    let config = SlaveConfig {
        address: 1,
        ..SlaveConfig::default()
    };
    let mut slave = Slave::new(config, SimaticStore::example()).unwrap();
    let request = Request::ReadHoldingRegisters {
        address: 0,
        quantity: 10,
    };
    let mut wire = [0u8; 300];
    let mut t = 0u64;
    let mut cycle = |master: &mut Master, slave: &mut Slave<SimaticStore>| {
        master
            .request(Instant::from_micros(t), 1, &request)
            .unwrap();
        let n = drain(master, &mut wire);
        t += 10_000;
        master.handle_tx_done(Instant::from_micros(t));
        drain(master, &mut wire);
        slave.handle_rx(Instant::from_micros(t), &wire[..n]);
        drain(slave, &mut wire);
        t += 5_000;
        slave.handle_timeout(Instant::from_micros(t));
        let n = drain(slave, &mut wire);
        assert_eq!(n, 25);
        slave.handle_tx_done(Instant::from_micros(t + 30_000));
        drain(slave, &mut wire);
        t += 30_000;
        master.handle_rx(Instant::from_micros(t), &wire[..n]);
        drain(master, &mut wire);
        t += 5_000;
        master.handle_timeout(Instant::from_micros(t));
        drain(master, &mut wire);
        assert!(!master.is_busy());
    };
    // Warm up: queues reach their working size.
    for _ in 0..5 {
        cycle(&mut master, &mut slave);
    }
    let region = Region::new(GLOBAL);
    for _ in 0..100 {
        cycle(&mut master, &mut slave);
    }
    let stats = region.change();
    // One `Bytes` for the request, one for the response, nothing else.
    assert_eq!(stats.allocations, 200, "{stats:?}");
}
