//! Structured output: `frame decode --json` gives the decoded fields, not Rust Debug
//! text; RK 512 names the job; `si sim` names the control characters of its line trace.

use crate::common;

use common::{si, stderr, stdout};
use serde_json::{json, Value};

/// `si --json ARGS`, one JSON line, checked to succeed.
fn json_line(args: &[&str]) -> Value {
    let o = si(&[&["--json"][..], args].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    serde_json::from_str(stdout(&o).trim()).expect("one JSON line")
}

#[test]
fn modbus_decode_json_gives_the_request_fields() {
    let v = json_line(&["frame", "decode", "modbus", "01 03 00 00 00 0A C5 CD"]);
    assert_eq!(v["reading"], "request");
    assert_eq!(
        v["request"],
        json!({"pdu": "read_holding_registers", "fields": {"address": 0, "quantity": 10}})
    );
    assert_eq!(v["response"], Value::Null);
    assert!(!v.to_string().contains("ReadHoldingRegisters"), "{v}");
}

/// `si frame encode modbus PDU` and then `si --json frame decode modbus` of the ADU.
fn decode_encoded(pdu: &str) -> Value {
    let adu = stdout(&si(&["frame", "encode", "modbus", pdu]));
    json_line(&["frame", "decode", "modbus", adu.trim()])
}

#[test]
fn modbus_decode_json_gives_registers_bits_and_exceptions_as_values() {
    // FC03 response with two registers 002A 1234.
    let v = decode_encoded("01 03 04 00 2A 12 34");
    assert_eq!(v["reading"], "response", "{v}");
    assert_eq!(
        v["response"],
        json!({"pdu": "read_holding_registers", "fields": [42, 0x1234]})
    );
    // Exception 02 to FC03.
    let v = json_line(&["frame", "decode", "modbus", "01 83 02 C0 F1"]);
    assert_eq!(
        v["response"],
        json!({"pdu": "exception", "fields": {"function": 3, "code": 2}})
    );
    // FC15 request: coils as booleans.
    let v = decode_encoded("01 0F 00 10 00 03 01 05");
    assert_eq!(
        v["request"],
        json!({"pdu": "write_multiple_coils", "fields": {"address": 16, "values": [true, false, true]}})
    );
}

#[test]
fn rk512_names_the_job_in_text_and_json() {
    let v = json_line(&["frame", "decode", "rk512", "00 00 41 44 0A 01 00 32 FF 1F"]);
    assert_eq!(v["job"], "SEND", "{v}");
    let v = json_line(&["frame", "decode", "rk512", "00 00 45 44 0A 01 00 32 FF 1F"]);
    assert_eq!(v["job"], "FETCH", "{v}");
    let o = si(&["frame", "decode", "rk512", "00 00 45 44 0A 01 00 32 FF 1F"]);
    assert!(stdout(&o).contains("FETCH"), "{}", stdout(&o));
}

/// The lines of `si sim NAME`.
fn sim_lines(name: &str) -> Vec<String> {
    let o = si(&["sim", name]);
    assert!(o.status.success(), "{}", stderr(&o));
    stdout(&o).lines().map(str::to_owned).collect()
}

#[test]
fn sim_3964r_names_stx_dle_and_the_blocks_end() {
    let lines = sim_lines("3964r");
    let has = |end: &str| lines.iter().any(|l| l.ends_with(end));
    assert!(has("A        tx 02  STX"), "{lines:#?}");
    assert!(has("B        rx 02  STX"), "{lines:#?}");
    assert!(has("B        tx 10  DLE"), "{lines:#?}");
    assert!(has("  DLE ETX BCC"), "{lines:#?}");
    assert!(has("rx 03  ETX"), "{lines:#?}");
    // A doubled DLE in the data is data: the first block has 10 10 before DLE ETX.
    let doubled = lines
        .iter()
        .filter(|l| l.contains("B        rx 10"))
        .take(3)
        .cloned()
        .collect::<Vec<_>>();
    assert_eq!(
        doubled.iter().filter(|l| l.ends_with("DLE")).count(),
        1,
        "{doubled:#?}"
    );
}

#[test]
fn sim_names_ascii_controls_and_leaves_modbus_binary() {
    let ascii = sim_lines("ascii-xon-xoff");
    assert!(
        ascii.iter().any(|l| l.ends_with("tx 13  XOFF")),
        "{ascii:#?}"
    );
    let modbus = sim_lines("modbus");
    let first = modbus.first().cloned().unwrap_or_default();
    assert!(
        first.ends_with("tx 01 10 00 00 00 02 04 12 34 56 78 88 9B"),
        "{first}"
    );
}
