//! `si uss poll` against `si uss sim-slave` over a pseudo-terminal pair made by socat
//! (`apt-get install socat`); skips with a message when socat is missing (fails with `CI` set).

use std::process::Stdio;
use std::time::{Duration, Instant};

use crate::common;

use common::{opened, pty_pair, pty_pair_ignoreeof, si_command, Kill};

/// `si uss sim-slave --address <address> <extra…> --port <port>`, given 300 ms to open the port.
fn drive(port: &str, address: &str, extra: &[&str]) -> Kill {
    let slave = Kill(
        si_command()
            .args(["uss", "sim-slave", "--address", address])
            .args(extra)
            .args(["--port", port])
            .stdout(Stdio::null())
            .spawn()
            .expect("start sim-slave"),
    );
    opened(&slave.0, port);
    slave
}

/// `si uss <args…> --slave <address> --response-timeout-ms 500 --port <port>`: success, stdout
/// and stderr, trimmed.
fn job(port: &str, address: &str, args: &[&str]) -> (bool, String, String) {
    let o = si_command()
        .arg("uss")
        .args(args)
        .args([
            "--slave",
            address,
            "--response-timeout-ms",
            "500",
            "--port",
            port,
        ])
        .output()
        .expect("run si");
    (
        o.status.success(),
        String::from_utf8_lossy(&o.stdout).trim().to_owned(),
        String::from_utf8_lossy(&o.stderr).trim().to_owned(),
    )
}

#[test]
fn poll_shows_changing_status_words_from_a_simulated_drive() {
    let Some(pair) = pty_pair() else { return };
    let (a, b) = (&pair.a, &pair.b);
    let _slave = drive(b, "3", &[]);
    let started = Instant::now();
    let o = si_command()
        .args([
            "--json",
            "uss",
            "poll",
            "--slaves",
            "3",
            "--stw",
            "0x047F",
            "--hsw",
            "2000",
            "--cycles",
            "40",
            "--response-timeout-ms",
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
    // The drive runs (ZSW bit 2) and its actual value ramps to the setpoint 2000 ...
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
    let _slave = drive(b, "5", &[]);
    let run = |args: &[&str]| job(a, "5", args);
    let (ok, out, err) = run(&["read-param", "700"]);
    assert!(ok, "{err}");
    assert_eq!(out, "slave 5 P700:0 = 5 (response ID 1)");

    let (ok, _, err) = run(&["write-param", "1082", "120"]);
    assert!(ok, "{err}");
    let (_, out, _) = run(&["read-param", "1082"]);
    assert_eq!(out, "slave 5 P1082:0 = 120 (response ID 1)");

    let (ok, _, err) = run(&["write-param", "1082", "1000"]);
    assert!(!ok);
    assert!(err.starts_with("si: error: node 5: 16#1503"), "{err}");
    assert!(
        err.contains("error number 2 (lower or upper value limit exceeded)"),
        "{err}"
    );
}

/// Lines of a `--record` trace that are telegrams the recording side sent.
fn telegrams_sent(trace: &std::path::Path) -> usize {
    std::fs::read_to_string(trace)
        .unwrap_or_default()
        .lines()
        .filter(|l| l.contains(r#""kind":"tx""#))
        .count()
}

#[test]
fn an_absent_node_gets_1_plus_wdh_telegrams_and_no_stray_one_and_the_run_fails() {
    let Some(pair) = pty_pair() else { return };
    let dir = common::test_dir("si-uss-absent");
    // Nobody answers on the other end.
    let trace = dir.join("read.jsonl");
    let o = si_command()
        .args(["--port", &pair.a, "--record"])
        .arg(&trace)
        .args(["uss", "read-param", "700", "--slave", "4", "--retries", "2"])
        .output()
        .expect("run read-param");
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.starts_with("si: error: node 4: 16#1408"), "{err}");
    assert_eq!(
        telegrams_sent(&trace),
        3,
        "first telegram + WDH 2, nothing after"
    );

    let trace = dir.join("poll.jsonl");
    let o = si_command()
        .args(["--port", &pair.a, "--record"])
        .arg(&trace)
        .args(["uss", "poll", "--slaves", "4", "--cycles", "3"])
        .output()
        .expect("run poll");
    assert_eq!(o.status.code(), Some(1), "{o:?}");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("node 4 never answered"), "{err}");
    assert_eq!(
        telegrams_sent(&trace),
        3,
        "3 cycles × 1 node, nothing after"
    );
}

#[test]
fn refusal_negative_values_pages_and_arrays_against_a_simulated_drive() {
    let Some(pair) = pty_pair_ignoreeof() else {
        return;
    };
    let (a, b) = (&pair.a, &pair.b);
    let slave = drive(b, "6", &[]);
    let run = |args: &[&str]| job(a, "6", args);
    // A negative word, read back signed and in hex.
    let (ok, out, err) = run(&["write-param", "1120", "-5"]);
    assert!(ok, "{err}");
    assert_eq!(out, "slave 6 P1120:0 := -5 done");
    let (_, out, _) = run(&["read-param", "1120", "--signed"]);
    assert_eq!(out, "slave 6 P1120:0 = -5 (response ID 1)");
    let (_, out, _) = run(&["read-param", "1120"]);
    assert_eq!(out, "slave 6 P1120:0 = 65531 (response ID 1)");
    let (_, out, _) = run(&["read-param", "0x460", "--hex"]);
    assert_eq!(out, "slave 6 P1120:0 = 16#FFFB (response ID 1)");
    // Above 19999 through the page index; an array element with task 7.
    let (ok, _, err) = run(&["write-param", "20001", "16#2A"]);
    assert!(ok, "{err}");
    let (_, out, _) = run(&["read-param", "20001"]);
    assert_eq!(out, "slave 6 P20001:0 = 42 (response ID 1)");
    let (ok, _, err) = run(&["write-param", "2010", "3", "--array", "--index", "1"]);
    assert!(ok, "{err}");
    let (_, out, _) = run(&["read-param", "2010:1", "--array"]);
    assert_eq!(out, "slave 6 P2010:1 = 3 (response ID 4)");
    let (ok, _, err) = run(&["read-param", "62000"]);
    assert!(!ok);
    assert!(err.contains("62000 is out of range: 0 … 61999"), "{err}");
    drop(slave);

    // The same drive without PKW rights: response ID 8, not "node does not answer".
    let _slave = drive(b, "6", &["--no-pkw-rights"]);
    let (ok, _, err) = run(&["read-param", "700"]);
    assert!(!ok);
    assert!(err.starts_with("si: error: node 6: 16#1505"), "{err}");
}

/// (AK, PKE) of every telegram a `--record` trace shows the recording side sending.
fn pkw_sent(trace: &std::path::Path) -> Vec<(u8, u16)> {
    std::fs::read_to_string(trace)
        .unwrap_or_default()
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .filter(|v| v["kind"] == "tx")
        .map(|v| {
            let b: Vec<u8> = v["bytes"]
                .as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_u64().unwrap() as u8)
                .collect();
            let pke = u16::from_be_bytes([b[3], b[4]]);
            ((pke >> 12) as u8, pke & 0x7FF)
        })
        .collect()
}

#[test]
fn poll_with_a_read_sends_task_0_after_it_or_with_pkw_repeat_the_read_again() {
    let Some(pair) = pty_pair_ignoreeof() else {
        return;
    };
    let (a, b) = (&pair.a, &pair.b);
    let _slave = drive(b, "7", &[]);
    let dir = common::test_dir("si-uss-pkw-repeat");
    for (repeat, want) in [
        (false, [(1, 700), (0, 0), (0, 0), (0, 0)]),
        (true, [(1, 700); 4]),
    ] {
        let trace = dir.join(format!("poll-{repeat}.jsonl"));
        let mut cmd = si_command();
        cmd.args(["--port", a, "--record"]).arg(&trace).args([
            "uss",
            "poll",
            "--slaves",
            "7",
            "--cycles",
            "4",
            "--read-param",
            "700",
            "--response-timeout-ms",
            "500",
        ]);
        if repeat {
            cmd.arg("--pkw-repeat");
        }
        let o = cmd.output().expect("run poll");
        let text = String::from_utf8_lossy(&o.stdout);
        assert!(
            o.status.success(),
            "{text}{}",
            String::from_utf8_lossy(&o.stderr)
        );
        assert!(
            text.contains("slave 7 P700:0 = 5 (response ID 1)"),
            "{text}"
        );
        assert_eq!(pkw_sent(&trace), want, "--pkw-repeat {repeat}");
    }
    // Node 8 is not there: the run fails and names it, node 7's lines are printed.
    let o = si_command()
        .args([
            "--port", a, "uss", "poll", "--slaves", "7,8", "--cycles", "2",
        ])
        .args(["--response-timeout-ms", "500"])
        .output()
        .expect("run poll");
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("node 8 never answered (no valid response in 2 cycles)"),
        "{err}"
    );
    assert!(String::from_utf8_lossy(&o.stdout).contains("cycle 1 slave 7: ZSW"));
}
