//! Many lines in one gateway: a hundred Modbus RTU lines on pseudo-terminals run on
//! the threads of one, a line with its own `listen` address routes its own unit ids, and the
//! open-file limit is raised at start (or named when even the hard limit is too low).
//!
//! The ptys come from openpty in this process, which holds both ends (no socat, so nothing to
//! skip); a thread answering FC03 on a pty's master end is the RTU slave.
#![cfg(target_os = "linux")]

use crate::common::{si, stderr, Kill};
use crate::harness::{launch_with, read_holding, Mbap};
use nix::fcntl::{fcntl, FcntlArg, FdFlag};
use nix::pty::{openpty, OpenptyResult};
use si_modbus::frame::crc16;
use std::io::{Read, Write};
use std::os::fd::{AsRawFd, OwnedFd};
use std::process::Command;

/// A pseudo-terminal whose both ends this test holds (so the line never sees an end of file);
/// the gateway opens `path`, the slave end's name.
struct Pty {
    master: OwnedFd,
    _slave: OwnedFd,
    path: String,
}

fn pty() -> Pty {
    let OpenptyResult { master, slave } = openpty(None, None).expect("openpty");
    // openpty's descriptors are inherited across exec: without this every gateway (and any
    // peer another test spawns meanwhile) would start with this test's 200 ptys open.
    for fd in [&master, &slave] {
        fcntl(fd, FcntlArg::F_SETFD(FdFlag::FD_CLOEXEC)).expect("FD_CLOEXEC");
    }
    let link = format!("/proc/self/fd/{}", slave.as_raw_fd());
    let path = std::fs::read_link(link).expect("the pty's name");
    Pty {
        master,
        _slave: slave,
        path: path.to_string_lossy().into_owned(),
    }
}

/// Answer every FC03 for `unit` on the master end of `pty` (holding register n holds n), on a
/// thread of its own that ends with the test process.
fn rtu_slave(pty: &Pty, unit: u8) {
    let mut line = std::fs::File::from(pty.master.try_clone().expect("dup the master"));
    std::thread::spawn(move || loop {
        let mut request = [0u8; 8];
        if line.read_exact(&mut request).is_err() {
            return;
        }
        let crc_ok = crc16(&request[..6]).to_le_bytes() == request[6..];
        if request[..2] != [unit, 0x03] || !crc_ok {
            continue;
        }
        let start = u16::from_be_bytes([request[2], request[3]]);
        let count = u16::from_be_bytes([request[4], request[5]]);
        let mut answer = vec![unit, 0x03, (2 * count) as u8];
        answer.extend((0..count).flat_map(|i| (start + i).to_be_bytes()));
        answer.extend(crc16(&answer).to_le_bytes());
        if line.write_all(&answer).is_err() {
            return;
        }
    });
}

/// A free loopback address (bound and released: another process could take it in between,
/// which only makes the test fail, never pass wrongly).
fn free_addr() -> String {
    let l = std::net::TcpListener::bind("127.0.0.1:0").expect("bind");
    l.local_addr().expect("addr").to_string()
}

/// A gateway with `n` lines under the shell command `limits` (e.g. `ulimit -Sn 64`): lines
/// 1 … n−1 serve units 1 … n−1 on the top-level address, with no slave; the last line has its
/// own address, serves unit 1 there, and has a slave.
struct Lines {
    gateway: Kill,
    top: String,
    own: String,
    _ptys: Vec<Pty>,
}

impl Lines {
    fn start(n: usize, limits: &str) -> Lines {
        let ptys: Vec<Pty> = (0..n).map(|_| pty()).collect();
        rtu_slave(&ptys[n - 1], 1);
        let own = free_addr();
        let keys = "baud = 19200\nparity = \"none\"\nresponse_timeout_ms = 50\nretries = 0\n";
        let mut toml = "listen = \"127.0.0.1:0\"\n".to_string();
        for (i, p) in ptys.iter().enumerate() {
            let (unit, listen) = if i + 1 == n {
                (1, format!("listen = \"{own}\"\n"))
            } else {
                (i + 1, String::new())
            };
            toml += &format!(
                "[[line]]\nname = \"l{i}\"\ndevice = \"{}\"\nunits = \"{unit}\"\n{keys}{listen}",
                p.path
            );
        }
        let mut sh = Command::new("sh");
        sh.args(["-c", &format!("{limits} && exec \"$0\" \"$@\"")])
            .arg(env!("CARGO_BIN_EXE_si"));
        let (top, _log, gateway, event) = launch_with(sh, &toml, &format!("lines-{n}"));
        let listeners = event["listeners"].as_array().expect("listeners");
        assert_eq!(listeners.len(), 2, "{event}");
        assert_eq!(listeners[1]["lines"][0], format!("l{}", n - 1), "{event}");
        assert_eq!(listeners[1]["addr"], own.as_str(), "{event}");
        Lines {
            gateway,
            top,
            own,
            _ptys: ptys,
        }
    }

    /// A `/proc/PID/status` or `/proc/PID/limits` line's first number after `key`.
    fn proc(&self, file: &str, key: &str) -> u64 {
        let path = format!("/proc/{}/{file}", self.gateway.0.id());
        let text = std::fs::read_to_string(&path).expect(&path);
        let line = text.lines().find(|l| l.starts_with(key)).expect(key);
        line[key.len()..]
            .split_whitespace()
            .find_map(|w| w.parse().ok())
            .expect(line)
    }
}

/// FC03 of 2 registers from 5 on `unit` at `addr`: the answer's PDU.
fn ask(addr: &str, unit: u8) -> Vec<u8> {
    let mut c = Mbap::connect(addr);
    c.send(7, unit, &read_holding(5, 2));
    let (tid, u, pdu) = c.recv();
    assert_eq!((tid, u), (7, unit));
    pdu
}

#[test]
fn a_hundred_lines_run_on_the_threads_of_one_and_each_address_routes_its_own_units() {
    let one = Lines::start(2, "ulimit -Sn 64");
    assert_eq!(ask(&one.own, 1), [0x03, 4, 0, 5, 0, 6]);
    let threads_one = one.proc("status", "Threads:");
    drop(one);

    // 100 lines and a soft limit of 64 open files: the gateway raised it, or it could not
    // have opened them all.
    let many = Lines::start(100, "ulimit -Sn 64");
    assert_eq!(ask(&many.own, 1), [0x03, 4, 0, 5, 0, 6], "the last line");
    // Unit 1 on the top-level address is line l0, which has no slave; unit 100 is on no line
    // there (the last line serves its unit on its own address only).
    assert_eq!(ask(&many.top, 1), [0x83, 0x0B]);
    assert_eq!(ask(&many.top, 99), [0x83, 0x0B]);
    assert_eq!(ask(&many.top, 100), [0x83, 0x0A]);
    let threads_many = many.proc("status", "Threads:");
    // The runtime's thread and the shared precise-timer thread, whatever the line count
    // (once a thread per line); one more for tokio's blocking pool at most.
    assert!(
        threads_many <= threads_one + 1 && threads_many <= 4,
        "{threads_one} threads with 2 lines, {threads_many} with 100"
    );
    let soft = many.proc("limits", "Max open files");
    assert!(soft > 64, "the soft open-file limit stayed at {soft}");
}

#[test]
fn a_hard_open_file_limit_too_low_is_named_before_any_line_opens() {
    let path = crate::common::test_dir("gateway").join("limit.toml");
    let mut toml = String::new();
    for i in 0..50 {
        toml += &format!(
            "[[line]]\ndevice = \"/nonexistent/tty{i}\"\nunits = \"{}\"\n",
            i + 1
        );
    }
    std::fs::write(&path, toml).expect("write the config");
    let path = path.to_string_lossy().into_owned();
    let si_path = env!("CARGO_BIN_EXE_si");
    let o = Command::new("sh")
        .args(["-c", "ulimit -n 40 && exec \"$0\" \"$@\""])
        .args([si_path, "gateway", "--config", &path])
        .output()
        .expect("run sh");
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    // 50 lines × 2 (the port and its termios handle) + 1 listener + 32 connections + the
    // runtime's 32 descriptors.
    assert!(err.contains("needs at least 165 open files"), "{err}");
    assert!(err.contains("RLIMIT_NOFILE is 40"), "{err}");
    assert!(!err.contains("nonexistent"), "no line was opened: {err}");
    // The same file with the usual limits gets as far as the first line.
    let o = si(&["gateway", "--config", &path]);
    assert!(stderr(&o).contains("nonexistent/tty0"), "{}", stderr(&o));
}
