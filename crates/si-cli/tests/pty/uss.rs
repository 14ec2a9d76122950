//! `si uss poll` against `si uss sim-slave` over a pseudo-terminal pair made by socat
//! (`apt-get install socat`); skips with a message when socat is missing (fails with `CI` set).

use std::process::Stdio;
use std::time::{Duration, Instant};

use crate::common;

use common::{pty_pair, si_command, Kill};

#[test]
fn poll_shows_changing_status_words_from_a_simulated_drive() {
    let Some(pair) = pty_pair() else { return };
    let (a, b) = (&pair.a, &pair.b);
    let _slave = Kill(
        si_command()
            .args(["uss", "sim-slave", "--address", "3", "--port", b])
            .stdout(Stdio::null())
            .spawn()
            .expect("start sim-slave"),
    );
    std::thread::sleep(Duration::from_millis(300));
    let started = Instant::now();
    let o = si_command()
        .args([
            "--json",
            "uss",
            "poll",
            "--slaves",
            "3",
            "--stw",
            "047F",
            "--hsw",
            "07D0",
            "--cycles",
            "40",
            "--response-timeout",
            "500",
            "--port",
            a,
        ])
        .output()
        .expect("run poll");
    assert!(started.elapsed() < Duration::from_secs(60));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{text}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let lines: Vec<serde_json::Value> = text
        .lines()
        .filter_map(|l| serde_json::from_str(l).ok())
        .collect();
    let responses: Vec<(u64, u64)> = lines
        .iter()
        .filter(|v| v["slave"] == 3 && v["zsw"].is_u64())
        .map(|v| (v["zsw"].as_u64().unwrap(), v["hiw"].as_u64().unwrap()))
        .collect();
    assert!(responses.len() >= 30, "{text}");
    // The drive runs (ZSW bit 2) and its actual value ramps to the setpoint 2000 (07D0H) ...
    assert!(
        responses.iter().all(|(z, _)| z & 0x0004 != 0),
        "{responses:?}"
    );
    let last = responses.last().unwrap();
    assert!(responses[0].1 < 2000, "{responses:?}");
    assert_eq!(last.1, 2000, "{responses:?}");
    // ... so the status word changes: "setpoint reached" (bit 10) comes on.
    assert_eq!(responses[0].0 & 0x0400, 0, "{responses:?}");
    assert_ne!(last.0 & 0x0400, 0, "{responses:?}");
}

#[test]
fn read_and_write_param_against_a_simulated_drive_with_an_ak7_refusal() {
    let Some(pair) = pty_pair() else { return };
    let (a, b) = (&pair.a, &pair.b);
    let _slave = Kill(
        si_command()
            .args(["uss", "sim-slave", "--address", "5", "--port", b])
            .stdout(Stdio::null())
            .spawn()
            .expect("start sim-slave"),
    );
    std::thread::sleep(Duration::from_millis(300));
    let run = |args: &[&str]| {
        let mut all = vec!["uss"];
        all.extend_from_slice(args);
        all.extend_from_slice(&["--slave", "5", "--response-timeout", "500", "--port", a]);
        si_command().args(&all).output().expect("run si")
    };
    let o = run(&["read-param", "700"]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert_eq!(text.trim(), "slave 5 P700:0 = 5 (response ID 1)");

    let o = run(&["write-param", "1082", "120"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = run(&["read-param", "1082"]);
    assert_eq!(
        String::from_utf8_lossy(&o.stdout).trim(),
        "slave 5 P1082:0 = 120 (response ID 1)"
    );

    let o = run(&["write-param", "1082", "1000"]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.starts_with("si: error: 16#1503"), "{err}");
    assert!(
        err.contains("error number 2 (lower or upper value limit exceeded)"),
        "{err}"
    );
}
