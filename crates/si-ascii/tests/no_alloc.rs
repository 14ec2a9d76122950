//! The engine allocates nothing per frame in steady state (the si-core contract): received
//! frames go into the preallocated 1024-byte ring and out into the caller's buffer; sent
//! frames go out as slices of the caller's `Bytes`; XON/XOFF come from a static table.

use bytes::Bytes;
use si_ascii::{Config, EndCriterion, FlowControl, Link};
use si_core::{Duration, Engine, Instant, Output};
use stats_alloc::{Region, StatsAlloc, INSTRUMENTED_SYSTEM};
use std::alloc::System;

#[global_allocator]
static GLOBAL: &StatsAlloc<System> = &INSTRUMENTED_SYSTEM;

fn drain(link: &mut Link) -> usize {
    let mut outputs = 0;
    while !matches!(link.poll_output(), Output::Wait(_)) {
        outputs += 1;
    }
    outputs
}

fn main() {
    steady_state_receive_and_send_do_not_allocate();
    println!("no_alloc: steady-state receive and send allocate nothing: ok");
}

fn steady_state_receive_and_send_do_not_allocate() {
    let config = Config {
        end: EndCriterion::EndChars {
            first: b'\r',
            second: b'\n',
        },
        flow_control: FlowControl::XonXoff,
        ..Config::default()
    };
    let mut link = Link::new(config).unwrap();
    let frame = Bytes::from_static(b"0123456789 steady state\r\n");
    let mut buf = [0u8; 200];
    let mut now = Instant::ZERO;
    let step = Duration::from_millis(1);
    let mut cycle = |link: &mut Link, now: &mut Instant| {
        // Receive one frame, fill the buffer towards XOFF now and then, read it back.
        link.handle_rx(*now, &frame);
        drain(link);
        assert_eq!(link.read_frame(*now, &mut buf), Some(frame.len()));
        drain(link);
        // Send one frame, one character per tx-done as flow control requires.
        link.send(*now, frame.clone()).unwrap();
        while link.is_sending() {
            drain(link);
            *now += step;
            link.handle_tx_done(*now);
        }
        drain(link);
        *now += step;
        link.handle_timeout(*now);
        drain(link);
    };
    for _ in 0..10 {
        cycle(&mut link, &mut now); // warm up
    }
    let region = Region::new(GLOBAL);
    for _ in 0..3_000 {
        cycle(&mut link, &mut now);
    }
    let stats = region.change();
    assert_eq!(
        (stats.allocations, stats.reallocations),
        (0, 0),
        "allocations in 3000 frames each way"
    );
}
