//! Property tests: decode(encode(x)) == x for every request and response, the decoders and
//! engines never panic on arbitrary bytes at arbitrary times, and S_SEND read jobs are accepted
//! exactly when their result fits S_RCV.

use proptest::prelude::*;
use si_core::{Engine, Instant, LineError, Output};
use si_modbus::fb::{parse_job, store_response, MAX_LEN};
use si_modbus::frame::{
    decode_request, decode_response, Adu, Bits, ExceptionCode, Registers, Request, Response,
    MAX_BITS, MAX_REGISTERS,
};
use si_modbus::master::{Completion, MasterEvent};
use si_modbus::mbap::{Decoder, HeaderError, TcpAdu};
use si_modbus::{Master, MasterConfig, Mode, SimaticStore, Slave, SlaveConfig, Tables};

#[derive(Debug, Clone)]
enum Req {
    Read(u8, u16, u16),
    Coil(u16, bool),
    Reg(u16, u16),
    Plain(u8),
    Diag(u16),
    Coils(u16, Vec<bool>),
    Regs(u16, Vec<u16>),
}

fn req() -> impl Strategy<Value = Req> {
    prop_oneof![
        (1u8..=2, any::<u16>(), 1..=MAX_BITS).prop_map(|(f, a, q)| Req::Read(f, a, q)),
        (3u8..=4, any::<u16>(), 1..=MAX_REGISTERS).prop_map(|(f, a, q)| Req::Read(f, a, q)),
        (any::<u16>(), any::<bool>()).prop_map(|(a, v)| Req::Coil(a, v)),
        (any::<u16>(), any::<u16>()).prop_map(|(a, v)| Req::Reg(a, v)),
        prop_oneof![Just(7u8), Just(11), Just(12)].prop_map(Req::Plain),
        any::<u16>().prop_map(Req::Diag),
        (
            any::<u16>(),
            prop::collection::vec(any::<bool>(), 1..=MAX_BITS as usize)
        )
            .prop_map(|(a, v)| Req::Coils(a, v)),
        (
            any::<u16>(),
            prop::collection::vec(any::<u16>(), 1..=MAX_REGISTERS as usize)
        )
            .prop_map(|(a, v)| Req::Regs(a, v)),
    ]
}

fn as_request(r: &Req) -> Request<'_> {
    match r {
        Req::Read(1, address, quantity) => Request::ReadCoils {
            address: *address,
            quantity: *quantity,
        },
        Req::Read(2, address, quantity) => Request::ReadDiscreteInputs {
            address: *address,
            quantity: *quantity,
        },
        Req::Read(3, address, quantity) => Request::ReadHoldingRegisters {
            address: *address,
            quantity: *quantity,
        },
        Req::Read(_, address, quantity) => Request::ReadInputRegisters {
            address: *address,
            quantity: *quantity,
        },
        Req::Coil(address, value) => Request::WriteSingleCoil {
            address: *address,
            value: *value,
        },
        Req::Reg(address, value) => Request::WriteSingleRegister {
            address: *address,
            value: *value,
        },
        Req::Plain(7) => Request::ReadExceptionStatus,
        Req::Plain(11) => Request::GetCommEventCounter,
        Req::Plain(_) => Request::GetCommEventLog,
        Req::Diag(data) => Request::Diagnostics { data: *data },
        Req::Coils(address, v) => Request::WriteMultipleCoils {
            address: *address,
            values: Bits::Bools(v),
        },
        Req::Regs(address, v) => Request::WriteMultipleRegisters {
            address: *address,
            values: Registers::Words(v),
        },
    }
}

#[derive(Debug, Clone)]
enum Resp {
    Bits(bool, Vec<u8>),
    Regs(bool, Vec<u16>),
    Echo(u8, u16, u16),
    Status(u8),
    Counter(u16, u16),
    Log(u16, u16, u16, Vec<u8>),
    Exception(u8, u8),
}

fn resp() -> impl Strategy<Value = Resp> {
    prop_oneof![
        (any::<bool>(), prop::collection::vec(any::<u8>(), 1..=255))
            .prop_map(|(c, v)| Resp::Bits(c, v)),
        (
            any::<bool>(),
            prop::collection::vec(any::<u16>(), 1..=MAX_REGISTERS as usize)
        )
            .prop_map(|(h, v)| Resp::Regs(h, v)),
        (
            prop_oneof![Just(5u8), Just(6), Just(8), Just(15), Just(16)],
            any::<u16>(),
            any::<u16>()
        )
            .prop_map(|(f, a, v)| Resp::Echo(f, a, v)),
        any::<u8>().prop_map(Resp::Status),
        (any::<u16>(), any::<u16>()).prop_map(|(s, c)| Resp::Counter(s, c)),
        (
            any::<u16>(),
            any::<u16>(),
            any::<u16>(),
            prop::collection::vec(any::<u8>(), 0..=64)
        )
            .prop_map(|(s, e, m, v)| Resp::Log(s, e, m, v)),
        (
            prop_oneof![1u8..=8, Just(11), Just(12), Just(15), Just(16)],
            1u8..=7
        )
            .prop_map(|(f, c)| Resp::Exception(f, c)),
    ]
}

fn as_response(r: &Resp) -> Response<'_> {
    match r {
        Resp::Bits(true, v) => Response::ReadCoils(Bits::packed(v, (v.len() * 8) as u16)),
        Resp::Bits(false, v) => Response::ReadDiscreteInputs(Bits::packed(v, (v.len() * 8) as u16)),
        Resp::Regs(true, v) => Response::ReadHoldingRegisters(Registers::Words(v)),
        Resp::Regs(false, v) => Response::ReadInputRegisters(Registers::Words(v)),
        Resp::Echo(5, a, v) => Response::WriteSingleCoil {
            address: *a,
            value: *v & 1 == 1,
        },
        Resp::Echo(6, a, v) => Response::WriteSingleRegister {
            address: *a,
            value: *v,
        },
        Resp::Echo(8, _, v) => Response::Diagnostics { data: *v },
        Resp::Echo(15, a, v) => Response::WriteMultipleCoils {
            address: *a,
            quantity: v % MAX_BITS + 1,
        },
        Resp::Echo(_, a, v) => Response::WriteMultipleRegisters {
            address: *a,
            quantity: v % MAX_REGISTERS + 1,
        },
        Resp::Status(s) => Response::ReadExceptionStatus(*s),
        Resp::Counter(s, c) => Response::GetCommEventCounter {
            status: *s,
            event_count: *c,
        },
        Resp::Log(s, e, m, v) => Response::GetCommEventLog {
            status: *s,
            event_count: *e,
            message_count: *m,
            events: v,
        },
        Resp::Exception(f, c) => Response::Exception {
            function: *f,
            code: ExceptionCode::from_u8(*c).unwrap(),
        },
    }
}

/// One input to an engine: bytes, a timeout, a line error or (master) a new job.
#[derive(Debug, Clone)]
enum Input {
    Rx(u32, Vec<u8>),
    Timeout(u32),
    TxDone(u32),
    LineError(u32, u8),
    Job(u32, u8, Req),
}

fn inputs() -> impl Strategy<Value = Vec<Input>> {
    let one = prop_oneof![
        4 => (0u32..20_000, prop::collection::vec(any::<u8>(), 0..40)).prop_map(|(t, b)| Input::Rx(t, b)),
        2 => (0u32..3_000_000).prop_map(Input::Timeout),
        1 => (0u32..20_000).prop_map(Input::TxDone),
        1 => (0u32..20_000, 0u8..4).prop_map(|(t, e)| Input::LineError(t, e)),
        1 => (0u32..20_000, any::<u8>(), req()).prop_map(|(t, u, r)| Input::Job(t, u, r)),
    ];
    prop::collection::vec(one, 0..60)
}

fn drive<E: Engine>(
    engine: &mut E,
    inputs: &[Input],
    mut job: impl FnMut(&mut E, Instant, u8, &Req),
) {
    let mut now = 0u64;
    for input in inputs {
        let step = |now: &mut u64, dt: u32| {
            *now += dt as u64;
            Instant::from_micros(*now)
        };
        match input {
            Input::Rx(dt, bytes) => engine.handle_rx(step(&mut now, *dt), bytes),
            Input::Timeout(dt) => engine.handle_timeout(step(&mut now, *dt)),
            Input::TxDone(dt) => engine.handle_tx_done(step(&mut now, *dt)),
            Input::LineError(dt, e) => {
                let e = [
                    LineError::Parity,
                    LineError::Framing,
                    LineError::Overrun,
                    LineError::Break,
                ][*e as usize];
                engine.handle_line_error(step(&mut now, *dt), e)
            }
            Input::Job(dt, unit, r) => {
                let t = step(&mut now, *dt);
                job(engine, t, *unit, r)
            }
        }
        // Drain until Wait, bounded: the engine must get there.
        let mut n = 0;
        while !matches!(engine.poll_output(), Output::Wait(_)) {
            n += 1;
            assert!(n < 100, "engine never says Wait");
        }
    }
}

/// Everything `engine` puts on the line until it waits.
fn transmitted<E: Engine>(engine: &mut E) -> Vec<u8> {
    let mut out = Vec::new();
    loop {
        match engine.poll_output() {
            Output::Transmit(b) => out.extend_from_slice(&b),
            Output::Wait(_) => return out,
            _ => {}
        }
    }
}

/// One request from a master to a slave with the manual's largest tables, and the master's
/// completion.
fn exchange(unit: u8, request: &Request<'_>) -> Completion {
    let at = Instant::from_micros;
    let mut m = Master::new(MasterConfig::default()).unwrap();
    let config = SlaveConfig {
        address: unit,
        ..SlaveConfig::default()
    };
    let mut s = Slave::new(config, Tables::new(2040, 2040, 127, 127)).unwrap();
    m.request(Instant::ZERO, unit, request).unwrap();
    let sent = transmitted(&mut m);
    m.handle_tx_done(at(10_000));
    s.handle_rx(at(10_000), &sent);
    s.handle_timeout(at(20_000));
    let answer = transmitted(&mut s);
    m.handle_rx(at(30_000), &answer);
    m.handle_timeout(at(400_000));
    loop {
        match m.poll_output() {
            Output::Event(MasterEvent::Completed(c)) => return c,
            Output::Wait(_) => panic!("no completion for {request:?}"),
            _ => {}
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    /// [Modbus/USS] §3.4.5–§3.4.16, §3.6: a read job (FC01–04) is accepted exactly when
    /// its count is in the manual's range and its result fits S_RCV's 200 bytes; a result that
    /// would not fit is 050EH; an accepted job's stored LEN is its result's size, never above
    /// 200.
    #[test]
    fn s_send_reads_are_accepted_exactly_when_the_result_fits(
        function in 1u8..=4,
        quantity in prop_oneof![0u16..=2100, 1590u16..=1610, 95u16..=130],
    ) {
        let [hi, lo] = quantity.to_be_bytes();
        let job = [1, function, 0, 0, hi, lo];
        let bits = function <= 2;
        let q = usize::from(quantity);
        let (max, result) = if bits {
            (MAX_BITS, q.div_ceil(8).next_multiple_of(2))
        } else {
            (MAX_REGISTERS, 2 * q)
        };
        let in_range = quantity >= 1 && quantity <= max;
        match parse_job(&job) {
            Ok((unit, request)) => {
                prop_assert!(in_range && result <= MAX_LEN, "{function} × {quantity}");
                let mut dest = [0u8; 300];
                prop_assert_eq!(store_response(&exchange(unit, &request), &mut dest), result);
            }
            Err(status) => {
                let expected = match (in_range, bits) {
                    (false, true) => 0x0E44,
                    (false, false) => 0x0E45,
                    (true, _) => 0x050E,
                };
                prop_assert_eq!(status.code(), expected, "{} × {}", function, quantity);
                prop_assert!(!in_range || result > MAX_LEN);
            }
        }
    }

    #[test]
    fn requests_round_trip(unit in any::<u8>(), r in req()) {
        let request = as_request(&r);
        let adu = Adu::request(unit, &request).unwrap();
        prop_assert_eq!(decode_request(adu.as_bytes()).unwrap(), (unit, request));
    }

    #[test]
    fn responses_round_trip(unit in any::<u8>(), r in resp()) {
        let response = as_response(&r);
        let adu = Adu::response(unit, &response).unwrap();
        prop_assert_eq!(decode_response(adu.as_bytes()).unwrap(), (unit, response));
    }

    #[test]
    fn decoders_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..300)) {
        let _ = decode_request(&bytes);
        let _ = decode_response(&bytes);
        // With a valid CRC appended the decoders look further in.
        let mut framed = bytes.clone();
        let c = si_modbus::frame::crc16(&framed).to_le_bytes();
        framed.extend_from_slice(&c);
        let _ = decode_request(&framed);
        let _ = decode_response(&framed);
        let _ = si_modbus::master::check_response(&[1, 3, 0, 0, 0, 2, 0xC4, 0x0B], &framed);
    }

    #[test]
    fn master_never_panics(inputs in inputs(), suppression in any::<bool>()) {
        let mut config = MasterConfig { retries: 1, ..MasterConfig::default() };
        if suppression { config.line.mode = Mode::InterferenceSuppression; }
        let mut m = Master::new(config).unwrap();
        drive(&mut m, &inputs, |m, now, unit, r| { let _ = m.request(now, unit, &as_request(r)); });
    }

    #[test]
    fn slaves_never_panic(inputs in inputs(), suppression in any::<bool>()) {
        let mut config = SlaveConfig { address: 1, ..SlaveConfig::default() };
        if suppression { config.line.mode = Mode::InterferenceSuppression; }
        let mut s = Slave::new(config, SimaticStore::example()).unwrap();
        drive(&mut s, &inputs, |_, _, _, _| {});
        let mut t = Slave::new(config, Tables::new(10, 10, 10, 10)).unwrap();
        drive(&mut t, &inputs, |_, _, _, _| {});
    }

    /// Valid requests, sent whole, get decodable answers from the SIMATIC slave.
    #[test]
    fn slave_answers_every_valid_request_decodably(r in req()) {
        let config = SlaveConfig { address: 1, ..SlaveConfig::default() };
        let mut s = Slave::new(config, SimaticStore::example()).unwrap();
        let adu = Adu::request(1, &as_request(&r)).unwrap();
        s.handle_rx(Instant::ZERO, adu.as_bytes());
        s.handle_timeout(Instant::from_micros(10_000));
        let mut answered = false;
        loop {
            match s.poll_output() {
                Output::Transmit(b) => { answered = true; prop_assert!(decode_response(&b).is_ok()); }
                Output::Wait(_) => break,
                _ => {}
            }
        }
        prop_assert!(answered);
    }
}

// Modbus TCP framing (src/mbap.rs): the same request and response generators, behind an MBAP
// header instead of a CRC.

/// Bytes that mostly look like an MBAP ADU (protocol id usually 0, a length around the
/// limits, a random body that may be shorter or longer than the length says), or plain noise.
fn mbap_piece() -> impl Strategy<Value = Vec<u8>> {
    prop_oneof![
        (
            any::<u16>(),
            prop_oneof![4 => Just(0u16), 1 => any::<u16>()],
            prop_oneof![0u16..=300, Just(2), Just(254), Just(255)],
            prop::collection::vec(any::<u8>(), 0..300),
        )
            .prop_map(|(t, p, l, body)| {
                let mut v = Vec::new();
                v.extend_from_slice(&t.to_be_bytes());
                v.extend_from_slice(&p.to_be_bytes());
                v.extend_from_slice(&l.to_be_bytes());
                v.extend_from_slice(&body);
                v
            }),
        prop::collection::vec(any::<u8>(), 0..40),
    ]
}

/// Feed `chunks` to one decoder; the ADUs it completes, or the header error that ended it.
fn mbap_decode(chunks: &[&[u8]]) -> (Vec<TcpAdu>, Option<HeaderError>) {
    let mut decoder = Decoder::new();
    let mut adus = Vec::new();
    for chunk in chunks {
        let mut input = *chunk;
        loop {
            match decoder.decode(&mut input) {
                Ok(Some(adu)) => adus.push(*adu),
                Ok(None) => break,
                Err(e) => return (adus, Some(e)),
            }
        }
    }
    (adus, None)
}

proptest! {
    /// Encode then decode gives the request back, or the encoder refuses it exactly when
    /// `unit | PDU` is longer than TCP's 254 bytes (the manual's larger quantities).
    #[test]
    fn mbap_requests_round_trip(transaction in any::<u16>(), unit in any::<u8>(), r in req()) {
        let request = as_request(&r);
        let unit_pdu = Adu::request(unit, &request).unwrap().as_bytes().len() - 2;
        match TcpAdu::request(transaction, unit, &request) {
            Ok(adu) => {
                prop_assert!(unit_pdu <= 254);
                let (adus, error) = mbap_decode(&[adu.as_bytes()]);
                prop_assert_eq!(error, None);
                prop_assert_eq!(adus.len(), 1);
                prop_assert_eq!(adus[0].transaction(), transaction);
                prop_assert_eq!(adus[0].decode_request().unwrap(), (unit, request));
            }
            Err(_) => prop_assert!(unit_pdu > 254),
        }
    }

    /// The same for responses.
    #[test]
    fn mbap_responses_round_trip(transaction in any::<u16>(), unit in any::<u8>(), r in resp()) {
        let response = as_response(&r);
        let unit_pdu = Adu::response(unit, &response).unwrap().as_bytes().len() - 2;
        match TcpAdu::response(transaction, unit, &response) {
            Ok(adu) => {
                prop_assert!(unit_pdu <= 254);
                let (adus, error) = mbap_decode(&[adu.as_bytes()]);
                prop_assert_eq!(error, None);
                prop_assert_eq!(adus[0].transaction(), transaction);
                prop_assert_eq!(adus[0].decode_response().unwrap(), (unit, response));
            }
            Err(_) => prop_assert!(unit_pdu > 254),
        }
    }

    /// Any bytes in any chunking: no panic, every ADU handed out is whole (header length
    /// matches) and reads as a request or response or fails with an error, and a header error
    /// comes with the offset of the field it names.
    #[test]
    fn mbap_decoder_never_panics(
        pieces in prop::collection::vec(mbap_piece(), 0..6),
        cuts in prop::collection::vec(any::<prop::sample::Index>(), 0..8),
    ) {
        let bytes = pieces.concat();
        let mut at: Vec<usize> = cuts.iter().map(|i| i.index(bytes.len() + 1)).collect();
        at.sort_unstable();
        let mut chunks = Vec::new();
        let mut from = 0;
        for cut in at.into_iter().chain([bytes.len()]) {
            chunks.push(&bytes[from..cut]);
            from = cut;
        }
        let (adus, error) = mbap_decode(&chunks);
        for adu in &adus {
            let b = adu.as_bytes();
            prop_assert_eq!(usize::from(u16::from_be_bytes([b[4], b[5]])), b.len() - 6);
            let _ = adu.decode_request();
            let _ = adu.decode_response();
        }
        if let Some(e) = error {
            prop_assert!(matches!((e.offset, e.field), (2, "protocol id") | (4, "length")));
        }
    }

    /// Valid ADUs back to back, cut at every offset into two chunks, decode the same as in one.
    #[test]
    fn mbap_adus_split_at_every_offset_decode_the_same(
        frames in prop::collection::vec((any::<u16>(), any::<u8>(), req()), 1..4),
    ) {
        let mut wire = Vec::new();
        for (transaction, unit, r) in &frames {
            if let Ok(adu) = TcpAdu::request(*transaction, *unit, &as_request(r)) {
                wire.extend_from_slice(adu.as_bytes());
            }
        }
        let whole = mbap_decode(&[&wire]);
        prop_assert_eq!(whole.1, None);
        for cut in 0..=wire.len() {
            let (a, b) = wire.split_at(cut);
            prop_assert_eq!(&mbap_decode(&[a, b]), &whole, "cut at {}", cut);
        }
    }
}
