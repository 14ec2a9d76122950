//! The `si` binary as a user meets it: help, version, offline frames, one-line errors.

use crate::common;

use common::{si, stderr, stdout};

#[test]
fn help_lists_the_subcommands() {
    let o = si(&["--help"]);
    assert!(o.status.success());
    let text = stdout(&o);
    for sub in [
        "ports", "frame", "sim", "3964r", "--port", "--tcp", "--baud", "--json",
    ] {
        assert!(text.contains(sub), "--help lacks {sub}:\n{text}");
    }
    let o = si(&["frame", "--help"]);
    assert!(o.status.success());
    let text = stdout(&o);
    assert!(text.contains("encode") && text.contains("decode"), "{text}");
}

#[test]
fn version_is_the_crate_version() {
    let o = si(&["--version"]);
    assert!(o.status.success());
    assert_eq!(
        stdout(&o).trim(),
        format!("si {}", env!("CARGO_PKG_VERSION"))
    );
}

#[test]
fn bad_hex_is_one_line_naming_the_position() {
    let o = si(&["frame", "decode", "3964r", "10 03 0G"]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("'G' at position 8"), "{err}");
}

#[test]
fn no_line_given_is_a_clear_error() {
    let o = si(&["3964r", "send", "01"]);
    assert!(!o.status.success());
    assert_eq!(
        stderr(&o).trim(),
        "si: error: no line given: use --port PATH or --tcp HOST:PORT"
    );
}

#[test]
fn bad_serial_settings_name_the_value() {
    let o = si(&[
        "--port",
        "/dev/null",
        "--baud",
        "9601",
        "3964r",
        "send",
        "01",
    ]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("baud rate 9601"), "{}", stderr(&o));
}

#[test]
fn sim_lists_its_scenarios_and_rejects_unknown_ones() {
    let o = si(&["sim"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(
        text.contains("line-timing") && text.contains("rs485-collision"),
        "{text}"
    );
    let o = si(&["sim", "no-such-thing"]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("unknown scenario \"no-such-thing\""), "{err}");
}

/// `si sim line-timing --json`: every character arrives at ceil(k × 11 / 9600 s) at 9600 8E1.
#[test]
fn sim_line_timing_prints_characters_at_their_character_times() {
    let o = si(&["--json", "--baud", "9600", "sim", "line-timing"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let arrivals: Vec<(u64, u64)> = stdout(&o)
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).expect("JSON line"))
        .filter(|v| v["kind"] == "rx" && v["station"] == "B")
        .map(|v| (v["at"].as_u64().unwrap(), v["byte"].as_u64().unwrap()))
        .collect();
    let expected: Vec<(u64, u64)> = (1..=10u64)
        .map(|k| ((k * 11 * 1_000_000).div_ceil(9600), u64::from(b'0') + k - 1))
        .collect();
    assert_eq!(arrivals, expected);
}

#[test]
fn sim_rs485_collision_garbles_every_character() {
    let o = si(&["sim", "rs485-collision"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(text.contains("rx error Framing"), "{text}");
    // Both senders' characters overlap in both character slots: the listener gets a framing
    // error for each of the four and not one clean character.
    assert!(
        text.contains("listener C: 4 garbled characters, 0 clean ones"),
        "{text}"
    );
}

/// USS allows 187 500 bit/s on top of the manuals' twelve rates; the other protocols do not.
#[test]
fn uss_accepts_187500_baud_and_3964r_refuses_it() {
    let o = si(&[
        "--port",
        "/nonexistent/tty",
        "--baud",
        "187500",
        "uss",
        "poll",
        "--slaves",
        "1",
    ]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(!err.contains("baud rate"), "{err}");
    assert!(err.contains("cannot open /nonexistent/tty"), "{err}");
    let o = si(&[
        "--port",
        "/nonexistent/tty",
        "--baud",
        "187500",
        "3964r",
        "send",
        "01",
    ]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("baud rate 187500"), "{}", stderr(&o));
}

/// Frame commands take the bytes as one quoted argument or as several words.
#[test]
fn frame_hex_may_be_one_argument_or_several_words() {
    let words = si(&[
        "frame", "encode", "modbus", "01", "03", "00", "00", "00", "0A",
    ]);
    let quoted = si(&["frame", "encode", "modbus", "01 03 00 00 00 0A"]);
    assert!(words.status.success(), "{}", stderr(&words));
    assert_eq!(stdout(&words), stdout(&quoted));
    assert_eq!(stdout(&words).trim(), "01 03 00 00 00 0A C5 CD");
}
