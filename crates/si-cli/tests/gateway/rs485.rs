//! A gateway line's RS-485 direction control (as mbusd's `-t`, `-r`, `-y`, `-Y`):
//! the `rs485` names and `rs485_file` are checked before anything opens, naming the key and
//! the value; and a Modbus TCP request forwarded to `si modbus serve` on a pty pair (socat; a
//! skip with a message when missing, a failure with `CI` set) writes '1' into the line's
//! `rs485_file` before the RTU request and '0' after it (a FIFO, read in order by the test).

use super::harness::{launch, read_holding, stop, Mbap};
use crate::common::fifo::{drain, mkfifo};
use crate::common::{modbus, si, stderr, test_dir};
use std::time::Duration;

/// `si gateway --config` with one line on /dev/null carrying `keys`: its stderr (it must fail).
fn refused(keys: &str) -> String {
    let path = test_dir("gateway-rs485").join("gw.toml");
    std::fs::write(
        &path,
        format!(
            "listen = \"127.0.0.1:0\"\n[[line]]\nname = \"bus\"\ndevice = \"/dev/null\"\n\
             units = \"1\"\n{keys}\n"
        ),
    )
    .unwrap();
    let o = si(&["gateway", "--config", path.to_str().unwrap()]);
    assert!(!o.status.success(), "{keys}");
    stderr(&o)
}

#[test]
fn an_unknown_rs485_mode_is_refused_with_the_names() {
    let e = refused("rs485 = \"sideways\"");
    assert!(
        e.contains(
            "line 1 (bus): rs485 = \"sideways\" is out of range: \
             kernel, rts, rts-inverted, sysfs, sysfs-inverted"
        ),
        "{e}"
    );
}

#[test]
fn a_sysfs_mode_needs_rs485_file_and_only_it_takes_one() {
    let e = refused("rs485 = \"sysfs-inverted\"");
    assert!(
        e.contains("line 1 (bus): rs485_file = missing is out of range: a file path, needed with rs485 = \"sysfs\""),
        "{e}"
    );
    let e = refused("rs485 = \"rts-inverted\"\nrs485_file = \"/tmp/x\"");
    assert!(
        e.contains(
            "line 1 (bus): rs485_file = \"/tmp/x\" is out of range: only with rs485 = \"sysfs\""
        ),
        "{e}"
    );
}

#[test]
fn a_forwarded_request_writes_1_before_and_0_after_into_the_line_file() {
    let Some((pair, _serve, _log, _)) = modbus::serving_8n1() else {
        return;
    };
    let fifo = test_dir("gateway-rs485-fifo").join("value");
    mkfifo(&fifo);
    let levels = drain(&fifo);
    let toml = format!(
        "listen = \"127.0.0.1:0\"\n[[line]]\nname = \"bus\"\ndevice = \"{}\"\nunits = \"1\"\n\
         baud = 19200\nparity = \"none\"\nrs485 = \"sysfs\"\nrs485_file = \"{}\"\n",
        pair.b,
        fifo.display()
    );
    let (addr, log, gateway) = launch(&toml, "rs485-fifo");
    let mut client = Mbap::connect(&addr);
    client.send(7, 1, &read_holding(0, 2));
    let (tid, unit, pdu) = client.recv();
    assert_eq!((tid, unit, pdu), (7, 1, vec![0x03, 4, 0, 0, 0, 0]));
    stop(&gateway, &log);
    drop(gateway);
    let levels = levels
        .recv_timeout(Duration::from_secs(10))
        .expect("the FIFO is closed when the gateway ends");
    // Receive when the line opens, transmit for the request, receive after it.
    assert_eq!(levels, "010");
}
