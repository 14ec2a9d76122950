//! Modbus TCP on loopback (127.0.0.1, port 0): our client against our server for every
//! function code the module serves, exceptions, the unit filter, the connection limit, a bad
//! header, a server that never answers, a late answer, and two clients at once.
#![cfg(feature = "tokio")]

use std::time::Duration;

use si_modbus::frame::{ExceptionCode, Registers, Request};
use si_modbus::mbap::TcpAdu;
use si_modbus::slave::Tables;
use si_modbus::tokio::tcp::{Client, Handler, Server, ServerConfig, Units};
use si_modbus::tokio::{Client as _, Error, Job};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};

/// A bound on waits for answers that never come; the tests assert the outcome, not the time.
const SHORT: Duration = Duration::from_millis(300);

async fn start(
    config: ServerConfig,
) -> (
    std::net::SocketAddr,
    std::sync::Arc<std::sync::Mutex<Tables>>,
) {
    let server = Server::bind("127.0.0.1:0", config, Tables::new(64, 64, 200, 64))
        .await
        .unwrap();
    let addr = server.local_addr().unwrap();
    let store = server.store();
    tokio::spawn(server.run());
    (addr, store)
}

#[tokio::test]
async fn every_function_code_between_our_client_and_server() {
    let (addr, store) = start(ServerConfig::default()).await;
    {
        let mut s = store.lock().unwrap();
        s.discrete_inputs[3] = true;
        s.discrete_inputs[9] = true;
        s.input_registers[5] = 0xBEEF;
    }
    let c = Client::connect(addr).await.unwrap();
    c.write_single_coil(1, 2, true).await.unwrap(); // FC05
    c.write_multiple_coils(1, 8, &[true, false, true])
        .await
        .unwrap(); // FC15
    let coils = c.read_coils(1, 0, 11).await.unwrap(); // FC01
    assert_eq!(
        coils,
        [false, false, true, false, false, false, false, false, true, false, true]
    );
    let inputs = c.read_discrete_inputs(1, 2, 8).await.unwrap(); // FC02
    assert_eq!(
        inputs,
        [false, true, false, false, false, false, false, true]
    );
    c.write_single_register(1, 7, 0x1234).await.unwrap(); // FC06
    c.write_multiple_registers(1, 8, &[1, 2, 3]).await.unwrap(); // FC16
    assert_eq!(
        c.read_holding_registers(1, 6, 5).await.unwrap(), // FC03
        [0, 0x1234, 1, 2, 3]
    );
    assert_eq!(c.read_input_registers(1, 4, 2).await.unwrap(), [0, 0xBEEF]); // FC04
    assert_eq!(c.diagnostics(1, 0xA537).await.unwrap(), 0xA537); // FC08
    let s = store.lock().unwrap();
    assert_eq!(&s.holding_registers[7..11], [0x1234, 1, 2, 3]);
    assert!(s.coils[2] && s.coils[8] && !s.coils[9] && s.coils[10]);
}

#[tokio::test]
async fn exceptions_pass_as_they_are() {
    let (addr, _) = start(ServerConfig::default()).await;
    let c = Client::connect(addr).await.unwrap();
    // Past the 200 holding registers: the store's exception 02.
    let e = c.read_holding_registers(1, 199, 2).await.unwrap_err();
    assert!(
        matches!(
            e,
            Error::Failed {
                job: Job { function: 3, .. },
                exception: Some(2),
                ..
            }
        ),
        "{e:?}"
    );
    assert_eq!(
        e.exception_code(),
        Some(ExceptionCode::IllegalDataAddress.code())
    );
    // FC07: the module's slave has none ([Modbus/USS] §3.5.6–§3.5.14), exception 01.
    let e = c
        .request(1, &Request::ReadExceptionStatus)
        .await
        .unwrap_err();
    assert_eq!(e.exception_code(), Some(1), "{e:?}");
    // 126 registers: within the manual's 127, but the answer does not fit a TCP PDU: 03.
    let raw = TcpAdu::request(
        0x0BAD,
        1,
        &Request::ReadHoldingRegisters {
            address: 0,
            quantity: 126,
        },
    );
    let answer = raw_exchange(addr, raw.unwrap().as_bytes(), 9).await;
    assert_eq!(answer, [0x0B, 0xAD, 0, 0, 0, 3, 1, 0x83, 0x03]);
    // The connection is still good after exceptions.
    assert_eq!(c.read_holding_registers(1, 0, 1).await.unwrap(), [0]);
}

/// Send `request` on a new connection and read `len` bytes of answer.
async fn raw_exchange(addr: std::net::SocketAddr, request: &[u8], len: usize) -> Vec<u8> {
    let mut s = TcpStream::connect(addr).await.unwrap();
    s.write_all(request).await.unwrap();
    let mut answer = vec![0; len];
    s.read_exact(&mut answer).await.unwrap();
    answer
}

#[tokio::test]
async fn a_unit_not_served_gets_no_answer() {
    let config = ServerConfig {
        units: Units::only(&[1, 17]),
        ..ServerConfig::default()
    };
    let (addr, _) = start(config).await;
    let c = Client::connect(addr)
        .await
        .unwrap()
        .with_response_timeout(SHORT);
    assert!(c.read_holding_registers(17, 0, 1).await.is_ok());
    let e = c.read_holding_registers(2, 0, 1).await.unwrap_err();
    assert_eq!(
        e.status(),
        Some(si_modbus::status::RESPONSE_TIMEOUT),
        "{e:?}"
    );
    assert!(c.read_holding_registers(1, 0, 1).await.is_ok());
}

#[tokio::test]
async fn a_server_that_never_answers_times_out_and_a_late_answer_is_discarded() {
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = listener.local_addr().unwrap();
    let peer = tokio::spawn(async move {
        let (mut s, _) = listener.accept().await.unwrap();
        let mut first = [0u8; 12];
        s.read_exact(&mut first).await.unwrap();
        // No answer to the first request. When the second comes, answer the first (late),
        // then the second.
        let mut second = [0u8; 12];
        s.read_exact(&mut second).await.unwrap();
        for (request, value) in [(first, 0xDEAD_u16), (second, 0x0042)] {
            let reply = TcpAdu::response(
                u16::from_be_bytes([request[0], request[1]]),
                request[6],
                &si_modbus::frame::Response::ReadHoldingRegisters(Registers::Words(&[value])),
            )
            .unwrap();
            s.write_all(reply.as_bytes()).await.unwrap();
        }
        let mut rest = Vec::new();
        let _ = s.read_to_end(&mut rest).await;
    });
    let c = Client::connect(addr)
        .await
        .unwrap()
        .with_response_timeout(SHORT);
    let e = c.read_holding_registers(1, 0, 1).await.unwrap_err();
    assert_eq!(
        e.status(),
        Some(si_modbus::status::RESPONSE_TIMEOUT),
        "{e:?}"
    );
    let c = c.with_response_timeout(Duration::from_secs(10));
    assert_eq!(c.read_holding_registers(1, 0, 1).await.unwrap(), [0x0042]);
    drop(c);
    peer.await.unwrap();
}

/// Two clients at once, both counting transaction ids from 1, their requests interleaved:
/// each gets its own answers.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn two_clients_at_once_with_interleaved_transaction_ids() {
    let (addr, _) = start(ServerConfig::default()).await;
    let run = |base: u16| async move {
        let c = Client::connect(addr).await.unwrap();
        for i in 0..50u16 {
            let value = base + i;
            let at = base / 1000;
            c.write_single_register(1, at, value).await.unwrap();
            assert_eq!(c.read_holding_registers(1, at, 1).await.unwrap(), [value]);
        }
        c.next_transaction_id().await
    };
    let (a, b) = tokio::join!(tokio::spawn(run(1000)), tokio::spawn(run(2000)));
    assert_eq!((a.unwrap(), b.unwrap()), (101, 101));
}

/// Two requests in one segment, transaction ids out of order: two answers, in order, each
/// with its own id.
#[tokio::test]
async fn pipelined_requests_are_answered_in_order_with_their_ids() {
    let (addr, store) = start(ServerConfig::default()).await;
    store.lock().unwrap().holding_registers[..2].copy_from_slice(&[11, 22]);
    let mut wire = Vec::new();
    for (transaction, address) in [(0x0102, 1), (0x0101, 0)] {
        let r = Request::ReadHoldingRegisters {
            address,
            quantity: 1,
        };
        wire.extend_from_slice(TcpAdu::request(transaction, 1, &r).unwrap().as_bytes());
    }
    let answer = raw_exchange(addr, &wire, 22).await;
    assert_eq!(
        answer,
        [
            0x01, 0x02, 0, 0, 0, 5, 1, 3, 2, 0, 22, //
            0x01, 0x01, 0, 0, 0, 5, 1, 3, 2, 0, 11
        ]
    );
}

#[tokio::test]
async fn a_bad_header_closes_the_connection() {
    let (addr, _) = start(ServerConfig::default()).await;
    for bad in [
        [0, 1, 0, 1, 0, 6, 1, 3, 0, 0, 0, 1], // protocol id 1
        [0, 1, 0, 0, 1, 0, 1, 3, 0, 0, 0, 1], // length 256
    ] {
        let mut s = TcpStream::connect(addr).await.unwrap();
        s.write_all(&bad).await.unwrap();
        let mut rest = Vec::new();
        // A bound only: a server that kept the connection open would hang here.
        let n = tokio::time::timeout(Duration::from_secs(10), s.read_to_end(&mut rest))
            .await
            .expect("the connection is closed");
        assert_eq!(n.unwrap(), 0, "closed without an answer");
    }
}

#[tokio::test]
async fn connections_over_the_limit_are_closed() {
    let config = ServerConfig {
        max_connections: 1,
        ..ServerConfig::default()
    };
    let (addr, _) = start(config).await;
    let first = Client::connect(addr).await.unwrap();
    first.read_coils(1, 0, 1).await.unwrap();
    let second = Client::connect(addr).await.unwrap();
    let e = second.read_coils(1, 0, 1).await.unwrap_err();
    assert!(matches!(e, Error::Stopped | Error::Io(_)), "{e:?}");
    first.read_coils(1, 0, 1).await.unwrap();
    drop(first);
    // The slot is free once the server has seen the first connection close.
    for attempt in 0.. {
        let third = Client::connect(addr).await.unwrap();
        match third.read_coils(1, 0, 1).await {
            Ok(_) => break,
            Err(e) if attempt < 50 => {
                assert!(matches!(e, Error::Stopped | Error::Io(_)), "{e:?}");
                tokio::task::yield_now().await;
            }
            Err(e) => panic!("the slot was never freed: {e}"),
        }
    }
}

/// A handler of our own (here: a gateway whose serial line is silent) answers through the
/// server, and an exception code the serial module never sends (0BH, "gateway target device
/// failed to respond") reaches the client as it is.
#[tokio::test]
async fn a_gateway_exception_code_from_a_handler_passes_as_it_is() {
    struct SilentLine;
    impl Handler for SilentLine {
        async fn answer(&self, request: TcpAdu) -> Option<TcpAdu> {
            let exception = [request.unit(), request.function() | 0x80, 0x0B];
            TcpAdu::from_unit_pdu(request.transaction(), &exception).ok()
        }
    }
    let server = Server::with_handler("127.0.0.1:0", ServerConfig::default(), SilentLine)
        .await
        .unwrap();
    let addr = server.local_addr().unwrap();
    tokio::spawn(server.run());
    let c = Client::connect(addr).await.unwrap();
    let e = c.read_holding_registers(5, 0, 1).await.unwrap_err();
    assert!(
        matches!(
            e,
            Error::Failed {
                job: Job { function: 3, .. },
                exception: Some(0x0B),
                ..
            }
        ),
        "{e:?}"
    );
    assert_eq!(
        e.to_string(),
        "unit 5 FC03 address 0: exception 0BH (gateway target device failed to respond)"
    );
}

/// The same request PDUs, valid and refused, sent to the RTU slave (over an in-memory line)
/// and to the TCP server, both serving equal tables: the response PDUs are byte for byte the
/// same (both execute with `si_modbus::serve`).
#[tokio::test]
async fn tcp_and_rtu_answer_every_request_alike() {
    use si_modbus::frame::crc16;
    use si_modbus::tokio::Slave;
    use si_modbus::SlaveConfig;

    let tables = || {
        let mut t = Tables::new(64, 64, 200, 64);
        t.holding_registers[1] = 0x1234;
        t.coils[3] = true;
        t
    };
    let (addr, _) = start(ServerConfig::default()).await;
    {
        // start() serves Tables::new(64, 64, 200, 64); give it the same contents.
        let c = Client::connect(addr).await.unwrap();
        c.write_single_register(1, 1, 0x1234).await.unwrap();
        c.write_single_coil(1, 3, true).await.unwrap();
    }
    let (mut line, slave_end) = tokio::io::duplex(1024);
    let config = SlaveConfig {
        address: 1,
        ..SlaveConfig::default()
    };
    let _slave = Slave::spawn(config, tables(), slave_end).unwrap();
    let mut tcp = TcpStream::connect(addr).await.unwrap();
    let pdus: &[&[u8]] = &[
        &[0x03, 0, 0, 0, 3],                // FC03
        &[0x03, 0, 0, 0, 0],                // quantity 0: 03
        &[0x03, 0, 199, 0, 2],              // past the table: 02
        &[0x01, 0, 0, 0, 10],               // FC01
        &[0x06, 0, 5, 0xAB, 0xCD],          // FC06
        &[0x05, 0, 1, 0x12, 0x34],          // coil value neither FF00H nor 0000H: 03
        &[0x07],                            // FC07, not served by the module's slave: 01
        &[0x2B, 0x0E, 1, 0],                // unknown function: 01
        &[0x08, 0, 1, 0, 0],                // FC08 sub-function 0001: 03
        &[0x10, 0, 0, 0, 2, 3, 0, 1, 0, 2], // FC16 byte count 3 for 2 registers: 03
        &[0x08, 0, 0, 0xA5, 0x37],          // FC08 echo
    ];
    for (i, pdu) in pdus.iter().enumerate() {
        let mut rtu = vec![1];
        rtu.extend_from_slice(pdu);
        let crc = crc16(&rtu).to_le_bytes();
        rtu.extend_from_slice(&crc);
        line.write_all(&rtu).await.unwrap();
        let mut rtu_answer = Vec::new();
        while rtu_answer.len() < 4 || !si_modbus::frame::crc_ok(&rtu_answer) {
            let mut b = [0u8; 64];
            let n = tokio::time::timeout(Duration::from_secs(5), line.read(&mut b))
                .await
                .expect("the RTU slave answers")
                .unwrap();
            rtu_answer.extend_from_slice(&b[..n]);
        }
        let mut tcp_request = vec![0, i as u8, 0, 0, 0, pdu.len() as u8 + 1, 1];
        tcp_request.extend_from_slice(pdu);
        tcp.write_all(&tcp_request).await.unwrap();
        let mut header = [0u8; 6];
        tcp.read_exact(&mut header).await.unwrap();
        assert_eq!(header[..4], [0, i as u8, 0, 0]);
        let mut unit_pdu = vec![0; usize::from(u16::from_be_bytes([header[4], header[5]]))];
        tcp.read_exact(&mut unit_pdu).await.unwrap();
        assert_eq!(
            unit_pdu,
            rtu_answer[..rtu_answer.len() - 2],
            "request PDU {pdu:02X?}"
        );
    }
}

/// A connection that stays silent past the idle timeout is closed, and its slot serves the
/// next client.
#[tokio::test]
async fn a_silent_connection_is_closed_after_the_idle_timeout() {
    let config = ServerConfig {
        max_connections: 1,
        idle_timeout: Some(Duration::from_millis(100)),
        ..ServerConfig::default()
    };
    let (addr, _) = start(config).await;
    let mut silent = TcpStream::connect(addr).await.unwrap();
    let mut rest = Vec::new();
    let closed = tokio::time::timeout(Duration::from_secs(10), silent.read_to_end(&mut rest)).await;
    assert!(matches!(closed, Ok(Ok(0))), "{closed:?}");
    let c = Client::connect(addr).await.unwrap();
    c.read_coils(1, 0, 1).await.unwrap();
}

/// A handler that answers transaction 2 only once the client has seen the answer to 1.
struct WaitsForTheFirstAnswer(std::sync::Arc<tokio::sync::Notify>);

impl Handler for WaitsForTheFirstAnswer {
    async fn answer(&self, request: TcpAdu) -> Option<TcpAdu> {
        if request.transaction() == 2 {
            self.0.notified().await;
        }
        let pdu = [request.unit(), request.function() | 0x80, 0x04];
        Some(TcpAdu::from_unit_pdu(request.transaction(), &pdu).unwrap())
    }
}

/// Behind a slow handler (a gateway's serial line) the answer to a pipelined request goes
/// out as soon as it is ready, not held back until the later ones are answered too.
#[tokio::test]
async fn a_pipelined_answer_is_not_held_back_by_the_next_request() {
    let first_seen = std::sync::Arc::new(tokio::sync::Notify::new());
    let handler = WaitsForTheFirstAnswer(std::sync::Arc::clone(&first_seen));
    let server = Server::with_handler("127.0.0.1:0", ServerConfig::default(), handler)
        .await
        .unwrap();
    let addr = server.local_addr().unwrap();
    tokio::spawn(server.run());
    let r = Request::ReadHoldingRegisters {
        address: 0,
        quantity: 1,
    };
    let mut wire = TcpAdu::request(1, 1, &r).unwrap().as_bytes().to_vec();
    wire.extend_from_slice(TcpAdu::request(2, 1, &r).unwrap().as_bytes());
    let mut s = TcpStream::connect(addr).await.unwrap();
    s.write_all(&wire).await.unwrap();
    let mut answer = [0u8; 9];
    tokio::time::timeout(Duration::from_secs(10), s.read_exact(&mut answer))
        .await
        .expect("the first answer before the second is computed")
        .unwrap();
    assert_eq!(answer, [0, 1, 0, 0, 0, 3, 1, 0x83, 0x04]);
    first_seen.notify_one();
    tokio::time::timeout(Duration::from_secs(10), s.read_exact(&mut answer))
        .await
        .expect("the second answer")
        .unwrap();
    assert_eq!(answer, [0, 2, 0, 0, 0, 3, 1, 0x83, 0x04]);
}

/// Answers a read with one register too few, and a register write with another value.
struct Misfits;

impl Handler for Misfits {
    async fn answer(&self, request: TcpAdu) -> Option<TcpAdu> {
        let (unit, t) = (request.unit(), request.transaction());
        let pdu: &[u8] = match request.function() {
            0x03 => &[unit, 0x03, 4, 0, 1, 0, 2],
            _ => &[unit, 0x06, 0, 5, 0, 9],
        };
        Some(TcpAdu::from_unit_pdu(t, pdu).unwrap())
    }
}

/// The client checks an answer's structure against its request as the RTU master does
/// ([Modbus/USS] §3.4.5–§3.4.16): a short read and a wrong echo are errors with the master's
/// STATUS, not values.
#[tokio::test]
async fn an_answer_that_does_not_fit_its_request_is_refused() {
    let server = Server::with_handler("127.0.0.1:0", ServerConfig::default(), Misfits)
        .await
        .unwrap();
    let addr = server.local_addr().unwrap();
    tokio::spawn(server.run());
    let c = Client::connect(addr)
        .await
        .unwrap()
        .with_response_timeout(SHORT);
    let e = c.read_holding_registers(1, 0, 3).await.unwrap_err();
    assert_eq!(
        e.status(),
        Some(si_modbus::status::BYTE_COUNT_TOO_SMALL),
        "{e}"
    );
    let e = c.write_single_register(1, 5, 7).await.unwrap_err();
    assert_eq!(e.status(), Some(si_modbus::status::ECHO_WRONG), "{e}");
}

/// `ClientConfig::retries`: a request that got no answer in time is sent again with a new
/// transaction id, and the answer to the repetition completes the job; without retries the same
/// silence fails the job with 0830H.
#[tokio::test]
async fn a_request_without_answer_is_repeated_as_configured() {
    use si_modbus::tokio::tcp::ClientConfig;
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = listener.local_addr().unwrap();
    let peer = tokio::spawn(async move {
        let (mut s, _) = listener.accept().await.unwrap();
        let mut ids = Vec::new();
        // Ignore the first request; answer the second.
        for answer in [false, true] {
            let mut request = [0u8; 12];
            s.read_exact(&mut request).await.unwrap();
            ids.push(u16::from_be_bytes([request[0], request[1]]));
            if answer {
                let reply = TcpAdu::response(
                    ids[1],
                    request[6],
                    &si_modbus::frame::Response::ReadHoldingRegisters(Registers::Words(&[7])),
                )
                .unwrap();
                s.write_all(reply.as_bytes()).await.unwrap();
            }
        }
        let mut rest = Vec::new();
        let _ = s.read_to_end(&mut rest).await;
        ids
    });
    let config = ClientConfig {
        response_timeout: SHORT.into(),
        retries: 1,
    };
    let c = Client::connect_with(config, addr).await.unwrap();
    assert_eq!(c.read_holding_registers(1, 0, 1).await.unwrap(), [7]);
    drop(c);
    assert_eq!(
        peer.await.unwrap(),
        [1, 2],
        "a new transaction id each time"
    );
}
