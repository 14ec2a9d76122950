//! The library's async RTU master on a pseudo-terminal against an independent slave:
//! pymodbus's serial server on the other end of a socat pty pair (19200 8N2). FC03, FC06 and
//! FC16 each way, and an exception for an address pymodbus does not have.
//!
//! Peers: `apt-get install socat`, `pip install pymodbus==3.16.1 pyserial==3.5` (what CI
//! installs). A missing peer skips the test with a message; with `CI` set it fails instead.
#![cfg(all(feature = "tokio", target_os = "linux"))]

use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};

use si_core::port::{self, PortOptions};
use si_core::{Parity, SerialSettings};
use si_modbus::tokio::{Client as _, Error, Master};
use si_modbus::MasterConfig;
use si_testkit::peers::{have_pymodbus_serial, Kill};
use si_testkit::pty::pty_pair;

/// pymodbus's RTU slave, unit 1: holding registers 0 … 99 hold their own address (its data
/// blocks start at 1 for wire address 0).
const SLAVE: &str = r#"
import sys, warnings
warnings.filterwarnings("ignore")
from pymodbus.server import StartSerialServer
from pymodbus.datastore import ModbusSequentialDataBlock, ModbusServerContext, ModbusDeviceContext
dev = ModbusDeviceContext(hr=ModbusSequentialDataBlock(1, list(range(100))))
ctx = ModbusServerContext(devices={1: dev}, single=False)
print("ready", flush=True)
StartSerialServer(context=ctx, port=sys.argv[1], baudrate=19200, parity="N", stopbits=2, bytesize=8)
"#;

fn slave(port: &str) -> Kill {
    let mut child = Kill(
        Command::new("python3")
            .args(["-c", SLAVE, port])
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("start the pymodbus slave"),
    );
    let out = child.0.stdout.take().expect("its stdout");
    let mut ready = String::new();
    BufReader::new(out).read_line(&mut ready).expect("a line");
    assert_eq!(ready.trim(), "ready", "the pymodbus slave did not start");
    child
}

#[tokio::test]
async fn the_rtu_master_reads_and_writes_a_pymodbus_slave_on_a_pty() {
    if !have_pymodbus_serial() {
        return;
    }
    let Some(pair) = pty_pair() else { return };
    let _slave = slave(&pair.b);
    let mut config = MasterConfig {
        response_timeout: si_core::Duration::from_millis(1_000),
        retries: 2,
        ..MasterConfig::default()
    };
    config.line.settings = SerialSettings::new(19_200, 8, Parity::None, 2).unwrap();
    let line = port::open(&pair.a, &config.line.settings, &PortOptions::default()).unwrap();
    let master = Master::spawn(config, line).unwrap();
    // pymodbus needs a moment after "ready" before it reads the port; the retries cover it.
    assert_eq!(
        master.read_holding_registers(1, 0, 4).await.unwrap(),
        [0, 1, 2, 3]
    );
    master.write_single_register(1, 2, 0x1234).await.unwrap();
    master
        .write_multiple_registers(1, 10, &[7, 8, 9])
        .await
        .unwrap();
    assert_eq!(
        master.read_holding_registers(1, 0, 4).await.unwrap(),
        [0, 1, 0x1234, 3]
    );
    assert_eq!(
        master.read_holding_registers(1, 10, 3).await.unwrap(),
        [7, 8, 9]
    );
    // Beyond the 100 registers: pymodbus answers exception 02 (illegal data address).
    let e = master.read_holding_registers(1, 200, 1).await.unwrap_err();
    assert!(matches!(e, Error::Failed { .. }), "{e:?}");
    assert_eq!(
        e.status().map(|s| s.code()),
        Some(si_modbus::status::EXCEPTION_ILLEGAL_DATA_ADDRESS.code()),
        "{e:?}"
    );
}
