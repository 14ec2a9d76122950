//! 3964(R) behind 16550-type FIFO UARTs (si-sim's [`FifoUart`], announcing nothing, as `ttyS`
//! ports under the tokio driver): with default configs both links exchange blocks longer than
//! the FIFO both ways at every trigger level, at 9600 and 19 200 bit/s ([ET200S SI] §2.7: ZVZ
//! and QVZ get the port's allowance while it is taken to hold bytes).

use crate::common;

use common::*;
use si_3964r::{Config, Event, Link, Priority};
use si_core::{Parity, SerialSettings};
use si_sim::{FifoUart, Simulator};

fn exchange(baud: u32, uart: FifoUart) {
    let s = SerialSettings::new(baud, 8, Parity::Even, 1).unwrap();
    let mut sim = Simulator::new(3964).without_trace();
    let high = Config {
        priority: Priority::High,
        ..Config::default()
    };
    let a = sim.add_station("A", s, Link::new(high.with_settings(s)).unwrap());
    let b = sim.add_station(
        "B",
        s,
        Link::new(Config::default().with_settings(s)).unwrap(),
    );
    sim.connect(a, b);
    sim.set_uart(a, uart).unwrap();
    sim.set_uart(b, uart).unwrap();
    let ping: Vec<u8> = (0..200u32).map(|i| (i * 7) as u8).collect();
    let pong: Vec<u8> = (0..150u32).map(|i| (i * 3 + 1) as u8).collect();
    let what = format!("{baud} bit/s, trigger {}", uart.trigger);
    let ja = sim.with(a, |l, now| l.send(now, ping.clone()).unwrap());
    settle(&mut sim);
    let jb = sim.with(b, |l, now| l.send(now, pong.clone()).unwrap());
    settle(&mut sim);
    assert_eq!(
        sim.take_events(a),
        vec![Event::Sent { job: ja }, Event::Received { len: 150 }],
        "{what}"
    );
    assert_eq!(
        sim.take_events(b),
        vec![Event::Received { len: 200 }, Event::Sent { job: jb }],
        "{what}"
    );
    assert_eq!(sim.with(a, |l, now| l.take_block(now)).unwrap(), pong);
    assert_eq!(sim.with(b, |l, now| l.take_block(now)).unwrap(), ping);
}

#[test]
fn long_blocks_both_ways_through_fifo_uarts_at_every_trigger_level() {
    for baud in [9_600, 19_200] {
        for trigger in FifoUart::TRIGGERS {
            exchange(baud, FifoUart::LINUX_16550A.with_trigger(trigger));
        }
    }
}
