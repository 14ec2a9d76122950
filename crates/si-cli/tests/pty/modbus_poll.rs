//! `si modbus read` as mbpoll users expect, over pseudo-terminal pairs: a poll
//! that survives a stopped slave and resumes when it returns, with counters at the end;
//! registers shown as f32 in either word order; addresses in hex and Modicon numbering;
//! several units in one poll.
//!
//! Peers: `apt-get install socat`, `pip install pymodbus pyserial` (several units). A missing
//! peer skips the test with a message; with `CI` set it fails instead. Time bounds are generous
//! (seconds): the tests wait for lines, never for a wall-clock moment.

use crate::common;

use common::modbus::{self, have_pymodbus, pymodbus_server};
use common::{pty_pair, pty_pair_ignoreeof, si_command, stderr, stdout, Kill};
use serde_json::Value;
use std::io::{BufRead, BufReader};
use std::process::{ExitStatus, Stdio};
use std::sync::mpsc::Receiver;
use std::time::{Duration, Instant};

const LINE: &[&str] = &["--baud", "19200", "--parity", "none", "--stop-bits", "2"];

/// How long a test waits for a line it expects before failing.
const PATIENCE: Duration = Duration::from_secs(15);

fn si(port: &str, args: &[&str]) -> std::process::Output {
    modbus::si_on(port, LINE, args)
}

/// The next line `want` accepts, skipping others; panics after [`PATIENCE`] with what came.
fn wait_for(lines: &Receiver<String>, what: &str, want: impl Fn(&str) -> bool) -> String {
    let start = Instant::now();
    let mut seen = Vec::new();
    while let Some(left) = PATIENCE.checked_sub(start.elapsed()) {
        match lines.recv_timeout(left) {
            Ok(line) if want(&line) => return line,
            Ok(line) => seen.push(line),
            Err(_) => break,
        }
    }
    panic!("no {what} within {PATIENCE:?}; saw:\n{}", seen.join("\n"));
}

/// `si modbus read holding --unit 1 --count 2` polling every `poll` ms with response time
/// `timeout` ms on `port`, its stdout piped; killed when dropped.
fn spawn_poll(port: &str, timeout: &str, poll: &str) -> Kill {
    Kill(
        si_command()
            .args(["--port", port])
            .args(LINE)
            .args(["modbus", "read", "holding", "--unit", "1", "--count", "2"])
            .args(["--response-timeout-ms", timeout, "--poll", poll])
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("spawn si --poll"),
    )
}

/// Send SIGINT (what Ctrl-C sends) to `child` and wait, at most [`PATIENCE`], for it to end.
fn interrupt(child: &mut Kill) -> ExitStatus {
    let sent = std::process::Command::new("kill")
        .args(["-INT", &child.0.id().to_string()])
        .status()
        .expect("run kill");
    assert!(sent.success());
    let start = Instant::now();
    loop {
        if let Some(status) = child.0.try_wait().expect("wait") {
            return status;
        }
        assert!(start.elapsed() < PATIENCE, "si did not end after SIGINT");
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// A poll stays up while the slave is gone and reads again when it is back; Ctrl-C prints
/// the counters and exits 130.
#[test]
fn poll_survives_a_stopped_slave_and_resumes_when_it_returns() {
    // ignoreeof: the slave's end survives `serve` closing it and a new `serve` opening it.
    let Some(pair) = pty_pair_ignoreeof() else {
        return;
    };
    let (serve, _, _) = modbus::serve(&pair.a, LINE, &[]);
    let mut poll = spawn_poll(&pair.b, "200", "50");
    let out = poll.0.stdout.take().expect("stdout");
    let (tx, lines) = std::sync::mpsc::channel();
    let reader = std::thread::spawn(move || {
        for line in BufReader::new(out).lines().map_while(Result::ok) {
            let _ = tx.send(line.clone());
        }
    });
    let answer = |l: &str| l == "unit 1 FC03 0…1: 0 0";
    wait_for(&lines, "first answer", answer);
    drop(serve);
    wait_for(&lines, "timeout line", |l| {
        l.starts_with("unit 1 FC03 failed: 16#0830")
    });
    let (_serve, _, _) = modbus::serve(&pair.a, LINE, &[]);
    wait_for(&lines, "answer after the slave returned", answer);
    let status = interrupt(&mut poll);
    let summary = wait_for(&lines, "counters", |l| l.starts_with("--- unit 1:"));
    reader.join().expect("reader");
    assert_eq!(status.code(), Some(130), "{summary}");
    // "--- unit 1: P polls, A answers, E exceptions, T timeouts, O other errors"
    let numbers: Vec<u64> = summary
        .split(|c: char| !c.is_ascii_digit())
        .filter_map(|w| w.parse().ok())
        .skip(1)
        .collect();
    let [polls, answers, exceptions, timeouts, others] = numbers[..] else {
        panic!("{summary}")
    };
    assert!(
        answers >= 2 && timeouts >= 1 && exceptions == 0,
        "{summary}"
    );
    assert_eq!(polls, answers + timeouts + others, "{summary}");
}

/// Ctrl-C inside a request (the request on the line, its answer not yet due) ends the run
/// the same way as between polls: counters, exit 130, without waiting for the response time.
#[test]
fn sigint_inside_a_request_prints_the_counters_and_exits_130() {
    let Some(pair) = pty_pair() else { return };
    // Nobody answers on `a`: the test reads the request there to know it is on the line.
    let mut slave_end = std::fs::File::open(&pair.a).expect("open the slave's end");
    let (tx, request) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let mut adu = [0u8; 8];
        let got = std::io::Read::read_exact(&mut slave_end, &mut adu);
        let _ = tx.send(got.map(|()| adu));
    });
    let mut poll = spawn_poll(&pair.b, "60000", "1000");
    let adu = request
        .recv_timeout(PATIENCE)
        .expect("the request reaches the line")
        .expect("read the request");
    assert_eq!(adu, [0x01, 0x03, 0x00, 0x00, 0x00, 0x02, 0xC4, 0x0B]); // FC03 0, 2
    let status = interrupt(&mut poll);
    let mut out = String::new();
    let _ = std::io::Read::read_to_string(&mut poll.0.stdout.take().expect("stdout"), &mut out);
    assert_eq!(status.code(), Some(130), "{out}");
    // The abandoned request is not counted.
    assert_eq!(
        out.trim(),
        "--- unit 1: 0 polls, 0 answers, 0 exceptions, 0 timeouts, 0 other errors"
    );
}

/// π as f32, low word first, read through hex and Modicon addresses (reads and writes);
/// `--timestamps`; `--cycles` ends a poll (read or diag) with counters and exit 0 when every
/// poll was answered; JSON lines carry timestamps.
#[test]
fn f32_word_order_hex_addresses_and_base_1() {
    let Some(pair) = pty_pair() else { return };
    let (_serve, _, _) = modbus::serve(&pair.a, LINE, &[]);
    let run = |args: &[&str]| modbus::si_ok(&pair.b, LINE, args);
    // 0x40490FDB (π) written low word first at 16, 17.
    let write = ["modbus", "write", "registers", "--unit", "1"];
    let written = run(&[&write[..], &["--addr", "0x10", "0x0FDB", "16#4049"]].concat());
    assert_eq!(written, "unit 1 FC16 wrote 2 from 16");
    let read = ["modbus", "read", "holding", "--unit", "1", "--count", "2"];
    let f32_swapped = ["--format", "f32", "--word-order", "swapped"];
    let at = |addr: &[&str], show: &[&str]| run(&[&read[..], addr, show].concat());
    assert_eq!(
        at(&["--addr", "0x10"], &f32_swapped),
        "unit 1 FC03 16…17: 3.1415927"
    );
    assert_eq!(
        at(&["--addr", "17", "--base", "1"], &f32_swapped),
        "unit 1 FC03 17…18: 3.1415927"
    );
    // The same two registers however the address is written.
    for addr in [
        &["--addr", "16"][..],
        &["--addr", "16#10"],
        &["--addr", "17", "--base", "1"],
    ] {
        let line = at(addr, &["--format", "hex"]);
        assert!(line.ends_with(": 0x0FDB 0x4049"), "{addr:?}: {line}");
    }
    // Writes take the base too: Modicon register 21 is PDU address 20.
    assert_eq!(
        run(&["modbus", "write", "register", "--unit", "1", "--addr", "21", "--base", "1", "7"]),
        "unit 1 register 21 = 7 written"
    );
    assert_eq!(
        at(&["--addr", "20"], &["--format", "i16"]),
        "unit 1 FC03 20…21: 7 0"
    );
    // --timestamps: the wall clock first, then the same line.
    let stamped = at(&["--addr", "16", "--timestamps"], &f32_swapped);
    let (ts, line) = stamped.split_once(' ').expect("two parts");
    assert!(
        ts.len() == 24 && ts.ends_with('Z') && ts.as_bytes()[10] == b'T',
        "{stamped}"
    );
    assert_eq!(line, "unit 1 FC03 16…17: 3.1415927");
    // diag polls too (FC08 as a ping).
    let diag = run(&[
        "modbus", "diag", "--unit", "1", "--poll", "10", "--cycles", "2",
    ]);
    assert_eq!(
        diag.lines().collect::<Vec<_>>(),
        [
            "unit 1 diagnostics echo 0xA537",
            "unit 1 diagnostics echo 0xA537",
            "--- unit 1: 2 polls, 2 answers, 0 exceptions, 0 timeouts, 0 other errors",
        ]
    );
    // High word first reads other bits.
    assert_ne!(
        at(&["--addr", "16"], &["--format", "f32"]),
        "unit 1 FC03 16…17: 3.1415927"
    );
    let o = si(
        &pair.b,
        &[
            &["--json"][..],
            &read,
            &["--addr", "16", "--poll", "20", "--cycles", "2"],
            &f32_swapped,
        ]
        .concat(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let lines: Vec<Value> = stdout(&o)
        .lines()
        .map(|l| serde_json::from_str(l).expect("JSON line"))
        .collect();
    assert_eq!(lines.len(), 3, "{}", stdout(&o));
    for l in &lines {
        let ts = l["timestamp"].as_str().expect("timestamp");
        assert!(ts.len() == 24 && ts.ends_with('Z'), "{ts}");
    }
    assert_eq!(lines[0]["values"].to_string(), "[3.1415927]");
    assert_eq!(lines[1]["registers"], serde_json::json!([0x0FDB, 0x4049]));
    assert_eq!(lines[2]["summary"]["polls"], 2);
    assert_eq!(lines[2]["summary"]["answers"], 2);
    assert_eq!(lines[2]["end"], "cycles");
}

const TWO_UNITS: &str = r#"
import sys, warnings
warnings.filterwarnings("ignore")
from pymodbus.server import StartSerialServer
from pymodbus.datastore import ModbusSequentialDataBlock, ModbusServerContext, ModbusDeviceContext
# pymodbus 3.x data blocks start at 1 for wire address 0.
def device(first):
    return ModbusDeviceContext(hr=ModbusSequentialDataBlock(1, [first + i for i in range(20)]))
ctx = ModbusServerContext(devices={1: device(100), 2: device(200)}, single=False)
print("ready", flush=True)
StartSerialServer(context=ctx, port=sys.argv[1], baudrate=19200, parity='N', stopbits=2, bytesize=8)
"#;

/// `--unit 1,2,5`: each line labelled with its unit, the silent unit 5 a failure line that does
/// not stop the others, counters per unit, exit 1 because polls failed.
#[test]
fn several_units_in_one_poll_with_counters_per_unit() {
    if !have_pymodbus() {
        return;
    }
    let Some(pair) = pty_pair() else { return };
    let _server = pymodbus_server(TWO_UNITS, &pair.b);
    modbus::wait_for_echo(&pair.a, LINE, &[]);
    let o = si(
        &pair.a,
        &[
            "modbus",
            "read",
            "holding",
            "--unit",
            "1,2",
            "-u",
            "5",
            "--addr",
            "3",
            "--count",
            "2",
            "--response-timeout-ms",
            "100",
            "--poll",
            "10",
            "--cycles",
            "2",
        ],
    );
    let text = stdout(&o);
    assert_eq!(o.status.code(), Some(1), "{text}{}", stderr(&o));
    assert!(stderr(&o).contains("2 of 6 polls failed"), "{}", stderr(&o));
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 9, "{text}");
    // pymodbus answers an unknown unit with exception 04 (3.16) or not at all (older
    // versions): either way a failure line, counted, and the poll goes on.
    let cycle = [
        "unit 1 FC03 3…4: 103 104",
        "unit 2 FC03 3…4: 203 204",
        "unit 5 FC03 failed: 16#0",
    ];
    for (i, line) in lines.iter().take(6).enumerate() {
        assert!(line.starts_with(cycle[i % 3]), "line {i}: {text}");
    }
    assert_eq!(
        lines[6..8],
        [
            "--- unit 1: 2 polls, 2 answers, 0 exceptions, 0 timeouts, 0 other errors",
            "--- unit 2: 2 polls, 2 answers, 0 exceptions, 0 timeouts, 0 other errors",
        ],
        "{text}"
    );
    assert!(
        [
            "--- unit 5: 2 polls, 0 answers, 2 exceptions, 0 timeouts, 0 other errors",
            "--- unit 5: 2 polls, 0 answers, 0 exceptions, 2 timeouts, 0 other errors",
        ]
        .contains(&lines[8]),
        "{text}"
    );
}
