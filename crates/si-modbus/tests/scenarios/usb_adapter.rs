//! Master and slave through USB-serial adapters: with default configs, both behind a
//! 16 ms / 62-byte adapter, a poll cycle of short and long reads completes at 9600 and 19 200
//! bit/s, whether the host announces the adapter's latency or the engines have to learn it;
//! and without an adapter the frames still end at the manual's gap ([Modbus/USS] §3.3.5, Table
//! 3-11).

use si_core::{Duration, Instant, Parity, SerialSettings};
use si_modbus::config::LineConfig;
use si_modbus::frame::{Request, Response};
use si_modbus::master::{Master, MasterEvent};
use si_modbus::slave::{Slave, SlaveEvent, Tables};
use si_modbus::{MasterConfig, SlaveConfig};
use si_sim::{Simulator, StationId, TraceKind, UsbAdapter};

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
    // [Modbus/USS] §3.3.5, Table 3-11: tZVZ = 4 ms at 9600 and at 19 200 bit/s.
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

/// A default master driven by hand: its request for 10 registers went out at 0, tx-done at
/// 10 ms; now it waits for the response.
fn waiting_master() -> Master {
    use si_core::Engine;
    let mut m = Master::new(MasterConfig::default()).unwrap();
    let request = Request::ReadHoldingRegisters {
        address: 0,
        quantity: 10,
    };
    m.request(Instant::ZERO, 1, &request).unwrap();
    m.handle_tx_done(Instant::ZERO + Duration::from_millis(10));
    m
}

/// Drives a default master by hand: the request goes out at 0, tx-done at 10 ms, then the
/// response arrives as `reads` (instant in ms, bytes); the job's failure status.
fn failure_after(reads: &[(u64, &[u8])]) -> si_core::Status {
    use si_core::{Engine, Output};
    let mut m = waiting_master();
    let mut events = Vec::new();
    let run_until = |m: &mut Master, until: Instant, events: &mut Vec<MasterEvent>| loop {
        match m.poll_output() {
            Output::Event(e) => events.push(e),
            Output::Wait(Some(d)) if d <= until => m.handle_timeout(d),
            Output::Wait(_) => break,
            _ => {}
        }
    };
    for &(ms, bytes) in reads {
        let at = Instant::ZERO + Duration::from_millis(ms);
        run_until(&mut m, at, &mut events);
        m.handle_rx(at, bytes);
    }
    run_until(&mut m, Instant::from_micros(10_000_000), &mut events);
    match events.as_slice() {
        [MasterEvent::Failed { status, .. }] => *status,
        other => panic!("{other:?}"),
    }
}

fn response10() -> Vec<u8> {
    let mut v = vec![1, 3, 20];
    v.extend((0..20).map(|i| i as u8));
    let crc = si_modbus::frame::crc16(&v).to_le_bytes();
    v.extend_from_slice(&crc);
    v
}

#[test]
fn a_response_cut_by_a_late_packet_names_the_adapter_latency_in_its_remedy() {
    // Three bytes at once (faster than the wire: a packetising port), then the rest 400 ms
    // later, longer than any adapter holds bytes (255 ms): the first piece ends, the rest
    // starts with no address: 0831H, whose remedy now names the adapter's latency timer
    // instead of the slave.
    let r = response10();
    let status = failure_after(&[(20, &r[..3]), (420, &r[3..])]);
    assert_eq!(status, si_modbus::status::WRONG_SLAVE_ADDRESS);
    let remedy = status.remedy().unwrap();
    assert_eq!(remedy, si_core::delivery::ADAPTER_REMEDY);
    assert!(remedy.contains("--latency-timer 1") && remedy.contains("latency_timer"));
}

#[test]
fn a_slaves_exception_behind_a_packetising_port_keeps_the_manuals_remedy() {
    // The exception answer arrives whole, in one read faster than the wire (a packetising
    // port): it is the slave's word (0E64H, exception 04), not a frame cut by the adapter, so
    // its remedy is the manual's, not the adapter's latency timer.
    let mut answer = vec![1, 0x83, 4];
    let crc = si_modbus::frame::crc16(&answer).to_le_bytes();
    answer.extend_from_slice(&crc);
    let status = failure_after(&[(20, &answer)]);
    assert_eq!(status.code(), 0x0E64);
    assert_ne!(status.remedy(), Some(si_core::delivery::ADAPTER_REMEDY));
}

#[test]
fn a_hole_shorter_than_the_longest_latency_inside_a_predicted_frame_is_waited_out() {
    // The hold estimate (16 ms on a port nobody declared) is a lower bound; while the header
    // says more bytes are coming, a hole of twice that is not the end of the frame.
    use si_core::{Engine, Output};
    let r = response10();
    let mut m = waiting_master();
    let at = |ms| Instant::ZERO + Duration::from_millis(ms);
    m.handle_rx(at(20), &r[..3]);
    while let Output::Wait(Some(d)) = m.poll_output() {
        if d > at(52) {
            break;
        }
        m.handle_timeout(d);
    }
    m.handle_rx(at(52), &r[3..]);
    assert!(matches!(
        m.poll_output(),
        Output::Event(MasterEvent::Completed(_))
    ));
}

#[test]
fn a_response_cut_on_a_byte_by_byte_line_keeps_the_manuals_remedy() {
    let r = response10();
    // The same cut, the bytes one by one (2 ms apart, within the gap).
    let at = |i: usize| {
        if i < 3 {
            20 + 2 * i as u64
        } else {
            120 + 2 * i as u64
        }
    };
    let reads: Vec<(u64, &[u8])> = (0..r.len()).map(|i| (at(i), &r[i..=i])).collect();
    let status = failure_after(&reads);
    assert_eq!(status, si_modbus::status::WRONG_SLAVE_ADDRESS);
    assert_eq!(
        status.remedy(),
        si_modbus::status::WRONG_SLAVE_ADDRESS
            .info()
            .map(|i| i.remedy)
    );
}
