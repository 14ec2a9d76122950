//! The `si` binary as a user meets it: help, version, offline frames, one-line errors.

use std::process::{Command, Output};

fn si(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_si"))
        .args(args)
        .output()
        .expect("run si")
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn help_lists_the_subcommands() {
    let o = si(&["--help"]);
    assert!(o.status.success());
    let text = stdout(&o);
    for sub in ["ports", "frame", "sim", "3964r", "--port", "--tcp", "--baud", "--json"] {
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
    assert_eq!(stdout(&o).trim(), format!("si {}", env!("CARGO_PKG_VERSION")));
}

#[test]
fn bad_hex_is_one_line_naming_the_position() {
    let o = si(&["frame", "decode", "3964r", "10 03 0G"]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("'G' at position 7"), "{err}");
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
    let o = si(&["--port", "/dev/null", "--baud", "9601", "3964r", "send", "01"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("baud rate 9601"), "{}", stderr(&o));
}
