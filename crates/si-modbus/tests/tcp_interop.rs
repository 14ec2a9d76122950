//! Modbus TCP interop on loopback with independent implementations: pymodbus's TCP client
//! against our [`Server`], our [`Client`] against pymodbus's TCP server, and `mbpoll -m tcp`
//! (libmodbus) against our server; FC 01, 02, 03, 04, 05, 06, 15, 16 and an exception each way.
//!
//! Peers: `pip install pymodbus==3.16.1` (the version CI installs), `apt-get install mbpoll`.
//! A missing peer skips the test with a message; with the environment variable `CI` set it
//! fails instead (as crates/si-cli/tests/common does).
#![cfg(feature = "tokio")]

use std::io::{BufRead, BufReader};
use std::net::SocketAddr;
use std::process::{Command, Output, Stdio};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use si_modbus::slave::Tables;
use si_modbus::tokio::tcp::{Client, Server, ServerConfig};
use si_modbus::tokio::Client as _;

use si_testkit::peers::{have_mbpoll, have_pymodbus, mbpoll_values, Kill};

/// Our server on a free loopback port, on a runtime of its own (the peers run as blocking
/// child processes).
fn our_server() -> (tokio::runtime::Runtime, SocketAddr, Arc<Mutex<Tables>>) {
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .build()
        .unwrap();
    let server = rt
        .block_on(Server::bind(
            "127.0.0.1:0",
            ServerConfig::default(),
            Tables::new(100, 100, 100, 100),
        ))
        .unwrap();
    let addr = server.local_addr().unwrap();
    let store = server.store();
    {
        let mut s = store.lock().unwrap();
        for (i, r) in s.input_registers.iter_mut().enumerate() {
            *r = 1000 + i as u16;
        }
        for (i, d) in s.discrete_inputs.iter_mut().enumerate() {
            *d = i % 2 == 1;
        }
    }
    rt.spawn(server.run());
    (rt, addr, store)
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

const PYMODBUS_CLIENT: &str = r#"
import sys
from pymodbus.client import ModbusTcpClient
c = ModbusTcpClient("127.0.0.1", port=int(sys.argv[1]), timeout=2, retries=0)
assert c.connect(), "connect"
def ok(r):
    assert not r.isError(), r
    return r
ok(c.write_registers(0, [11, 22, 33], device_id=1))                                     # FC16
assert ok(c.read_holding_registers(0, count=3, device_id=1)).registers == [11, 22, 33]  # FC03
ok(c.write_register(5, 0xBEEF, device_id=1))                                             # FC06
assert ok(c.read_holding_registers(5, count=1, device_id=1)).registers == [0xBEEF]
assert ok(c.read_input_registers(2, count=2, device_id=1)).registers == [1002, 1003]    # FC04
ok(c.write_coil(3, True, device_id=1))                                                   # FC05
ok(c.write_coils(8, [True, False, True], device_id=1))                                   # FC15
bits = ok(c.read_coils(0, count=16, device_id=1)).bits[:16]                              # FC01
assert bits == [False]*3 + [True] + [False]*4 + [True, False, True] + [False]*5, bits
assert ok(c.read_discrete_inputs(0, count=4, device_id=1)).bits[:4] == [False, True, False, True]  # FC02
r = c.read_holding_registers(99, count=2, device_id=1)                                   # past the table
assert r.isError() and r.exception_code == 2, r
print("OK")
"#;

#[test]
fn pymodbus_tcp_client_against_our_server() {
    if !have_pymodbus() {
        return;
    }
    let (_rt, addr, store) = our_server();
    let out = Command::new("python3")
        .args(["-c", PYMODBUS_CLIENT, &addr.port().to_string()])
        .output()
        .expect("run python3");
    assert!(
        out.status.success() && text(&out).contains("OK"),
        "pymodbus client failed:\n{}",
        text(&out)
    );
    let s = store.lock().unwrap();
    assert_eq!(&s.holding_registers[..6], [11, 22, 33, 0, 0, 0xBEEF]);
    assert!(s.coils[3] && s.coils[8] && !s.coils[9] && s.coils[10]);
}

/// pymodbus's TCP server on port 0: it prints the port the kernel gave it once it listens, so
/// no port is picked, freed and bound again (a parallel test could take it in between).
const PYMODBUS_SERVER: &str = r#"
import asyncio, warnings
warnings.filterwarnings("ignore")
from pymodbus.server import ModbusTcpServer
from pymodbus.datastore import ModbusSequentialDataBlock, ModbusServerContext, ModbusDeviceContext
# pymodbus 3.x data blocks start at 1 for wire address 0.
dev = ModbusDeviceContext(
    di=ModbusSequentialDataBlock(1, [False, True] * 50),
    co=ModbusSequentialDataBlock(1, [False] * 100),
    hr=ModbusSequentialDataBlock(1, list(range(100))),
    ir=ModbusSequentialDataBlock(1, [1000 + i for i in range(100)]),
)
ctx = ModbusServerContext(devices={1: dev}, single=False)
async def main():
    server = ModbusTcpServer(ctx, address=("127.0.0.1", 0))
    await server.serve_forever(background=True)
    print(server.transport.sockets[0].getsockname()[1], flush=True)
    await server.serving
asyncio.run(main())
"#;

#[test]
fn our_client_against_pymodbus_tcp_server() {
    if !have_pymodbus() {
        return;
    }
    let mut child = Command::new("python3")
        .args(["-c", PYMODBUS_SERVER])
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .expect("spawn pymodbus server");
    let mut port = String::new();
    BufReader::new(child.stdout.take().expect("stdout"))
        .read_line(&mut port)
        .expect("the server prints its port");
    let _server = Kill(child);
    let addr: SocketAddr = format!("127.0.0.1:{}", port.trim()).parse().unwrap();
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    rt.block_on(async {
        // The server prints its port before it listens: connect until it does (at most 15 s).
        let mut c = None;
        for _ in 0..150 {
            if let Ok(client) = Client::connect(addr).await {
                c = Some(client);
                break;
            }
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
        let c = c.expect("pymodbus server listening");
        assert_eq!(
            c.read_holding_registers(1, 0, 5).await.unwrap(),
            [0, 1, 2, 3, 4]
        ); // FC03
        assert_eq!(c.read_input_registers(1, 2, 2).await.unwrap(), [1002, 1003]); // FC04
        assert_eq!(
            c.read_discrete_inputs(1, 0, 4).await.unwrap(), // FC02
            [false, true, false, true]
        );
        c.write_multiple_registers(1, 10, &[7, 0x0102])
            .await
            .unwrap(); // FC16
        c.write_single_register(1, 12, 99).await.unwrap(); // FC06
        assert_eq!(
            c.read_holding_registers(1, 10, 3).await.unwrap(),
            [7, 258, 99]
        );
        c.write_single_coil(1, 4, true).await.unwrap(); // FC05
        c.write_multiple_coils(1, 6, &[true, false, true])
            .await
            .unwrap(); // FC15
        assert_eq!(
            c.read_coils(1, 0, 10).await.unwrap(), // FC01
            [false, false, false, false, true, false, true, false, true, false]
        );
        // Beyond the server's 100 registers: exception 02, passed as it is.
        let e = c.read_holding_registers(1, 200, 2).await.unwrap_err();
        assert_eq!(e.exception_code(), Some(2), "{e:?}");
    });
}

/// `mbpoll -m tcp` once (`-1`), addresses from 0 (`-0`), unit 1, 2 s timeout.
fn mbpoll(addr: SocketAddr, args: &[&str], values: &[&str]) -> Output {
    let port = addr.port().to_string();
    let mut cmd = Command::new("mbpoll");
    cmd.args(["-m", "tcp", "-p", &port, "-a", "1", "-0", "-1", "-o", "2"])
        .args(args)
        .arg(addr.ip().to_string());
    if !values.is_empty() {
        cmd.arg("--").args(values);
    }
    cmd.output().expect("run mbpoll")
}

#[test]
fn mbpoll_tcp_against_our_server() {
    if !have_mbpoll() {
        return;
    }
    let (_rt, addr, store) = our_server();
    let ok = |o: Output| assert!(o.status.success(), "{}", text(&o));
    ok(mbpoll(addr, &["-t", "4", "-r", "0"], &["7", "8", "9"])); // FC16
    ok(mbpoll(addr, &["-t", "4", "-r", "3"], &["4660"])); // FC06
    assert_eq!(
        mbpoll_values(&mbpoll(addr, &["-t", "4", "-r", "0", "-c", "4"], &[])), // FC03
        ["7", "8", "9", "4660"]
    );
    assert_eq!(
        mbpoll_values(&mbpoll(addr, &["-t", "3", "-r", "1", "-c", "2"], &[])), // FC04
        ["1001", "1002"]
    );
    ok(mbpoll(addr, &["-t", "0", "-r", "3"], &["1"])); // FC05
    ok(mbpoll(addr, &["-t", "0", "-r", "8"], &["1", "0", "1"])); // FC15
    assert_eq!(
        mbpoll_values(&mbpoll(addr, &["-t", "0", "-r", "0", "-c", "12"], &[])), // FC01
        ["0", "0", "0", "1", "0", "0", "0", "0", "1", "0", "1", "0"]
    );
    assert_eq!(
        mbpoll_values(&mbpoll(addr, &["-t", "1", "-r", "0", "-c", "4"], &[])), // FC02
        ["0", "1", "0", "1"]
    );
    // Register 100 is past the table: exception 02.
    let o = mbpoll(addr, &["-t", "4", "-r", "100"], &["1"]);
    assert!(text(&o).contains("Illegal data address"), "{}", text(&o));
    let s = store.lock().unwrap();
    assert_eq!(&s.holding_registers[..4], [7, 8, 9, 4660]);
}
