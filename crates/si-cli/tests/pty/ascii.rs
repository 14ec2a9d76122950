//! `si ascii` over a Linux pseudo-terminal pair made by socat: `si ascii recv --end chars 0D,0A`
//! receives the lines `si ascii send` writes ([ET200S SI] §2.8, two end-of-text
//! characters). Skips with a message when socat is not installed (`apt-get install socat`); with
//! the environment variable `CI` set it fails instead (`common::pty_pair`).

use std::process::Stdio;
use std::time::{Duration, Instant};

use crate::common;

use common::{opened, pty_pair, si_command, PtyPair};

#[test]
fn recv_end_chars_cr_lf_receives_the_lines_send_writes() {
    let Some(pair) = pty_pair() else { return };
    let recv = si_command()
        .args([
            "ascii", "recv", "--port", &pair.a, "--end", "chars", "0D,0A",
        ])
        .args(["--count", "2", "--timeout", "20"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start si ascii recv");
    // The receiver opens its port before anything is written.
    opened(&recv, &pair.a);

    let first = si_command()
        .args([
            "ascii",
            "send",
            "--port",
            &pair.b,
            "--text",
            r"first line\r\n",
        ])
        .output()
        .expect("run si ascii send");
    assert!(
        first.status.success(),
        "{}",
        String::from_utf8_lossy(&first.stderr)
    );
    assert_eq!(
        String::from_utf8_lossy(&first.stdout).trim(),
        "sent 12 bytes: 66 69 72 73 74 20 6C 69 6E 65 0D 0A"
    );
    let second = si_command()
        .args([
            "ascii",
            "send",
            "--port",
            &pair.b,
            "73 65 63 6F 6E 64 0D 0A",
        ])
        .output()
        .expect("run si ascii send");
    assert!(second.status.success());

    let started = Instant::now();
    let out = recv.wait_with_output().expect("si ascii recv ends");
    assert!(started.elapsed() < Duration::from_secs(25));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let lines: Vec<&str> = stdout.lines().collect();
    assert_eq!(
        lines,
        vec![
            r#"frame 12 bytes: 66 69 72 73 74 20 6C 69 6E 65 0D 0A  "first line\r\n""#,
            r#"frame 8 bytes: 73 65 63 6F 6E 64 0D 0A  "second\r\n""#,
        ]
    );
}

#[test]
fn recv_json_and_timeout_without_a_partner() {
    let Some(pair) = pty_pair() else { return };
    let out = si_command()
        .args(["ascii", "recv", "--port", &pair.a, "--end", "fixed", "4"])
        .args(["--count", "1", "--timeout", "0.5"])
        .output()
        .expect("run si ascii recv");
    assert!(!out.status.success());
    assert_eq!(
        String::from_utf8_lossy(&out.stderr).trim(),
        "si: error: no 1 frame(s) within 0.5 s"
    );
}

#[test]
fn bad_end_criterion_is_one_clear_line() {
    let out = si_command()
        .args([
            "ascii",
            "recv",
            "--port",
            "/nonexistent",
            "--end",
            "chars",
            "00",
        ])
        .output()
        .expect("run si");
    assert!(!out.status.success());
    assert_eq!(
        String::from_utf8_lossy(&out.stderr).trim(),
        "si: error: end-of-text character 1 = 00H is out of range: 01H … FFH with 8 data bits"
    );
    let out = si_command()
        .args([
            "--baud",
            "1200",
            "ascii",
            "recv",
            "--port",
            "/x",
            "--char-delay-ms",
            "10",
        ])
        .output()
        .expect("run si");
    assert_eq!(
        String::from_utf8_lossy(&out.stderr).trim(),
        "si: error: character delay time = 10 ms is out of range: 34 … 65535 ms at 1200 bit/s"
    );
}

#[test]
fn sim_scenarios_lose_nothing() {
    let out = si_command()
        .args(["sim", "ascii"])
        .output()
        .expect("run si sim");
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains(r#"B received 7 bytes: "HELLO\r\n""#),
        "{text}"
    );
    assert!(
        text.contains(r#"B received 13 bytes: "SECOND LINE\r\n""#),
        "{text}"
    );

    let out = si_command()
        .args(["--json", "sim", "ascii-xon-xoff"])
        .output()
        .expect("run si sim");
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    let last: serde_json::Value =
        serde_json::from_str(text.lines().last().expect("a summary line")).unwrap();
    assert_eq!(last["intact"], true);
    assert_eq!(last["received"], 1200);
    // The trace shows the XOFF and the XON the receiver sent.
    assert!(text.contains(r#""bytes":[19]"#), "XOFF in the trace");
    assert!(text.contains(r#""bytes":[17]"#), "XON in the trace");
}

#[test]
fn monitor_prints_timestamped_frames_and_never_transmits() {
    use std::io::{Read, Write};
    let Some(pair) = pty_pair() else { return };
    // Even with XON/XOFF asked for, the monitor must not send its startup XON.
    let monitor = si_command()
        .args(["--json", "ascii", "monitor", "--port", &pair.a])
        .args([
            "--end", "chars", "0D,0A", "--flow", "xon-xoff", "--count", "2",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start si ascii monitor");
    opened(&monitor, &pair.a);
    let mut partner = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .open(&pair.b)
        .expect("open the partner side");
    partner.write_all(b"abc\r\nsecond\r\n").unwrap();
    partner.flush().unwrap();

    // Whatever the monitor might transmit would arrive here.
    let mut reader = partner.try_clone().unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let mut byte = [0u8; 1];
        if let Ok(1) = reader.read(&mut byte) {
            let _ = tx.send(byte[0]);
        }
    });

    let out = monitor
        .wait_with_output()
        .expect("monitor ends after two frames");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let frames: Vec<serde_json::Value> = stdout
        .lines()
        .map(|l| serde_json::from_str(l).expect("one JSON object per line"))
        .collect();
    assert_eq!(frames.len(), 2, "{stdout}");
    assert_eq!(frames[0]["frame"], "61 62 63 0D 0A");
    assert_eq!(frames[1]["text"], r"second\r\n");
    let (t0, t1) = (
        frames[0]["at_us"].as_u64().unwrap(),
        frames[1]["at_us"].as_u64().unwrap(),
    );
    assert!(t0 > 0 && t1 >= t0, "timestamps in driver time: {t0} {t1}");
    assert!(
        rx.recv_timeout(Duration::from_millis(300)).is_err(),
        "the monitor transmitted something"
    );
}

/// Start `si ascii recv` on `port` with `args`, wait until it holds the port open, run `send` (each a full
/// `si ascii send` argument list after the port), and return recv's stdout lines.
fn recv_while_sending(pair: &PtyPair, recv_args: &[&str], sends: &[&[&str]]) -> Vec<String> {
    let recv = si_command()
        .args([
            "--json",
            "ascii",
            "recv",
            "--port",
            &pair.a,
            "--timeout",
            "20",
        ])
        .args(recv_args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start si ascii recv");
    opened(&recv, &pair.a);
    for (i, args) in sends.iter().enumerate() {
        if i > 0 {
            // Longer than the CDT of the character-delay test, so each send is its own frame.
            std::thread::sleep(Duration::from_millis(400));
        }
        let out = si_command()
            .args(["ascii", "send", "--port", &pair.b])
            .args(*args)
            .output()
            .expect("run si ascii send");
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let out = recv.wait_with_output().expect("recv ends");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(str::to_owned)
        .collect()
}

fn frame_of(line: &str) -> String {
    let v: serde_json::Value = serde_json::from_str(line).expect("a JSON line");
    v["frame"].as_str().expect("a frame").to_owned()
}

#[test]
fn char_delay_criterion_over_a_pty_cuts_one_frame_per_send() {
    let Some(pair) = pty_pair() else { return };
    // A generous CDT: a pseudo-terminal and the OS scheduler add jitter the module never sees.
    let lines = recv_while_sending(
        &pair,
        &["--end", "delay", "--char-delay-ms", "100", "--count", "2"],
        &[&["01 02 03"], &["04 05"]],
    );
    let frames: Vec<String> = lines.iter().map(|l| frame_of(l)).collect();
    assert_eq!(frames, vec!["01 02 03", "04 05"]);
}

#[test]
fn xon_xoff_on_both_sides_still_delivers_the_line() {
    let Some(pair) = pty_pair() else { return };
    // Under flow control the sender hands out a chunk per tx-done; the receiver starts with XON.
    // A pseudo-terminal does not pace characters at the baud rate: a chunk arrives at once and
    // the next one a whole chunk time later, so the receiver's CDT must cover that gap here (on
    // a real UART the gap is only the driver's timer latency).
    let lines = recv_while_sending(
        &pair,
        &[
            "--end",
            "chars",
            "0D,0A",
            "--char-delay-ms",
            "200",
            "--flow",
            "xon-xoff",
            "--count",
            "1",
        ],
        &[&["--flow", "xon-xoff", "--text", r"flow controlled\r\n"]],
    );
    assert_eq!(lines.len(), 1, "{lines:?}");
    let v: serde_json::Value = serde_json::from_str(&lines[0]).unwrap();
    assert_eq!(v["text"], r"flow controlled\r\n");
}

#[test]
fn max_frame_and_module_are_checked_with_the_fixed_length() {
    let run = |args: &[&str]| {
        let out = si_command()
            .args(["ascii", "recv", "--port", "/nonexistent"])
            .args(args)
            .output()
            .expect("run si");
        String::from_utf8_lossy(&out.stderr).trim().to_owned()
    };
    // ET 200S 1SI (the default): 1 … 200 bytes (Table 2-10).
    assert_eq!(
        run(&["--end", "fixed", "224"]),
        "si: error: length of received frame = 224 bytes is out of range: 1 … 200 bytes"
    );
    // The 2005 module takes 224 (Table 2-8): the error is now the missing port.
    assert!(!run(&["--module", "2005", "--end", "fixed", "224"]).contains("out of range"));
    assert_eq!(
        run(&["--max-frame", "2000"]),
        "si: error: maximum frame length = 2000 bytes is out of range: 1 … 1024 bytes"
    );
    assert!(run(&["--module", "cp340"]).contains("\"cp340\" is not a module type"));
}

#[test]
fn cp341_frames_of_1_kb_pass_and_the_et200s_refuses_201_bytes_with_050e() {
    let Some(pair) = pty_pair() else { return };
    let recv = si_command()
        .args(["ascii", "recv", "--port", &pair.a, "--module", "cp341"])
        .args(["--end", "chars", "0D,0A", "--count", "1", "--timeout", "20"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start si ascii recv");
    opened(&recv, &pair.a);
    let line = format!("{}0D 0A", "41 ".repeat(1022));
    let sent = si_command()
        .args([
            "ascii", "send", "--port", &pair.b, "--module", "cp341", &line,
        ])
        .output()
        .expect("run si ascii send");
    assert!(
        sent.status.success(),
        "{}",
        String::from_utf8_lossy(&sent.stderr)
    );
    let out = recv.wait_with_output().expect("si ascii recv ends");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.starts_with("frame 1024 bytes: 41 41"), "{stdout}");

    let refused = si_command()
        .args(["ascii", "send", "--port", &pair.b, &"41 ".repeat(201)])
        .output()
        .expect("run si ascii send");
    assert!(!refused.status.success());
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert!(
        stderr.contains("201 bytes is longer than the maximum of 200 bytes (16#050E"),
        "{stderr}"
    );
}
