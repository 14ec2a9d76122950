//! Ending frames at their predicted length (`FrameEnd::Length`, a host extension next to the
//! module's silence-based framing of [Modbus/USS] §3.3.5, Table 3-11), on the line simulator in
//! virtual time: when a frame ends, what happens to frames that do not fit the prediction, the
//! master's silence before its next request, and interoperation with `FrameEnd::Gap`.
//!
//! The line is the default 9600 bit/s 8E1: a character takes 1146 µs (11 bits), 8 characters
//! 9167 µs, 25 characters 28 646 µs, and the end-of-frame gap is 4 ms (Table 3-11).

use proptest::prelude::*;
use si_core::{Duration, Engine, Instant, LineError, Output, SerialSettings};
use si_modbus::config::FrameEnd;
use si_modbus::frame::{crc16, Bits, Registers, Request, Response};
use si_modbus::master::{Master, MasterEvent};
use si_modbus::slave::{Slave, SlaveEvent, Tables};
use si_modbus::status::{self, slave as codes};
use si_modbus::{MasterConfig, Mode, SlaveConfig};
use si_sim::{Faults, Simulator, StationId, TraceKind};

/// A scripted partner: hears bytes, says nothing unless the test transmits for it.
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

fn at(us: u64) -> Instant {
    Instant::from_micros(us)
}

const LIMIT: Instant = Instant::from_micros(60_000_000);
const GAP: u64 = 4_000;
/// 8 and 25 characters of 11 bits at 9600 bit/s, rounded up as the simulator does.
const CHARS_8: u64 = 9_167;
const CHARS_25: u64 = 28_646;
/// `01 03 00 00 00 0A C5 CD`: FC03, 10 registers from 0 ([Modbus/USS] §3.4.5–§3.4.16).
const READ10: Request<'static> = Request::ReadHoldingRegisters {
    address: 0,
    quantity: 10,
};
const READ10_ADU: [u8; 8] = [0x01, 0x03, 0x00, 0x00, 0x00, 0x0A, 0xC5, 0xCD];
/// FC03, 2 registers from 0: answered by 9 bytes.
const READ2: Request<'static> = Request::ReadHoldingRegisters {
    address: 0,
    quantity: 2,
};

fn tables() -> Tables {
    let mut t = Tables::new(100, 100, 100, 100);
    for (i, r) in t.holding_registers.iter_mut().enumerate() {
        *r = 0x100 + i as u16;
    }
    t
}

fn slave(frame_end: FrameEnd) -> Slave<Tables> {
    let config = SlaveConfig {
        address: 1,
        ..SlaveConfig::default()
    };
    Slave::new(config, tables())
        .unwrap()
        .with_frame_end(frame_end)
}

fn master(frame_end: FrameEnd) -> Master {
    Master::new(MasterConfig::default())
        .unwrap()
        .with_frame_end(frame_end)
}

/// A scripted master and a slave with this frame end.
fn slave_rig(frame_end: FrameEnd) -> (Simulator, StationId<Partner>, StationId<Slave<Tables>>) {
    let mut sim = Simulator::new(11);
    let s = SerialSettings::default();
    let p = sim.add_station("master", s, Partner);
    let sl = sim.add_station("slave", s, slave(frame_end));
    sim.connect(p, sl);
    (sim, p, sl)
}

/// When a station's engine queued bytes, and which.
/// A master with [`FrameEnd::Length`] whose FC03 request for 2 registers has gone out to a
/// scripted partner, 1 ms before the partner answers (at `CHARS_8 + 1_000`).
fn master_waiting_for_read2() -> (Simulator, StationId<Master>, StationId<Partner>) {
    let mut sim = Simulator::new(5);
    let s = SerialSettings::default();
    let m = sim.add_station("master", s, master(FrameEnd::Length));
    let p = sim.add_station("slave", s, Partner);
    sim.connect(m, p);
    sim.with(m, |e, now| e.request(now, 1, &READ2)).unwrap();
    sim.run_until(at(CHARS_8 + 1_000));
    (sim, m, p)
}

fn transmissions(sim: &Simulator, station: &str) -> Vec<(Instant, Vec<u8>)> {
    sim.trace()
        .of(station)
        .filter_map(|e| match &e.kind {
            TraceKind::Tx { bytes } => Some((e.at, bytes.clone())),
            _ => None,
        })
        .collect()
}

/// When a station reported events, and their `Debug` text.
fn event_times(sim: &Simulator, station: &str) -> Vec<(Instant, String)> {
    sim.trace()
        .of(station)
        .filter_map(|e| match &e.kind {
            TraceKind::Event { text } => Some((e.at, text.clone())),
            _ => None,
        })
        .collect()
}

/// Start a job and step until it completes; the event and its virtual time.
fn run_job<E>(
    sim: &mut Simulator,
    m: StationId<Master>,
    unit: u8,
    request: &Request<'_>,
    other: Option<StationId<E>>,
) -> (MasterEvent, Instant)
where
    E: Engine + 'static,
{
    sim.with(m, |e, now| e.request(now, unit, request))
        .expect("the master accepts the job");
    while sim.step() {
        if let Some(o) = other {
            sim.take_events(o);
        }
        let done = sim
            .take_events(m)
            .into_iter()
            .find(|e| !matches!(e, MasterEvent::Diagnostic(_)));
        if let Some(e) = done {
            return (e, sim.now());
        }
    }
    panic!("the job did not complete");
}

#[test]
fn s3_5_extension_length_slave_answers_at_the_request_end_not_after_the_gap() {
    for (frame_end, answer_at) in [(FrameEnd::Gap, CHARS_8 + GAP), (FrameEnd::Length, CHARS_8)] {
        let (mut sim, p, sl) = slave_rig(frame_end);
        sim.transmit(p, &READ10_ADU);
        sim.run_until_quiet(LIMIT);
        let tx = transmissions(&sim, "slave");
        assert_eq!(tx.len(), 1, "{frame_end:?}: {tx:?}");
        // The engine takes no virtual time to process: it answers when the frame ends.
        assert_eq!(tx[0].0, at(answer_at), "{frame_end:?}");
        assert_eq!(tx[0].1.len(), 25);
        assert_eq!(&tx[0].1[..3], &[0x01, 0x03, 20]);
        // The answer's last character is at the master one answer-length later.
        let rx = sim.trace().received("master");
        assert_eq!(rx.last().unwrap().0, at(answer_at + CHARS_25));
        assert_eq!(
            sim.take_events(sl),
            vec![SlaveEvent::Served {
                function: 3,
                address: 0,
                quantity: 10
            }]
        );
    }
}

#[test]
fn s3_5_extension_length_predicts_every_request_layout() {
    // FC01–06 and 08: 8 bytes; FC07/11/12 (not served by the module's slave, [Modbus/USS]
    // §3.5.6–§3.5.14: exception 01): 4; FC15/16: 9 + byte count. Each is answered at its own end.
    let requests: Vec<Vec<u8>> = vec![
        with_crc(vec![1, 0x01, 0, 0, 0, 8]),
        with_crc(vec![1, 0x02, 0, 0, 0, 8]),
        with_crc(vec![1, 0x03, 0, 0, 0, 2]),
        with_crc(vec![1, 0x04, 0, 0, 0, 2]),
        with_crc(vec![1, 0x05, 0, 3, 0xFF, 0]),
        with_crc(vec![1, 0x06, 0, 3, 0x12, 0x34]),
        with_crc(vec![1, 0x07]),
        with_crc(vec![1, 0x08, 0, 0, 0xA5, 0x37]),
        with_crc(vec![1, 0x0B]),
        with_crc(vec![1, 0x0C]),
        with_crc(vec![1, 0x0F, 0, 8, 0, 10, 2, 0xFF, 0x03]),
        with_crc(vec![1, 0x10, 0, 4, 0, 2, 4, 0xAB, 0xCD, 0x12, 0x34]),
    ];
    let char_us = SerialSettings::default().char_time().as_micros();
    for request in requests {
        let (mut sim, p, _) = slave_rig(FrameEnd::Length);
        sim.transmit(p, &request);
        sim.run_until_quiet(LIMIT);
        let end = SerialSettings::default()
            .chars_time(request.len() as u64)
            .as_micros();
        let tx = transmissions(&sim, "slave");
        assert_eq!(tx.len(), 1, "{request:02X?}");
        assert_eq!(
            tx[0].0,
            at(end),
            "{request:02X?} ({char_us} µs a character)"
        );
    }
}

#[test]
fn s3_5_extension_length_request_with_a_bad_crc_ends_at_the_gap_and_is_discarded() {
    let (mut sim, p, sl) = slave_rig(FrameEnd::Length);
    let mut bad = READ10_ADU;
    bad[7] ^= 0x01;
    sim.transmit(p, &bad);
    sim.run_until_quiet(LIMIT);
    assert!(
        transmissions(&sim, "slave").is_empty(),
        "no answer ([Modbus/USS] §3.5.6–§3.5.14)"
    );
    // 0836H, reported when the gap ends the frame, as with FrameEnd::Gap.
    let events = event_times(&sim, "slave");
    assert_eq!(events.len(), 1, "{events:?}");
    assert_eq!(events[0].0, at(CHARS_8 + GAP));
    assert_eq!(sim.take_events(sl), vec![SlaveEvent::Error(codes::CRC)]);
    assert_eq!(sim.engine(sl).counters().discarded, 1);
}

#[test]
fn s3_5_extension_trailing_garbage_after_a_complete_request_is_a_new_frame_discarded_at_its_gap() {
    let (mut sim, p, sl) = slave_rig(FrameEnd::Length);
    let mut bytes = READ10_ADU.to_vec();
    bytes.extend_from_slice(&[0x55, 0xAA]);
    sim.transmit(p, &bytes);
    sim.run_until_quiet(LIMIT);
    // The request is answered at its own end; the two bytes after it are a frame of their
    // own, too short, dropped at the gap after the last of them.
    let tx = transmissions(&sim, "slave");
    assert_eq!(tx.len(), 1);
    assert_eq!(tx[0].0, at(CHARS_8));
    let counters = sim.engine(sl).counters();
    assert_eq!((counters.frames, counters.discarded), (1, 1));
    assert_eq!(sim.take_events(sl).len(), 1);
    // The garbage came while the slave was answering; the next request is still served, not
    // taken for a sequence error (0837H).
    sim.transmit(p, &READ10_ADU);
    sim.run_until_quiet(LIMIT);
    assert_eq!(transmissions(&sim, "slave").len(), 2);
    assert!(matches!(
        sim.take_events(sl)[..],
        [SlaveEvent::Served { function: 3, .. }]
    ));
}

#[test]
fn s3_5_extension_a_request_for_another_slave_ends_by_length_and_is_ignored() {
    let (mut sim, p, sl) = slave_rig(FrameEnd::Length);
    let mut other = READ10_ADU;
    other[0] = 2;
    let other = with_crc(other[..6].to_vec());
    sim.transmit(p, &other);
    sim.transmit(p, &READ10_ADU);
    sim.run_until_quiet(LIMIT);
    // Back to back, no gap between them: with FrameEnd::Gap they would be one frame and
    // neither answered; ended by length, the second one is ours and is answered at its end.
    let tx = transmissions(&sim, "slave");
    assert_eq!(tx.len(), 1, "{tx:?}");
    assert_eq!(
        tx[0].0,
        Instant::ZERO + SerialSettings::default().chars_time(16)
    );
    assert_eq!(sim.engine(sl).counters().frames, 2);
}

#[test]
fn s3_7_extension_length_with_interference_suppression_skips_garbage_before_the_address() {
    let mut sim = Simulator::new(3);
    let s = SerialSettings::default();
    let p = sim.add_station("master", s, Partner);
    let config = SlaveConfig {
        address: 1,
        line: si_modbus::config::LineConfig {
            mode: Mode::InterferenceSuppression,
            ..Default::default()
        },
    };
    let sl = sim.add_station(
        "slave",
        s,
        Slave::new(config, tables())
            .unwrap()
            .with_frame_end(FrameEnd::Length),
    );
    sim.connect(p, sl);
    let mut bytes = vec![0x55, 0xAA];
    bytes.extend_from_slice(&READ10_ADU);
    sim.transmit(p, &bytes);
    sim.run_until_quiet(LIMIT);
    let tx = transmissions(&sim, "slave");
    assert_eq!(tx.len(), 1);
    // Ten characters on the line; the answer follows the last at once.
    assert_eq!(tx[0].0, Instant::ZERO + s.chars_time(10));
    assert_eq!(sim.engine(sl).counters().skipped_bytes, 2);
}

#[test]
fn s3_5_extension_master_completes_at_the_response_end_and_holds_the_next_request_for_the_gap() {
    for frame_end in [FrameEnd::Gap, FrameEnd::Length] {
        let mut sim = Simulator::new(5);
        let s = SerialSettings::default();
        let m = sim.add_station("master", s, master(frame_end));
        let sl = sim.add_station("slave", s, slave(frame_end));
        sim.connect(m, sl);

        let (e, done_at) = run_job(&mut sim, m, 1, &READ10, Some(sl));
        assert!(matches!(e, MasterEvent::Completed(_)), "{e:?}");
        let (answer_end, completed) = match frame_end {
            // Request 8 characters, gap, answer 25 characters, gap.
            FrameEnd::Gap => (CHARS_8 + GAP + CHARS_25, CHARS_8 + GAP + CHARS_25 + GAP),
            FrameEnd::Length => (CHARS_8 + CHARS_25, CHARS_8 + CHARS_25),
        };
        assert_eq!(done_at, at(completed), "{frame_end:?}");

        // A second job at once: it leaves only when the line has been silent for the gap
        // since the answer's last character ([Modbus/USS] §3.3.5, Table 3-11), in both modes.
        let (e, _) = run_job(&mut sim, m, 1, &READ10, Some(sl));
        assert!(matches!(e, MasterEvent::Completed(_)), "{e:?}");
        let tx = transmissions(&sim, "master");
        assert_eq!(tx.len(), 2);
        assert_eq!(tx[1].0, at(answer_end + GAP), "{frame_end:?}");
        assert_eq!(tx[1].1, READ10_ADU);
    }
}

#[test]
fn s3_5_extension_bytes_during_the_hold_extend_it() {
    let (mut sim, m, p) = master_waiting_for_read2();
    let s = SerialSettings::default();
    // An answer, then a stray character 2 ms after its end (within the gap).
    let answer = with_crc(vec![1, 3, 4, 0, 1, 0, 2]);
    sim.transmit(p, &answer);
    let answer_end = CHARS_8 + 1_000 + s.chars_time(9).as_micros();
    sim.run_until(at(answer_end));
    let done = sim.take_events(m);
    assert!(matches!(done[..], [MasterEvent::Completed(_)]), "{done:?}");
    sim.with(m, |e, now| e.request(now, 1, &READ10)).unwrap();
    sim.run_until(at(answer_end + 2_000 - s.char_time().as_micros()));
    sim.transmit(p, &[0x00]);
    sim.run_until(at(answer_end + 10_000));
    let tx = transmissions(&sim, "master");
    assert_eq!(tx.len(), 2);
    assert_eq!(tx[1].0, at(answer_end + 2_000 + GAP));
}

#[test]
fn s4_4_extension_length_response_with_a_bad_crc_ends_at_the_gap_with_0e57h() {
    let (mut sim, m, p) = master_waiting_for_read2();
    let s = SerialSettings::default();
    let mut answer = with_crc(vec![1, 3, 4, 0, 1, 0, 2]);
    answer[8] ^= 0x80;
    sim.transmit(p, &answer);
    sim.run_until_quiet(LIMIT);
    let events = event_times(&sim, "master");
    assert_eq!(events.len(), 1, "{events:?}");
    assert_eq!(
        events[0].0,
        at(CHARS_8 + 1_000 + s.chars_time(9).as_micros() + GAP)
    );
    assert_eq!(
        sim.take_events(m),
        vec![MasterEvent::Failed {
            job: si_core::job::JobId(1),
            unit: 1,
            function: 3,
            status: status::RESPONSE_CRC
        }]
    );
}

#[test]
fn s4_4_extension_length_response_with_another_function_code_ends_at_the_gap_with_0e51h() {
    let (mut sim, m, p) = master_waiting_for_read2();
    let s = SerialSettings::default();
    let answer = with_crc(vec![1, 4, 4, 0, 1, 0, 2]);
    sim.transmit(p, &answer);
    sim.run_until_quiet(LIMIT);
    let events = event_times(&sim, "master");
    assert_eq!(
        events[0].0,
        at(CHARS_8 + 1_000 + s.chars_time(9).as_micros() + GAP)
    );
    assert_eq!(
        sim.take_events(m),
        vec![MasterEvent::Failed {
            job: si_core::job::JobId(1),
            unit: 1,
            function: 3,
            status: status::WRONG_FUNCTION
        }]
    );
}

/// Every kind of job against a slave with `slave_end`, from a master with `master_end`; returns
/// the completions' response bytes (a failure's STATUS), then both sides' discard counts.
fn all_jobs(master_end: FrameEnd, slave_end: FrameEnd) -> Vec<Vec<u8>> {
    let mut sim = Simulator::new(9);
    let s = SerialSettings::default();
    let m = sim.add_station("master", s, master(master_end));
    let sl = sim.add_station("slave", s, slave(slave_end));
    sim.connect(m, sl);
    let jobs = [
        Request::WriteMultipleRegisters {
            address: 0,
            values: Registers::Words(&[0x1234, 0x5678]),
        },
        READ10,
        Request::ReadInputRegisters {
            address: 1,
            quantity: 3,
        },
        Request::WriteSingleCoil {
            address: 3,
            value: true,
        },
        Request::WriteMultipleCoils {
            address: 8,
            values: Bits::Bools(&[true, false, true]),
        },
        Request::ReadCoils {
            address: 0,
            quantity: 12,
        },
        Request::ReadDiscreteInputs {
            address: 0,
            quantity: 3,
        },
        Request::WriteSingleRegister {
            address: 9,
            value: 7,
        },
        Request::Diagnostics { data: 0xA537 },
        // Beyond the tables: exception 02 (5 bytes).
        Request::ReadHoldingRegisters {
            address: 99,
            quantity: 2,
        },
        // FC07, not served by the module's slave: exception 01.
        Request::ReadExceptionStatus,
    ];
    let mut out = Vec::new();
    for job in &jobs {
        let (e, _) = run_job(&mut sim, m, 1, job, Some(sl));
        match e {
            MasterEvent::Completed(c) => out.push(c.response_bytes().unwrap().to_vec()),
            MasterEvent::Failed { status, .. } => out.push(status.code().to_be_bytes().to_vec()),
            MasterEvent::Diagnostic(_) => unreachable!(),
        }
    }
    // Frames each side threw away (the master counts the two exception responses).
    out.push(vec![
        sim.engine(m).counters().discarded as u8,
        sim.engine(sl).counters().discarded as u8,
    ]);
    out
}

#[test]
fn s3_5_extension_length_and_gap_interoperate_both_ways() {
    let reference = all_jobs(FrameEnd::Gap, FrameEnd::Gap);
    assert_eq!(
        reference[9],
        status::EXCEPTION_ILLEGAL_DATA_ADDRESS
            .code()
            .to_be_bytes()
            .to_vec()
    );
    assert_eq!(reference[11], [2, 0]);
    for (m, s) in [
        (FrameEnd::Length, FrameEnd::Gap),
        (FrameEnd::Gap, FrameEnd::Length),
        (FrameEnd::Length, FrameEnd::Length),
    ] {
        assert_eq!(all_jobs(m, s), reference, "master {m:?}, slave {s:?}");
    }
}

#[test]
fn s4_1_extension_length_on_an_rs485_bus_with_local_echo_polls_two_slaves() {
    let mut sim = Simulator::new(13);
    let s = SerialSettings::default();
    let mut mc = MasterConfig::default();
    mc.line.local_echo = true;
    let m = sim.add_station(
        "master",
        s,
        Master::new(mc).unwrap().with_frame_end(FrameEnd::Length),
    );
    let mut ids = Vec::new();
    for address in [1u8, 2] {
        let mut sc = SlaveConfig {
            address,
            ..SlaveConfig::default()
        };
        sc.line.local_echo = true;
        let name = format!("slave{address}");
        let id = sim.add_station(
            &name,
            s,
            Slave::new(sc, tables())
                .unwrap()
                .with_frame_end(FrameEnd::Length),
        );
        ids.push(id);
    }
    sim.bus(&[m.index(), ids[0].index(), ids[1].index()]);
    for round in 0..3 {
        for unit in [1u8, 2] {
            let (e, _) = run_job(&mut sim, m, unit, &READ10, Some(ids[0]));
            assert!(
                matches!(e, MasterEvent::Completed(ref c) if c.unit() == unit),
                "round {round} unit {unit}: {e:?}"
            );
            sim.take_events(ids[1]);
        }
    }
    // Every station sees silence of at least the gap between the end of an answer and the
    // next request (measured as the module does, between received characters: [Modbus/USS] §3.3.5,
    // Table 3-11).
    let heard = sim.trace().received("slave1");
    let mut quiet = 0;
    for w in heard.windows(2) {
        let dt = (w[1].0 - w[0].0).as_micros();
        if dt > s.char_time().as_micros() {
            assert!(dt >= GAP, "{dt} µs between frames on the bus");
            quiet += 1;
        }
    }
    assert_eq!(quiet, 5, "six requests, each after an answer but the first");
    for id in ids {
        assert_eq!(sim.engine(id).counters().discarded, 0);
    }
    assert_eq!(sim.engine(m).counters().discarded, 0);
}

#[test]
fn s3_7_extension_length_master_in_normal_mode_reports_a_line_error_after_the_response_once() {
    let (mut sim, m, p) = master_waiting_for_read2();
    let s = SerialSettings::default();
    sim.transmit(p, &with_crc(vec![1, 3, 4, 0, 1, 0, 2]));
    sim.schedule_break(m, at(CHARS_8 + 1_000 + s.chars_time(9).as_micros() + 500));
    sim.run_until_quiet(LIMIT);
    let events = sim.take_events(m);
    assert!(
        matches!(
            events[..],
            [
                MasterEvent::Completed(_),
                MasterEvent::Diagnostic(s)
            ] if s == status::BREAK
        ),
        "{events:?}"
    );
}

/// Inputs for the engines fed directly (no simulator): arbitrary bytes and timing.
#[derive(Debug, Clone)]
enum Input {
    Rx(u32, Vec<u8>),
    Timeout(u32),
    TxDone(u32),
    LineError(u32, u8),
    Job(u32, u8, bool),
}

fn inputs() -> impl Strategy<Value = Vec<Input>> {
    let frame = prop_oneof![
        Just(READ10_ADU.to_vec()),
        Just(with_crc(vec![
            1, 3, 20, 0, 1, 0, 2, 0, 3, 0, 4, 0, 5, 0, 6, 0, 7, 0, 8, 0, 9, 0, 10
        ])),
        Just(with_crc(vec![1, 0x83, 2])),
        Just(with_crc(vec![1, 0x10, 0, 0, 0, 1, 2, 0, 7])),
        Just(with_crc(vec![1, 0x10, 0, 0, 0, 1])),
        prop::collection::vec(any::<u8>(), 0..40),
    ];
    let one = prop_oneof![
        4 => (0u32..6_000, frame, prop::collection::vec(any::<u8>(), 0..4))
            .prop_map(|(t, mut b, tail)| { b.extend(tail); Input::Rx(t, b) }),
        2 => (0u32..3_000_000).prop_map(Input::Timeout),
        1 => (0u32..20_000).prop_map(Input::TxDone),
        1 => (0u32..20_000, 0u8..4).prop_map(|(t, e)| Input::LineError(t, e)),
        2 => (0u32..20_000, 0u8..3, any::<bool>()).prop_map(|(t, u, w)| Input::Job(t, u, w)),
    ];
    prop::collection::vec(one, 0..60)
}

/// Drain until `Wait`; the number of job completions seen.
fn drain<E: Engine>(
    engine: &mut E,
    is_completion: impl Fn(&E::Event) -> bool,
) -> (usize, Option<Instant>) {
    let mut done = 0;
    for _ in 0..100 {
        match engine.poll_output() {
            Output::Event(e) if is_completion(&e) => done += 1,
            Output::Wait(d) => return (done, d),
            _ => {}
        }
    }
    panic!("engine never says Wait");
}

fn completion(e: &MasterEvent) -> bool {
    !matches!(e, MasterEvent::Diagnostic(_))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    /// Any bytes and timing, either frame end, either mode: the master never panics, and
    /// every job it accepts ends exactly once (after the line falls silent at the latest).
    #[test]
    fn master_every_job_ends_once(
        inputs in inputs(),
        length in any::<bool>(),
        suppression in any::<bool>(),
        echo in any::<bool>(),
    ) {
        let mut config = MasterConfig { retries: 1, response_timeout: si_core::Duration::from_millis(100), ..MasterConfig::default() };
        if suppression { config.line.mode = Mode::InterferenceSuppression; }
        config.line.local_echo = echo;
        let end = if length { FrameEnd::Length } else { FrameEnd::Gap };
        let mut m = Master::new(config).unwrap().with_frame_end(end);
        let (mut accepted, mut ended) = (0usize, 0usize);
        let mut now = 0u64;
        for input in &inputs {
            let mut step = |dt: u32| { now += dt as u64; Instant::from_micros(now) };
            match input {
                Input::Rx(dt, b) => m.handle_rx(step(*dt), b),
                Input::Timeout(dt) => m.handle_timeout(step(*dt)),
                Input::TxDone(dt) => m.handle_tx_done(step(*dt)),
                Input::LineError(dt, e) => m.handle_line_error(step(*dt), [
                    LineError::Parity, LineError::Framing, LineError::Overrun, LineError::Break,
                ][*e as usize]),
                Input::Job(dt, unit, write) => {
                    let t = step(*dt);
                    let r = if *write {
                        Request::WriteMultipleRegisters { address: 0, values: Registers::Words(&[7]) }
                    } else {
                        READ10
                    };
                    if m.request(t, *unit, &r).is_ok() { accepted += 1; }
                }
            }
            ended += drain(&mut m, completion).0;
            prop_assert!(ended <= accepted, "{ended} ended, {accepted} accepted");
        }
        // Silence: follow the deadlines until the engine has none.
        let mut t = Instant::from_micros(now);
        for _ in 0..20 {
            m.handle_tx_done(t);
            let (n, d) = drain(&mut m, completion);
            ended += n;
            match d {
                Some(d) => { t = d.max(t); m.handle_timeout(t); ended += drain(&mut m, completion).0; }
                None => break,
            }
        }
        prop_assert_eq!(ended, accepted);
        prop_assert!(!m.is_busy());
    }

    /// Any bytes and timing, either frame end, either mode: the slave never panics and
    /// answers at most once per frame it took.
    #[test]
    fn slave_never_panics_with_either_frame_end(
        inputs in inputs(),
        length in any::<bool>(),
        suppression in any::<bool>(),
        echo in any::<bool>(),
    ) {
        let mut config = SlaveConfig { address: 1, ..SlaveConfig::default() };
        if suppression { config.line.mode = Mode::InterferenceSuppression; }
        config.line.local_echo = echo;
        let end = if length { FrameEnd::Length } else { FrameEnd::Gap };
        let mut s = Slave::new(config, tables()).unwrap().with_frame_end(end);
        let mut now = 0u64;
        let mut answers = 0u64;
        for input in &inputs {
            let mut step = |dt: u32| { now += dt as u64; Instant::from_micros(now) };
            match input {
                Input::Rx(dt, b) => s.handle_rx(step(*dt), b),
                Input::Timeout(dt) => s.handle_timeout(step(*dt)),
                Input::TxDone(dt) => s.handle_tx_done(step(*dt)),
                Input::LineError(dt, e) => s.handle_line_error(step(*dt), [
                    LineError::Parity, LineError::Framing, LineError::Overrun, LineError::Break,
                ][*e as usize]),
                Input::Job(dt, _, _) => s.handle_timeout(step(*dt)),
            }
            for _ in 0..100 {
                match s.poll_output() {
                    Output::Transmit(_) => answers += 1,
                    Output::Wait(_) => break,
                    _ => {}
                }
            }
        }
        prop_assert!(answers <= s.counters().frames);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Master and slave on a faulty simulated line, any mix of frame ends: every job ends
    /// once, and every read returns the registers of one single write (the CRC check at the
    /// predicted length lets no corrupted frame through).
    #[test]
    fn faulty_line_every_job_ends_once_with_any_frame_ends(
        seed in any::<u64>(),
        master_length in any::<bool>(),
        slave_length in any::<bool>(),
    ) {
        let ends = |l: bool| if l { FrameEnd::Length } else { FrameEnd::Gap };
        let mut sim = Simulator::new(seed).without_trace();
        let s = SerialSettings::new(115_200, 8, si_core::Parity::Even, 1).unwrap();
        let mut mc = MasterConfig { response_timeout: si_core::Duration::from_millis(50), ..MasterConfig::default() };
        mc.line.settings = s;
        let m = sim.add_station("master", s, Master::new(mc).unwrap().with_frame_end(ends(master_length)));
        let mut sc = SlaveConfig { address: 1, ..SlaveConfig::default() };
        sc.line.settings = s;
        let sl = sim.add_station("slave", s, Slave::new(sc, Tables::new(0, 0, 16, 0)).unwrap().with_frame_end(ends(slave_length)));
        sim.connect(m, sl);
        let faults = Faults { bit_flip: 0.002, drop: 0.002, insert: 0.002, extra_latency: Duration::ZERO };
        sim.set_faults(m, faults);
        sim.set_faults(sl, faults);
        let mut done = 0;
        for i in 0..40u16 {
            let write = Request::WriteMultipleRegisters { address: 0, values: Registers::Words(&[i; 10]) };
            let request = if i % 2 == 0 { write } else { READ10 };
            sim.with(m, |e, now| e.request(now, 1, &request)).expect("idle between jobs");
            let mut ended = 0;
            for _ in 0..100 {
                sim.run_for(Duration::from_millis(10));
                for e in sim.take_events(m) {
                    match e {
                        MasterEvent::Completed(c) => {
                            ended += 1;
                            done += 1;
                            if let Some(Response::ReadHoldingRegisters(r)) = c.response() {
                                let v: Vec<u16> = r.iter().collect();
                                prop_assert!(v.iter().all(|&x| x == v[0]), "{:?}", v);
                            }
                        }
                        MasterEvent::Failed { status, .. } => {
                            ended += 1;
                            prop_assert!(status.info().is_some());
                        }
                        MasterEvent::Diagnostic(_) => {}
                    }
                }
                sim.take_events(sl);
                if ended > 0 { break; }
            }
            prop_assert_eq!(ended, 1, "job {} ended {} times", i, ended);
        }
        // A line that works at all: at 0.6 % faults per byte about 33 of 40 jobs end well, but
        // the simulator's fault sequence for some seeds comes in runs (seed
        // 13320529681020295147: 18, with the same engines as before the change that found it),
        // so the bound only tells a working line from a broken one.
        prop_assert!(done > 10, "{} of 40 done", done);
    }
}

/// The extension's patience: a master that ends frames by length waits out a pause inside a
/// response whose header predicts more bytes, even on a port that delivers byte by byte (the
/// simulator's stations declare exact delivery). With the gap alone, the 10 ms pause below
/// would cut the answer into two frames and fail the job.
#[test]
fn s3_5_extension_length_master_waits_out_a_pause_inside_a_response() {
    let (mut sim, m, p) = master_waiting_for_read2();
    let answer = with_crc(vec![1, 3, 4, 0, 1, 0, 2]);
    sim.transmit(p, &answer[..4]);
    let s = SerialSettings::default();
    let paused = sim.now() + s.chars_time(4) + Duration::from_millis(10);
    sim.run_until(paused);
    assert!(sim.take_events(m).is_empty(), "the job ended in the pause");
    sim.transmit(p, &answer[4..]);
    sim.run_until_quiet(LIMIT);
    let events = sim.take_events(m);
    assert_eq!(events.len(), 1, "{events:?}");
    let MasterEvent::Completed(c) = &events[0] else {
        panic!("expected the completed job, got {events:?}");
    };
    assert_eq!(
        c.response(),
        Some(Response::ReadHoldingRegisters(Registers::Words(&[1, 2])))
    );
}

/// A response cut short for good still ends, after the gap and the patience
/// (`Delivery::assumed_patience`: 4 × 16 ms and one character), as a length error, not as
/// "no response".
#[test]
fn s4_4_extension_length_a_response_cut_short_ends_after_the_patience_with_0e52h() {
    let (mut sim, m, p) = master_waiting_for_read2();
    let s = SerialSettings::default();
    let start = sim.now();
    sim.transmit(p, &[1, 3, 4, 0]);
    sim.run_until_quiet(LIMIT);
    let events = event_times(&sim, "master");
    assert_eq!(events.len(), 1, "{events:?}");
    let patience = 64_000 + s.chars_time(1).as_micros();
    assert_eq!(
        events[0].0,
        start + s.chars_time(4) + Duration::from_micros(GAP + patience)
    );
    assert_eq!(
        sim.take_events(m),
        vec![MasterEvent::Failed {
            job: si_core::job::JobId(1),
            unit: 1,
            function: 3,
            status: status::TOO_FEW_BYTES
        }]
    );
}
