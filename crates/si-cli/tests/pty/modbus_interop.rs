//! Modbus RTU interop with independent implementations over Linux pseudo-terminal pairs
//! ([Modbus/USS] §3.3–§3.5): pymodbus as client against `si modbus serve` and as
//! server against `si modbus read/write`, and mbpoll (libmodbus) against `si modbus serve`,
//! covering FC 01–06, 15, 16 and an exception.
//!
//! Peers: `pip install pymodbus pyserial`, `apt-get install mbpoll socat`. A missing peer skips
//! the test with a message; with the environment variable `CI` set it fails instead.
//!
//! The line is 19200 baud, 8 data bits, no parity, 2 stop bits: the manual's 11-bit frame with
//! parity "none" ([Modbus/USS] §3.4.3, §3.5.4, §3.9), and Linux pseudo-terminals refuse pyserial's
//! even-parity setting.

use std::io::Write;
use std::process::{Command, Output, Stdio};
use std::time::Duration;

use crate::common;

use common::modbus::{
    self, have_mbpoll, have_pymodbus, pymodbus_client_ok, pymodbus_server, served,
};
use common::{have_socat, pty_pair, si_command, stderr, stdout, test_dir, Kill};
use si_testkit::peers::mbpoll_values;
use std::sync::mpsc::Receiver;

const LINE: &[&str] = &["--baud", "19200", "--parity", "none", "--stop-bits", "2"];

fn si(port: &str, args: &[&str]) -> Output {
    modbus::si_on(port, LINE, args)
}

/// `si modbus serve --unit 1 <extra>` on `port`, with its stdout collected until it is killed.
fn serve(port: &str, extra: &[&str]) -> (Kill, Receiver<String>) {
    let (kill, _, log) = modbus::serve(port, LINE, extra);
    (kill, log)
}

const PYMODBUS_CLIENT: &str = r#"
import sys
from pymodbus.client import ModbusSerialClient
c = ModbusSerialClient(port=sys.argv[1], baudrate=19200, parity='N', stopbits=2, bytesize=8, timeout=2, retries=0)
assert c.connect(), "connect"
def ok(r):
    assert not r.isError(), r
    return r
ok(c.write_registers(0, [11, 22, 33], device_id=1))                      # FC16 -> DB6.DBW0..4
assert ok(c.read_holding_registers(0, count=3, device_id=1)).registers == [11, 22, 33]  # FC03
ok(c.write_register(5, 0xBEEF, device_id=1))                             # FC06
assert ok(c.read_holding_registers(5, count=1, device_id=1)).registers == [0xBEEF]
assert ok(c.read_input_registers(0, count=2, device_id=1)).registers == [0, 0]          # FC04 (DB2)
ok(c.write_coil(3, True, device_id=1))                                   # FC05 -> M500.3
ok(c.write_coils(8, [True, False, True], device_id=1))                   # FC15 -> M501.0..2
bits = ok(c.read_coils(0, count=16, device_id=1)).bits[:16]              # FC01
assert bits == [False]*3 + [True] + [False]*4 + [True, False, True] + [False]*5, bits
assert ok(c.read_discrete_inputs(8160, count=8, device_id=1)).bits[:8] == [False]*8     # FC02 (M800)
r = c.write_register(512, 1, device_id=1)                                # DB7 > DB_Max: exception 02
assert r.isError() and r.exception_code == 2, r
r = c.read_holding_registers(0, count=3, device_id=1)
assert r.registers == [11, 22, 33], r
print("OK")
"#;

#[test]
fn pymodbus_client_against_si_modbus_serve() {
    if !(have_socat() && have_pymodbus()) {
        return;
    }
    let Some(pair) = pty_pair() else { return };
    let (_serve, log) = serve(&pair.a, &[]);
    pymodbus_client_ok(PYMODBUS_CLIENT, &pair.b);
    let log = served(&log);
    for fc in [
        "FC16", "FC03", "FC06", "FC04", "FC05", "FC15", "FC01", "FC02",
    ] {
        assert!(
            log.contains(&format!("served {fc}")),
            "{fc} missing in:\n{log}"
        );
    }
    assert!(
        log.contains("answered FC06 with exception 02"),
        "exception missing in:\n{log}"
    );
}

#[test]
fn pymodbus_server_against_si_modbus_read_and_write() {
    if !(have_socat() && have_pymodbus()) {
        return;
    }
    let Some(pair) = pty_pair() else { return };
    let _server = pymodbus_server(modbus::RTU_SERVER_19200, &pair.b);
    modbus::wait_for_echo(&pair.a, LINE, &[]);
    let run = |args: &[&str]| modbus::si_ok(&pair.a, LINE, args);
    let a = "--addr";
    assert_eq!(
        run(&["modbus", "read", "holding", "--unit", "1", a, "0", "--count", "5"]),
        "unit 1 FC03 0…4: 0 1 2 3 4"
    );
    assert_eq!(
        run(&["modbus", "read", "input", "--unit", "1", a, "2", "--count", "2"]),
        "unit 1 FC04 2…3: 1002 1003"
    );
    assert_eq!(
        run(&["modbus", "read", "discrete", "--unit", "1", a, "0", "--count", "4"]),
        "unit 1 FC02 0…3: 0 1 0 1"
    );
    assert_eq!(
        run(&[
            "modbus",
            "write",
            "registers",
            "--unit",
            "1",
            a,
            "10",
            "7",
            "0x0102"
        ]),
        "unit 1 FC16 wrote 2 from 10"
    );
    assert_eq!(
        run(&["modbus", "write", "register", "--unit", "1", a, "12", "99"]),
        "unit 1 register 12 = 99 written"
    );
    assert_eq!(
        run(&["modbus", "read", "holding", "--unit", "1", a, "10", "--count", "3"]),
        "unit 1 FC03 10…12: 7 258 99"
    );
    assert_eq!(
        run(&["modbus", "write", "coil", "--unit", "1", a, "4", "on"]),
        "unit 1 coil 4 = ON written"
    );
    assert_eq!(
        run(&["modbus", "write", "coils", "--unit", "1", a, "6", "1", "0", "1"]),
        "unit 1 FC15 wrote 3 from 6"
    );
    assert_eq!(
        run(&["modbus", "read", "coils", "--unit", "1", a, "0", "--count", "10"]),
        "unit 1 FC01 0…9: 0 0 0 0 1 0 1 0 1 0"
    );
    // --poll repeats the read until interrupted.
    let mut poll = si_command()
        .args(["--port", &pair.a])
        .args(LINE)
        .args([
            "modbus", "read", "input", "--unit", "1", a, "0", "--count", "1", "--poll", "100",
        ])
        .stdout(Stdio::piped())
        .spawn()
        .expect("spawn si --poll");
    std::thread::sleep(Duration::from_millis(800));
    let _ = poll.kill();
    let polled = stdout(&poll.wait_with_output().expect("poll output"));
    let lines: Vec<&str> = polled.lines().collect();
    assert!(lines.len() >= 3, "{polled}");
    assert!(
        lines.iter().all(|l| *l == "unit 1 FC04 0…0: 1000"),
        "{polled}"
    );
    // Beyond the server's 100 registers: exception 02 → 16#0E62, exit code non-zero.
    let o = si(
        &pair.a,
        &[
            "modbus", "read", "holding", "--unit", "1", a, "200", "--count", "2",
        ],
    );
    assert!(!o.status.success());
    assert!(stderr(&o).contains("16#0E62"), "{}", stderr(&o));
}

fn mbpoll(port: &str, args: &[&str]) -> Output {
    Command::new("mbpoll")
        .args([
            "-m", "rtu", "-a", "1", "-b", "19200", "-P", "none", "-s", "2", "-0", "-1", "-o", "2",
        ])
        .args(args)
        .arg(port)
        .output()
        .expect("run mbpoll")
}

fn mbpoll_write(port: &str, args: &[&str], values: &[&str]) -> Output {
    Command::new("mbpoll")
        .args([
            "-m", "rtu", "-a", "1", "-b", "19200", "-P", "none", "-s", "2", "-0", "-1", "-o", "2",
        ])
        .args(args)
        .arg(port)
        .arg("--")
        .args(values)
        .output()
        .expect("run mbpoll")
}

#[test]
fn mbpoll_against_si_modbus_serve() {
    if !(have_socat() && have_mbpoll()) {
        return;
    }
    let Some(pair) = pty_pair() else { return };
    let (_serve, log) = serve(&pair.a, &[]);
    let b = pair.b.as_str();
    let o = mbpoll_write(b, &["-t", "4", "-r", "0"], &["7", "8", "9"]); // FC16
    assert!(o.status.success(), "{}", stderr(&o));
    let o = mbpoll_write(b, &["-t", "4", "-r", "3"], &["4660"]); // FC06
    assert!(o.status.success(), "{}", stderr(&o));
    let o = mbpoll(b, &["-t", "4", "-r", "0", "-c", "4"]); // FC03
    assert_eq!(mbpoll_values(&o), ["7", "8", "9", "4660"]);
    let o = mbpoll(b, &["-t", "3", "-r", "0", "-c", "2"]); // FC04
    assert_eq!(mbpoll_values(&o), ["0", "0"]);
    let o = mbpoll_write(b, &["-t", "0", "-r", "3"], &["1"]); // FC05
    assert!(o.status.success(), "{}", stderr(&o));
    let o = mbpoll_write(b, &["-t", "0", "-r", "8"], &["1", "0", "1"]); // FC15
    assert!(o.status.success(), "{}", stderr(&o));
    let o = mbpoll(b, &["-t", "0", "-r", "0", "-c", "12"]); // FC01
    assert_eq!(
        mbpoll_values(&o),
        ["0", "0", "0", "1", "0", "0", "0", "0", "1", "0", "1", "0"]
    );
    let o = mbpoll(b, &["-t", "1", "-r", "8160", "-c", "4"]); // FC02
    assert_eq!(mbpoll_values(&o), ["0", "0", "0", "0"]);
    // R = 512 → DB7, above DB_Max 6: exception 02.
    let o = mbpoll_write(b, &["-t", "4", "-r", "512"], &["1"]);
    assert!(
        stdout(&o).contains("Illegal data address") || stderr(&o).contains("Illegal data address"),
        "{}{}",
        stdout(&o),
        stderr(&o)
    );
    let log = served(&log);
    for fc in [
        "FC16", "FC06", "FC03", "FC04", "FC05", "FC15", "FC01", "FC02",
    ] {
        assert!(
            log.contains(&format!("served {fc}")),
            "{fc} missing in:\n{log}"
        );
    }
    assert!(log.contains("answered FC06 with exception 02"), "{log}");
    let _ = std::io::stdout().flush();
}

const CONFIG: &str = r#"
mode = "interference-suppression"
char_delay_multiplier = 2

[conversion]
db_fc03_06_16 = 3
db_fc04 = 3
db_min = 3
db_max = 3

[memory]
dbs = [{ number = 3, length = 64 }]
"#;

const PYMODBUS_CONFIGURED: &str = r#"
import sys
from pymodbus.client import ModbusSerialClient
c = ModbusSerialClient(port=sys.argv[1], baudrate=19200, parity='N', stopbits=2, bytesize=8, timeout=2, retries=0)
assert c.connect(), "connect"
r = c.write_registers(30, [0x1111, 0x2222], device_id=1); assert not r.isError(), r   # DB3.DBW60..62
r = c.read_input_registers(30, count=2, device_id=1); assert r.registers == [0x1111, 0x2222], r  # FC04 base DB3 too
r = c.read_holding_registers(31, count=2, device_id=1)                           # DBW64: past the 64-byte DB
assert r.isError() and r.exception_code == 4, r
print("OK")
"#;

/// `serve --config`: the TOML file's conversion DB and memory sizes are the ones served.
#[test]
fn pymodbus_client_against_si_modbus_serve_with_a_config_file() {
    if !(have_socat() && have_pymodbus()) {
        return;
    }
    let dir = test_dir("si-modbus-interop");
    let path = dir.join("serve.toml");
    std::fs::write(&path, CONFIG).expect("write config");
    let Some(pair) = pty_pair() else { return };
    let (_serve, log) = serve(&pair.a, &["--config", path.to_str().expect("utf-8 path")]);
    pymodbus_client_ok(PYMODBUS_CONFIGURED, &pair.b);
    let log = served(&log);
    assert!(
        log.contains("answered FC03 with exception 04 slave device failure: S_MODB ERROR_NR 21"),
        "{log}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
