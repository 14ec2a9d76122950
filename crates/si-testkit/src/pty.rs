//! Pseudo-terminal pairs for the pty tests of the engine crates: a library handle on one end,
//! a real peer (pymodbus, another handle, raw bytes) on the other. Made by socat, a skip
//! without it and a failure under `CI` ([`crate::peers`]).

use crate::peers::{have_socat, Kill};
use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};

/// Two connected pseudo-terminals; socat is killed when the pair is dropped.
pub struct PtyPair {
    /// One end's path.
    pub a: String,
    /// The other end's path.
    pub b: String,
    _socat: Kill,
}

/// A raw pty pair (`socat -d -d pty,rawer pty,rawer`: no echo, no line discipline, so bytes
/// written to one end by a plain file write arrive unchanged), or `None` without socat.
pub fn pty_pair() -> Option<PtyPair> {
    let (socat, a, b) = socat_pair("pty,rawer")?;
    Some(PtyPair {
        a,
        b,
        _socat: socat,
    })
}

/// `socat -d -d END END` with both ends' options `end` (e.g. `pty,raw,echo=0,ignoreeof`): the
/// running socat (killed when dropped) and the two pty names read from its log, or `None`
/// without socat. socat present but not making the pair is a failure.
pub fn socat_pair(end: &str) -> Option<(Kill, String, String)> {
    if !have_socat() {
        return None;
    }
    let child = Command::new("socat")
        .args(["-d", "-d", end, end])
        .stderr(Stdio::piped())
        .stdout(Stdio::null())
        .spawn()
        .expect("spawn socat");
    let mut socat = Kill(child);
    let log = socat.0.stderr.take().expect("socat stderr");
    let mut names = Vec::new();
    let mut lines = BufReader::new(log).lines();
    while names.len() < 2 {
        let line = lines
            .next()
            .expect("socat ended before printing two pty names")
            .expect("socat log line");
        if let Some(i) = line.find("PTY is ") {
            names.push(line[i + 7..].trim().to_owned());
        }
    }
    // Keep draining socat's log so it never blocks on a full pipe nor dies of SIGPIPE when it
    // logs an end of file later.
    std::thread::spawn(move || for _ in lines {});
    let b = names.pop().expect("second pty");
    let a = names.pop().expect("first pty");
    Some((socat, a, b))
}

/// Wait until process `pid` holds the device at `path` open (one of its `/proc/<pid>/fd` links
/// names that device, symlinks resolved), checking every 2 ms for at most `bound`; `false` if
/// it did not by then (or `path` does not exist). A test that writes to a peer process's
/// port waits for this instead of a guessed sleep, which is slow on an idle machine and too
/// short on a loaded one. Linux only (`/proc`); elsewhere it waits out `bound` and says no.
pub fn wait_until_open(pid: u32, path: &str, bound: std::time::Duration) -> bool {
    let Ok(device) = std::fs::canonicalize(path) else {
        return false;
    };
    let start = std::time::Instant::now();
    loop {
        if holds_open(pid, &device) {
            return true;
        }
        if start.elapsed() > bound {
            return false;
        }
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
}

fn holds_open(pid: u32, device: &std::path::Path) -> bool {
    let Ok(fds) = std::fs::read_dir(format!("/proc/{pid}/fd")) else {
        return false;
    };
    fds.filter_map(Result::ok)
        .any(|fd| std::fs::read_link(fd.path()).is_ok_and(|target| target == device))
}
