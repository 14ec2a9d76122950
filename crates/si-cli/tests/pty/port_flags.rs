//! The port flags for USB adapters and RS-485, without hardware: `--latency-timer`, `--rs485`,
//! `--local-echo` parse, and a port that cannot do what they ask is refused with a message that
//! says why.

use crate::common;

use common::{pty_pair, si, stdout, text};

#[test]
fn a_latency_timer_on_a_port_without_one_is_a_clear_error() {
    let o = si(&["--port", "/dev/null", "--latency-timer", "1", "ports"]);
    assert!(!o.status.success());
    let t = text(&o);
    if cfg!(target_os = "linux") {
        assert!(t.contains("has no latency timer to set"), "{t}");
    }
}

#[test]
fn a_latency_timer_out_of_range_is_refused() {
    let o = si(&["--port", "/dev/null", "--latency-timer", "256", "ports"]);
    assert!(!o.status.success());
    assert!(text(&o).contains("out of range"), "{}", text(&o));
}

#[test]
fn rs485_names_its_modes() {
    let o = si(&["--rs485", "sideways", "ports"]);
    assert!(!o.status.success());
    let t = text(&o);
    assert!(t.contains("kernel") && t.contains("rts"), "{t}");
}

#[test]
fn rs485_over_tcp_is_refused() {
    let o = si(&[
        "--tcp",
        "127.0.0.1:9",
        "--rs485",
        "rts",
        "modbus",
        "read",
        "holding",
        "--unit",
        "1",
        "--addr",
        "0",
        "--count",
        "1",
    ]);
    assert!(!o.status.success());
    assert!(text(&o).contains("need a serial port"), "{}", text(&o));
}

#[test]
fn a_pty_refuses_rs485_and_the_latency_timer_with_reasons() {
    let Some(pair) = pty_pair() else { return };
    let read = [
        "modbus", "read", "holding", "--unit", "1", "--addr", "0", "--count", "1",
    ];
    let run = |flags: &[&str]| {
        let args = [&["--port", pair.a.as_str()][..], flags, &read[..]].concat();
        si(&args)
    };
    let o = run(&["--rs485", "kernel"]);
    assert!(!o.status.success());
    assert!(text(&o).contains("kernel's RS-485 mode"), "{}", text(&o));
    let o = run(&["--rs485", "rts"]);
    assert!(!o.status.success());
    assert!(text(&o).contains("cannot drive RTS"), "{}", text(&o));
    let o = run(&["--latency-timer", "1"]);
    assert!(!o.status.success());
    assert!(text(&o).contains("no latency timer"), "{}", text(&o));
}

#[test]
fn ports_lists_in_json_with_usb_and_latency_fields() {
    let o = si(&["--json", "ports"]);
    assert!(o.status.success(), "{}", text(&o));
    for line in stdout(&o).lines() {
        let v: serde_json::Value = serde_json::from_str(line).expect("a JSON line");
        assert!(v["port"].is_string(), "{v}");
        assert!(
            v.get("usb").is_some() && v.get("latency_timer_ms").is_some(),
            "{v}"
        );
    }
}

/// A data byte FFH, which the kernel doubles on a port in line-error mode, reaches the
/// receiving station once and is recorded once in its trace (the recorder decodes the marked
/// stream the driver reads).
#[test]
fn a_data_ff_is_received_and_recorded_once_on_a_marking_port() {
    use std::process::Stdio;
    let Some(pair) = common::pty_pair_ignoreeof() else {
        return;
    };
    let trace = common::test_dir("si-port-flags").join("ff.jsonl");
    let recv = common::si_command()
        .args(["--json", "--port", &pair.b, "--record"])
        .arg(&trace)
        .args(["3964r", "recv", "--count", "1", "--priority", "low"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start recv");
    std::thread::sleep(std::time::Duration::from_millis(300));
    let o = si(&[
        "--port",
        &pair.a,
        "3964r",
        "send",
        "--priority",
        "high",
        "41 FF 42",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let o = recv.wait_with_output().expect("recv ends");
    assert!(o.status.success(), "{}", text(&o));
    let line: serde_json::Value = serde_json::from_str(stdout(&o).trim()).expect("JSON line");
    assert_eq!(line["hex"], "41 FF 42");
    let recorded: Vec<u8> = std::fs::read_to_string(&trace)
        .unwrap()
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .filter(|e| e["kind"] == "rx_chunk")
        .flat_map(|e| {
            e["bytes"]
                .as_array()
                .map(|b| {
                    b.iter()
                        .filter_map(|x| x.as_u64())
                        .map(|x| x as u8)
                        .collect()
                })
                .unwrap_or_else(Vec::new)
        })
        .collect();
    // STX, the block 41 FF 42, DLE ETX, BCC: one FF in the data.
    let ffs = recorded.iter().filter(|&&b| b == 0xFF).count();
    assert!(
        recorded.windows(3).any(|w| w == [0x41, 0xFF, 0x42]),
        "{recorded:02X?}"
    );
    assert_eq!(ffs, 1, "{recorded:02X?}");
}

/// `modbus read --auto-v24` with `ARGS` on a pseudo-terminal, which has no modem lines.
fn modbus_auto_v24(args: &[&str]) -> std::process::Output {
    let Some(pair) = pty_pair() else {
        panic!("no pty pair")
    };
    let read = [
        "modbus",
        "read",
        "holding",
        "-u",
        "1",
        "--response-timeout-ms",
        "200",
    ];
    si(&[&["--port", &pair.a][..], &read, &["--auto-v24"], args].concat())
}

#[test]
fn modbus_auto_v24_checks_its_times_and_needs_rs232() {
    if !common::have_socat() {
        return;
    }
    // Times on the 10 ms grid (si_core::v24), as the ASCII driver's: exit 2 naming the time.
    let o = modbus_auto_v24(&["--rts-off-ms", "15"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains("time to RTS off = 15 ms is out of range"),
        "{}",
        text(&o)
    );
    // RS-485 has no V.24 signals ([Modbus/USS] §3.2.2).
    let o = modbus_auto_v24(&["--rs485", "rts"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains("--auto-v24 needs RS-232C"),
        "{}",
        text(&o)
    );
    // The times need the mode.
    let o = si(&[
        "modbus",
        "read",
        "holding",
        "-u",
        "1",
        "--data-wait-ms",
        "20",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
}

#[test]
fn modbus_auto_v24_on_a_port_without_rts_says_so() {
    if !common::have_socat() {
        return;
    }
    // The sequence raises RTS before the request: a pseudo-terminal cannot, and the log says
    // why the line failed instead of only that it did.
    let o = modbus_auto_v24(&[]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(
        text(&o).contains("cannot set the RTS/DTR outputs"),
        "{}",
        text(&o)
    );
}

#[test]
fn ascii_v24_flow_control_with_rs485_direction_is_refused() {
    // Table 2-1: the secondary signals and RTS/CTS exist on RS-232C only; RS-485 direction
    // control would share RTS with them.
    for flow in ["rts-cts", "auto-v24"] {
        let o = si(&[
            "--port",
            "/dev/null",
            "--rs485",
            "rts",
            "ascii",
            "send",
            "--flow",
            flow,
            "41",
        ]);
        assert_eq!(o.status.code(), Some(2), "{flow}: {}", text(&o));
        assert!(text(&o).contains("need RS-232C"), "{}", text(&o));
    }
}
