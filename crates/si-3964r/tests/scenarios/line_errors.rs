//! A parity error on a simulated 3964(R) line reaches S_RCV as the manual's 080C
//! ([ET200S SI] §2.13, Table 2-28: "transmission error (parity, stop-bit or overrun error)";
//! [ET200S SI] §2.7 state table: in idle reported at once, while receiving the block is marked bad
//! and repeated).
//!
//! The path is the one a real Linux port takes: the UART finds the bad parity, the kernel
//! marks the character in the stream (`FF 00 x`, si_core::linemark), and the driver's receive
//! path ([`RxPath`], what si_core::driver runs) turns the mark into a `LineError` for the link.
//! [`MarkingPort`] marks the chosen character as the kernel would after the UART found its
//! parity wrong: with one data bit flipped by the simulator (`corrupt_received`), or with only
//! the parity bit flipped (data intact, which nothing but the UART can see).

use crate::common;

use common::*;
use si_3964r::status::TRANSMISSION_ERROR;
use si_3964r::{Config, Event, Link, Priority};
use si_core::linemark::{bad_char_error, mark, Received};
use si_core::port_facts::PortFacts;
use si_core::rx_path::RxPath;
use si_core::{Engine, Instant, LineError, Output};
use si_sim::Simulator;

/// A link behind a parity-checking UART and a `PARMRK` kernel: the `bad`-th received
/// character (counting from 0) arrives marked, and everything passes the driver's receive
/// path.
struct MarkingPort {
    link: Link,
    rx_path: RxPath,
    received: u64,
    bad: Option<u64>,
}

impl MarkingPort {
    fn new(config: Config, bad: Option<u64>) -> Self {
        let facts = PortFacts {
            marked_errors: Some(bad_char_error(&line())),
            ..PortFacts::default()
        };
        MarkingPort {
            link: Link::new(config.with_settings(line())).unwrap(),
            rx_path: RxPath::new(&facts),
            received: 0,
            bad,
        }
    }
}

impl Engine for MarkingPort {
    type Event = Event;
    fn handle_rx(&mut self, now: Instant, bytes: &[u8]) {
        let mut marked = Vec::new();
        for &b in bytes {
            let item = if self.bad == Some(self.received) {
                Received::Bad(b)
            } else {
                Received::Byte(b)
            };
            self.received += 1;
            mark(item, &mut marked);
        }
        self.rx_path.deliver(&mut self.link, now, &marked, |_| {});
    }
    fn handle_timeout(&mut self, now: Instant) {
        self.link.handle_timeout(now);
    }
    fn handle_tx_done(&mut self, now: Instant) {
        self.link.handle_tx_done(now);
    }
    fn handle_line_error(&mut self, now: Instant, error: LineError) {
        self.link.handle_line_error(now, error);
    }
    fn poll_output(&mut self) -> Output<Event> {
        self.link.poll_output()
    }
}

#[test]
fn a_parity_error_on_the_idle_line_reaches_s_rcv_as_080c_at_once() {
    let mut sim = Simulator::new(3964);
    // The scripted partner sends nothing at start: character 0 is the stray byte we corrupt.
    let host = sim.add_station("host", line(), MarkingPort::new(Config::default(), Some(0)));
    let p = sim.add_station("P", line(), Partner);
    sim.connect(host, p);
    settle(&mut sim);
    sim.take_events(host);
    sim.corrupt_received(host, 0, 0x04);
    sim.transmit(p, &[0x41]);
    settle(&mut sim);
    assert_eq!(
        sim.take_events(host),
        vec![Event::ReceiveError(TRANSMISSION_ERROR)]
    );
}

#[test]
fn a_flipped_parity_bit_inside_a_block_is_refused_and_repeated() {
    let mut sim = Simulator::new(3964);
    let a = sim.add_station(
        "A",
        line(),
        Link::new(with_priority(Priority::High).with_settings(line())).unwrap(),
    );
    // B receives: 0 = A's startup NAK, 1 = STX, 2.. = the block; a data byte is bad.
    let b = sim.add_station(
        "B",
        line(),
        MarkingPort::new(with_priority(Priority::Low), Some(3)),
    );
    sim.connect(a, b);
    // The parity bit itself flipped: data and BCC are intact, only the UART can tell. Without
    // the mark the block would be taken at the first attempt.
    let job = sim.with(a, |l, now| l.send(now, &b"hello"[..]).unwrap());
    settle(&mut sim);
    assert_eq!(sim.take_events(a), vec![Event::Sent { job }]);
    let events = sim.take_events(b);
    // [ET200S SI] §2.7, Fig. 2-15: a block received with a character error is answered with NAK;
    // the repetition is taken, and S_RCV sees only the good block.
    assert_eq!(events, vec![Event::Received { len: 5 }]);
    assert_eq!(
        sim.with(b, |port, now| port.link.take_block(now).map(|b| b.to_vec())),
        Some(b"hello".to_vec())
    );
    // The first attempt was refused (NAK) and repeated.
    assert_eq!(count_tx(&sim, "A", si_3964r::frame::STX), 2);
}
