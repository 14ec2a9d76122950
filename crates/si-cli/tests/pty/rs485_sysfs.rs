//! RS-485 direction control through a sysfs-style file (mbusd's `-y`/`-Y`): a
//! Modbus request from `si modbus read --rs485 sysfs --rs485-file F` to `si modbus serve` on a
//! pseudo-terminal pair (socat; a skip with a message when it is missing, a failure with `CI`
//! set) writes '1' before the request and '0' after it. A FIFO read by the test gives the exact
//! sequence; a regular file (what a GPIO's `value` is) ends with the receive level, and the
//! `--record` trace shows the switch to transmit before the request. A pty has no modem
//! lines, so this is also the proof that the file kinds do not touch RTS.

use crate::common;

use common::fifo::{drain, mkfifo};
use common::modbus;
use common::{si_command, stderr, stdout, test_dir, text};
use std::time::Duration;

const READ: &[&str] = &[
    "modbus", "read", "holding", "--unit", "1", "--addr", "0", "--count", "2",
];

#[test]
fn a_request_writes_1_before_and_0_after_into_the_sysfs_file() {
    let Some((pair, _serve, _log, line)) = modbus::serving_8n1() else {
        return;
    };
    for (mode, expected) in [("sysfs", "010"), ("sysfs-inverted", "101")] {
        let fifo = test_dir("si-rs485-sysfs").join(format!("{mode}.fifo"));
        mkfifo(&fifo);
        let levels = drain(&fifo);
        let o = si_command()
            .args(["--port", &pair.b])
            .args(line)
            .args(["--rs485", mode, "--rs485-file"])
            .arg(&fifo)
            .args(READ)
            .output()
            .expect("run si");
        assert!(o.status.success(), "{mode}: {}", stderr(&o));
        // A fresh `si modbus serve` holds 0 in each register: the whole answer came back.
        assert_eq!(stdout(&o).trim(), "unit 1 FC03 0…1: 0 0", "{mode}");
        let levels = levels
            .recv_timeout(Duration::from_secs(10))
            .expect("the FIFO is closed when si ends");
        // Receive when the port opens, transmit for the request, receive after it.
        assert_eq!(levels, expected, "{mode}");
    }
}

#[test]
fn a_profile_names_the_file_and_the_trace_shows_the_switches() {
    let Some((pair, _serve, _log, _)) = modbus::serving_8n1() else {
        return;
    };
    let dir = test_dir("si-rs485-sysfs-file");
    let value = dir.join("value");
    std::fs::write(&value, "1").unwrap();
    let config = dir.join("config.toml");
    std::fs::write(
        &config,
        format!(
            "[profile.bus]\nport = \"{}\"\nbaud = 19200\nparity = \"none\"\n\
             rs485 = \"sysfs\"\nrs485_file = \"{}\"\n",
            pair.b,
            value.display()
        ),
    )
    .unwrap();
    let trace = dir.join("read.jsonl");
    let o = si_command()
        .env("SI_CONFIG", &config)
        .args(["--profile", "bus", "--record"])
        .arg(&trace)
        .args(READ)
        .output()
        .expect("run si");
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read_to_string(&value).unwrap(), "0");
    // In the trace, "rts" is the direction whatever the output: on to transmit.
    let kinds: Vec<String> = std::fs::read_to_string(&trace)
        .unwrap()
        .lines()
        .skip(1)
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .filter_map(|e| match e["kind"].as_str()? {
            "signals" => Some(format!("rts {}", e["update"]["rts"])),
            "tx" => Some("tx".to_owned()),
            _ => None,
        })
        .collect();
    // On a pty the answer can come before the request's computed wire time has passed: the
    // command may end before the driver's "off after tx-done", and the port switches to
    // receive as it closes (the file's "0" above), which the trace does not see.
    assert_eq!(kinds[..2], ["rts true", "tx"], "{kinds:?}");
    assert!(kinds[2..].iter().all(|k| k == "rts false"), "{kinds:?}");
}

#[test]
fn a_sysfs_mode_needs_its_file() {
    let o = si_command()
        .args(["--port", "/dev/null", "--rs485", "sysfs"])
        .args(READ)
        .output()
        .expect("run si");
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("--rs485-file"), "{}", text(&o));
    // And the file is for the sysfs modes only.
    let o = si_command()
        .args(["--port", "/dev/null", "--rs485", "rts-inverted"])
        .args(["--rs485-file", "/dev/null"])
        .args(READ)
        .output()
        .expect("run si");
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains("--rs485-file is for --rs485 sysfs or sysfs-inverted"),
        "{}",
        text(&o)
    );
}

#[test]
fn a_file_that_cannot_be_opened_is_named() {
    let Some(pair) = common::pty_pair() else {
        return;
    };
    let missing = test_dir("si-rs485-missing").join("gpio17/value");
    let o = si_command()
        .args([
            "--port",
            &pair.a,
            "--rs485",
            "sysfs-inverted",
            "--rs485-file",
        ])
        .arg(&missing)
        .args(READ)
        .output()
        .expect("run si");
    assert!(!o.status.success());
    assert!(
        text(&o).contains(&format!("cannot open {}", missing.display())),
        "{}",
        text(&o)
    );
}

#[test]
fn rs485_over_tcp_stays_refused_for_every_mode() {
    for mode in ["rts-inverted", "sysfs"] {
        let o = si_command()
            .args(["--tcp", "127.0.0.1:9", "--rs485", mode])
            .args(["--rs485-file", "/dev/null"])
            .args(READ)
            .output()
            .expect("run si");
        assert!(!o.status.success());
        assert!(text(&o).contains("need a serial port"), "{}", text(&o));
    }
}
