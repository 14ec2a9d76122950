//! `si frame encode|decode uss` and the USS `si sim` scenarios, run through the built binary.

use crate::common;

use common::{si, stdout};

#[test]
fn encode_builds_the_whole_telegram_with_lge_and_bcc_including_stx() {
    // [SINAMICS CU240S] p. 178: PKW 4 + PZD 2 → LGE 0EH, 16 bytes; BCC worked out in si-uss's
    // golden tests.
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

/// `si frame decode uss --pkw-words 4 <args…>`, which must succeed: its output.
fn decode_pkw4(args: &[&str]) -> String {
    let mut all = vec!["frame", "decode", "uss", "--pkw-words", "4"];
    all.extend_from_slice(args);
    let o = si(&all);
    assert!(o.status.success(), "{o:?}");
    stdout(&o)
}

#[test]
fn decode_splits_pkw_and_pzd() {
    let text = decode_pkw4(&["02 0E 00 12 BC 00 00 00 00 00 00 04 7E 00 00 D8"]);
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
    // 3 cycles × 3 nodes and no telegram after the run.
    assert_eq!(counters["sent"], 9);
}

#[test]
fn decode_shows_the_full_parameter_number_from_the_page_index() {
    // [MM 420] p. 115, [G120 Fieldbus] §5.3: p2029[5] → PKE 101DH (AK 1), IND 8005H; P60000 → IND
    // 74xxH.
    for (net, want) in [
        (
            [0x10, 0x1D, 0x80, 0x05, 0, 0, 0, 0],
            "PNU 29 IND 8005H (P2029:5)",
        ),
        (
            [0x10, 0x00, 0x74, 0x00, 0, 0, 0, 0],
            "PNU 0 IND 7400H (P60000:0)",
        ),
    ] {
        let mut t = [0u8; 12];
        let n = si_uss::frame::encode(si_uss::frame::Adr(1), &net, &mut t).unwrap();
        let text = decode_pkw4(&["--pzd-words", "0", &si_core::hex::format(&t[..n])]);
        assert!(text.contains(want), "{text}");
    }
}

#[test]
fn help_documents_the_radix_wdh_and_both_pkw_modes() {
    let o = si(&["uss", "poll", "--help"]);
    let help = stdout(&o);
    assert!(help.contains("--stw"), "{help}");
    assert!(help.contains("0x047F"), "{help}");
    assert!(
        help.contains("repetitions after the first telegram"),
        "{help}"
    );
    assert!(help.contains("--pkw-repeat"), "{help}");
    assert!(help.contains("task 0"), "{help}");
    let o = si(&["uss", "write-param", "--help"]);
    let help = stdout(&o);
    assert!(
        help.contains("--array") && help.contains("--index"),
        "{help}"
    );
    assert!(help.contains("negative allowed"), "{help}");
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
