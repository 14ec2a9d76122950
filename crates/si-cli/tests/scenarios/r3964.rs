//! `si frame encode|decode 3964r` and the 3964(R) scenarios of `si sim`, as a user runs them.

use crate::common;

use common::{si, stderr, stdout};

#[test]
fn encode_prints_the_worked_example_of_5_2() {
    let o = si(&["frame", "encode", "3964r", "41 42 10 43"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stdout(&o).trim(), "41 42 10 10 43 10 03 53");
    let o = si(&["frame", "encode", "3964r", "--no-bcc", "10"]);
    assert_eq!(stdout(&o).trim(), "10 10 10 03");
}

#[test]
fn decode_prints_the_payload_or_names_the_error() {
    let o = si(&["frame", "decode", "3964r", "41 42 10 10 43 10 03 53"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stdout(&o).trim(), "41 42 10 43");
    let o = si(&["frame", "decode", "3964r", "41 10 03 00"]);
    assert!(!o.status.success());
    assert_eq!(
        stderr(&o).trim(),
        "si: error: BCC error: expected 52H, found 00H (STATUS 16#0808)"
    );
    let o = si(&["frame", "decode", "3964r", "41 10 41 10 03 00"]);
    assert!(
        stderr(&o).contains("odd DLE: DLE followed by 41H"),
        "{}",
        stderr(&o)
    );
    let o = si(&["frame", "decode", "3964r", "41 42"]);
    assert!(stderr(&o).contains("missing DLE ETX"), "{}", stderr(&o));
    let o = si(&["frame", "decode", "3964r", "--no-bcc", "41 10 03"]);
    assert_eq!(stdout(&o).trim(), "41");
    let o = si(&[
        "frame",
        "decode",
        "3964r",
        "--max-len",
        "1",
        "41 42 10 03 50",
    ]);
    assert!(
        stderr(&o).contains("longer than the maximum of 1"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn out_of_range_timer_names_parameter_range_and_value() {
    let o = si(&[
        "--port",
        "/dev/null",
        "3964r",
        "send",
        "01",
        "--char-delay-ms",
        "5",
    ]);
    assert!(!o.status.success());
    assert_eq!(
        stderr(&o).trim(),
        "si: error: character delay time (ZVZ) = 5 ms is out of range: 20 … 655350 ms"
    );
}

fn scenario(name: &str) -> String {
    let o = si(&["sim", name]);
    assert!(o.status.success(), "{}", stderr(&o));
    stdout(&o)
}

#[test]
fn sim_3964r_exchanges_blocks_both_ways() {
    let text = scenario("3964r");
    assert!(
        text.contains("A: send 16#0000 no error; received \"21.5 C\""),
        "{text}"
    );
    assert!(
        text.contains("B: send 16#0000 no error; received \"temperature?"),
        "{text}"
    );
}

#[test]
fn sim_3964r_conflict_both_jobs_succeed() {
    let text = scenario("3964r-conflict");
    assert!(
        text.contains("A: send 16#0000 no error; received \"from B (low)\""),
        "{text}"
    );
    assert!(
        text.contains("B: send 16#0000 no error; received \"from A (high)\""),
        "{text}"
    );
}

#[test]
fn sim_3964r_nak_retry_reports_080a_and_then_succeeds() {
    let text = scenario("3964r-nak-retry");
    assert!(text.contains("A: send 16#0000"), "{text}");
    assert!(
        text.contains("received \"first\", \"second\"; receive errors 16#080A"),
        "{text}"
    );
}

#[test]
fn sim_3964r_bcc_error_is_repaired() {
    let text = scenario("3964r-bcc-error");
    assert!(text.contains("A: send 16#0000"), "{text}");
    assert!(
        text.contains("B: no send job; received \"setpoint=42\""),
        "{text}"
    );
    // B answered the corrupted block with NAK before the repetition was acknowledged.
    assert!(text.contains("B        tx 15"), "{text}");
}

#[test]
fn sim_3964r_timeout_is_0703() {
    let text = scenario("3964r-timeout");
    assert!(text.contains("A: send 16#0703"), "{text}");
    let o = si(&["--json", "sim", "3964r-timeout"]);
    let last = stdout(&o)
        .lines()
        .rev()
        .nth(1)
        .unwrap_or_default()
        .to_owned();
    let v: serde_json::Value = serde_json::from_str(&last).unwrap();
    assert_eq!(v["station"], "A");
    assert_eq!(v["status"], 0x0703);
}
