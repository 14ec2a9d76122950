//! The port flags of issue 16 without hardware: `--latency-timer`, `--rs485`, `--local-echo`
//! parse, and a port that cannot do what they ask is refused with a message that says why.

mod common;

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
