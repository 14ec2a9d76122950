//! The exit codes `si --help` documents: 0 done, 1 protocol or I/O failure, 2 usage,
//! 130 interrupted. Usage errors found by si's own checks exit 2 like clap's, before any port
//! is opened: every command here names a port that does not exist, so reaching it would be
//! exit 1 ("cannot open"). Ctrl-C (130) and a closed line (1) are in tests/pty/lost_line.rs.

use crate::common;

use common::{si, stderr, stdout};

/// No such port: opening it is an I/O failure (exit 1), so exit 2 proves it was never opened.
const NO_PORT: &str = "/nonexistent/tty-si-exit-codes";

/// Exit code and the one stderr line of `si --port NO_PORT <args…>`.
fn run(args: &[&str]) -> (Option<i32>, String) {
    let o = si(&[&["--port", NO_PORT][..], args].concat());
    let err = stderr(&o);
    assert_eq!(err.lines().count(), 1, "{args:?}: {err}");
    (o.status.code(), err.trim().to_owned())
}

#[test]
fn help_documents_the_exit_codes() {
    let o = si(&["--help"]);
    assert_eq!(o.status.code(), Some(0));
    let text = stdout(&o);
    let codes = &text[text.find("Exit codes:").expect("an Exit codes section")..];
    for line in [
        "0    done",
        "1    protocol or I/O failure",
        "2    usage",
        "130  interrupted (Ctrl-C, SIGINT)",
    ] {
        assert!(codes.contains(line), "{line:?} missing:\n{codes}");
    }
}

#[test]
fn an_io_failure_exits_1() {
    let (code, err) = run(&[
        "modbus", "read", "holding", "--unit", "1", "--addr", "0", "--count", "1",
    ]);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains(NO_PORT), "{err}");
}

#[test]
fn clap_usage_errors_exit_2() {
    let o = si(&["modbus", "read", "holding", "--addr", "0"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    // --timeout bounds a counted receive only.
    let o = si(&["--port", NO_PORT, "ascii", "recv", "--timeout", "1"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}

#[test]
fn modbus_address_and_format_checks_are_usage_errors() {
    for (args, text) in [
        (
            &["--addr", "65535", "--count", "2"][..],
            "--addr 65535 with 2 items runs to 65536, past the last address 65535",
        ),
        (
            &["--addr", "0", "--base", "1", "--count", "1"][..],
            "--addr 0 does not exist with --base 1",
        ),
        (
            &["--addr", "0", "--count", "3", "--format", "f32"][..],
            "--format f32 takes 2 registers per value, and --count 3 is odd",
        ),
    ] {
        let (code, err) = run(&[&["modbus", "read", "holding", "--unit", "1"][..], args].concat());
        assert_eq!(code, Some(2), "{args:?}: {err}");
        assert!(err.starts_with(&format!("si: error: {text}")), "{err}");
    }
    let (code, err) = run(&[
        "modbus", "read", "coils", "--unit", "1", "--addr", "0", "--count", "2", "--format", "u16",
    ]);
    assert_eq!(code, Some(2), "{err}");
    let (code, err) = run(&[
        "modbus", "write", "register", "--unit", "1", "--addr", "0", "1", "2",
    ]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("takes exactly one value, got 2"), "{err}");
}

#[test]
fn rk512_send_without_db_is_a_usage_error_not_a_write_to_db1() {
    let (code, err) = run(&["rk512", "send", "01 02"]);
    assert_eq!(code, Some(2), "{err}");
    assert_eq!(
        err,
        "si: error: --db N is required with --area db or dx (the data block to use)"
    );
    // Areas addressed by --start need no DB: the error is then the missing port.
    let (code, _) = run(&["rk512", "fetch", "--area", "m", "--count", "1"]);
    assert_eq!(code, Some(1));
}

#[test]
fn rk512_1e41_names_the_allowed_range_and_the_value() {
    let range = "1 … 1024 bytes, even for D, X, T and Z";
    let (code, err) = run(&["rk512", "fetch", "--db", "10", "--count", "0"]);
    assert_eq!(code, Some(2), "{err}");
    assert_eq!(
        err,
        format!(
            "si: error: 16#1E41 invalid number of bytes in the FB's LEN: invalid length 0: {range}"
        )
    );
    let (code, err) = run(&["rk512", "send", "--db", "10", "01 02 03"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.ends_with(&format!("invalid length 3: {range}")),
        "{err}"
    );
    let (code, err) = run(&["rk512", "fetch", "--db", "10", "--count", "513"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.ends_with(&format!("invalid length 1026: {range}")),
        "{err}"
    );
}

#[test]
fn other_argument_checks_are_usage_errors() {
    for line in [
        "uss read-param --slave 3 62000",
        "uss write-param --slave 3 1082 70000",
        "uss sim-slave --address 3 --pkw-words 2",
        "rk512 fetch --db 1 --count 1 --cpu 9",
        // Values a library refuses: the baud rate list, the manual's parameter ranges.
        "--baud 1234 3964r recv",
        "--parity sometimes ascii recv",
        "--baud 1200 ascii recv --char-delay-ms 10",
        "3964r recv --char-delay-ms 0",
        "rk512 fetch --db 1 --count 1 --response-timeout-ms 0",
        "modbus read holding --unit 1 --addr 0 --count 1 --response-timeout-ms 1",
    ] {
        let args: Vec<&str> = line.split_whitespace().collect();
        let (code, err) = run(&args);
        assert_eq!(code, Some(2), "{line}: {err}");
    }
}
