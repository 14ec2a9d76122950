//! A lost line is an error: every long-running role (`modbus serve`, `uss
//! sim-slave`, `monitor`, `3964r recv`, `rk512 serve`, `ascii recv`, `dp-coord module`) exits 1 with one line
//! naming what closed when its pseudo-terminal hangs up (socat killed) or its TCP peer closes
//! the connection; Ctrl-C exits 130. `modbus serve` logs each request with the text of its own
//! code. socat makes the pty pairs (`apt-get install socat`): missing, the pty tests skip with a
//! message (fail with `CI` set); the TCP tests need no peer.

use std::io::Write;
use std::net::{TcpListener, TcpStream};
use std::process::{Child, Output, Stdio};
use std::time::{Duration, Instant};

use crate::common;

use common::{opened, pty_pair, si_command, stderr, stdout, Kill};

/// How long a role may take to notice the hang-up: a bound for a stuck process, not a timing
/// claim (it ends within milliseconds).
const BOUND: Duration = Duration::from_secs(10);

/// Wait for `child` to end within [`BOUND`] and take its output; a child still running after
/// it is killed and the test fails.
fn ended(child: Child, what: &str) -> Output {
    let mut child = Kill(child);
    let start = Instant::now();
    while child.0.try_wait().expect("try_wait").is_none() {
        assert!(
            start.elapsed() < BOUND,
            "{what} still runs {BOUND:?} after its line closed"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    let Kill(inner) = &mut child;
    let mut out = Output {
        status: inner.wait().expect("wait"),
        stdout: Vec::new(),
        stderr: Vec::new(),
    };
    use std::io::Read;
    if let Some(mut s) = inner.stdout.take() {
        s.read_to_end(&mut out.stdout).unwrap();
    }
    if let Some(mut s) = inner.stderr.take() {
        s.read_to_end(&mut out.stderr).unwrap();
    }
    out
}

/// `si <line…> <args…>` with its output piped; stdin stays open until the child is reaped
/// (`dp-coord module` ends with stdin, not with the line).
fn start(line: &[&str], args: &[&str]) -> Child {
    si_command()
        .args(line)
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start si")
}

/// Start `si --port <first pty> <args…>`, wait until it holds the port open, write `feed` (raw bytes, each
/// a piece written after a pause) into the other end, hang up (socat killed), and return how
/// `si` ended and the pty's name. `None` when socat is missing.
fn hang_up(args: &[&str], feed: &[&[u8]]) -> Option<(Output, String)> {
    let pair = pty_pair()?;
    let port = pair.a.clone();
    let child = start(&["--port", &port], args);
    opened(&child, &port);
    // Then it reads the line: the hang-up comes while it runs, not while it starts.
    std::thread::sleep(Duration::from_millis(300));
    if !feed.is_empty() {
        let mut other = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .open(&pair.b)
            .expect("open the other end");
        for piece in feed {
            other.write_all(piece).unwrap();
            std::thread::sleep(Duration::from_millis(300));
        }
    }
    drop(pair);
    Some((ended(child, &args.join(" ")), port))
}

/// Exit 1 and, as the last line on stderr, the line that names the pty that hung up.
fn assert_lost(o: &Output, port: &str) {
    assert_eq!(o.status.code(), Some(1), "{}{}", stdout(o), stderr(o));
    let last = stderr(o).lines().last().unwrap_or_default().to_owned();
    assert_eq!(last, format!("si: error: the line closed: {port} hung up"));
}

#[test]
fn modbus_serve_exits_1_when_its_pty_hangs_up() {
    let Some((o, port)) = hang_up(&["modbus", "serve", "--unit", "1"], &[]) else {
        return;
    };
    assert_lost(&o, &port);
}

#[test]
fn uss_sim_slave_exits_1_when_its_pty_hangs_up() {
    let Some((o, port)) = hang_up(&["uss", "sim-slave", "--address", "3"], &[]) else {
        return;
    };
    assert_lost(&o, &port);
}

#[test]
fn monitor_exits_1_when_its_pty_hangs_up_after_printing_its_counters() {
    let Some((o, port)) = hang_up(&["--json", "monitor", "--protocol", "modbus"], &[]) else {
        return;
    };
    assert_lost(&o, &port);
    assert!(stdout(&o).contains("\"counters\""), "{}", stdout(&o));
}

#[test]
fn r3964_recv_rk512_serve_and_dp_coord_module_name_the_pty_that_hung_up() {
    for args in [
        &["3964r", "recv"][..],
        &["rk512", "serve"][..],
        &["dp-coord", "module", "--protocol", "ascii"][..],
    ] {
        let Some((o, port)) = hang_up(args, &[]) else {
            return;
        };
        assert_lost(&o, &port);
    }
}

#[test]
fn ascii_recv_without_count_keeps_receiving_until_the_line_closes() {
    let Some((o, port)) = hang_up(
        &["--json", "ascii", "recv", "--end", "chars", "0D,0A"],
        &[b"one\r\n", b"two\r\n", b"three\r\n"],
    ) else {
        return;
    };
    assert_lost(&o, &port);
    let frames: Vec<String> = stdout(&o)
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .filter_map(|v| v["text"].as_str().map(str::to_owned))
        .collect();
    assert_eq!(frames, [r"one\r\n", r"two\r\n", r"three\r\n"]);
}

/// A Modbus RTU ADU: `body` and its CRC, low byte first.
fn adu(body: &[u8]) -> Vec<u8> {
    let mut crc: u16 = 0xFFFF;
    for &b in body {
        crc ^= u16::from(b);
        for _ in 0..8 {
            crc = if crc & 1 == 1 {
                (crc >> 1) ^ 0xA001
            } else {
                crc >> 1
            };
        }
    }
    let mut v = body.to_vec();
    v.extend_from_slice(&crc.to_le_bytes());
    v
}

#[test]
fn modbus_serve_logs_each_request_with_the_text_of_its_own_code() {
    let too_short = adu(&[1, 3, 0, 0]);
    let invalid_function = adu(&[1, 7]);
    let broadcast_read = adu(&[0, 3, 0, 0, 0, 1]);
    let flood = [1u8; 400];
    let Some((o, port)) = hang_up(
        &["modbus", "serve", "--unit", "1"],
        &[&invalid_function, &broadcast_read, &too_short, &flood],
    ) else {
        return;
    };
    assert_lost(&o, &port);
    let log = stdout(&o);
    // The request lines, whatever else serve prints around them (banner, address map).
    let lines: Vec<&str> = log
        .lines()
        .filter(|l| l.starts_with("answered ") || l.starts_with("request not answered"))
        .collect();
    assert_eq!(lines.len(), 4, "{log}");
    // Exception 01 with the slave's 0831H, not the master's "first response character".
    assert!(
        lines[0].starts_with(
            "answered FC07 with exception 01 illegal function: 16#0831 invalid function code received"
        ),
        "{log}"
    );
    // A broadcast read: the slave's 0830H, not the master's response timeout.
    assert!(
        lines[1].starts_with(
            "request not answered: 16#0830 broadcast not allowed for this function code"
        ),
        "{log}"
    );
    // No STATUS in [Modbus/USS] §3.5.6–§3.5.14 for a request of the wrong length: the log says what
    // was wrong.
    assert!(
        lines[2].starts_with(
            "answered FC03 with exception 03 illegal data value: the request is too short or too long for FC03"
        ),
        "{log}"
    );
    // A slave that overflows was receiving a request.
    assert!(
        lines[3].starts_with(
            "request not answered: 16#080A receive buffer overflow while receiving a request"
        ),
        "{log}"
    );
    assert!(
        !log.contains("response timeout") && !log.contains("a response"),
        "{log}"
    );
}

/// `si --tcp <a listener of ours> <args…>`, once it has connected: the child, our end of the connection, and the address.
fn connected(args: &[&str]) -> (Child, TcpStream, String) {
    let listener = TcpListener::bind("127.0.0.1:0").expect("bind");
    let addr = listener.local_addr().unwrap().to_string();
    let child = start(&["--tcp", &addr], args);
    let (conn, _) = listener.accept().expect("si connects");
    std::thread::sleep(Duration::from_millis(300));
    (child, conn, addr)
}

/// `si --tcp … <args…>` whose peer (we) closes the connection: how `si` ended, and the address.
fn peer_closes(args: &[&str]) -> (Output, String) {
    let (child, conn, addr) = connected(args);
    drop(conn);
    (ended(child, &args.join(" ")), addr)
}

#[test]
fn every_long_running_role_exits_1_naming_the_tcp_peer_that_closed() {
    let roles: [&[&str]; 7] = [
        &["modbus", "serve", "--unit", "1"],
        &["uss", "sim-slave", "--address", "3"],
        &["monitor", "--protocol", "3964r"],
        &["3964r", "recv"],
        &["rk512", "serve"],
        &["ascii", "recv"],
        &["dp-coord", "module", "--protocol", "3964r"],
    ];
    for args in roles {
        let (o, addr) = peer_closes(args);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {}", stderr(&o));
        assert_eq!(
            stderr(&o).lines().last().unwrap_or_default(),
            format!("si: error: the line closed: TCP peer {addr} closed the connection"),
            "{args:?}"
        );
    }
}

#[test]
fn ctrl_c_ends_every_long_running_role_with_130() {
    for args in [
        &["modbus", "serve", "--unit", "1"][..],
        &["--json", "monitor", "--protocol", "modbus"][..],
        &["uss", "sim-slave", "--address", "3"][..],
        &["3964r", "recv"][..],
        &["rk512", "serve"][..],
        &["ascii", "recv"][..],
    ] {
        let (child, _conn, _) = connected(args);
        let sent = std::process::Command::new("kill")
            .args(["-INT", &child.id().to_string()])
            .status()
            .expect("run kill");
        assert!(sent.success());
        let o = ended(child, &args.join(" "));
        assert_eq!(o.status.code(), Some(130), "{args:?}: {}", stderr(&o));
        assert_eq!(
            stderr(&o).lines().last(),
            Some("si: error: interrupted"),
            "{args:?}"
        );
        // A monitor still prints its counters before it goes.
        if args.contains(&"monitor") {
            assert!(stdout(&o).contains("\"counters\""), "{}", stdout(&o));
        }
    }
}
