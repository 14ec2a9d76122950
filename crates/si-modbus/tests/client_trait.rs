//! One program for every Modbus client: a generic function polls a holding register through
//! the [`Client`] trait over RTU (a `tokio::io::duplex` pipe to our slave), with the engine in a
//! driver task ([`Master`]) and in the caller's future ([`InlineMaster`]), and over Modbus TCP
//! (loopback to our server). Errors read alike on both lines: unit, function, address, and the
//! slave's exception code.
#![cfg(feature = "tokio")]

use si_modbus::frame::Request;
use si_modbus::slave::Tables;
use si_modbus::tokio::{tcp, Client, Error, InlineMaster, Job, Master, Slave};
use si_modbus::{MasterConfig, SlaveConfig};

/// The program written once: register `address` of unit 7, and what reading past the table
/// gives.
async fn poll(client: &impl Client, address: u16) -> Result<u16, Error> {
    Ok(client.read_holding_registers(7, address, 1).await?[0])
}

fn tables() -> Tables {
    let mut t = Tables::new(0, 0, 16, 0);
    t.holding_registers[3] = 0xBEEF;
    t
}

/// An RTU slave with address 7 at the other end of a pipe.
fn rtu_line() -> (tokio::io::DuplexStream, Slave<Tables>) {
    let (a, b) = tokio::io::duplex(1024);
    let config = SlaveConfig {
        address: 7,
        ..SlaveConfig::default()
    };
    (a, Slave::spawn(config, tables(), b).unwrap())
}

/// What every client must show: the value, and exception 02 named with unit, FC and address.
async fn check(client: &impl Client) {
    assert_eq!(poll(client, 3).await.unwrap(), 0xBEEF);
    let e = poll(client, 16).await.unwrap_err();
    assert_eq!(e.exception_code(), Some(2), "{e}");
    assert_eq!(
        e.status(),
        Some(si_modbus::status::EXCEPTION_ILLEGAL_DATA_ADDRESS)
    );
    assert_eq!(
        e.job(),
        Some(Job {
            unit: 7,
            function: 3,
            address: Some(16)
        })
    );
    assert!(
        e.to_string()
            .starts_with("unit 7 FC03 address 16: exception 02 illegal data address"),
        "{e}"
    );
}

#[tokio::test]
async fn one_generic_function_polls_over_rtu_and_tcp() {
    // RTU, engine in a driver task.
    let (port, _slave) = rtu_line();
    let master = Master::spawn(MasterConfig::default(), port).unwrap();
    check(&master).await;
    master.close().await.unwrap();

    // RTU, engine in the caller's future.
    let (port, _slave) = rtu_line();
    let inline = InlineMaster::new(MasterConfig::default(), port).unwrap();
    check(&inline).await;
    inline.close().await.unwrap();

    // Modbus TCP, loopback.
    let server = tcp::Server::bind("127.0.0.1:0", tcp::ServerConfig::default(), tables())
        .await
        .unwrap();
    let addr = server.local_addr().unwrap();
    tokio::spawn(server.run());
    let client = tcp::Client::connect(addr).await.unwrap();
    check(&client).await;
}

/// The inline master runs every function code against our slave as the driver-backed one does,
/// and refuses a job that breaks [Modbus/USS] §3.4.5–§3.4.16 before sending it, naming the job.
#[tokio::test]
async fn the_inline_master_runs_every_function_code() {
    let (port, slave) = rtu_line();
    let m = InlineMaster::new(MasterConfig::default(), port).unwrap();
    m.write_multiple_registers(7, 2, &[0xAAAA, 0x5555])
        .await
        .unwrap();
    assert_eq!(
        m.read_holding_registers(7, 1, 3).await.unwrap(),
        [0, 0xAAAA, 0x5555]
    );
    m.write_single_register(7, 0, 1).await.unwrap();
    assert_eq!(m.diagnostics(7, 0xA537).await.unwrap(), 0xA537);
    let reply = m
        .request(
            7,
            &Request::ReadHoldingRegisters {
                address: 0,
                quantity: 1,
            },
        )
        .await
        .unwrap();
    assert_eq!(reply.response_bytes().map(<[u8]>::len), Some(7));
    let e = m.read_holding_registers(7, 0, 200).await.unwrap_err();
    assert!(matches!(e, Error::Refused { .. }), "{e:?}");
    assert_eq!(e.status(), Some(si_modbus::status::REGISTER_COUNT));
    assert!(e.to_string().starts_with("unit 7 FC03 address 0: "), "{e}");
    assert_eq!(
        slave.with_store(|s| s.holding_registers[3]).await.unwrap(),
        0x5555
    );
}

/// A job whose future is dropped before its answer came (unit 9 does not exist) is run to its
/// end by the next call, which then gets its own answer, not the abandoned one's.
#[tokio::test(start_paused = true)]
async fn an_inline_job_dropped_midway_does_not_hand_its_outcome_to_the_next() {
    let (port, _slave) = rtu_line();
    let config = MasterConfig {
        response_timeout: std::time::Duration::from_millis(100).into(),
        ..MasterConfig::default()
    };
    let m = InlineMaster::new(config, port).unwrap();
    let dropped = tokio::time::timeout(
        std::time::Duration::from_millis(20),
        m.read_holding_registers(9, 0, 1),
    )
    .await;
    assert!(dropped.is_err(), "unit 9 never answers");
    assert_eq!(m.read_holding_registers(7, 3, 1).await.unwrap(), [0xBEEF]);
}

/// A silent unit: the inline master's job fails with 0830H after the Response Time, named.
#[tokio::test(start_paused = true)]
async fn an_inline_job_to_a_silent_unit_times_out_with_0830h() {
    let (port, _slave) = rtu_line();
    let m = InlineMaster::new(MasterConfig::default(), port).unwrap();
    let (result, attempts) = m
        .request_with_attempts(
            9,
            &Request::ReadCoils {
                address: 4,
                quantity: 1,
            },
        )
        .await;
    let e = result.unwrap_err();
    assert_eq!(e.status(), Some(si_modbus::status::RESPONSE_TIMEOUT));
    assert_eq!(e.exception_code(), None);
    assert!(
        e.to_string().starts_with("unit 9 FC01 address 4: 16#0830"),
        "{e}"
    );
    assert_eq!((attempts.sent, attempts.timeouts), (1, 1));
}

/// `close()` returns once the driver task has dropped the port: the other end then sees the
/// pipe closed.
#[tokio::test]
async fn close_returns_once_the_port_is_released() {
    use tokio::io::AsyncReadExt;
    let (a, mut b) = tokio::io::duplex(64);
    let master = Master::spawn(MasterConfig::default(), a).unwrap();
    master.close().await.unwrap();
    let mut buf = [0u8; 1];
    assert_eq!(b.read(&mut buf).await.unwrap(), 0, "the port was released");
}

/// The inline master writes a job's request from where the engine keeps it: a silent unit's
/// retries put the same request on the line again, a longer request before it leaves nothing
/// behind, and the engine still gives a completed job's outcome by its id.
#[tokio::test(start_paused = true)]
async fn an_inline_request_and_its_retries_go_out_as_encoded() {
    use si_modbus::frame::{Adu, Registers};
    use tokio::io::AsyncReadExt;
    let (port, mut far) = tokio::io::duplex(1024);
    let config = MasterConfig {
        retries: 2,
        response_timeout: std::time::Duration::from_millis(100).into(),
        ..MasterConfig::default()
    };
    let m = InlineMaster::new(config, port).unwrap();
    let long = Request::WriteMultipleRegisters {
        address: 0,
        values: Registers::Words(&[1, 2, 3, 4]),
    };
    let short = Request::ReadCoils {
        address: 4,
        quantity: 1,
    };
    let (result, attempts) = m.request_with_attempts(9, &long).await;
    assert_eq!(
        result.unwrap_err().status(),
        Some(si_modbus::status::RESPONSE_TIMEOUT)
    );
    assert_eq!(attempts.sent, 3);
    let (result, attempts) = m.request_with_attempts(9, &short).await;
    assert!(result.is_err());
    assert_eq!(attempts.sent, 3);
    let long = Adu::request(9, &long).unwrap();
    let short = Adu::request(9, &short).unwrap();
    let mut expected = Vec::new();
    for adu in [long; 3].iter().chain(&[short; 3]) {
        expected.extend_from_slice(adu.as_bytes());
    }
    let mut sent = vec![0u8; expected.len()];
    far.read_exact(&mut sent).await.unwrap();
    assert_eq!(sent, expected);

    // A completed job's outcome, by its id, is the completion the caller got, also after a
    // longer answer before it.
    let (port, _slave) = rtu_line();
    let m = InlineMaster::new(MasterConfig::default(), port).unwrap();
    for (address, quantity) in [(3, 4), (0, 1)] {
        let request = Request::ReadHoldingRegisters { address, quantity };
        let c = m.request(7, &request).await.unwrap();
        let kept = m.call(move |engine, _| engine.outcome(c.job())).await;
        assert_eq!(kept, Some(Ok(c)));
        assert_eq!(kept.unwrap().unwrap().response_bytes(), c.response_bytes());
    }
}
