//! 3964(R) through USB-serial adapters: with default configs both links behind a
//! 16 ms / 62-byte adapter exchange blocks longer than a packet both ways at 9600 and 19 200
//! bit/s, announced or learnt. The procedure's own timers (ZVZ 220 ms, QVZ 2000 ms, [ET200S SI]
//! §2.7) are far above 16 ms, and get the port's allowance on top; without the adapter the receiver
//! still acknowledges the block the moment its BCC arrives ([ET200S SI] §2.7).

use crate::common;

use common::*;
use si_3964r::frame::{DLE, ETX};
use si_3964r::{Config, Event, Link, Priority};
use si_core::{Parity, SerialSettings};
use si_sim::{Simulator, StationId, TraceKind, UsbAdapter};

fn rig(baud: u32, adapter: Option<UsbAdapter>) -> (Simulator, StationId<Link>, StationId<Link>) {
    let s = SerialSettings::new(baud, 8, Parity::Even, 1).unwrap();
    let mut sim = Simulator::new(3964);
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
    if let Some(adapter) = adapter {
        sim.set_adapter(a, adapter).unwrap();
        sim.set_adapter(b, adapter).unwrap();
    }
    (sim, a, b)
}

/// A sends 200 bytes (DLE among them, doubled on the line), then B answers with 150.
fn exchange(baud: u32, adapter: UsbAdapter) {
    let (mut sim, a, b) = rig(baud, Some(adapter));
    let ping: Vec<u8> = (0..200u32).map(|i| (i * 7) as u8).collect();
    let pong: Vec<u8> = (0..150u32).map(|i| (i * 3 + 1) as u8).collect();
    let what = format!("{baud} bit/s, {adapter:?}");
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
fn long_blocks_both_ways_through_announced_16ms_adapters() {
    for baud in [9_600, 19_200] {
        exchange(baud, UsbAdapter::FTDI_DEFAULT);
    }
}

#[test]
fn long_blocks_both_ways_through_unannounced_16ms_adapters() {
    for baud in [9_600, 19_200] {
        exchange(baud, UsbAdapter::FTDI_DEFAULT.unannounced());
    }
}

#[test]
fn without_an_adapter_the_block_is_acknowledged_as_its_bcc_arrives() {
    for baud in [9_600, 19_200] {
        let (mut sim, a, _) = rig(baud, None);
        sim.with(a, |l, now| l.send(now, vec![1, 2, 3]).unwrap());
        settle(&mut sim);
        let rx: Vec<_> = sim.trace().received("B");
        let bcc_at = rx.last().unwrap().0;
        assert_eq!(rx[rx.len() - 3].1, DLE);
        assert_eq!(rx[rx.len() - 2].1, ETX);
        let ack_at = sim
            .trace()
            .of("B")
            .filter(|e| matches!(&e.kind, TraceKind::Tx { bytes } if bytes[..] == [DLE]))
            .last()
            .unwrap()
            .at;
        assert_eq!(ack_at, bcc_at, "{baud} bit/s");
    }
}
