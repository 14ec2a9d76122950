//! Modbus through a pacing, chunking relay that behaves like a USB-serial adapter:
//! with default settings, `si modbus read` against pymodbus's serial server, and pymodbus's
//! client against `si modbus serve`, each with a 16 ms / 62-byte adapter in the line. At
//! 19 200 bit/s a 205-byte response reaches the host in about eight packets with 16 ms holes,
//! four times the 4 ms end-of-frame gap ([Modbus/USS] §3.3.5, Table 3-11): the engines must not
//! take a hole for the end of the frame.
//!
//! Peers as in modbus_interop.rs (`pip install pymodbus pyserial`, `apt-get install socat`); a
//! missing peer skips the test with a message, with `CI` set it fails. Each peer run is bounded
//! in time.

use crate::common;

use common::modbus::{self, have_pymodbus, pymodbus_server, served};
use common::{exit_within, have_socat, pty_pair_ignoreeof, stderr, stdout, Kill, PtyPair};
use si_testkit::relay::{usb_relay, Adapter};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// 19 200 bit/s 8N2: the manual's 11-bit character with parity "none" ([Modbus/USS] §3.4.3, §3.5.4,
/// §3.9); pseudo-terminals refuse pyserial's even parity.
const LINE: &[&str] = &["--baud", "19200", "--parity", "none", "--stop-bits", "2"];

/// Two socat pairs joined by the relay: the test's two ends are `.0.a` and `.1.b`.
fn line_with_adapter() -> Option<(PtyPair, PtyPair)> {
    if !(have_socat() && have_pymodbus()) {
        return None;
    }
    let near = pty_pair_ignoreeof()?;
    let far = pty_pair_ignoreeof()?;
    let _relay = usb_relay(&near.b, &far.a, Adapter::ftdi_default(19_200, 11));
    Some((near, far))
}

/// Runs `cmd` to its end, failing the test (and killing it) if it takes longer than `limit`.
/// Its output is small: read once it has exited.
fn bounded(cmd: &mut Command, limit: Duration) -> Output {
    use std::io::Read;
    let mut child = Kill(
        cmd.stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("spawn"),
    );
    let start = Instant::now();
    let status = exit_within(&mut child, start, limit, &format_args!("{cmd:?}"));
    let (mut out, mut err) = (Vec::new(), Vec::new());
    child
        .0
        .stdout
        .take()
        .unwrap()
        .read_to_end(&mut out)
        .unwrap();
    child
        .0
        .stderr
        .take()
        .unwrap()
        .read_to_end(&mut err)
        .unwrap();
    Output {
        status,
        stdout: out,
        stderr: err,
    }
}

const PYMODBUS_SERVER: &str = r#"
import sys, warnings
warnings.filterwarnings("ignore")
from pymodbus.server import StartSerialServer
from pymodbus.datastore import ModbusSequentialDataBlock, ModbusServerContext, ModbusDeviceContext
dev = ModbusDeviceContext(hr=ModbusSequentialDataBlock(1, [1000 + i for i in range(125)]))
ctx = ModbusServerContext(devices={1: dev}, single=False)
print("ready", flush=True)
StartSerialServer(context=ctx, port=sys.argv[1], baudrate=19200, parity='N', stopbits=2, bytesize=8)
"#;

#[test]
fn si_modbus_read_gets_a_long_response_through_a_16ms_adapter_with_default_settings() {
    let Some((near, far)) = line_with_adapter() else {
        return;
    };
    let _server = pymodbus_server(PYMODBUS_SERVER, &far.b);
    modbus::wait_for_echo(&near.a, LINE, &[]);
    for _ in 0..3 {
        let o = bounded(
            common::si_command()
                .args(["--port", &near.a])
                .args(LINE)
                .args(["modbus", "read", "holding", "--unit", "1", "--count", "100"]),
            Duration::from_secs(20),
        );
        assert!(o.status.success(), "si modbus read failed: {}", stderr(&o));
        let values: Vec<String> = (1000..1100).map(|v: u32| v.to_string()).collect();
        assert_eq!(
            stdout(&o).trim(),
            format!("unit 1 FC03 0…99: {}", values.join(" "))
        );
    }
}

const PYMODBUS_CLIENT: &str = r#"
import sys
from pymodbus.client import ModbusSerialClient
c = ModbusSerialClient(port=sys.argv[1], baudrate=19200, parity='N', stopbits=2, bytesize=8, timeout=2, retries=0)
assert c.connect(), "connect"
values = [(7 * i + 3) & 0xFFFF for i in range(100)]
for _ in range(3):
    r = c.write_registers(0, values, device_id=1)          # FC16, a 209-byte request
    assert not r.isError(), r
    r = c.read_holding_registers(0, count=100, device_id=1)  # FC03, a 205-byte response
    assert not r.isError(), r
    assert r.registers == values, r.registers
print("OK")
"#;

#[test]
fn pymodbus_client_against_si_modbus_serve_through_a_16ms_adapter_with_default_settings() {
    let Some((near, far)) = line_with_adapter() else {
        return;
    };
    let (_serve, _, log) = modbus::serve(&far.b, LINE, &[]);
    let o = bounded(
        Command::new("python3").args(["-c", PYMODBUS_CLIENT, &near.a]),
        Duration::from_secs(60),
    );
    assert!(
        o.status.success() && stdout(&o).contains("OK"),
        "pymodbus client failed:\n{}\n{}\nserve:\n{}",
        stdout(&o),
        stderr(&o),
        served(&log)
    );
}

#[test]
fn si_modbus_read_of_125_registers_succeeds_20_times_in_20_behind_an_unannounced_adapter() {
    // A pty announces no latency: each `si` process starts from an unknown port, which the
    // engines take for a 16 ms adapter until reads show otherwise, so the first response
    // (a 255-byte frame in about nine packets) is never judged over at its first hole.
    let Some((near, far)) = line_with_adapter() else {
        return;
    };
    let _server = pymodbus_server(PYMODBUS_SERVER, &far.b);
    modbus::wait_for_echo(&near.a, LINE, &[]);
    let values: Vec<String> = (1000..1125).map(|v: u32| v.to_string()).collect();
    for run in 0..20 {
        let o = bounded(
            common::si_command()
                .args(["--port", &near.a])
                .args(LINE)
                .args(["modbus", "read", "holding", "--unit", "1", "--count", "125"]),
            Duration::from_secs(20),
        );
        assert!(
            o.status.success(),
            "run {run}: si modbus read failed: {}",
            stderr(&o)
        );
        assert_eq!(
            stdout(&o).trim(),
            format!("unit 1 FC03 0…124: {}", values.join(" ")),
            "run {run}"
        );
    }
}
