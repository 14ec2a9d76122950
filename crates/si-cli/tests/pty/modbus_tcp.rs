//! `si modbus read|write|diag --modbus-tcp HOST:PORT`: the master's jobs to a Modbus
//! TCP server on loopback, with the output, counters and STATUS texts of the RTU master.
//!
//! Peers: pymodbus's TCP server (`pip install pymodbus`) for FC03, FC16, FC08, an exception and
//! several units; two servers written here for what pymodbus does not do on demand (never
//! answering, answering with gateway exception 0BH). A missing pymodbus skips its test with a
//! message; with `CI` set it fails instead. Time bounds are generous (seconds) and only bound
//! a wait; no test asserts a wall-clock duration.

use crate::common;

use common::modbus::{have_pymodbus, pymodbus_first_line};
use common::{si, stderr, stdout, text, Kill};
use serde_json::{json, Value};
use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::process::Output;
use std::time::{Duration, Instant};

/// pymodbus TCP server on 127.0.0.1, units 1 and 2 (data blocks start at 1 for wire address
/// 0). It binds port 0 and prints the port the kernel gave it once it listens: no port picked
/// by the test, freed and bound later, which a parallel test could take in between.
const PYMODBUS_TCP_SERVER: &str = r#"
import asyncio, warnings
warnings.filterwarnings("ignore")
from pymodbus.server import ModbusTcpServer
from pymodbus.datastore import ModbusSequentialDataBlock, ModbusServerContext, ModbusDeviceContext
def device():
    return ModbusDeviceContext(
        di=ModbusSequentialDataBlock(1, [False, True] * 50),
        co=ModbusSequentialDataBlock(1, [False] * 100),
        hr=ModbusSequentialDataBlock(1, list(range(100))),
        ir=ModbusSequentialDataBlock(1, [1000 + i for i in range(100)]),
    )
ctx = ModbusServerContext(devices={1: device(), 2: device()}, single=False)
async def main():
    server = ModbusTcpServer(ctx, address=("127.0.0.1", 0))
    await server.serve_forever(background=True)
    print(server.transport.sockets[0].getsockname()[1], flush=True)
    await server.serving
asyncio.run(main())
"#;

/// Starts [`PYMODBUS_TCP_SERVER`]: the process (killed when dropped) and its `127.0.0.1:PORT`.
fn pymodbus_tcp_server() -> (Kill, String) {
    let (server, port) = pymodbus_first_line(PYMODBUS_TCP_SERVER, &[]);
    let port: u16 = port.parse().expect("a port number");
    (server, format!("127.0.0.1:{port}"))
}

/// `si ARGS --modbus-tcp SERVER`, the arguments split at spaces, run to its end.
fn si_to(server: &str, args: &str) -> Output {
    let args: Vec<&str> = args.split_whitespace().collect();
    si(&[&args[..], &["--modbus-tcp", server]].concat())
}

/// [`si_to`] that must succeed: its stdout trimmed.
fn si_ok(server: &str, args: &str) -> String {
    let o = si_to(server, args);
    assert!(o.status.success(), "si {args} failed: {}", text(&o));
    stdout(&o).trim().to_owned()
}

/// `--json` output as its JSON lines.
fn json_lines(o: &Output) -> Vec<Value> {
    stdout(o)
        .lines()
        .map(|l| serde_json::from_str(l).expect("JSON line"))
        .collect()
}

/// Ask `server` for an FC08 echo until it answers (a server just started may not listen
/// yet), at most 15 s.
fn wait_for_echo(server: &str) {
    let start = Instant::now();
    loop {
        let o = si_to(server, "modbus diag --unit 1 --response-timeout-ms 500");
        if o.status.success() {
            assert_eq!(stdout(&o).trim(), "unit 1 diagnostics echo 0xA537"); // FC08
            return;
        }
        assert!(
            start.elapsed() < Duration::from_secs(15),
            "the server never answered: {}",
            text(&o)
        );
        std::thread::sleep(Duration::from_millis(100));
    }
}

#[test]
fn modbus_tcp_read_write_and_exception_against_pymodbus() {
    if !have_pymodbus() {
        return;
    }
    let (_server, server) = pymodbus_tcp_server();
    wait_for_echo(&server);
    let ok = |args| si_ok(&server, args);
    assert_eq!(
        ok("modbus read holding -u 1 --addr 0 --count 5"),
        "unit 1 FC03 0…4: 0 1 2 3 4"
    );
    assert_eq!(
        ok("modbus write registers -u 1 --addr 10 7 0x8 16#9"),
        "unit 1 FC16 wrote 3 from 10"
    );
    assert_eq!(
        ok("modbus read holding -u 1 --addr 10 --count 3 --format hex"),
        "unit 1 FC03 10…12: 0x0007 0x0008 0x0009"
    );
    // Bits come in whole bytes: shown up to the count asked.
    assert_eq!(
        ok("modbus read discrete -u 1 --addr 0 --count 3"),
        "unit 1 FC02 0…2: 0 1 0"
    );
    // Past the 100 registers: exception 02 as the RTU master reports it (0E62H), exit 1.
    let o = si_to(&server, "modbus read holding -u 1 --addr 98 --count 5");
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let why = "16#0E62 exception 02 received: illegal data address";
    assert!(stderr(&o).contains(why), "{}", text(&o));
    // Several units in one poll, each in its own MBAP unit id, with the counters per unit.
    let poll = "--json modbus read input -u 1,2 --addr 0 --count 2 --poll 10 --cycles 2";
    let o = si_to(&server, poll);
    assert!(o.status.success(), "{}", text(&o));
    let lines = json_lines(&o);
    let read: Vec<_> = lines.iter().filter(|l| l.get("values").is_some()).collect();
    let units: Vec<_> = read.iter().map(|l| l["unit"].clone()).collect();
    assert_eq!(units, [1, 2, 1, 2], "{lines:?}");
    assert!(
        read.iter().all(|l| l["values"] == json!([1000, 1001])),
        "{lines:?}"
    );
    let summaries: Vec<_> = lines.iter().filter_map(|l| l.get("summary")).collect();
    assert_eq!(summaries.len(), 2, "{lines:?}");
    for s in summaries {
        assert_eq!((&s["polls"], &s["answers"]), (&json!(2), &json!(2)), "{s}");
    }
}

/// A Modbus TCP server on loopback that answers every request with `reply(request)` (`None`:
/// never answers), for one connection at a time, until the test ends.
fn fake_server(reply: fn(&[u8]) -> Option<Vec<u8>>) -> String {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap().to_string();
    std::thread::spawn(move || {
        for stream in listener.incoming() {
            let Ok(mut stream) = stream else { return };
            std::thread::spawn(move || serve_one(&mut stream, reply));
        }
    });
    addr
}

/// Read MBAP frames from `stream` and answer each with `reply`.
fn serve_one(stream: &mut TcpStream, reply: fn(&[u8]) -> Option<Vec<u8>>) {
    loop {
        let mut header = [0u8; 7];
        if stream.read_exact(&mut header).is_err() {
            return;
        }
        let len = usize::from(u16::from_be_bytes([header[4], header[5]]));
        let mut pdu = vec![0u8; len.saturating_sub(1)];
        if stream.read_exact(&mut pdu).is_err() {
            return;
        }
        let request = [&header[..], &pdu].concat();
        if let Some(answer) = reply(&request) {
            if stream.write_all(&answer).is_err() {
                return;
            }
        }
    }
}

#[test]
fn modbus_tcp_no_answer_is_the_response_timeout() {
    let server = fake_server(|_| None);
    let o = si_to(
        &server,
        "modbus read holding -u 1 --response-timeout-ms 200",
    );
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(stderr(&o).contains("16#0830"), "{}", text(&o));
    // In a poll each timeout is counted, and the poll goes on.
    let poll = "modbus read holding -u 1 --response-timeout-ms 100 --poll 1 --cycles 2";
    let o = si_to(&server, poll);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let out = stdout(&o);
    assert_eq!(
        out.matches("unit 1 FC03 failed: 16#0830").count(),
        2,
        "{out}"
    );
    let counters = "--- unit 1: 2 polls, 0 answers, 0 exceptions, 2 timeouts, 0 other errors";
    assert!(out.contains(counters), "{out}");
    assert!(stderr(&o).contains("2 of 2 polls failed"), "{}", text(&o));
}

#[test]
fn modbus_tcp_gateway_exception_is_counted_without_a_status() {
    // Exception 0BH (gateway target failed to respond): the module has no STATUS for it.
    let server = fake_server(|req| {
        let mut answer = req[..4].to_vec();
        answer.extend_from_slice(&[0, 3, req[6], req[7] | 0x80, 0x0B]);
        Some(answer)
    });
    let o = si_to(
        &server,
        "--json modbus read holding -u 7 --poll 1 --cycles 1",
    );
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let lines = json_lines(&o);
    assert_eq!(lines[0]["failed"], "exception", "{lines:?}");
    assert_eq!(lines[0]["unit"], 7);
    assert_eq!(lines[0]["status"], Value::Null);
    let why = "exception 0BH (gateway target device failed to respond)";
    assert!(
        lines[0]["error"].as_str().unwrap().contains(why),
        "{lines:?}"
    );
    assert_eq!(lines[1]["summary"]["exceptions"], 1, "{lines:?}");
}

#[test]
fn modbus_tcp_conflicts_with_a_serial_line() {
    let job = [
        "modbus",
        "read",
        "holding",
        "-u",
        "1",
        "--modbus-tcp",
        "127.0.0.1:1",
    ];
    for line in [["--port", "/dev/null"], ["--tcp", "127.0.0.1:1"]] {
        // The line before the subcommand (global) and after it.
        for args in [[&line[..], &job].concat(), [&job[..], &line].concat()] {
            let o = si(&args);
            assert_eq!(o.status.code(), Some(2), "{args:?}: {}", text(&o));
            let flag = format!("cannot be used with '{}", line[0]);
            assert!(stderr(&o).contains(&flag), "{args:?}: {}", text(&o));
        }
    }
}

#[test]
fn modbus_tcp_poll_connects_again_after_the_server_drops_the_connection() {
    // Each connection gets one answer (FC03, one register holding the connection's number),
    // then the server closes it, as a server restarting or dropping idle connections would.
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let server = listener.local_addr().unwrap().to_string();
    std::thread::spawn(move || {
        for (n, stream) in listener.incoming().enumerate() {
            let Ok(mut stream) = stream else { return };
            let mut request = [0u8; 12];
            if stream.read_exact(&mut request).is_err() {
                continue;
            }
            let mut answer = request[..4].to_vec();
            answer.extend_from_slice(&[0, 5, request[6], 3, 2, 0, n as u8 + 1]);
            let _ = stream.write_all(&answer);
        }
    });
    let poll = "--json modbus read holding -u 1 --response-timeout-ms 1000 --poll 10 --cycles 4";
    let o = si_to(&server, poll);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let lines = json_lines(&o);
    // Answer on connection 1, lost, answer on connection 2, lost: the run goes on.
    let answers: Vec<_> = lines.iter().filter_map(|l| l.get("values")).collect();
    assert_eq!(answers, [&json!([1]), &json!([2])], "{lines:?}");
    let lost: Vec<_> = lines.iter().filter_map(|l| l["error"].as_str()).collect();
    assert_eq!(lost.len(), 2, "{lines:?}");
    assert!(lost.iter().all(|e| e.contains("lost")), "{lost:?}");
    let summary = lines.iter().find_map(|l| l.get("summary")).unwrap();
    assert_eq!(
        (
            &summary["polls"],
            &summary["answers"],
            &summary["other_errors"]
        ),
        (&json!(4), &json!(2), &json!(2)),
        "{summary}"
    );
}
