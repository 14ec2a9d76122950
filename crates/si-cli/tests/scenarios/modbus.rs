//! `si frame encode|decode modbus` and the Modbus `si sim` scenarios, offline
//! ([Modbus/USS] §3.3.1, Table 3-9, §3.3.5, §3.4.3, Table 3-17, §3.4.5–§3.4.16).

use crate::common;

use common::{si, stderr, stdout};

#[test]
fn frame_encode_appends_the_crc_low_byte_first() {
    let o = si(&["frame", "encode", "modbus", "01 03 00 00 00 0A"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stdout(&o).trim(), "01 03 00 00 00 0A C5 CD");
    let o = si(&["--json", "frame", "encode", "modbus", "05 85 02"]);
    let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap();
    assert_eq!(v["adu"], "05 85 02 82 90");
    assert_eq!(v["reading"], "response");
}

#[test]
fn frame_decode_says_which_reading_it_used() {
    let o = si(&["frame", "decode", "modbus", "01 03 00 00 00 0A C5 CD"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        stdout(&o).trim(),
        "request: unit 1 FC03 read 10 holding registers from 0, CRC CDC5 ok"
    );
    let o = si(&["frame", "decode", "modbus", "01 03 02 00 01 79 84"]);
    assert!(stdout(&o).starts_with("response: unit 1 FC03 1 register: 0001,"));
    let o = si(&["frame", "decode", "modbus", "01 06 00 01 00 03 98 0B"]);
    assert!(
        stdout(&o).starts_with("request and response"),
        "{}",
        stdout(&o)
    );
}

#[test]
fn frame_decode_names_the_crc_error() {
    let o = si(&["frame", "decode", "modbus", "01 03 00 00 00 0A C5 CE"]);
    assert!(!o.status.success());
    assert_eq!(
        stderr(&o).trim(),
        "si: error: request byte 6: CRC expected 52677 (0xCDC5), found 52933 (0xCEC5)"
    );
}

#[test]
fn sim_modbus_polls_and_ends_with_the_write_limit_exception() {
    let o = si(&["sim", "modbus"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(
        text.contains("job done: Some(ReadHoldingRegisters([1234, 5678]))"),
        "{text}"
    );
    assert!(text.contains("job failed: 16#0E62"), "{text}");
}

#[test]
fn sim_modbus_timeout_is_0830h_after_2_s() {
    let o = si(&["sim", "modbus-timeout"]);
    let last = stdout(&o).lines().last().unwrap_or_default().to_string();
    // 8 characters at 9600 8E1 (9.167 ms) + the 2000 ms response time.
    assert!(
        last.starts_with("2.009167 s: job failed: 16#0830"),
        "{last}"
    );
}

#[test]
fn sim_modbus_crc_error_is_0e57h() {
    let o = si(&["--json", "sim", "modbus-crc-error"]);
    let last = stdout(&o).lines().last().unwrap_or_default().to_string();
    let v: serde_json::Value = serde_json::from_str(&last).unwrap();
    assert_eq!(v["status"], 0x0E57);
}

#[test]
fn write_single_with_two_values_is_refused_before_opening_the_line() {
    let o = si(&["modbus", "write", "register", "--unit", "1", "1", "2"]);
    assert!(!o.status.success());
    assert_eq!(
        stderr(&o).trim(),
        "si: error: write register takes exactly one value, got 2"
    );
}

/// `si --port /dev/null <line> modbus serve --unit 1 <extra>`: refused before the port is
/// opened when a parameter is out of range.
fn serve_on_null(line: &[&str], extra: &[&str]) -> std::process::Output {
    let args = [
        &["--port", "/dev/null"][..],
        line,
        &["modbus", "serve", "--unit", "1"],
        extra,
    ];
    si(&args.concat())
}

#[test]
fn serve_rejects_seven_data_bits_with_0e20h() {
    let o = serve_on_null(&["--data-bits", "7"], &[]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("16#0E20"), "{}", stderr(&o));
}

/// The `--long` flags a subcommand's help lists.
fn flags(sub: &str) -> Vec<String> {
    let o = si(&["modbus", sub, "--help"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let mut v: Vec<String> = stdout(&o)
        .split_whitespace()
        .filter(|w| w.starts_with("--"))
        .map(|w| {
            w.trim_end_matches(|c: char| !c.is_ascii_alphanumeric())
                .to_owned()
        })
        .collect();
    v.sort();
    v.dedup();
    v
}

/// Every framing option `si modbus read` takes is also a flag on `serve`.
#[test]
fn serve_takes_every_framing_flag_read_takes() {
    let (read, serve) = (flags("read"), flags("serve"));
    // Master-only job options: which slave (on a serial line or a Modbus TCP server), how long
    // to wait, how often to retry or poll, what to read, and how to show it.
    let master_only = [
        "--unit",
        "--modbus-tcp",
        "--response-timeout-ms",
        "--retries",
        "--poll",
        "--cycles",
        "--addr",
        "--base",
        "--count",
        "--format",
        "--word-order",
        "--timestamps",
        "--help",
    ];
    for f in read.iter().filter(|f| !master_only.contains(&f.as_str())) {
        assert!(serve.contains(f), "serve lacks {f}: {serve:?}");
    }
    for f in ["--mode", "--char-delay-multiplier", "--frame-end"] {
        assert!(serve.contains(&f.to_owned()), "serve lacks {f}");
    }
}

/// [Modbus/USS] §3.3.5, Table 3-11: fMUL is 1–10; 11 is refused with 0E21H before the port is
/// opened.
#[test]
fn serve_refuses_a_char_delay_multiplier_out_of_range_with_0e21h() {
    let o = serve_on_null(&[], &["--char-delay-multiplier", "11"]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(err.contains("16#0E21") && err.contains("11"), "{err}");
}

/// [Modbus/USS] §3.3.5, Table 3-11: tZVZ = tZVZ_TAB × fMUL; at 9600 bit/s 4 ms × 3 = 12 ms.
#[test]
fn serve_char_delay_multiplier_sets_the_gap() {
    let Some(pair) = common::pty_pair() else {
        return;
    };
    let (_serve, banner, _) =
        common::modbus::serve(&pair.a, &[], &["--char-delay-multiplier", "3"]);
    assert!(banner.contains("end-of-frame gap 12 ms"), "{banner}");
}

#[test]
fn serve_config_errors_name_the_file_and_field() {
    let dir = std::env::temp_dir().join(format!("si-modbus-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("bad.toml");
    std::fs::write(&path, "[conversion]\nm_fromm = 1\n").unwrap();
    let o = serve_on_null(&[], &["--config", path.to_str().unwrap()]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("m_fromm"), "{}", stderr(&o));
    // [Modbus/USS] §3.4.3, §3.5.4, §3.6: an operating mode other than the two is 0E22H, driver not
    // ready.
    std::fs::write(&path, "mode = \"fast\"\n").unwrap();
    let o = serve_on_null(&[], &["--config", path.to_str().unwrap()]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(
        err.contains("bad.toml") && err.contains("\"fast\"") && err.contains("16#0E22"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// `read`'s usage errors name the value, and come before any port is opened (none
/// is given here).
#[test]
fn read_usage_errors_name_the_value() {
    let cases: [(&[&str], &str); 7] = [
        (&["holding", "--addr", "0", "--base", "1"], "--addr 0"),
        (&["holding", "--count", "3", "--format", "f32"], "--count 3"),
        (&["holding", "--addr", "0x10000"], "--addr 65536 is past"),
        (&["holding", "--addr", "0x10001"], "0x10001"),
        (&["holding", "--addr", "65535", "--count", "2"], "65536"),
        (&["coils", "--format", "hex"], "coils"),
        (&["holding", "--cycles", "3"], "--poll"),
    ];
    for (args, named) in cases {
        let o = si(&[&["modbus", "read", "--unit", "1"][..], args].concat());
        assert!(!o.status.success(), "{args:?} passed");
        assert!(stderr(&o).contains(named), "{args:?}: {}", stderr(&o));
    }
}
