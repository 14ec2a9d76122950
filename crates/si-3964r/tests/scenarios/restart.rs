//! "Clear SI receive buffer at startup" for 3964(R) ([ET200S SI] §2.9, Table 2-11
//! and §2.11, [ET200S SI 2005] §2.9.3, Table 2-9: no/yes, default yes; [ET200S SI 2005]
//! §2.11: with "no", buffered frames are delivered again after the CPU's STOP → RUN), as
//! the ASCII driver's `clear_at_startup` (its receive_buffer tests).

use crate::common;

use common::*;
use si_3964r::{Config, Event, Link, Priority};
use si_sim::{Simulator, StationId};

/// A (high) sends `data` to B (low) and the block waits in B's buffer.
fn deliver(sim: &mut Simulator, a: StationId<Link>, data: &[u8]) {
    let job = sim.with(a, |l, now| l.send(now, data.to_vec()).unwrap());
    settle(sim);
    assert_eq!(sim.take_events(a), vec![Event::Sent { job }]);
}

fn take(sim: &mut Simulator, b: StationId<Link>) -> Option<Vec<u8>> {
    sim.with(b, |l, now| l.take_block(now)).map(|b| b.to_vec())
}

fn receiver(clear_at_startup: bool, receive_buffer_blocks: u8) -> Config {
    Config {
        clear_at_startup,
        receive_buffer_blocks,
        ..Config::default()
    }
}

#[test]
fn a_block_received_before_startup_is_dropped_when_clearing_is_set() {
    let (mut sim, a, b) = pair(with_priority(Priority::High), receiver(true, 5));
    deliver(&mut sim, a, b"before");
    sim.with(b, |l, now| l.restart(now));
    assert_eq!(take(&mut sim, b), None);
    // Blocks after the startup are delivered as usual.
    deliver(&mut sim, a, b"after");
    assert_eq!(take(&mut sim, b).as_deref(), Some(&b"after"[..]));
}

#[test]
fn a_block_received_before_startup_is_delivered_when_clearing_is_off() {
    let (mut sim, a, b) = pair(with_priority(Priority::High), receiver(false, 5));
    deliver(&mut sim, a, b"before");
    sim.with(b, |l, now| l.restart(now));
    assert_eq!(take(&mut sim, b).as_deref(), Some(&b"before"[..]));
}

#[test]
fn clearing_a_full_buffer_answers_a_partner_waiting_for_a_slot() {
    let (mut sim, a, b) = pair(with_priority(Priority::High), receiver(true, 1));
    deliver(&mut sim, a, b"one");
    sim.take_events(b);
    // The buffer is full: B holds the next STX in the 400 ms wait.
    let job = sim.with(a, |l, now| l.send(now, &b"two"[..]).unwrap());
    run_ms(&mut sim, 100);
    sim.with(b, |l, now| l.restart(now));
    settle(&mut sim);
    assert_eq!(sim.take_events(a), vec![Event::Sent { job }]);
    assert_eq!(take(&mut sim, b).as_deref(), Some(&b"two"[..]));
    assert_eq!(take(&mut sim, b), None);
}
