//! A noise test per role: servers are flooded, then answer a valid request. Each
//! server role (`si modbus serve`, `si uss sim-slave`, `si rk512 serve`) runs on one end of a
//! socat pty pair; a client stores known data, the noise peer floods the client's end with 01H
//! for about 2 s and stops, and after a pause to settle the same client reads the data back:
//! the server must answer with it and still be running. The flood and the pause are plain
//! durations and each client ends within its own timeout: nothing here claims a timing. Skips
//! without socat (fails with `CI` set).

use std::io::Write;
use std::process::{Output, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use crate::common;

use common::modbus;
use common::noise::{noise_peer, one_at_a_time, Noise};
use common::{opened, pty_pair, pty_pair_ignoreeof, si, si_command, test_dir, text, Kill};

/// How long the flood lasts (the issue: "flooded").
const FLOOD: Duration = Duration::from_secs(2);

/// The pause after the flood: the server reads what is left in the pty and drops it.
const SETTLE: Duration = Duration::from_millis(500);

/// Floods `port` (the client's end of the pair) with 01H for [`FLOOD`], stops the noise peer
/// and waits [`SETTLE`].
fn flood(port: &str) {
    let stop = Arc::new(AtomicBool::new(false));
    noise_peer(port, Noise::Flood, stop.clone());
    std::thread::sleep(FLOOD);
    stop.store(true, Ordering::Relaxed);
    std::thread::sleep(SETTLE);
}

/// The server has not ended (neither crashed nor gave up on the flooded line).
fn assert_still_running(server: &mut Kill, role: &str) {
    let status = server.0.try_wait().expect("ask whether the server ended");
    assert!(status.is_none(), "{role} ended after the flood: {status:?}");
}

/// The client's run succeeded; its stdout, trimmed.
fn ok(o: &Output, what: &str) -> String {
    assert!(o.status.success(), "{what}: {}", text(o));
    String::from_utf8_lossy(&o.stdout).trim().to_owned()
}

#[test]
fn modbus_serve_answers_after_a_flood() {
    let _one = one_at_a_time();
    let Some((pair, mut server, log, line)) = modbus::serving_8n1() else {
        return;
    };
    let run = |args: &[&str]| modbus::si_ok(&pair.b, line, args);
    let write = [
        "modbus", "write", "register", "--unit", "1", "--addr", "12", "99",
    ];
    assert_eq!(run(&write), "unit 1 register 12 = 99 written");

    flood(&pair.b);

    let read = ["modbus", "read", "holding", "--unit", "1", "--addr", "12"];
    assert_eq!(run(&read), "unit 1 FC03 12…12: 99");
    assert_still_running(&mut server, "si modbus serve");
    // The flood reached the server: 01H is its unit address, so it framed the noise as
    // requests and dropped them (a CRC error or a receive buffer overflow).
    let log = modbus::served(&log);
    assert!(log.contains("request not answered"), "{log}");
}

/// `si uss <args…> --slave 5 --response-timeout-ms 500 --port <port>`, run to its end.
fn uss_job(port: &str, args: &[&str]) -> Output {
    si_command()
        .arg("uss")
        .args(args)
        .args([
            "--slave",
            "5",
            "--response-timeout-ms",
            "500",
            "--port",
            port,
        ])
        .output()
        .expect("run si uss")
}

#[test]
fn uss_sim_slave_answers_after_a_flood() {
    let _one = one_at_a_time();
    let Some(pair) = pty_pair() else { return };
    let mut slave = Kill(
        si_command()
            .args(["uss", "sim-slave", "--address", "5", "--port", &pair.b])
            .stdout(Stdio::null())
            .spawn()
            .expect("start sim-slave"),
    );
    // Time to open the port (as in pty/uss.rs). The drive hunts for STX and drops 01H without
    // an event, so only the answer after the flood shows it coped.
    opened(&slave.0, &pair.b);
    let written = uss_job(&pair.a, &["write-param", "1082", "120"]);
    ok(&written, "write-param");

    flood(&pair.a);

    let read = uss_job(&pair.a, &["read-param", "1082"]);
    assert_eq!(
        ok(&read, "read-param after the flood"),
        "slave 5 P1082:0 = 120 (response ID 1)"
    );
    assert_still_running(&mut slave, "si uss sim-slave");
}

#[test]
fn rk512_serve_answers_after_a_flood() {
    let _one = one_at_a_time();
    let Some(pair) = pty_pair_ignoreeof() else {
        return;
    };
    let dir = test_dir("si-rk512-flooded");
    let config = dir.join("serve.toml");
    // The server's stderr goes to a file: no pipe to fill while nobody reads it.
    let errors = dir.join("serve.stderr");
    let mut f = std::fs::File::create(&config).unwrap();
    writeln!(f, "[[db]]\nnumber = 10\nlength = 64").unwrap();
    drop(f);
    let mut serve = Kill(
        si_command()
            .args(["--port", &pair.b, "rk512", "serve"])
            .args(["--config", config.to_str().unwrap()])
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(&errors).unwrap())
            .spawn()
            .expect("start rk512 serve"),
    );
    // Time to open the port (as in pty/rk512.rs).
    opened(&serve.0, &pair.b);
    let hex = "12 34 56 78";
    let sent = si(&[
        "--port", &pair.a, "rk512", "send", "--db", "10", "--dw", "4", hex,
    ]);
    ok(&sent, "send");

    flood(&pair.a);

    let fetched = si(&[
        "--json", "--port", &pair.a, "rk512", "fetch", "--db", "10", "--dw", "4", "--count", "2",
    ]);
    let out = ok(&fetched, "fetch after the flood");
    let line: serde_json::Value = serde_json::from_str(&out).expect("one JSON line");
    assert_eq!(line["hex"], hex, "{out}");
    assert_still_running(&mut serve, "si rk512 serve");
    // The flood reached the server: 01H in idle is a connection setup error
    // ([CP 341 Diag], class 08H: 16#0802), reported on stderr.
    let errors = std::fs::read_to_string(&errors).unwrap();
    assert!(errors.contains("16#0802"), "{errors}");
}
