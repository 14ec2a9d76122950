//! Unit-id remapping: a TCP unit id reaches (line, slave address), so slaves of one address on
//! two lines are told apart; the answer carries the client's unit id.

use crate::common::{read, start};
use si_gateway::config::File;

/// Two lines, each with a slave at address 1 (registers from 500 and from 700), reached as
/// units 11 and 21; line "b" also serves its address 1 unmapped as unit 1.
const TWO_SLAVES_AT_1: &str = r#"
listen = "127.0.0.1:0"
[[line]]
name = "a"
device = "1@500"
unit_map = { 11 = 1 }
pause_ms = 0
[[line]]
name = "b"
device = "1@700"
units = "1"
unit_map = { 21 = 1 }
pause_ms = 0
"#;

#[tokio::test]
async fn two_slaves_of_address_1_on_two_lines_are_units_11_and_21() {
    let (gateway, _slaves) = start(TWO_SLAVES_AT_1).await;
    let h = gateway.handler();
    let a = h.call(read(1, 11, 3)).await.unwrap();
    assert_eq!(
        a.unit_pdu(),
        [11, 0x03, 2, 0x01, 0xF7],
        "line a's slave, unit 11 back"
    );
    let b = h.call(read(2, 21, 3)).await.unwrap();
    assert_eq!(
        b.unit_pdu(),
        [21, 0x03, 2, 0x02, 0xBF],
        "line b's slave, unit 21 back"
    );
    assert_eq!(b.transaction(), 2);
    let plain = h.call(read(3, 1, 3)).await.unwrap();
    assert_eq!(
        plain.unit_pdu(),
        [1, 0x03, 2, 0x02, 0xBF],
        "unit 1 is b's address 1"
    );
    // A slave's exception and the gateway's own carry the client's unit id too.
    let past = h.call(read(4, 21, 200)).await.unwrap();
    assert_eq!(past.unit_pdu(), [21, 0x83, 0x02]);
    let stats = gateway.stats();
    assert_eq!((stats.lines[0].answers, stats.lines[1].answers), (1, 2));
}

#[test]
fn one_tcp_unit_on_two_lines_is_refused_when_the_file_loads() {
    let clash = TWO_SLAVES_AT_1.replace("unit_map = { 21 = 1 }", "unit_map = { 11 = 1 }");
    let e = File::from_toml(&clash)
        .unwrap()
        .check()
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("line 2 (b): units = 11 is out of range: unit ids not served by a"),
        "{e}"
    );
    let twice = TWO_SLAVES_AT_1.replace("unit_map = { 21 = 1 }", "unit_map = { 1 = 1 }");
    let e = File::from_toml(&twice)
        .unwrap()
        .check()
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("unit_map = 1 is out of range: unit ids not also in units"),
        "{e}"
    );
    let bad = TWO_SLAVES_AT_1.replace("{ 21 = 1 }", "{ 21 = 248 }");
    let e = File::from_toml(&bad)
        .unwrap()
        .check()
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("unit_map = 248 (slave address) is out of range: 1 … 247"),
        "{e}"
    );
}
