//! `si rk512 fetch` against `si rk512 serve` over a pseudo-terminal pair returns what
//! `si rk512 send` wrote ([CP 341] §2.2.3); socat makes the pair
//! (`apt-get install socat`); the test skips with a message when socat is missing (fails with
//! `CI` set).

use std::io::Write;
use std::process::{Command, Stdio};

use crate::common;

use common::{opened, pty_pair_ignoreeof, si, si_command, test_dir, text, Kill};

#[test]
fn fetch_returns_what_send_wrote_to_serve() {
    let Some(pair) = pty_pair_ignoreeof() else {
        return;
    };
    let (a, b) = (&pair.a, &pair.b);
    let config = test_dir("si-rk512-pty").join("serve.toml");
    let mut f = std::fs::File::create(&config).unwrap();
    writeln!(
        f,
        "[memory]\nflags = 256\n[[db]]\nnumber = 10\nlength = 1024"
    )
    .unwrap();
    drop(f);
    let serve = si_command()
        .args(["--json", "--port", b, "rk512", "serve", "--count", "3"])
        .args(["--config", config.to_str().unwrap()])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start serve");
    let serve = Kill(serve);
    opened(&serve.0, b);

    // 150 bytes: a first telegram of 128 bytes and a continuation; a DLE (10H) in the data.
    let data: Vec<String> = (0..150u32)
        .map(|i| format!("{:02X}", (i * 7) % 256))
        .collect();
    let hex = data.join(" ");
    let o = si(&[
        "--port", a, "rk512", "send", "--db", "10", "--dw", "4", &hex,
    ]);
    assert!(o.status.success(), "send: {}", text(&o));
    assert!(text(&o).contains("16#0000"), "{}", text(&o));

    let o = si(&[
        "--json", "--port", a, "rk512", "fetch", "--db", "10", "--dw", "4", "--count", "75",
    ]);
    assert!(o.status.success(), "fetch: {}", text(&o));
    let line: serde_json::Value =
        serde_json::from_str(String::from_utf8_lossy(&o.stdout).trim()).expect("JSON line");
    assert_eq!(line["hex"], hex.as_str());
    assert_eq!(line["len"], 150);

    // A job the server refuses: DB 99 does not exist (error number 14H, STATUS 16#0903).
    let o = si(&["--port", a, "rk512", "fetch", "--db", "99", "--count", "1"]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("16#0903"), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");

    let mut serve = serve;
    let o = std::mem::replace(&mut serve.0, Command::new("true").spawn().unwrap());
    let o = o.wait_with_output().expect("serve ends");
    let out = text(&o);
    assert!(o.status.success(), "serve: {out}");
    let lines: Vec<serde_json::Value> = String::from_utf8_lossy(&o.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).expect("JSON line"))
        .collect();
    assert_eq!(lines.len(), 3, "{out}");
    assert_eq!(lines[0]["served"], "SEND");
    assert_eq!(lines[0]["address"], "DB10.DW4");
    assert_eq!(lines[1]["served"], "FETCH");
    assert_eq!(lines[2]["refused"], 0x14);
    // The server reports its own side's code: DB 99 missing is 0606 (the requester's 0903).
    assert_eq!(lines[2]["status"], 0x0606);
}

#[test]
fn fetch_without_a_partner_fails_with_the_3964r_status() {
    let Some(pair) = pty_pair_ignoreeof() else {
        return;
    };
    let a = &pair.a;
    let o = si(&[
        "--port",
        a,
        "rk512",
        "fetch",
        "--area",
        "m",
        "--count",
        "1",
        "--ack-delay-ms",
        "50",
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    // [CP 341 Diag]: the link's 0703, then the job's 051A, on one line.
    let at = |code: &str| err.find(code).unwrap_or_else(|| panic!("{code} in {err}"));
    assert!(at("16#0703") < at("16#051A"), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
}
