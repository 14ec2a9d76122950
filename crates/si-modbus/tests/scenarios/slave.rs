//! Slave scenarios on the line simulator ([Modbus/USS] §3.3.2, §3.3.5, Table 3-11, §3.3.6, Table
//! 3-12, §3.5.5–§3.5.19, §3.5.6–§3.5.14): a scripted master sends raw frames, the slave's answers
//! and events are asserted.

use si_core::memory::Area;
use si_core::{Duration, Engine, Instant, Output, SerialSettings};
use si_modbus::frame::{crc16, ExceptionCode};
use si_modbus::slave::{Slave, SlaveEvent};
use si_modbus::status::slave as codes;
use si_modbus::{SimaticStore, SlaveConfig};
use si_sim::{Simulator, StationId};

#[derive(Default)]
struct Partner;
impl Engine for Partner {
    type Event = ();
    fn handle_rx(&mut self, _: Instant, _: &[u8]) {}
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

struct Rig {
    sim: Simulator,
    master: StationId<Partner>,
    slave: StationId<Slave<SimaticStore>>,
}

impl Rig {
    /// Slave 1 with Table 3-20's conversion DB (DB6 registers, M500 coils, T40 at 4080, …).
    fn new() -> Rig {
        let mut sim = Simulator::new(5);
        let s = SerialSettings::default();
        let master = sim.add_station("master", s, Partner);
        let config = SlaveConfig {
            address: 1,
            ..SlaveConfig::default()
        };
        let slave = sim.add_station(
            "slave",
            s,
            Slave::new(config, SimaticStore::example()).unwrap(),
        );
        sim.connect(master, slave);
        Rig { sim, master, slave }
    }

    /// Send raw bytes, let everything settle, return what the slave answered.
    fn exchange(&mut self, bytes: &[u8]) -> Vec<u8> {
        let before = self.sim.trace().received("master").len();
        self.sim.transmit(self.master, bytes);
        self.sim.run_until_quiet(LIMIT);
        self.sim.run_for(Duration::from_millis(10));
        self.sim.trace().received("master")[before..]
            .iter()
            .map(|r| r.1)
            .collect()
    }

    fn events(&mut self) -> Vec<SlaveEvent> {
        self.sim.take_events(self.slave)
    }
}

fn exception(function: u8, code: ExceptionCode) -> Vec<u8> {
    with_crc(vec![1, function | 0x80, code.code()])
}

#[test]
fn s5_7_fc03_reads_db6_and_fc06_writes_it() {
    let mut rig = Rig::new();
    let answer = rig.exchange(&with_crc(vec![1, 6, 0, 2, 0xAB, 0xCD]));
    assert_eq!(answer, with_crc(vec![1, 6, 0, 2, 0xAB, 0xCD]), "FC06 echo");
    assert_eq!(
        rig.sim
            .engine(rig.slave)
            .store()
            .memory
            .word(Area::Db(6), 4)
            .unwrap(),
        0xABCD
    );
    let answer = rig.exchange(&with_crc(vec![1, 3, 0, 1, 0, 2]));
    assert_eq!(answer, with_crc(vec![1, 3, 4, 0, 0, 0xAB, 0xCD]));
    assert_eq!(
        rig.events(),
        vec![
            SlaveEvent::Served {
                function: 6,
                address: 2,
                quantity: 1
            },
            SlaveEvent::Served {
                function: 3,
                address: 1,
                quantity: 2
            },
        ]
    );
}

#[test]
fn s5_7_fc15_then_fc01_reads_back_m500() {
    let mut rig = Rig::new();
    let answer = rig.exchange(&with_crc(vec![1, 0x0F, 0, 3, 0, 10, 2, 0xCD, 0x01]));
    assert_eq!(answer, with_crc(vec![1, 0x0F, 0, 3, 0, 10]));
    // Coils 3…12 = M500.3 … M501.4.
    let m = rig
        .sim
        .engine(rig.slave)
        .store()
        .memory
        .bytes(Area::Flags)
        .unwrap()[500..502]
        .to_vec();
    assert_eq!(m, [0xCD << 3, (0xCD >> 5) | (0x01 << 3)]);
    let answer = rig.exchange(&with_crc(vec![1, 1, 0, 3, 0, 10]));
    assert_eq!(answer, with_crc(vec![1, 1, 2, 0xCD, 0x01]));
}

#[test]
fn s5_7_fc08_is_echoed_by_the_driver_and_other_subcodes_are_0835h() {
    let mut rig = Rig::new();
    let req = with_crc(vec![1, 8, 0, 0, 0xA5, 0x37]);
    assert_eq!(rig.exchange(&req), req);
    let answer = rig.exchange(&with_crc(vec![1, 8, 0, 1, 0, 0]));
    assert_eq!(answer, exception(8, ExceptionCode::IllegalDataValue));
    assert_eq!(
        rig.events()[1],
        SlaveEvent::Exception {
            function: 8,
            code: ExceptionCode::IllegalDataValue,
            status: Some(codes::SUB_FUNCTION),
            error: None
        }
    );
}

#[test]
fn s3_6_driver_checks_answer_the_right_exception() {
    let cases: Vec<(Vec<u8>, u8, ExceptionCode, si_core::Status)> = vec![
        (
            vec![1, 7],
            7,
            ExceptionCode::IllegalFunction,
            codes::INVALID_FUNCTION,
        ),
        (
            vec![1, 0x11],
            0x11,
            ExceptionCode::IllegalFunction,
            codes::INVALID_FUNCTION,
        ),
        (
            vec![1, 3, 0, 0, 0, 128],
            3,
            ExceptionCode::IllegalDataValue,
            codes::QUANTITY,
        ),
        (
            vec![1, 1, 0, 0, 0x07, 0xF9],
            1,
            ExceptionCode::IllegalDataValue,
            codes::QUANTITY,
        ),
        (
            vec![1, 0x10, 0, 0, 0, 2, 3, 0, 0, 0],
            0x10,
            ExceptionCode::IllegalDataValue,
            codes::BYTE_COUNT,
        ),
        (
            vec![1, 5, 0, 0, 0x12, 0x34],
            5,
            ExceptionCode::IllegalDataValue,
            codes::COIL_VALUE,
        ),
    ];
    for (req, function, code, status) in cases {
        let mut rig = Rig::new();
        assert_eq!(
            rig.exchange(&with_crc(req.clone())),
            exception(function, code),
            "{req:02X?}"
        );
        assert_eq!(
            rig.events(),
            vec![SlaveEvent::Exception {
                function,
                code,
                status: Some(status),
                error: None
            }]
        );
    }
}

#[test]
fn s5_7_crc_error_is_0836h_and_not_answered() {
    let mut rig = Rig::new();
    let mut req = with_crc(vec![1, 3, 0, 0, 0, 1]);
    req[7] ^= 0xFF;
    assert_eq!(rig.exchange(&req), Vec::<u8>::new());
    assert_eq!(rig.events(), vec![SlaveEvent::Error(codes::CRC)]);
}

#[test]
fn s3_2_other_addresses_are_ignored_and_broadcasts_never_answered() {
    let mut rig = Rig::new();
    assert!(rig.exchange(&with_crc(vec![2, 3, 0, 0, 0, 1])).is_empty());
    assert!(rig.events().is_empty());
    // Broadcast write: executed, not answered.
    assert!(rig
        .exchange(&with_crc(vec![0, 6, 0, 0, 0x12, 0x34]))
        .is_empty());
    assert_eq!(
        rig.sim
            .engine(rig.slave)
            .store()
            .memory
            .word(Area::Db(6), 0)
            .unwrap(),
        0x1234
    );
    // Broadcast read: 0830H, not answered.
    assert!(rig.exchange(&with_crc(vec![0, 3, 0, 0, 0, 1])).is_empty());
    assert_eq!(
        rig.events(),
        vec![
            SlaveEvent::Broadcast {
                function: 6,
                address: 0,
                quantity: 1
            },
            SlaveEvent::Error(codes::BROADCAST_NOT_ALLOWED)
        ]
    );
}

#[test]
fn s3_5_short_frames_and_garbage_between_frames_resync_on_the_next_gap() {
    let mut rig = Rig::new();
    // Garbage, a gap, a short frame, a gap, then a good request.
    assert!(rig
        .exchange(&[0x55, 0xAA, 0x01, 0x17, 0x99, 0x00, 0x42])
        .is_empty());
    assert!(rig.exchange(&[0x01, 0x03]).is_empty());
    let answer = rig.exchange(&with_crc(vec![1, 3, 0, 0, 0, 1]));
    assert_eq!(answer, with_crc(vec![1, 3, 2, 0, 0]));
    let c = rig.sim.engine(rig.slave).counters();
    assert_eq!(c.discarded, 2, "{c:?}");
    assert_eq!(c.frames, 2, "{c:?}");
}

#[test]
fn s3_5_a_character_gap_inside_a_request_ends_it_early() {
    let mut rig = Rig::new();
    let req = with_crc(vec![1, 3, 0, 0, 0, 1]);
    rig.sim.transmit(rig.master, &req[..4]);
    rig.sim
        .run_for(SerialSettings::default().chars_time(4) + Duration::from_micros(4_100));
    rig.sim.transmit(rig.master, &req[4..]);
    rig.sim.run_until_quiet(LIMIT);
    assert!(
        rig.sim.trace().received("master").is_empty(),
        "no answer to either piece"
    );
    // Piece one (01 03 00 00) and piece two (00 01 CRC, read as a broadcast) both fail the CRC.
    assert_eq!(
        rig.events(),
        vec![SlaveEvent::Error(codes::CRC), SlaveEvent::Error(codes::CRC)]
    );
    // Just under the gap, measured between received characters as a UART reports them
    // (end of one character to end of the next: 2.7 ms silence + 1.146 ms character), the
    // same pieces are one frame and are answered.
    let mut rig = Rig::new();
    rig.sim.transmit(rig.master, &req[..4]);
    rig.sim
        .run_for(SerialSettings::default().chars_time(4) + Duration::from_micros(2_700));
    rig.sim.transmit(rig.master, &req[4..]);
    rig.sim.run_until_quiet(LIMIT);
    assert_eq!(rig.sim.trace().received("master").len(), 7);
}

#[test]
fn s5_7_a_request_during_the_response_is_a_sequence_error_0837h() {
    let mut rig = Rig::new();
    let req = with_crc(vec![1, 3, 0, 0, 0, 100]);
    rig.sim.transmit(rig.master, &req);
    // The 205-byte response takes ~235 ms; send the next request while it is on the line.
    rig.sim
        .run_for(SerialSettings::default().chars_time(8) + Duration::from_millis(50));
    rig.sim.transmit(rig.master, &req);
    rig.sim.run_until_quiet(LIMIT);
    let events = rig.events();
    assert_eq!(events[1], SlaveEvent::Error(codes::SEQUENCE), "{events:?}");
}

#[test]
fn s5_6_write_limits_answer_exception_02_with_s_modb_error() {
    let mut rig = Rig::new();
    // R = 512 → DB7, above DB_Max = 6.
    let answer = rig.exchange(&with_crc(vec![1, 6, 0x02, 0x00, 0, 1]));
    assert_eq!(answer, exception(6, ExceptionCode::IllegalDataAddress));
    let SlaveEvent::Exception { error: Some(e), .. } = rig.events()[0] else {
        panic!()
    };
    assert_eq!((e.error_nr, e.info), (23, 7));
    // Coil 2040 = Q21.0 is writable (Q_Max = 100) …
    assert_eq!(
        rig.exchange(&with_crc(vec![1, 5, 0x07, 0xF8, 0xFF, 0])),
        with_crc(vec![1, 5, 0x07, 0xF8, 0xFF, 0])
    );
    assert!(rig
        .sim
        .engine(rig.slave)
        .store()
        .memory
        .bit(Area::Outputs, 21, 0)
        .unwrap());
    // … but Q101.0 = coil 2040 + 80 × 8 is above Q_Max: ERROR_NR 27.
    let coil = 2040u16 + 80 * 8;
    let [h, l] = coil.to_be_bytes();
    assert_eq!(
        rig.exchange(&with_crc(vec![1, 5, h, l, 0xFF, 0])),
        exception(5, ExceptionCode::IllegalDataAddress)
    );
    let SlaveEvent::Exception { error: Some(e), .. } = rig.events()[1] else {
        panic!()
    };
    assert_eq!(e.error_nr, 27);
}

#[test]
fn s5_5_timers_and_counters_are_read_only_words_of_16_bits() {
    let mut rig = Rig::new();
    rig.sim.with(rig.slave, |s, _| {
        s.store_mut()
            .memory
            .set_element(Area::Timers, 41, 0x0123)
            .unwrap();
        s.store_mut()
            .memory
            .set_element(Area::Counters, 40, 0x0999)
            .unwrap();
    });
    // FC01 at 4096 (= T41) for 16 bits.
    assert_eq!(
        rig.exchange(&with_crc(vec![1, 1, 0x10, 0x00, 0, 16])),
        with_crc(vec![1, 1, 2, 0x01, 0x23])
    );
    // Counters from 6120 (C40).
    assert_eq!(
        rig.exchange(&with_crc(vec![1, 1, 0x17, 0xE8, 0, 16])),
        with_crc(vec![1, 1, 2, 0x09, 0x99])
    );
    // Not a multiple of 16: exception 03 with 0832H.
    assert_eq!(
        rig.exchange(&with_crc(vec![1, 1, 0x10, 0x00, 0, 8])),
        exception(1, ExceptionCode::IllegalDataValue)
    );
    assert_eq!(
        rig.exchange(&with_crc(vec![1, 1, 0x10, 0x01, 0, 16])),
        exception(1, ExceptionCode::IllegalDataValue)
    );
    // FC05 on a timer: refused with exception 02.
    assert_eq!(
        rig.exchange(&with_crc(vec![1, 5, 0x10, 0x00, 0xFF, 0])),
        exception(5, ExceptionCode::IllegalDataAddress)
    );
    let events = rig.events();
    for e in &events[2..4] {
        let SlaveEvent::Exception { status, .. } = e else {
            panic!("{e:?}")
        };
        assert_eq!(*status, Some(codes::QUANTITY));
    }
}

#[test]
fn s5_1_s_modb_not_started_answers_exception_04() {
    let mut rig = Rig::new();
    rig.sim
        .with(rig.slave, |s, _| s.store_mut().started = false);
    assert_eq!(
        rig.exchange(&with_crc(vec![1, 3, 0, 0, 0, 1])),
        exception(3, ExceptionCode::SlaveDeviceFailure)
    );
}

/// [Modbus/USS] §3.4.3, §3.5.4 interference suppression: leading garbage before the slave address
/// is skipped, a request with a BREAK in it is ignored without a word, and a BREAK after a complete
/// request does not spoil it.
#[test]
fn s3_7_interference_suppression_on_the_slave() {
    let mut sim = Simulator::new(5);
    let s = SerialSettings::default();
    let master = sim.add_station("master", s, Partner);
    let mut config = SlaveConfig {
        address: 1,
        ..SlaveConfig::default()
    };
    config.line.mode = si_modbus::Mode::InterferenceSuppression;
    let slave = sim.add_station(
        "slave",
        s,
        Slave::new(config, SimaticStore::example()).unwrap(),
    );
    sim.connect(master, slave);
    let req = with_crc(vec![1, 3, 0, 0, 0, 1]);
    let mut noisy = vec![0xFF, 0x7F, 0x55];
    noisy.extend_from_slice(&req);
    sim.transmit(master, &noisy);
    sim.run_until_quiet(LIMIT);
    assert_eq!(
        sim.trace().received("master").len(),
        7,
        "answered after skipping garbage"
    );
    // A BREAK in the middle of the next request: ignored, no event.
    sim.run_for(Duration::from_millis(20));
    sim.transmit(master, &req[..3]);
    sim.run_for(SerialSettings::default().chars_time(3));
    sim.schedule_break(slave, sim.now());
    sim.transmit(master, &req[3..]);
    sim.run_until_quiet(LIMIT);
    assert_eq!(
        sim.trace().received("master").len(),
        7,
        "corrupt request not answered"
    );
    // A BREAK right after a complete request: the request still counts.
    sim.run_for(Duration::from_millis(20));
    sim.transmit(master, &req);
    sim.run_for(SerialSettings::default().chars_time(8) + Duration::from_micros(500));
    sim.schedule_break(slave, sim.now());
    sim.run_until_quiet(LIMIT);
    assert_eq!(sim.trace().received("master").len(), 14);
    let events = sim.take_events(slave);
    assert_eq!(events.len(), 2, "{events:?}");
    assert!(events
        .iter()
        .all(|e| matches!(e, SlaveEvent::Served { function: 3, .. })));
    assert_eq!(sim.engine(slave).counters().suppressed, 1);
}

/// [Modbus/USS] §3.4.3, §3.5.4 Normal mode: the same BREAK inside a request is reported (080DH) and
/// not answered.
#[test]
fn s3_7_normal_mode_reports_a_break_in_a_request() {
    let mut rig = Rig::new();
    let req = with_crc(vec![1, 3, 0, 0, 0, 1]);
    rig.sim.transmit(rig.master, &req[..3]);
    rig.sim.run_for(SerialSettings::default().chars_time(3));
    let now = rig.sim.now();
    rig.sim.schedule_break(rig.slave, now);
    rig.sim.transmit(rig.master, &req[3..]);
    rig.sim.run_until_quiet(LIMIT);
    assert!(rig.sim.trace().received("master").is_empty());
    assert_eq!(
        rig.events(),
        vec![SlaveEvent::Error(si_modbus::status::BREAK)]
    );
}
