//! Master and slave through USB-serial adapters (issue 16): with default configs, both behind a
//! 16 ms / 62-byte adapter, a poll cycle of short and long reads completes at 9600 and 19 200
//! bit/s, whether the host announces the adapter's latency or the engines have to learn it;
//! and without an adapter the frames still end at the manual's gap (§3.5, Table 3-11).

use si_core::sim::{Simulator, StationId, TraceKind, UsbAdapter};
use si_core::{Duration, Instant, Parity, SerialSettings};
use si_modbus::config::LineConfig;
use si_modbus::frame::{Request, Response};
use si_modbus::master::{Master, MasterEvent};
use si_modbus::slave::{Slave, SlaveEvent, Tables};
use si_modbus::{MasterConfig, SlaveConfig};

fn line(baud: u32) -> LineConfig {
    LineConfig {
        settings: SerialSettings::new(baud, 8, Parity::Even, 1).unwrap(),
        ..LineConfig::default()
    }
}

type Rig = (Simulator, StationId<Master>, StationId<Slave<Tables>>);

/// Default master and slave (address 1) at `baud`, each behind `adapter` if given.
fn rig(baud: u32, adapter: Option<UsbAdapter>) -> Rig {
    let mut sim = Simulator::new(16);
    let l = line(baud);
    let master = Master::new(MasterConfig {
        line: l,
        ..MasterConfig::default()
    })
    .unwrap();
    let mut tables = Tables::new(200, 200, 200, 200);
    for (i, r) in tables.holding_registers.iter_mut().enumerate() {
        *r = 0x100 + i as u16;
    }
    let slave_config = SlaveConfig {
        address: 1,
        line: l,
    };
    let m = sim.add_station("master", l.settings, master);
    let sl = sim.add_station(
        "slave",
        l.settings,
        Slave::new(slave_config, tables).unwrap(),
    );
    sim.connect(m, sl);
    if let Some(a) = adapter {
        sim.set_adapter(m, a).unwrap();
        sim.set_adapter(sl, a).unwrap();
    }
    (sim, m, sl)
}

/// Reads `quantity` holding registers from 0 and checks the values; the completion instant.
fn read(sim: &mut Simulator, m: StationId<Master>, quantity: u16) -> Instant {
    let request = Request::ReadHoldingRegisters {
        address: 0,
        quantity,
    };
    sim.with(m, |e, now| e.request(now, 1, &request)).unwrap();
    while sim.take_events(m).is_empty() && sim.step() {}
    let done = sim.now();
    let events = event_texts(sim, "master");
    let last = events.last().expect("an event");
    assert!(
        last.contains("Completed"),
        "{quantity} registers: {events:?}"
    );
    done
}

fn event_texts(sim: &Simulator, station: &str) -> Vec<String> {
    sim.trace()
        .of(station)
        .filter_map(|e| match &e.kind {
            TraceKind::Event { text } => Some(text.clone()),
            _ => None,
        })
        .collect()
}

/// The poll cycle: short, long (125 registers, a 255-byte response: five packets at 9600),
/// short again, each checked against the slave's tables.
fn poll_cycle(sim: &mut Simulator, m: StationId<Master>, sl: StationId<Slave<Tables>>) {
    for quantity in [10, 125, 2, 125] {
        let request = Request::ReadHoldingRegisters {
            address: 0,
            quantity,
        };
        sim.with(m, |e, now| e.request(now, 1, &request)).unwrap();
        let event = loop {
            if let Some(e) = sim.take_events(m).pop() {
                break e;
            }
            assert!(sim.step(), "the job ended without an event");
        };
        let MasterEvent::Completed(c) = event else {
            panic!("{quantity} registers: {event:?}");
        };
        let Some(Response::ReadHoldingRegisters(regs)) = c.response() else {
            panic!("{quantity} registers: {:?}", c.response());
        };
        let expected: Vec<u16> = (0..quantity).map(|i| 0x100 + i).collect();
        assert_eq!(regs.iter().collect::<Vec<_>>(), expected);
    }
    sim.run_until_quiet(sim.now() + Duration::from_secs(1));
    for e in sim.take_events(sl) {
        assert!(matches!(e, SlaveEvent::Served { .. }), "slave: {e:?}");
    }
    assert_eq!(sim.engine(m).counters().discarded, 0);
    assert_eq!(sim.engine(sl).counters().discarded, 0);
}

#[test]
fn polls_complete_through_announced_16ms_adapters_at_9600_and_19200() {
    for baud in [9_600, 19_200] {
        let (mut sim, m, sl) = rig(baud, Some(UsbAdapter::FTDI_DEFAULT));
        poll_cycle(&mut sim, m, sl);
    }
}

#[test]
fn polls_complete_through_unannounced_16ms_adapters_at_9600_and_19200() {
    // The engines learn the latency from the first packet of two or more bytes; every request
    // (8 bytes) arrives as one packet, so even the first exchange is safe.
    for baud in [9_600, 19_200] {
        let (mut sim, m, sl) = rig(baud, Some(UsbAdapter::FTDI_DEFAULT.unannounced()));
        poll_cycle(&mut sim, m, sl);
    }
}

#[test]
fn a_long_response_first_seen_through_an_unannounced_adapter_completes() {
    // The hardest first exchange: nothing learnt yet and the response spans five packets.
    for baud in [9_600, 19_200] {
        let (mut sim, m, _) = rig(baud, Some(UsbAdapter::FTDI_DEFAULT.unannounced()));
        read(&mut sim, m, 125);
    }
}

#[test]
fn behind_an_adapter_a_response_ends_by_its_length_not_gap_plus_latency() {
    // The last packet of the response is handed over; the job completes then, not a gap and
    // an allowance later.
    let (mut sim, m, _) = rig(9_600, Some(UsbAdapter::FTDI_DEFAULT));
    let done = read(&mut sim, m, 10);
    let last_chunk = sim
        .trace()
        .of("master")
        .filter(|e| matches!(e.kind, TraceKind::RxChunk { .. }))
        .map(|e| e.at)
        .last()
        .unwrap();
    assert_eq!(done, last_chunk);
}

#[test]
fn without_an_adapter_frames_end_at_the_manuals_gap() {
    // §3.5, Table 3-11: tZVZ = 4 ms at 9600 and at 19 200 bit/s.
    for baud in [9_600, 19_200] {
        let (mut sim, m, _) = rig(baud, None);
        let s = line(baud).settings;
        let gap = Duration::from_millis(4);
        let done = read(&mut sim, m, 10);
        // The slave answers when the 8-byte request has been followed by the gap …
        let answered = sim
            .trace()
            .of("slave")
            .find(|e| matches!(e.kind, TraceKind::Tx { .. }))
            .unwrap()
            .at;
        assert_eq!(answered, Instant::ZERO + s.chars_time(8) + gap);
        // … and the master completes the gap after the 25-byte response's last character.
        assert_eq!(done, answered + s.chars_time(25) + gap);
    }
}
