//! `si frame encode|decode uss` and the USS `si sim` scenarios, run through the built binary.

use crate::common;

use common::{si, stdout};

#[test]
fn encode_builds_the_whole_telegram_with_lge_and_bcc_including_stx() {
    // public-facts.md §3: PKW 4 + PZD 2 → LGE 0EH, 16 bytes; BCC worked out in si-uss's golden tests.
    let o = si(&[
        "frame",
        "encode",
        "uss",
        "00 12 BC 00 00 00 00 00 00 04 7E 00 00",
    ]);
    assert!(o.status.success(), "{o:?}");
    assert_eq!(
        stdout(&o).trim(),
        "02 0E 00 12 BC 00 00 00 00 00 00 04 7E 00 00 D8"
    );
}

#[test]
fn decode_splits_pkw_and_pzd() {
    let o = si(&[
        "frame",
        "decode",
        "uss",
        "--pkw-words",
        "4",
        "02 0E 00 12 BC 00 00 00 00 00 00 04 7E 00 00 D8",
    ]);
    assert!(o.status.success(), "{o:?}");
    let text = stdout(&o);
    assert!(text.contains("AK 1 SPM 0 PNU 700"), "{text}");
    assert!(text.contains("PZD: [047E, 0000]"), "{text}");
}

#[test]
fn decode_rejects_a_bcc_computed_without_stx_in_one_line() {
    let o = si(&[
        "frame",
        "decode",
        "uss",
        "02 0E 00 12 BC 00 00 00 00 00 00 04 7E 00 00 DA",
    ]);
    assert!(!o.status.success());
    assert_eq!(
        String::from_utf8_lossy(&o.stderr).trim(),
        "si: error: BCC at byte 15 is DAH, expected D8H"
    );
}

#[test]
fn sim_uss_cycle_goes_on_past_the_silent_drive() {
    let o = si(&["sim", "uss-cycle", "--json"]);
    assert!(o.status.success(), "{o:?}");
    let text = stdout(&o);
    let last: Vec<serde_json::Value> = text
        .lines()
        .filter_map(|l| serde_json::from_str(l).ok())
        .collect();
    let slave2 = last.iter().find(|v| v["slave"] == 2).expect("slave 2 line");
    assert_eq!(slave2["status"], 0x1408);
    assert_eq!(slave2["comm_error"], 0x80);
    let counters = &last.last().unwrap()["counters"];
    assert_eq!(counters["no_answer"], 3);
    assert_eq!(counters["ok"], 6);
}

#[test]
fn sim_uss_param_shows_the_ak7_error_number() {
    let o = si(&["sim", "uss-param"]);
    assert!(o.status.success(), "{o:?}");
    let text = stdout(&o);
    assert!(
        text.contains("P1082:0 := 120: done, response ID 1 value 120"),
        "{text}"
    );
    assert!(text.contains("failed 16#1503"), "{text}");
    assert!(
        text.contains("error number 2 (lower or upper value limit exceeded)"),
        "{text}"
    );
}
