//! Master scenarios on the line simulator, one per error path of [Modbus/USS]
//! [Modbus/USS] §3.3.5–§3.4.3, Table 3-11, Table 3-17 and §3.4.5–§3.4.16, each asserting the
//! manual's STATUS in virtual time.

use si_core::{Duration, Engine, Instant, Interface, LineError, Output, SerialSettings};
use si_modbus::frame::{crc16, Registers, Request, Response};
use si_modbus::master::{Master, MasterEvent};
use si_modbus::slave::{Slave, SlaveEvent, Tables};
use si_modbus::{status, MasterConfig, Mode, SlaveConfig};
use si_sim::Simulator;

/// A scripted partner: hears bytes, says nothing unless the test transmits for it.
#[derive(Default)]
struct Partner(Vec<u8>);
impl Engine for Partner {
    type Event = ();
    fn handle_rx(&mut self, _: Instant, bytes: &[u8]) {
        self.0.extend_from_slice(bytes);
    }
    fn handle_timeout(&mut self, _: Instant) {}
    fn poll_output(&mut self) -> Output<()> {
        Output::Wait(None)
    }
}

fn with_crc(mut v: Vec<u8>) -> Vec<u8> {
    let c = crc16(&v).to_le_bytes();
    v.extend_from_slice(&c);
    v
}

const LIMIT: Instant = Instant::from_micros(60_000_000);
const READ10: Request<'static> = Request::ReadHoldingRegisters {
    address: 0,
    quantity: 10,
};

fn slave_config(address: u8) -> SlaveConfig {
    SlaveConfig {
        address,
        ..SlaveConfig::default()
    }
}

fn master_with_slave(
    config: MasterConfig,
) -> (
    Simulator,
    si_sim::StationId<Master>,
    si_sim::StationId<Slave<Tables>>,
) {
    let mut sim = Simulator::new(7);
    let s = SerialSettings::default();
    let m = sim.add_station("master", s, Master::new(config).unwrap());
    let mut tables = Tables::new(100, 100, 100, 100);
    for (i, r) in tables.holding_registers.iter_mut().enumerate() {
        *r = 0x100 + i as u16;
    }
    let sl = sim.add_station("slave", s, Slave::new(slave_config(1), tables).unwrap());
    sim.connect(m, sl);
    (sim, m, sl)
}

#[test]
fn s4_4_read_holding_registers_completes_with_the_slave_data() {
    let (mut sim, m, _) = master_with_slave(MasterConfig::default());
    sim.with(m, |e, now| e.request(now, 1, &READ10)).unwrap();
    sim.run_until_quiet(LIMIT);
    let events = sim.take_events(m);
    assert_eq!(events.len(), 1, "{events:?}");
    let MasterEvent::Completed(c) = &events[0] else {
        panic!("{events:?}")
    };
    let Some(Response::ReadHoldingRegisters(regs)) = c.response() else {
        panic!()
    };
    assert_eq!(
        regs.iter().collect::<Vec<_>>(),
        (0x100..0x10A).collect::<Vec<_>>()
    );
    // The request went out as the golden bytes.
    let sent: Vec<u8> = sim.trace().received("slave").iter().map(|r| r.1).collect();
    assert_eq!(sent[..8], [0x01, 0x03, 0x00, 0x00, 0x00, 0x0A, 0xC5, 0xCD]);
}

#[test]
fn s3_8_response_timeout_is_0830h_after_the_response_time() {
    let (mut sim, m, sl) = master_with_slave(MasterConfig::default());
    sim.silence(sl, Instant::ZERO);
    sim.with(m, |e, now| e.request(now, 1, &READ10)).unwrap();
    sim.run_until_quiet(LIMIT);
    let events = sim.take_events(m);
    assert_eq!(
        events,
        vec![MasterEvent::Failed {
            job: si_core::job::JobId(1),
            unit: 1,
            function: 3,
            status: status::RESPONSE_TIMEOUT
        }]
    );
    // 8 characters of 1146 µs, then 2000 ms: the failure is at (or just after) 2009.2 ms.
    let request_end = SerialSettings::default().chars_time(8);
    let failed_at = sim.now();
    assert!(failed_at >= Instant::ZERO + request_end + Duration::from_millis(2000));
    assert!(failed_at < Instant::ZERO + request_end + Duration::from_millis(2001));
}

#[test]
fn s3_8_extension_retries_resend_before_failing() {
    let config = MasterConfig {
        retries: 2,
        response_timeout: si_core::Duration::from_millis(100),
        ..MasterConfig::default()
    };
    let (mut sim, m, sl) = master_with_slave(config);
    sim.silence(sl, Instant::ZERO);
    sim.with(m, |e, now| e.request(now, 1, &READ10)).unwrap();
    sim.run_until_quiet(LIMIT);
    assert_eq!(
        sim.trace().received("slave").len(),
        24,
        "three attempts of 8 bytes"
    );
    assert_eq!(
        sim.take_events(m),
        vec![MasterEvent::Failed {
            job: si_core::job::JobId(1),
            unit: 1,
            function: 3,
            status: status::RESPONSE_TIMEOUT
        }]
    );
    let attempts = sim.engine(m).attempts();
    assert_eq!(
        (attempts.sent, attempts.timeouts, attempts.crc_errors),
        (3, 3, 0)
    );
}

/// A corrupt first answer and a good retry: the job completes, and its attempts still show
/// the CRC error (`Attempts`), which the next job starts over from.
#[test]
fn s4_4_a_crc_error_cured_by_a_retry_is_counted_in_the_attempts() {
    let config = MasterConfig {
        retries: 1,
        ..MasterConfig::default()
    };
    let (mut sim, m, _) = master_with_slave(config);
    sim.corrupt_received(m, 3, 0x01);
    sim.with(m, |e, now| e.request(now, 1, &READ10)).unwrap();
    sim.run_until_quiet(LIMIT);
    let events = sim.take_events(m);
    assert!(
        matches!(events[..], [MasterEvent::Completed(_)]),
        "{events:?}"
    );
    let attempts = sim.engine(m).attempts();
    assert_eq!(
        (attempts.sent, attempts.crc_errors, attempts.timeouts),
        (2, 1, 0)
    );

    sim.with(m, |e, now| e.request(now, 1, &READ10)).unwrap();
    sim.run_until_quiet(LIMIT);
    assert!(matches!(
        sim.take_events(m)[..],
        [MasterEvent::Completed(_)]
    ));
    assert_eq!(
        sim.engine(m).attempts(),
        si_modbus::master::Attempts {
            sent: 1,
            ..Default::default()
        }
    );
}

type PartnerRig = (
    Simulator,
    si_sim::StationId<Master>,
    si_sim::StationId<Partner>,
);

fn master_with_partner(mode: Mode) -> PartnerRig {
    master_with_partner_on(mode, Interface::Rs232)
}

/// A master in `mode` on `interface` facing a scripted partner.
fn master_with_partner_on(mode: Mode, interface: Interface) -> PartnerRig {
    let mut sim = Simulator::new(3);
    let s = SerialSettings::default();
    let mut config = MasterConfig::default();
    config.line.mode = mode;
    let master = Master::new(config).unwrap().with_interface(interface);
    let m = sim.add_station("master", s, master);
    let p = sim.add_station("partner", s, Partner::default());
    sim.connect(m, p);
    (sim, m, p)
}

fn failed(status: si_core::Status) -> Vec<MasterEvent> {
    vec![MasterEvent::Failed {
        job: si_core::job::JobId(1),
        unit: 1,
        function: 3,
        status,
    }]
}

#[test]
fn s3_7_wrong_address_in_response_is_0831h_in_normal_mode() {
    let (mut sim, m, p) = master_with_partner(Mode::Normal);
    sim.with(m, |e, now| e.request(now, 1, &READ10)).unwrap();
    sim.run_for(Duration::from_millis(20));
    sim.transmit(p, &with_crc(vec![2, 3, 2, 0, 1]));
    sim.run_until_quiet(LIMIT);
    assert_eq!(sim.take_events(m), failed(status::WRONG_SLAVE_ADDRESS));
}

#[test]
fn s3_7_interference_suppression_skips_garbage_before_the_address() {
    let (mut sim, m, p) = master_with_partner(Mode::InterferenceSuppression);
    sim.with(m, |e, now| {
        e.request(
            now,
            1,
            &Request::ReadHoldingRegisters {
                address: 0,
                quantity: 1,
            },
        )
    })
    .unwrap();
    sim.run_for(Duration::from_millis(20));
    let mut bytes = vec![0xFF, 0x00, 0x7E];
    bytes.extend(with_crc(vec![1, 3, 2, 0x12, 0x34]));
    sim.transmit(p, &bytes);
    sim.run_until_quiet(LIMIT);
    let events = sim.take_events(m);
    let [MasterEvent::Completed(c)] = &events[..] else {
        panic!("{events:?}")
    };
    assert_eq!(
        c.response(),
        Some(Response::ReadHoldingRegisters(Registers::Words(&[0x1234])))
    );
    assert_eq!(sim.engine(m).counters().skipped_bytes, 3);
}

#[test]
fn s4_4_crc_error_in_response_is_0e57h() {
    let (mut sim, m, sl) = master_with_slave(MasterConfig::default());
    // Flip a bit in the 4th byte of the response.
    sim.corrupt_received(m, 3, 0x01);
    sim.with(m, |e, now| e.request(now, 1, &READ10)).unwrap();
    sim.run_until_quiet(LIMIT);
    assert_eq!(sim.take_events(m), failed(status::RESPONSE_CRC));
    assert_eq!(sim.take_events(sl).len(), 1);
}

#[test]
fn s4_4_every_response_check_has_its_status() {
    let cases: Vec<(Vec<u8>, si_core::Status)> = vec![
        (with_crc(vec![1, 4, 2, 0, 1]), status::WRONG_FUNCTION),
        (with_crc(vec![1, 3, 2, 0]), status::TOO_FEW_BYTES),
        (with_crc(vec![1, 3, 1, 0]), status::BYTE_COUNT_TOO_SMALL),
        (
            with_crc(vec![1, 3, 4, 0, 1, 0, 2]),
            status::BYTE_COUNT_WRONG,
        ),
        (with_crc(vec![1, 3, 2, 0, 1, 9]), status::TOO_MANY_BYTES),
        (
            with_crc(vec![1, 0x83, 2]),
            status::EXCEPTION_ILLEGAL_DATA_ADDRESS,
        ),
        (with_crc(vec![1, 0x83, 6]), status::EXCEPTION_BUSY),
    ];
    for (bytes, expected) in cases {
        let (mut sim, m, p) = master_with_partner(Mode::Normal);
        sim.with(m, |e, now| {
            e.request(
                now,
                1,
                &Request::ReadHoldingRegisters {
                    address: 0,
                    quantity: 1,
                },
            )
        })
        .unwrap();
        sim.run_for(Duration::from_millis(20));
        sim.transmit(p, &bytes);
        sim.run_until_quiet(LIMIT);
        assert_eq!(sim.take_events(m), failed(expected), "{bytes:02X?}");
    }
}

#[test]
fn s4_4_echo_error_is_0e56h() {
    let (mut sim, m, p) = master_with_partner(Mode::Normal);
    sim.with(m, |e, now| {
        e.request(
            now,
            1,
            &Request::WriteSingleRegister {
                address: 1,
                value: 3,
            },
        )
    })
    .unwrap();
    sim.run_for(Duration::from_millis(20));
    sim.transmit(p, &with_crc(vec![1, 6, 0, 1, 0, 4]));
    sim.run_until_quiet(LIMIT);
    assert_eq!(
        sim.take_events(m),
        vec![MasterEvent::Failed {
            job: si_core::job::JobId(1),
            unit: 1,
            function: 6,
            status: status::ECHO_WRONG
        }]
    );
}

#[test]
fn s4_4_response_without_request_is_0e50h() {
    let (mut sim, m, p) = master_with_partner(Mode::Normal);
    sim.transmit(p, &with_crc(vec![1, 3, 2, 0, 1]));
    sim.run_until_quiet(LIMIT);
    assert_eq!(
        sim.take_events(m),
        vec![MasterEvent::Diagnostic(status::UNSOLICITED_RESPONSE)]
    );
}

#[test]
fn s3_7_parity_error_in_response_is_reported_in_normal_mode_and_ignored_in_suppression() {
    let (mut sim, m, p) = master_with_partner(Mode::Normal);
    sim.with(m, |e, now| e.request(now, 1, &READ10)).unwrap();
    sim.run_for(Duration::from_millis(20));
    sim.schedule_break(m, sim.now());
    sim.transmit(p, &with_crc(vec![1, 3, 2, 0, 1]));
    sim.run_until_quiet(LIMIT);
    assert_eq!(sim.take_events(m), failed(status::BREAK));

    let (mut sim, m, p) = master_with_partner(Mode::InterferenceSuppression);
    sim.with(m, |e, now| e.request(now, 1, &READ10)).unwrap();
    sim.run_for(Duration::from_millis(20));
    sim.schedule_break(m, sim.now());
    sim.transmit(p, &with_crc(vec![1, 3, 2, 0, 1]));
    sim.run_until_quiet(LIMIT);
    // The corrupt response is ignored; no valid start follows: the job times out.
    assert_eq!(sim.take_events(m), failed(status::RESPONSE_TIMEOUT));
    assert_eq!(sim.engine(m).counters().suppressed, 1);
    let _ = LineError::Break;
}

#[test]
fn s3_5_a_gap_inside_the_response_ends_it_early() {
    let (mut sim, m, p) = master_with_partner(Mode::Normal);
    sim.with(m, |e, now| e.request(now, 1, &READ10)).unwrap();
    sim.run_for(Duration::from_millis(20));
    let mut regs = vec![1, 3, 20];
    regs.extend([0u8; 20]);
    let frame = with_crc(regs);
    sim.transmit(p, &frame[..10]);
    // 10 characters take 11.46 ms; pause 4 ms (the 9600-baud gap of Table 3-11) after them.
    sim.run_for(SerialSettings::default().chars_time(10) + Duration::from_millis(5));
    sim.transmit(p, &frame[10..]);
    sim.run_until_quiet(LIMIT);
    // The first piece is too short for its byte count; the rest is a frame nobody asked for.
    let mut expected = failed(status::TOO_FEW_BYTES);
    expected.push(MasterEvent::Diagnostic(status::UNSOLICITED_RESPONSE));
    assert_eq!(sim.take_events(m), expected);
}

#[test]
fn s3_2_broadcast_completes_after_the_turnaround_without_a_reply() {
    let mut sim = Simulator::new(1);
    let s = SerialSettings::default();
    let mut mc = MasterConfig::default();
    mc.line.local_echo = true;
    let m = sim.add_station("master", s, Master::new(mc).unwrap());
    let mut sc = slave_config(1);
    sc.line.local_echo = true;
    let a = sim.add_station(
        "slave1",
        s,
        Slave::new(sc, Tables::new(8, 8, 8, 8)).unwrap(),
    );
    sc.address = 2;
    let b = sim.add_station(
        "slave2",
        s,
        Slave::new(sc, Tables::new(8, 8, 8, 8)).unwrap(),
    );
    sim.bus(&[m.index(), a.index(), b.index()]);
    sim.with(m, |e, now| {
        e.request(
            now,
            0,
            &Request::WriteSingleRegister {
                address: 2,
                value: 0xBEEF,
            },
        )
    })
    .unwrap();
    sim.run_until_quiet(LIMIT);
    let events = sim.take_events(m);
    let [MasterEvent::Completed(c)] = &events[..] else {
        panic!("{events:?}")
    };
    assert_eq!(c.response(), None);
    // 8 characters, then the 100 ms turnaround.
    assert_eq!(
        sim.now(),
        Instant::ZERO + s.chars_time(8) + Duration::from_millis(100)
    );
    for st in [a, b] {
        assert_eq!(sim.engine(st).store().holding_registers[2], 0xBEEF);
        assert_eq!(
            sim.take_events(st),
            vec![SlaveEvent::Broadcast {
                function: 6,
                address: 2,
                quantity: 1
            }]
        );
    }
    // Nobody answered: the only bytes on the bus are the 8 of the request.
    assert_eq!(sim.trace().received("master").len(), 8);
    // A broadcast read is refused at once (0E43H).
    let e = sim
        .with(m, |e, now| e.request(now, 0, &READ10))
        .unwrap_err();
    assert_eq!(e.status(), status::BROADCAST_NOT_ALLOWED_FOR_FC);
}

#[test]
fn s4_3_job_checks_refuse_with_0e44h_0e45h_0e46h() {
    let mut m = Master::new(MasterConfig::default()).unwrap();
    let e = m
        .request(
            Instant::ZERO,
            1,
            &Request::ReadCoils {
                address: 0,
                quantity: 2041,
            },
        )
        .unwrap_err();
    assert_eq!(e.status(), status::BIT_COUNT);
    let e = m
        .request(
            Instant::ZERO,
            1,
            &Request::ReadInputRegisters {
                address: 0,
                quantity: 0,
            },
        )
        .unwrap_err();
    assert_eq!(e.status(), status::REGISTER_COUNT);
    let e = m
        .request(
            Instant::ZERO,
            1,
            &Request::WriteMultipleRegisters {
                address: 0,
                values: Registers::Words(&[0; 128]),
            },
        )
        .unwrap_err();
    assert_eq!(e.status(), status::WRITE_COUNT);
    m.request(Instant::ZERO, 1, &READ10).unwrap();
    assert_eq!(
        m.request(Instant::ZERO, 1, &READ10),
        Err(si_modbus::master::RequestError::Busy)
    );
}

// --- [Modbus/USS] §3.4.1, §3.4.3 against §3.4.3, §3.5.4: a turnaround glitch on RS-485
// ------------------------------------------

/// A Normal-mode master on `interface`: READ10 sent, then the partner answers with `glitch`
/// (a byte, or a framing error) before a correct response.
fn glitch_then_response(interface: Interface, glitch: Option<u8>) -> (Vec<MasterEvent>, u64) {
    let (mut sim, m, p) = master_with_partner_on(Mode::Normal, interface);
    sim.with(m, |e, now| e.request(now, 1, &READ10)).unwrap();
    sim.run_for(Duration::from_millis(20));
    let mut pdu = vec![1, 3, 20];
    pdu.extend([0u8; 20]);
    let response = with_crc(pdu);
    match glitch {
        Some(byte) => {
            let mut bytes = vec![byte];
            bytes.extend_from_slice(&response);
            sim.transmit(p, &bytes);
        }
        None => {
            sim.with(m, |e, now| e.handle_line_error(now, LineError::Framing));
            sim.transmit(p, &response);
        }
    }
    sim.run_until_quiet(LIMIT);
    let skipped = sim.engine(m).counters().skipped_bytes;
    (sim.take_events(m), skipped)
}

#[test]
fn s2_5_rs485_normal_mode_skips_a_glitch_byte_before_the_address() {
    let (events, skipped) = glitch_then_response(Interface::Rs485, Some(0xFF));
    assert!(
        matches!(events[..], [MasterEvent::Completed(_)]),
        "{events:?}"
    );
    assert_eq!(skipped, 1);
}

#[test]
fn s2_5_rs485_normal_mode_ignores_a_framing_error_before_the_address() {
    let (events, _) = glitch_then_response(Interface::Rs485, None);
    assert!(
        matches!(events[..], [MasterEvent::Completed(_)]),
        "{events:?}"
    );
}

#[test]
fn s3_7_rs422_normal_mode_keeps_0831h_for_a_glitch_byte() {
    for interface in [Interface::Rs422, Interface::Rs232] {
        let (events, _) = glitch_then_response(interface, Some(0xFF));
        assert_eq!(events, failed(status::WRONG_SLAVE_ADDRESS), "{interface:?}");
    }
}

// --- An overrun the port counted (Linux TIOCGICOUNT, reported by the driver as
// LineError::Overrun) inside a response: 080CH "transmission error (parity, stop bit,
// overrun)", [Modbus/USS] §3.6 ----------------------------------------------------------------

#[test]
fn an_overrun_inside_the_response_fails_the_job_with_080ch() {
    let (mut sim, m, p) = master_with_partner_on(Mode::Normal, Interface::Rs232);
    sim.with(m, |e, now| e.request(now, 1, &READ10)).unwrap();
    sim.run_for(Duration::from_millis(20));
    let mut pdu = vec![1, 3, 20];
    pdu.extend([0u8; 20]);
    let response = with_crc(pdu);
    sim.transmit(p, &response[..5]);
    // The first five characters are in (1.15 ms each at 9600 8E1): the port's count rises.
    sim.run_for(Duration::from_micros(5 * 1_146 + 100));
    sim.with(m, |e, now| e.handle_line_error(now, LineError::Overrun));
    sim.transmit(p, &response[5..]);
    sim.run_until_quiet(LIMIT);
    assert_eq!(sim.take_events(m), failed(status::TRANSMISSION_ERROR));
}
