//! `si 3964r probe` on a pty pair: a receiving `si 3964r recv` answers STX with DLE; a line
//! with nobody on it answers nothing. Both runs end within the time announced first.

use crate::common;

use common::{opened, pty_pair_ignoreeof, si_command, stdout, text, Kill};
use std::process::Stdio;
use std::time::{Duration, Instant};

/// `si --json --port PORT 3964r probe ARGS`: its JSON lines and how long it ran.
fn probe(port: &str, args: &[&str]) -> (Vec<serde_json::Value>, Duration, String) {
    let started = Instant::now();
    let o = si_command()
        .args(["--json", "--port", port, "3964r", "probe"])
        .args(args)
        .output()
        .expect("run si");
    let took = started.elapsed();
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    let lines = stdout(&o)
        .lines()
        .map(|l| serde_json::from_str(l).expect("JSON line"))
        .collect();
    (lines, took, t)
}

#[test]
fn a_receiving_partner_answers_stx_with_dle_within_the_announced_time() {
    let Some(pair) = pty_pair_ignoreeof() else {
        return;
    };
    let _partner = Kill(
        si_command()
            .args(["--port", &pair.b, "3964r", "recv"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("start recv"),
    );
    // The partner opens its port (its own STX comes only when it sends).
    opened(&_partner.0, &pair.b);
    let (lines, took, t) = probe(&pair.a, &["--ack-delay-ms", "500"]);
    let bound = lines[0]["bound_ms"].as_u64().expect("the announced bound");
    assert_eq!(lines.len(), 2, "{t}");
    assert_eq!(lines[1]["reply"], 0x10, "{t}");
    assert_eq!(lines[1]["ready"], true, "{t}");
    assert!(
        took.as_millis() as u64 <= bound,
        "took {took:?}, announced {bound} ms"
    );
}

#[test]
fn a_line_without_a_partner_answers_nothing() {
    let Some(pair) = pty_pair_ignoreeof() else {
        return;
    };
    let (lines, took, t) = probe(&pair.a, &["--ack-delay-ms", "200"]);
    let bound = lines[0]["bound_ms"].as_u64().expect("the announced bound");
    assert_eq!(lines[1]["reply"], serde_json::Value::Null, "{t}");
    assert_eq!(lines[1]["ready"], false, "{t}");
    assert!(
        took.as_millis() as u64 <= bound,
        "took {took:?}, announced {bound} ms"
    );
}
