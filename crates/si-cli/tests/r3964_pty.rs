//! `si 3964r recv` in one process receives what `si 3964r send` sends in another, over a
//! pseudo-terminal pair made by socat (`apt-get install socat`); skips with a message when socat
//! is missing.

use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};
use std::time::Duration;

struct Kill(Child);
impl Drop for Kill {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Start socat and read the two pty names it prints.
fn pty_pair() -> Option<(Kill, String, String)> {
    let mut child = Command::new("socat")
        .args([
            "-d",
            "-d",
            "pty,raw,echo=0,ignoreeof",
            "pty,raw,echo=0,ignoreeof",
        ])
        .stderr(Stdio::piped())
        .spawn()
        .ok()?;
    let stderr = child.stderr.take()?;
    let mut names = Vec::new();
    for line in BufReader::new(stderr).lines() {
        let line = line.ok()?;
        if let Some(i) = line.find("PTY is ") {
            names.push(line[i + 7..].trim().to_owned());
            if names.len() == 2 {
                break;
            }
        }
    }
    let b = names.pop()?;
    let a = names.pop()?;
    Some((Kill(child), a, b))
}

#[test]
fn recv_gets_what_send_sends_and_both_exit_0() {
    let Some((_socat, a, b)) = pty_pair() else {
        eprintln!("SKIPPED: socat not found (apt-get install socat)");
        return;
    };
    let si = env!("CARGO_BIN_EXE_si");
    let recv = Command::new(si)
        .args(["--json", "--port", &b, "3964r", "recv", "--count", "2"])
        .args(["--priority", "low"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start recv");
    // If the test fails early, killing socat closes the pty and recv exits with an error.
    std::thread::sleep(Duration::from_millis(300));

    // A block with a DLE in it (doubled on the line) and one given as text.
    for args in [vec!["41 42 10 43"], vec!["--text", "hello over a pty"]] {
        let o = Command::new(si)
            .args(["--port", &a, "3964r", "send", "--priority", "high"])
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
    let Some((_socat, a, _b)) = pty_pair() else {
        eprintln!("SKIPPED: socat not found (apt-get install socat)");
        return;
    };
    let o = Command::new(env!("CARGO_BIN_EXE_si"))
        .args(["--port", &a, "3964r", "send", "01", "--qvz-ms", "50"])
        .args(["--connection-attempts", "2"])
        .output()
        .expect("run send");
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("16#0703"), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
}
