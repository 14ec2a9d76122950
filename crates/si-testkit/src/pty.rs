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
