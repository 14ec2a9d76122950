//! FC03 turnaround of `si modbus serve` over a pseudo-terminal pair, beside pymodbus's serial
//! server on the same kind of pair (issue 9, BENCHMARKS.md).
//!
//! A client written here (blocking reads, no async runtime in the measured path) writes
//! `01 03 00 00 00 0A C5 CD` and times until the 25-byte response is complete, a few thousand
//! times; it prints the median and the 99th percentile. The line is 115200 baud, 8N2 (Linux
//! pseudo-terminals refuse pyserial's even parity): a pseudo-terminal moves bytes at once, so
//! what is measured is the server's own turnaround, including the end-of-frame gap it waits
//! for (et200s-si-modbus-uss.md §3.5, Table 3-11: 1 ms at 115200 baud for the module).
//!
//! Needs socat (`apt-get install socat`) and the `si` binary (`cargo build --release -p
//! si-cli`; set `SI_BIN` if it is not under `target/release`); pymodbus is measured when
//! `python3 -c 'import pymodbus, serial'` works. Run:
//!
//! ```text
//! cargo build --release -p si-cli && cargo run --release --example latency [requests]
//! ```

use std::fs::{File, OpenOptions};
use std::io::{BufRead, BufReader, Read, Write};
use std::os::unix::fs::OpenOptionsExt;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

const REQUEST: [u8; 8] = [0x01, 0x03, 0x00, 0x00, 0x00, 0x0A, 0xC5, 0xCD];
const RESPONSE_LEN: usize = 3 + 20 + 2;
/// Linux `O_NONBLOCK` (asm-generic/fcntl.h), to poll the pseudo-terminal without blocking.
const O_NONBLOCK: i32 = 0o4000;

/// A child process killed when dropped.
struct Proc(Child);
impl Drop for Proc {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Two connected pseudo-terminals from socat: (socat, server side, client side).
fn pty_pair() -> (Proc, String, String) {
    let mut child = Command::new("socat")
        .args(["-d", "-d", "pty,raw,echo=0", "pty,raw,echo=0"])
        .stderr(Stdio::piped())
        .stdout(Stdio::null())
        .spawn()
        .expect("socat is needed: apt-get install socat");
    let stderr = child.stderr.take().expect("socat stderr");
    let mut lines = BufReader::new(stderr).lines();
    let mut names = Vec::new();
    while names.len() < 2 {
        let line = lines.next().expect("socat output").expect("socat line");
        if let Some(i) = line.find("/dev/pts/") {
            names.push(line[i..].trim().to_string());
        }
    }
    std::thread::spawn(move || for _ in lines {});
    let client = names.pop().unwrap();
    let server = names.pop().unwrap();
    (Proc(child), server, client)
}

/// One FC03 exchange; `None` if no complete answer came within `limit`.
fn exchange(port: &mut File, limit: Duration) -> Option<Duration> {
    let start = Instant::now();
    port.write_all(&REQUEST).ok()?;
    let mut got = [0u8; 64];
    let mut n = 0;
    while n < RESPONSE_LEN {
        if start.elapsed() > limit {
            return None;
        }
        // Non-blocking reads, polled: a sleep would add its own scheduling delay.
        match port.read(&mut got[n..]) {
            Ok(k) => n += k,
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => std::thread::yield_now(),
            Err(_) => return None,
        }
    }
    let took = start.elapsed();
    (got[0] == 0x01 && got[1] == 0x03 && got[2] == 20).then_some(took)
}

/// Median and p99 of `requests` turnarounds against the server on the client pty.
fn measure(name: &str, client: &str, requests: usize) -> Option<(Duration, Duration)> {
    let mut port = OpenOptions::new()
        .read(true)
        .write(true)
        .custom_flags(O_NONBLOCK)
        .open(client)
        .expect("open the client pty");
    // Wait for the server to answer at all (it may still be opening its port).
    let start = Instant::now();
    while exchange(&mut port, Duration::from_millis(500)).is_none() {
        if start.elapsed() > Duration::from_secs(20) {
            eprintln!("{name}: no answer");
            return None;
        }
        drain(&mut port);
    }
    let mut times = Vec::with_capacity(requests);
    for _ in 0..requests {
        match exchange(&mut port, Duration::from_secs(2)) {
            Some(t) => times.push(t),
            None => drain(&mut port),
        }
        // Keep to the protocol: leave an end-of-frame gap before the next request.
        std::thread::sleep(Duration::from_millis(2));
    }
    times.sort();
    let pick = |q: f64| times[((times.len() - 1) as f64 * q) as usize];
    let (median, p99) = (pick(0.5), pick(0.99));
    println!(
        "{name}: FC03 turnaround median {:.3} ms, p99 {:.3} ms ({} of {requests} answered)",
        median.as_secs_f64() * 1e3,
        p99.as_secs_f64() * 1e3,
        times.len()
    );
    Some((median, p99))
}

/// Throw away whatever is waiting on the port (a late answer after a timeout).
fn drain(port: &mut File) {
    std::thread::sleep(Duration::from_millis(20));
    let mut junk = [0u8; 256];
    while matches!(port.read(&mut junk), Ok(k) if k > 0) {}
}

fn si_binary() -> PathBuf {
    if let Some(p) = std::env::var_os("SI_BIN") {
        return p.into();
    }
    let target =
        std::env::var_os("CARGO_TARGET_DIR").map_or_else(|| "target".into(), PathBuf::from);
    target.join("release").join("si")
}

const PYMODBUS_SERVER: &str = r#"
import sys
from pymodbus.server import StartSerialServer
from pymodbus.datastore import ModbusSequentialDataBlock, ModbusServerContext, ModbusDeviceContext
dev = ModbusDeviceContext(hr=ModbusSequentialDataBlock(1, list(range(100))))
StartSerialServer(context=ModbusServerContext(devices={1: dev}, single=False),
                  port=sys.argv[1], baudrate=115200, parity='N', stopbits=2, bytesize=8)
"#;

fn main() {
    let requests: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(2_000);
    let si = si_binary();
    assert!(
        si.exists(),
        "{} not found: cargo build --release -p si-cli, or set SI_BIN",
        si.display()
    );

    let (_socat, server, client) = pty_pair();
    let _si = Proc(
        Command::new(&si)
            .args(["--port", &server, "--baud", "115200", "--parity", "none"])
            .args(["--stop-bits", "2", "modbus", "serve", "--unit", "1"])
            .stdout(Stdio::null())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("spawn si modbus serve"),
    );
    let ours = measure("si modbus serve", &client, requests);
    drop(_si);

    let have_pymodbus = Command::new("python3")
        .args(["-c", "import pymodbus, serial"])
        .status()
        .is_ok_and(|s| s.success());
    if !have_pymodbus {
        println!("pymodbus: not installed (pip install pymodbus pyserial), not measured");
        return;
    }
    let (_socat2, server, client) = pty_pair();
    let _py = Proc(
        Command::new("python3")
            .args(["-c", PYMODBUS_SERVER, &server])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("spawn the pymodbus server"),
    );
    let theirs = measure("pymodbus StartSerialServer", &client, requests);
    if let (Some((a, _)), Some((b, _))) = (ours, theirs) {
        println!(
            "median ratio pymodbus / si: {:.2}",
            b.as_secs_f64() / a.as_secs_f64()
        );
    }
}
