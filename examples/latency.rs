//! FC03 turnaround of `si modbus serve` over a pseudo-terminal pair, beside pymodbus's serial
//! server on the same kind of pair (BENCHMARKS.md).
//!
//! A client written here (blocking reads, no async runtime in the measured path) writes
//! `01 03 00 00 00 0A C5 CD` and times until the 25-byte response is complete, a few thousand
//! times; it prints the median and the 99th percentile. The line is 115200 baud, 8N2 (Linux
//! pseudo-terminals refuse pyserial's even parity): a pseudo-terminal moves bytes at once, so
//! what is measured is the server's own turnaround.
//!
//! `si modbus serve` is measured twice: with `--frame-end gap`, the module's behaviour, it
//! waits for the end-of-frame gap after the request ([Modbus/USS] §3.3.5, Table 3-11:
//! 1 ms at 115200 baud); with `--frame-end length` (host extension) it answers as soon as the
//! request has its predicted length and a good CRC, as pymodbus and libmodbus do.
//!
//! Needs socat (`apt-get install socat`) and the `si` binary (`cargo build --release -p
//! si-cli`; set `SI_BIN` if it is not under `target/release`); pymodbus is measured when
//! `python3 -c 'import pymodbus, serial'` works. Run:
//!
//! ```text
//! cargo build --release -p si-cli && cargo run --release --example latency [requests]
//! ```
//!
//! With your own target directory, point `SI_BIN` at its `release/si`.

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
fn measure(name: &str, client: &str, requests: usize) -> Option<Row> {
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
    if times.is_empty() {
        eprintln!("{name}: no answers");
        return None;
    }
    times.sort();
    let pick = |q: f64| times[((times.len() - 1) as f64 * q) as usize];
    let row = Row {
        name: name.to_string(),
        median: pick(0.5),
        p99: pick(0.99),
        answered: times.len(),
        requests,
    };
    eprintln!(
        "{name}: median {:.3} ms, p99 {:.3} ms",
        ms(row.median),
        ms(row.p99)
    );
    Some(row)
}

/// One implementation's result.
struct Row {
    name: String,
    median: Duration,
    p99: Duration,
    answered: usize,
    requests: usize,
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

/// `si modbus serve` with this `--frame-end`, measured on a fresh pty pair.
fn measure_si(si: &std::path::Path, frame_end: &str, requests: usize) -> Option<Row> {
    let (_socat, server, client) = pty_pair();
    let _si = Proc(
        Command::new(si)
            .args(["--port", &server, "--baud", "115200", "--parity", "none"])
            .args(["--stop-bits", "2", "modbus", "serve", "--unit", "1"])
            .args(["--frame-end", frame_end])
            .stdout(Stdio::null())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("spawn si modbus serve"),
    );
    measure(
        &format!("si modbus serve --frame-end {frame_end}"),
        &client,
        requests,
    )
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

    let mut rows: Vec<Row> = ["gap", "length"]
        .iter()
        .filter_map(|end| measure_si(&si, end, requests))
        .collect();

    let have_pymodbus = Command::new("python3")
        .args(["-c", "import pymodbus, serial"])
        .status()
        .is_ok_and(|s| s.success());
    if have_pymodbus {
        let (_socat, server, client) = pty_pair();
        let _py = Proc(
            Command::new("python3")
                .args(["-c", PYMODBUS_SERVER, &server])
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .spawn()
                .expect("spawn the pymodbus server"),
        );
        rows.extend(measure("pymodbus StartSerialServer", &client, requests));
    } else {
        println!("pymodbus: not installed (pip install pymodbus pyserial), not measured");
    }

    println!("FC03 turnaround over a pseudo-terminal pair, 115200 baud 8N2");
    println!(
        "{:<36} {:>11} {:>11} {:>10}",
        "server", "median ms", "p99 ms", "answered"
    );
    for r in &rows {
        println!(
            "{:<36} {:>11.3} {:>11.3} {:>5}/{}",
            r.name,
            ms(r.median),
            ms(r.p99),
            r.answered,
            r.requests
        );
    }
    if let Some(py) = rows.iter().find(|r| r.name.starts_with("pymodbus")) {
        for r in rows.iter().filter(|r| r.name.starts_with("si")) {
            println!(
                "median pymodbus / {}: {:.2}",
                r.name,
                py.median.as_secs_f64() / r.median.as_secs_f64()
            );
        }
    }
}
