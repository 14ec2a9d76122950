//! `si frame decode rk512` and `si sim rk512` without a line ([CP 341] §2.2.3, Table 2-1, Fig. 2-13
//! to 2-16).

use crate::common;

use common::{si, stdout};

/// Fig. 2-13: the SEND header of 50 data words to DB10 from DW1, CPU 1.
#[test]
fn decode_fig_2_13_send_header() {
    let o = si(&["frame", "decode", "rk512", "00 00 41 44 0A 01 00 32 FF 1F"]);
    assert!(o.status.success());
    assert_eq!(
        stdout(&o).trim(),
        "command telegram: SEND ('A') DB10.DW1 data block ('D'), 50 words (100 bytes), no coordination flag, CPU 1"
    );
}

/// Fig. 2-15 with data, as JSON; Fig. 2-16 continuation; a reaction with an error number.
#[test]
fn decode_fetch_continuation_and_reaction() {
    let o = si(&[
        "--json",
        "frame",
        "decode",
        "rk512",
        "00 00 45 44 0A 64 00 32 14 03",
    ]);
    let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap();
    assert_eq!(v["telegram"], "command");
    assert_eq!(v["command"], "E");
    assert_eq!(v["address"], "DB10.DW100");
    assert_eq!(v["length"], 50);
    assert_eq!(v["flag_byte"], 20);
    assert_eq!(v["flag_bit"], 3);
    assert_eq!(v["cpu"], 0);
    let o = si(&["frame", "decode", "rk512", "FF 00 45 44"]);
    assert_eq!(
        stdout(&o).trim(),
        "continuation command telegram: FETCH ('E') data block ('D')"
    );
    let o = si(&["frame", "decode", "rk512", "FF 00 00 00 12 34"]);
    assert_eq!(
        stdout(&o).trim(),
        "continuation reaction telegram: error number 00H (no error); 2 data bytes: 12 34"
    );
    let o = si(&["--json", "frame", "decode", "rk512", "00 00 00 32"]);
    let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap();
    assert_eq!(v["error"], 0x32);
    assert_eq!(v["status"], 0x0909);
}

/// Decode errors name the offset, what was expected and what was found, and exit non-zero.
#[test]
fn decode_errors_name_offset_expected_and_found() {
    let o = si(&["frame", "decode", "rk512", "00 00 51 44 0A 01 00 32 FF 1F"]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("offset 2: expected command 'A' (41H), 'O' (4FH) or 'E' (45H), found 51H"),
        "{err}"
    );
}

/// `si sim rk512`: SEND then FETCH of 300 bytes; `si sim rk512-locked`: 16#0909.
#[test]
fn sim_scenarios() {
    let o = si(&["sim", "rk512"]);
    assert!(o.status.success());
    let out = stdout(&o);
    assert!(out.contains("host: job 1 done: 16#0000"), "{out}");
    assert!(
        out.contains("host: job 2 done: 300 bytes 00 01 02"),
        "{out}"
    );
    assert!(
        out.contains("PLC: served SEND DB10.DW0, 300 bytes"),
        "{out}"
    );
    let o = si(&["sim", "rk512-locked"]);
    let out = stdout(&o);
    assert!(out.contains("host: job 2 failed: 16#0909"), "{out}");
    assert!(out.contains("PLC: M20.3 = 1"), "{out}");
}
