//! `-v`/`-vv` on a real exchange: `si modbus read` against `si modbus serve` over a
//! pseudo-terminal pair. The logs go to stderr, each line with its wall-clock time; without
//! `-v` nothing is logged, and stderr (a pipe here) never gets a colour escape.

use crate::common;

use common::modbus::{self, served};
use common::{pty_pair, stderr, stdout};

const LINE: &[&str] = &["--baud", "19200"];
const READ: &[&str] = &[
    "modbus", "read", "--unit", "1", "--addr", "0", "--count", "2", "holding",
];

/// An RFC 3339 UTC time at the start of a log line: `2026-11-25T16:22:35.663177Z`.
fn stamped(line: &str) -> bool {
    let b = line.as_bytes();
    let digits = |r: std::ops::Range<usize>| {
        r.into_iter()
            .all(|i| b.get(i).is_some_and(u8::is_ascii_digit))
    };
    digits(0..4)
        && b.get(4) == Some(&b'-')
        && b.get(10) == Some(&b'T')
        && digits(11..13)
        && b.get(19) == Some(&b'.')
        && line
            .split_whitespace()
            .next()
            .is_some_and(|t| t.ends_with('Z'))
}

#[test]
fn v_logs_each_frame_decoded_with_its_time_vv_adds_hex_and_events() {
    let Some(pair) = pty_pair() else { return };
    let (_serve, _, log) = modbus::serve(&pair.a, LINE, &[]);

    let quiet = modbus::si_on(&pair.b, LINE, READ);
    assert!(
        quiet.status.success(),
        "{}{}",
        stdout(&quiet),
        stderr(&quiet)
    );
    assert_eq!(stderr(&quiet), "", "no log lines without -v");

    let v = modbus::si_on(&pair.b, LINE, &[&["-v"], READ].concat());
    assert!(v.status.success(), "{}", stderr(&v));
    assert!(stdout(&v).contains("unit 1 FC03"), "{}", stdout(&v));
    let logs = stderr(&v);
    assert!(!logs.contains('\x1b'), "no colour into a pipe: {logs:?}");
    let sent = logs.lines().find(|l| l.contains("sent FC03 req"));
    let received = logs.lines().find(|l| l.contains("received FC03 resp"));
    for line in [sent, received] {
        let line = line.unwrap_or_else(|| panic!("both frames logged:\n{logs}"));
        assert!(stamped(line), "a wall-clock time first: {line}");
        assert!(line.contains("INFO"), "{line}");
    }
    assert!(!logs.contains("DEBUG"), "-v is INFO only:\n{logs}");

    let vv = modbus::si_on(&pair.b, LINE, &[&["-vv"], READ].concat());
    assert!(vv.status.success(), "{}", stderr(&vv));
    let logs = stderr(&vv);
    // FC03, unit 1, address 0, 2 registers, CRC: the raw request, and the engine's event.
    assert!(logs.contains("tx 01 03 00 00 00 02"), "{logs}");
    assert!(logs.contains("event Completed"), "{logs}");
    assert!(!logs.contains("TRACE"), "-vv stops at DEBUG:\n{logs}");
    assert!(!logs.contains("mio"), "only si's logs are raised:\n{logs}");

    let vvv = modbus::si_on(&pair.b, LINE, &[&["-vvv"], READ].concat());
    let logs = stderr(&vvv);
    assert!(logs.contains("TRACE") && logs.contains("timer"), "{logs}");
    assert!(!logs.contains("mio"), "only si's logs are raised:\n{logs}");
    assert_eq!(served(&log).matches("served FC03").count(), 4);
}
