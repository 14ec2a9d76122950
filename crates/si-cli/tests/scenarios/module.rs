//! `si diag`, `si im`, `si params` as a user runs them ([ET200S SI 2005] Tables 2-30, 3-73,
//! [ET200S SI 2005] §2.9.4, Tables 2-10/2-11; parameter Tables 2-8, 2-9, 3-18, 3-21).

use crate::common;

use common::{si, stderr, stdout, test_dir};

/// A file in the test's own temporary directory (also used by `bounds`).
pub(crate) fn temp_file(name: &str, text: &str) -> std::path::PathBuf {
    let path = test_dir("si-module-cli").join(name);
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn params_check_reports_three_wrong_values_in_one_run() {
    let path = temp_file(
        "three_wrong.toml",
        "driver = \"3964r\"\nbaud = 9601\nchar_delay_ms = 5\nconnection_attempts = 0\npriority = \"low\"\n",
    );
    let o = si(&["params", "check", path.to_str().unwrap()]);
    assert!(!o.status.success());
    let text = stdout(&o);
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 3, "{text}");
    assert!(lines[0].ends_with("baud = 9601 is not one of: 110, 300, 600, 1200, 2400, 4800, 9600, 19200, 38400, 57600, 76800, 115200 (line 2)"), "{text}");
    assert!(
        lines[1].ends_with("character delay time (ZVZ) = 5 ms is out of range: 20 … 655350 ms"),
        "{text}"
    );
    assert!(
        lines[2].ends_with("connection attempts = 0 is out of range: 1 … 255"),
        "{text}"
    );
    assert!(stderr(&o).contains("3 wrong parameters"), "{}", stderr(&o));

    let o = si(&["--json", "params", "check", path.to_str().unwrap()]);
    assert!(!o.status.success());
    let params: Vec<String> = stdout(&o)
        .lines()
        .map(|l| {
            serde_json::from_str::<serde_json::Value>(l).unwrap()["parameter"]
                .as_str()
                .unwrap()
                .to_string()
        })
        .collect();
    assert_eq!(
        params,
        ["baud", "character delay time (ZVZ)", "connection attempts"]
    );
}

#[test]
fn params_check_prints_the_checked_set_with_defaults() {
    let path = temp_file("slave.toml", "driver = \"modbus-slave\"\naddress = 5\n");
    let o = si(&["params", "check", path.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(text.contains("valid modbus-slave parameters"), "{text}");
    assert!(text.contains("address = 5"), "{text}");
    assert!(
        !text.contains("response_timeout_ms"),
        "a slave has no response time: {text}"
    );
    assert!(text.contains("char_delay_multiplier = 1"), "{text}");
    // The printed set is itself a valid file.
    let printed = temp_file("printed.toml", &text);
    assert!(si(&["params", "check", printed.to_str().unwrap()])
        .status
        .success());

    let json = temp_file("ascii.json", r#"{"driver": "ascii", "baud": 19200}"#);
    let o = si(&["--json", "params", "check", json.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap();
    assert_eq!(v["params"]["baud"], 19200);
    assert_eq!(v["params"]["char_delay_ms"], 4);

    let o = si(&["params", "check", "/nonexistent/si-params.toml"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("cannot read"), "{}", stderr(&o));
}

#[test]
fn diag_decode_names_the_channel_error_and_its_action() {
    let o = si(&[
        "diag",
        "decode",
        "08 0C 00 02 80 E0",
        "42 04",
        "05 82 00 00 10",
        "83 C0 96",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(
        text.contains("ident 80E0H: extended diagnosis present"),
        "{text}"
    );
    assert!(
        text.contains("module diagnosis: module 3 reports"),
        "{text}"
    );
    assert!(text.contains("module 3: module error"), "{text}");
    assert!(
        text.contains("slot 3 channel 0 (input/output, byte)"),
        "{text}"
    );
    assert!(
        text.contains("error type 10110 (22) message error: frame error or parity error. Action: check the communication settings"),
        "{text}"
    );
    let o = si(&[
        "diag",
        "decode",
        "--variant",
        "modbus-uss",
        "08 0C 00 02 80 E0 83 C0 88",
    ]);
    assert!(
        stdout(&o).contains("check why the partner sends frames without user data"),
        "{}",
        stdout(&o)
    );
    let o = si(&["diag", "decode", "08 0C 00 02 80 E0 83 C0"]);
    assert!(!o.status.success());
    assert_eq!(
        stderr(&o).trim(),
        "si: error: truncated at offset 6: the channel-specific diagnosis needs 3 bytes, 2 remain"
    );
}

/// A full station: besides the SI module's entry, another module's channel error (type 1),
/// an entry with reserved I/O and channel types, and an interrupt block. They are shown with
/// their raw bytes, and the SI module's entry is decoded as usual.
#[test]
fn diag_decode_shows_what_the_si_tables_do_not_describe_raw() {
    let words = [
        "diag",
        "decode",
        "08 0C 00 02 80 E0",
        "42 18",
        "05 82 00 00 50",
        "83 C0 96",
        "84 41 21",
        "85 02 E6",
        "08 01 04 01 00 11 22 33",
    ];
    let o = si(&words);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(
        text.contains("error type 10110 (22) message error: frame error or parity error"),
        "{text}"
    );
    let unknown: Vec<&str> = text
        .lines()
        .filter(|l| l.starts_with("not decoded"))
        .collect();
    assert_eq!(
        unknown,
        [
            "not decoded at offset 16: channel entry: slot 4 channel 1 (input, bit): error type \
             00001 (1), not in the SI module's tables (see the reporting module's manual); raw 84 41 21",
            "not decoded at offset 19: channel entry: slot 5 channel 2 (I/O type 00 reserved, \
             channel type reserved): error type 00110 (6); raw 85 02 E6",
            "not decoded at offset 22: device-related block of status type 01H, not the module \
             status 82H 00H 00H: an interrupt, a status message or manufacturer-specific data; \
             raw 08 01 04 01 00 11 22 33",
        ],
        "{text}"
    );

    let mut json = vec!["--json"];
    json.extend_from_slice(&words);
    let o = si(&json);
    assert!(o.status.success(), "{}", stderr(&o));
    let parts: Vec<serde_json::Value> = stdout(&o)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .filter(|v: &serde_json::Value| v["part"] == "unknown")
        .collect();
    assert_eq!(parts.len(), 3);
    assert_eq!(parts[0]["offset"], 16);
    assert_eq!(parts[0]["bytes"], "84 41 21");
    assert_eq!(parts[0]["kind"]["channel"]["error_type"], 1);
    assert_eq!(parts[2]["kind"]["status-block"]["status_type"], 1);
}

#[test]
fn im_encode_then_decode() {
    let o = si(&["im", "encode", "--hid", "PLANT-A", "--location", "HALL 2"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let hex = stdout(&o).trim().to_string();
    assert_eq!(hex.split(' ').count(), 64);
    assert!(
        hex.starts_with("F1 11 00 02 00 38 00 01 00 02 50 4C 41 4E 54 2D 41 20"),
        "{hex}"
    );
    let o = si(&["im", "decode", &hex]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        stdout(&o).trim(),
        "I&M1 (DS 232): plant designation \"PLANT-A\", location \"HALL 2\""
    );
    let o = si(&["im", "encode", "--location", &"L".repeat(23)]);
    assert!(!o.status.success());
    assert_eq!(
        stderr(&o).trim(),
        "si: error: location designation (OKZ) is 23 characters long, at most 22 allowed"
    );
    let o = si(&["im", "decode", "F1 11 00 01"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("64 bytes, got 4"), "{}", stderr(&o));
}

#[test]
fn params_default_prints_a_valid_file_for_every_driver() {
    for driver in [
        "ascii",
        "3964r",
        "modbus-master",
        "modbus-slave",
        "uss-master",
    ] {
        let o = si(&["params", "default", driver]);
        assert!(o.status.success(), "{}", stderr(&o));
        let text = stdout(&o);
        assert!(text.contains(&format!("driver = \"{driver}\"")), "{text}");
        let path = temp_file(&format!("{driver}.toml"), &text);
        let o = si(&["params", "check", path.to_str().unwrap()]);
        assert!(o.status.success(), "{driver}: {}", stderr(&o));
    }
    let text = stdout(&si(&["params", "default", "3964r"]));
    for line in [
        "char_delay_ms = 220",
        "ack_delay_ms = 2000",
        "connection_attempts = 6",
        "priority = \"low\"",
    ] {
        assert!(text.contains(line), "{line}: {text}");
    }
}
