//! Helpers shared by the integration tests of the `si` binary: running the built binary,
//! turning its output into text, killing child processes on drop, and making a pseudo-terminal
//! pair with socat. One copy here instead of one per test file, so a fix (a drained pipe, a
//! clearer skip message) reaches every test.
//!
//! Each file under `tests/` is its own test crate and uses only some of these helpers.
#![allow(dead_code, unused_imports)]

pub mod fifo;
pub mod modbus;
pub mod noise;

use serde_json::Value;
use std::ffi::OsStr;
use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Command, ExitStatus, Output, Stdio};
use std::time::{Duration, Instant};

/// The built `si` binary as a command, for tests that add pipes, spawn it or set stdin.
pub fn si_command() -> Command {
    Command::new(env!("CARGO_BIN_EXE_si"))
}

/// Runs `si ARGS` to the end and returns its status and output (panics only when the binary
/// cannot be started at all: a failing `si` is for the test to judge).
pub fn si(args: &[&str]) -> Output {
    si_command().args(args).output().expect("run si")
}

/// The output's stdout as text (invalid UTF-8 shown as U+FFFD, so a test never panics on it).
pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// The output's stderr as text (invalid UTF-8 shown as U+FFFD).
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Stdout followed by stderr: everything the process said, for assertion messages.
pub fn text(o: &Output) -> String {
    format!("{}{}", stdout(o), stderr(o))
}

/// `si --json monitor ARGS`: the JSON records it printed, one a line, and the counters of its
/// last line. The monitor failing, or printing anything but JSON lines, fails the test.
pub fn monitor_json<S: AsRef<OsStr>>(args: &[S]) -> (Vec<Value>, Value) {
    let o = si_command()
        .args(["--json", "monitor"])
        .args(args)
        .output()
        .unwrap();
    let text = stdout(&o);
    assert!(o.status.success(), "monitor: {text}{}", stderr(&o));
    let mut lines: Vec<Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).expect("JSON line"))
        .collect();
    let counters = lines.pop().expect("counters line")["counters"].clone();
    (lines, counters)
}

/// A directory of its own for this test binary's files: `$TMPDIR/<name>-<pid>`, created if
/// needed. The process id keeps parallel runs of the same tests apart.
pub fn test_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

pub use si_testkit::peers::{peer, Kill};

/// Waits for `child` to exit, polling every 20 ms; fails the test (the child is killed when
/// dropped) once `limit` has passed since `started`: a bound on a wait, not a timing claim.
/// `what` names the process in that failure.
pub fn exit_within(
    child: &mut Kill,
    started: Instant,
    limit: Duration,
    what: &dyn std::fmt::Display,
) -> ExitStatus {
    loop {
        if let Some(status) = child.0.try_wait().expect("wait for the child") {
            return status;
        }
        assert!(
            started.elapsed() < limit,
            "{what} still running after {limit:?}"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Is socat installed? A skip with a message if not, a failure with `CI` set (see [`peer`]).
pub use si_testkit::peers::have_socat;

/// Two connected pseudo-terminals made by socat; socat is killed when the pair is dropped,
/// which closes both ends.
pub struct PtyPair {
    socat: Kill,
    /// The first pseudo-terminal socat opened (`/dev/pts/N`).
    pub a: String,
    /// The second one, joined to `a`.
    pub b: String,
}

/// A pair of raw pseudo-terminals without echo (`pty,raw,echo=0` on both sides); socat ends
/// the link when one side reaches end of file. `None` (after a SKIPPED message) when socat is
/// not installed, except with `CI` set (see [`peer`]).
pub fn pty_pair() -> Option<PtyPair> {
    socat_pty_pair("pty,raw,echo=0")
}

/// Like [`pty_pair`], with `ignoreeof` on both sides: the link survives one process closing
/// its end and another opening it (a sender run after a sender, a receiver started first).
/// The tests that always used it keep it; the others keep plain [`pty_pair`].
pub fn pty_pair_ignoreeof() -> Option<PtyPair> {
    socat_pty_pair("pty,raw,echo=0,ignoreeof")
}

/// Wait until `child` holds the port at `path` open (at most 10 s, then fail): a receiver or
/// server started before its peer must be listening before the first byte comes, and a
/// fixed sleep is slow on an idle machine and too short on a loaded one.
pub fn opened(child: &std::process::Child, path: &str) {
    let bound = std::time::Duration::from_secs(10);
    assert!(
        si_testkit::pty::wait_until_open(child.id(), path, bound),
        "process {} did not open {path} within {bound:?}",
        child.id()
    );
}

/// The pair of si-testkit's `socat -d -d END END` with both ends' options `end`.
fn socat_pty_pair(end: &str) -> Option<PtyPair> {
    let (socat, a, b) = si_testkit::pty::socat_pair(end)?;
    Some(PtyPair { socat, a, b })
}

/// The root package's example `name`, built beside the `si` binary
/// (`target/<profile>/examples/<name>`; `cargo test --workspace --all-features` builds the
/// examples with the tests). Not built, it is a skip with the command that builds it, a
/// failure with `CI` set.
pub fn example(name: &str) -> Option<PathBuf> {
    let si = PathBuf::from(env!("CARGO_BIN_EXE_si"));
    let path = si.parent()?.join("examples").join(name);
    if path.exists() {
        return Some(path);
    }
    let build = format!("cargo build --example {name} --all-features");
    if std::env::var_os("CI").is_some() {
        panic!("the {name} example is not built and CI is set: {build}");
    }
    eprintln!("SKIPPED: the {name} example is not built ({build})");
    None
}
