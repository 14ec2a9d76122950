//! `si 3964r recv` in one process receives what `si 3964r send` sends in another, over a
//! pseudo-terminal pair made by socat (`apt-get install socat`); skips with a message when socat
//! is missing (fails with `CI` set).

use std::process::Stdio;

use crate::common;

use common::{opened, pty_pair_ignoreeof, si_command};

#[test]
fn recv_gets_what_send_sends_and_both_exit_0() {
    let Some(pair) = pty_pair_ignoreeof() else {
        return;
    };
    let (a, b) = (&pair.a, &pair.b);
    let recv = si_command()
        .args(["--json", "--port", b, "3964r", "recv", "--count", "2"])
        .args(["--priority", "low"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start recv");
    // If the test fails early, killing socat closes the pty and recv exits with an error.
    opened(&recv, b);

    // A block with a DLE in it (doubled on the line) and one given as text.
    for args in [vec!["41 42 10 43"], vec!["--text", "hello over a pty"]] {
        let o = si_command()
            .args(["--port", a, "3964r", "send", "--priority", "high"])
            .args(&args)
            .output()
            .expect("run send");
        assert!(
            o.status.success(),
            "send {args:?} failed: {}{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        );
        assert!(String::from_utf8_lossy(&o.stdout).contains("16#0000"));
    }

    let o = recv.wait_with_output().expect("recv ends");
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "recv failed: {text}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let lines: Vec<serde_json::Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).expect("JSON line"))
        .collect();
    assert_eq!(lines.len(), 2, "{text}");
    assert_eq!(lines[0]["hex"], "41 42 10 43");
    assert_eq!(lines[1]["text"], "hello over a pty");
}

#[test]
fn send_without_a_partner_fails_with_0703() {
    let Some(pair) = pty_pair_ignoreeof() else {
        return;
    };
    let a = &pair.a;
    let o = si_command()
        .args(["--port", a, "3964r", "send", "01", "--ack-delay-ms", "50"])
        .args(["--connection-attempts", "2"])
        .output()
        .expect("run send");
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("16#0703"), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
}
