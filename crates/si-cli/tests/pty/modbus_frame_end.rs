//! `--frame-end length` (host extension: a frame also ends at its predicted length once its CRC
//! checks, si-modbus `FrameEnd::Length`) through the binary, against independent peers over
//! Linux pseudo-terminal pairs: pymodbus and mbpoll (libmodbus) as clients of
//! `si modbus serve --frame-end length`, pymodbus's server and `si modbus serve` as slaves of
//! `si modbus read/write --frame-end length`, and `frame_end` in the `serve --config` file.
//!
//! Peers: `pip install pymodbus pyserial`, `apt-get install mbpoll socat`. A missing peer skips
//! the test with a message; with the environment variable `CI` set it fails instead. The line
//! is 115 200 bit/s 8N2, where the end-of-frame gap is 1 ms (Table 3-11).

use std::process::{Command, Output};

use crate::common;

use common::modbus::{
    self, have_mbpoll, have_pymodbus, pymodbus_client_ok, pymodbus_server, served,
};
use common::{have_socat, pty_pair, si_command, stderr, stdout, test_dir, Kill};
use std::sync::mpsc::Receiver;

const LINE: &[&str] = &["--baud", "115200", "--parity", "none", "--stop-bits", "2"];

fn si(port: &str, args: &[&str]) -> Output {
    modbus::si_on(port, LINE, args)
}

fn serve(port: &str, extra: &[&str]) -> (Kill, String, Receiver<String>) {
    modbus::serve(port, LINE, extra)
}

const PYMODBUS_CLIENT: &str = r#"
import sys
from pymodbus.client import ModbusSerialClient
c = ModbusSerialClient(port=sys.argv[1], baudrate=115200, parity='N', stopbits=2, bytesize=8, timeout=2, retries=0)
assert c.connect(), "connect"
def ok(r):
    assert not r.isError(), r
    return r
for i in range(50):                                                      # back to back
    ok(c.write_registers(0, [i, i + 1, i + 2], device_id=1))            # FC16
    assert ok(c.read_holding_registers(0, count=3, device_id=1)).registers == [i, i + 1, i + 2]
ok(c.write_register(5, 0xBEEF, device_id=1))                             # FC06
ok(c.write_coil(3, True, device_id=1))                                   # FC05
ok(c.write_coils(8, [True, False, True], device_id=1))                   # FC15
bits = ok(c.read_coils(0, count=16, device_id=1)).bits[:16]              # FC01
assert bits == [False]*3 + [True] + [False]*4 + [True, False, True] + [False]*5, bits
assert ok(c.read_input_registers(0, count=2, device_id=1)).registers == [0, 0]          # FC04
r = c.write_register(512, 1, device_id=1)                                # exception 02
assert r.isError() and r.exception_code == 2, r
print("OK")
"#;

#[test]
fn pymodbus_client_against_si_modbus_serve_frame_end_length() {
    if !(have_socat() && have_pymodbus()) {
        return;
    }
    let Some(pair) = pty_pair() else { return };
    let (_serve, first, log) = serve(&pair.a, &["--frame-end", "length"]);
    assert!(first.contains("or at the predicted length"), "{first}");
    pymodbus_client_ok(PYMODBUS_CLIENT, &pair.b);
    let log = served(&log);
    assert_eq!(log.matches("served FC03").count(), 50, "{log}");
    assert!(!log.contains("not answered"), "{log}");
    assert!(log.contains("answered FC06 with exception 02"), "{log}");
}

fn mbpoll(port: &str, args: &[&str], values: &[&str]) -> Output {
    Command::new("mbpoll")
        .args([
            "-m", "rtu", "-b", "115200", "-P", "none", "-s", "2", "-a", "1",
        ])
        .args(["-0", "-1", "-o", "2"])
        .args(args)
        .arg(port)
        .arg("--")
        .args(values)
        .output()
        .expect("run mbpoll")
}

#[test]
fn mbpoll_against_si_modbus_serve_frame_end_length() {
    if !(have_socat() && have_mbpoll()) {
        return;
    }
    let Some(pair) = pty_pair() else { return };
    let (_serve, _, log) = serve(&pair.a, &["--frame-end", "length"]);
    let b = pair.b.as_str();
    let o = mbpoll(b, &["-t", "4", "-r", "0"], &["7", "8", "9"]); // FC16
    assert!(o.status.success(), "{}{}", stdout(&o), stderr(&o));
    let o = mbpoll(b, &["-t", "4", "-r", "0", "-c", "3"], &[]); // FC03
    assert!(o.status.success(), "{}{}", stdout(&o), stderr(&o));
    // mbpoll prints `[ref]: \tvalue` lines.
    let text = stdout(&o);
    let values: Vec<&str> = text
        .lines()
        .filter(|l| l.starts_with('['))
        .filter_map(|l| l.split(':').nth(1))
        .map(str::trim)
        .collect();
    assert_eq!(values, ["7", "8", "9"], "{text}");
    let log = served(&log);
    assert!(
        log.contains("served FC16") && log.contains("served FC03"),
        "{log}"
    );
}

const PYMODBUS_SERVER: &str = r#"
import sys, warnings
warnings.filterwarnings("ignore")
from pymodbus.server import StartSerialServer
from pymodbus.datastore import ModbusSequentialDataBlock, ModbusServerContext, ModbusDeviceContext
# pymodbus 3.x data blocks start at 1 for wire address 0.
dev = ModbusDeviceContext(hr=ModbusSequentialDataBlock(1, list(range(100))))
ctx = ModbusServerContext(devices={1: dev}, single=False)
print("ready", flush=True)
StartSerialServer(context=ctx, port=sys.argv[1], baudrate=115200, parity='N', stopbits=2, bytesize=8)
"#;

#[test]
fn si_modbus_read_and_write_frame_end_length_against_pymodbus_server() {
    if !(have_socat() && have_pymodbus()) {
        return;
    }
    let Some(pair) = pty_pair() else { return };
    let _server = pymodbus_server(PYMODBUS_SERVER, &pair.b);
    let fe = ["--frame-end", "length"];
    modbus::wait_for_echo(&pair.a, LINE, &fe);
    let run = |args: &[&str]| modbus::si_ok(&pair.a, LINE, &[args, &fe].concat());
    assert_eq!(
        run(&[
            "modbus",
            "write",
            "registers",
            "--unit",
            "1",
            "--addr",
            "10",
            "7",
            "0x0102"
        ]),
        "unit 1 FC16 wrote 2 from 10"
    );
    assert_eq!(
        run(&["modbus", "read", "holding", "--unit", "1", "--addr", "9", "--count", "3"]),
        "unit 1 FC03 9…11: 9 7 258"
    );
    // Exception 02 (5 bytes, predicted from the function code | 80H) → 16#0E62.
    let o = si(
        &pair.a,
        &[
            &[
                "modbus", "read", "holding", "--unit", "1", "--addr", "200", "--count", "2",
            ][..],
            &fe,
        ]
        .concat(),
    );
    assert!(!o.status.success());
    assert!(stderr(&o).contains("16#0E62"), "{}", stderr(&o));
}

#[test]
fn si_master_and_si_serve_both_frame_end_length() {
    if !have_socat() {
        return;
    }
    let Some(pair) = pty_pair() else { return };
    let (_serve, _, log) = serve(&pair.a, &["--frame-end", "length"]);
    let fe = ["--frame-end", "length"];
    let o = si(
        &pair.b,
        &[
            &[
                "modbus",
                "write",
                "registers",
                "--unit",
                "1",
                "--addr",
                "0",
                "1",
                "2",
            ][..],
            &fe,
        ]
        .concat(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let o = si(
        &pair.b,
        &[
            &[
                "modbus", "read", "holding", "--unit", "1", "--addr", "0", "--count", "2",
            ][..],
            &fe,
        ]
        .concat(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stdout(&o).trim(), "unit 1 FC03 0…1: 1 2");
    let log = served(&log);
    assert!(
        log.contains("served FC16") && log.contains("served FC03"),
        "{log}"
    );
}

#[test]
fn serve_config_file_frame_end_length_is_used_and_a_wrong_value_is_named() {
    if !have_socat() {
        return;
    }
    let dir = test_dir("si-modbus-frame-end");
    let good = dir.join("length.toml");
    std::fs::write(&good, "frame_end = \"length\"\n").expect("write config");
    let Some(pair) = pty_pair() else { return };
    let (_serve, first, _) = serve(&pair.a, &["--config", good.to_str().expect("utf-8")]);
    assert!(first.contains("or at the predicted length"), "{first}");
    drop(_serve);

    let bad = dir.join("bad.toml");
    std::fs::write(&bad, "frame_end = \"silence\"\n").expect("write config");
    let o = si(
        &pair.a,
        &[
            "modbus",
            "serve",
            "--unit",
            "1",
            "--config",
            bad.to_str().expect("utf-8"),
        ],
    );
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(e.contains("bad.toml") && e.contains("silence"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn frame_end_takes_gap_or_length_only() {
    let o = si_command()
        .args(["--port", "/dev/null", "modbus", "serve", "--unit", "1"])
        .args(["--frame-end", "silence"])
        .output()
        .expect("run si");
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(
        e.contains("--frame-end") && e.contains("gap") && e.contains("length"),
        "{e}"
    );
}
