//! `si ports --check PORT` on what a user meets in the first hour: a working port (a pty pair),
//! a path that is not there, a port this user may not open, a port another program holds.
//! Each gives its finding with a remedy and the exit code (0 nothing wrong, 1 otherwise); and
//! `si --port PTY ports` reads the line-error counters of a pty without error.

use crate::common;

use common::{pty_pair, si, si_command, stdout, text, Kill};
use std::process::{Command, Stdio};

#[test]
fn a_pty_pair_checks_clean_and_exits_0() {
    let Some(pair) = pty_pair() else { return };
    let o = si(&["ports", "--check", &pair.a]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(t.contains("pseudo-terminal"), "{t}");
    assert!(t.contains("may be opened read-write"), "{t}");
    // socat holds the master: the other end, not a problem.
    assert!(t.contains("which made the pseudo-terminal"), "{t}");
    assert!(t.contains("nothing wrong found"), "{t}");
    assert!(!t.contains("PROBLEM"), "{t}");
}

#[test]
fn a_path_that_is_not_there_is_named_with_where_ports_are() {
    let o = si(&["ports", "--check", "/dev/ttyUSB-si-none"]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(1), "{t}");
    assert!(t.contains("/dev/ttyUSB-si-none does not exist"), "{t}");
    assert!(t.contains("remedy:") && t.contains("si ports"), "{t}");
}

#[test]
fn check_takes_the_port_from_port_too_and_wants_one() {
    let o = si(&["--port", "/dev/ttyUSB-si-none", "ports", "--check"]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(text(&o).contains("does not exist"), "{}", text(&o));
    let o = si(&["ports", "--check"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("--check PATH"), "{}", text(&o));
}

#[test]
fn a_file_is_not_a_port() {
    let o = si(&["ports", "--check", "/etc/hostname"]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(text(&o).contains("not a character device"), "{}", text(&o));
}

#[test]
fn a_port_this_user_may_not_open_says_so_with_mode_group_and_remedy() {
    let Some(pair) = pty_pair() else { return };
    if Command::new("setpriv").arg("--version").output().is_err() {
        eprintln!("SKIPPED: setpriv (util-linux) is not installed");
        return;
    }
    // Tests run as root, who may open anything: the check runs as nobody, on a pty only root
    // may read and write.
    let chmod = Command::new("chmod")
        .args(["600", &pair.a])
        .status()
        .expect("chmod");
    assert!(chmod.success());
    let o = Command::new("setpriv")
        .args(["--reuid=65534", "--regid=65534", "--clear-groups"])
        .arg(env!("CARGO_BIN_EXE_si"))
        .args(["ports", "--check", &pair.a])
        .output()
        .expect("run setpriv");
    let t = text(&o);
    assert_eq!(o.status.code(), Some(1), "{t}");
    assert!(t.contains("permission denied: mode 0600"), "{t}");
    assert!(t.contains("uid 65534"), "{t}");
    // The group gives no read-write: joining it would not help, a udev rule does.
    assert!(t.contains("udev rule"), "{t}");
}

#[test]
fn a_port_held_by_another_program_names_it_and_exits_1() {
    let Some(pair) = pty_pair() else { return };
    let port = std::fs::File::open(&pair.a).expect("open pty");
    let holder = Kill(
        Command::new("sleep")
            .arg("60")
            .stdin(Stdio::from(port))
            .spawn()
            .expect("spawn sleep"),
    );
    let pid = holder.0.id().to_string();
    let o = si(&["--json", "ports", "--check", &pair.a]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(1), "{t}");
    let report: serde_json::Value =
        serde_json::from_str(stdout(&o).lines().next().expect("a JSON line")).expect("JSON");
    assert_eq!(report["ok"], false, "{t}");
    let held = report["findings"]
        .as_array()
        .expect("findings")
        .iter()
        .find(|f| f["severity"] == "problem")
        .unwrap_or_else(|| panic!("no problem found: {t}"));
    assert_eq!(held["check"], "holders", "{t}");
    assert!(
        held["text"]
            .as_str()
            .unwrap()
            .contains(&format!("held open by {pid} sleep")),
        "{t}"
    );
    assert!(
        held["remedy"]
            .as_str()
            .unwrap()
            .contains(&format!("kill {pid}")),
        "{t}"
    );
    drop(holder);
}

#[test]
fn the_line_error_counters_of_a_pty_read_without_error() {
    let Some(pair) = pty_pair() else { return };
    let o = si_command()
        .args(["--json", "--port", &pair.a, "ports"])
        .output()
        .expect("run si");
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    let last: serde_json::Value =
        serde_json::from_str(stdout(&o).lines().last().expect("a line")).expect("JSON");
    assert_eq!(last["port"], pair.a.as_str(), "{t}");
    // A pseudo-terminal's driver keeps no counters: said so, not an error.
    assert!(last["counters"].is_null(), "{t}");
}

/// A pty whose other end echoes (socat's PIPE address), and socat, killed on drop.
fn echoing_pty() -> Option<(Kill, String)> {
    if !common::have_socat() {
        return None;
    }
    let mut child = Command::new("socat")
        .args(["-d", "-d", "pty,raw,echo=0", "pipe"])
        .stderr(Stdio::piped())
        .stdout(Stdio::null())
        .spawn()
        .expect("spawn socat");
    let log = child.stderr.take().expect("socat log");
    let socat = Kill(child);
    let mut lines = std::io::BufRead::lines(std::io::BufReader::new(log));
    let pty = loop {
        let line = lines.next().expect("socat names its pty").expect("a line");
        if let Some(i) = line.find("PTY is ") {
            break line[i + 7..].trim().to_owned();
        }
    };
    std::thread::spawn(move || for _ in lines {});
    Some((socat, pty))
}

/// A pty whose other end echoes: the loopback reports the echo and, per baud rate, what came
/// back, in how many reads, and the hold measured.
#[test]
fn loopback_on_an_echoing_pty_reports_the_echo_and_the_measured_hold() {
    let Some((_socat, pty)) = echoing_pty() else {
        return;
    };
    let o = si(&["ports", "--check", &pty, "--loopback"]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(
        t.contains("echo: the port hears its own transmission"),
        "{t}"
    );
    for baud in ["9600", "115200"] {
        let line = t
            .lines()
            .find(|l| l.contains(&format!("loopback: {baud} bit/s")))
            .unwrap_or_else(|| panic!("no loopback line at {baud}: {t}"));
        assert!(line.contains("100 of 100 bytes back"), "{line}");
        assert!(
            line.contains("held") && line.contains("ms past the wire"),
            "{line}"
        );
    }
}

/// Parity and framing errors during the loopback come from the driver's counters; a
/// pseudo-terminal keeps none (it has no parity), which the check says instead of a count, and
/// that is no problem. (A count above zero, the loop garbling characters, needs a real UART:
/// the finding's rule is tested in si-core, `port::loopback`.)
#[test]
fn loopback_on_a_pty_says_parity_errors_cannot_be_counted_there() {
    let Some((_socat, pty)) = echoing_pty() else {
        return;
    };
    let o = si(&["--json", "ports", "--check", &pty, "--loopback"]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    let report: serde_json::Value =
        serde_json::from_str(stdout(&o).lines().last().expect("a line")).expect("JSON");
    let findings = report["findings"].as_array().expect("findings");
    let errors = findings
        .iter()
        .rev()
        .find(|f| f["check"] == "line errors")
        .unwrap_or_else(|| panic!("no line-error finding after the loopback: {t}"));
    assert_eq!(errors["severity"], "ok", "{t}");
    let said = errors["text"].as_str().unwrap_or_default();
    assert!(
        said.contains("parity") && said.contains("cannot be counted"),
        "{said}"
    );
}

/// A pty whose other end does not echo: nothing comes back, a problem with its remedy, exit 1.
#[test]
fn loopback_without_an_echo_says_so_and_exits_1() {
    let Some(pair) = pty_pair() else { return };
    let o = si(&["ports", "--check", &pair.a, "--loopback"]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(1), "{t}");
    assert!(t.contains("nothing came back"), "{t}");
    assert!(t.contains("wire TX to RX"), "{t}");
}

/// Parity-error detection needs a wire and a second UART: on a pty pair given as port and
/// peer, the check says "not testable" with the reason and what to wire, never "yes"; that is
/// no problem, so the exit code stays 0. Without a peer `--loopback` says the same.
#[test]
fn parity_detection_on_a_pty_pair_is_not_testable_and_says_what_to_wire() {
    let Some(pair) = pty_pair() else { return };
    let o = si(&["ports", "--check", &pair.a, "--loopback-peer", &pair.b]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    let line = t
        .lines()
        .find(|l| l.contains("parity: parity errors detected: not testable"))
        .unwrap_or_else(|| panic!("no parity finding: {t}"));
    assert!(line.contains("pseudo-terminal"), "{line}");
    assert!(t.contains("--loopback-peer PATH"), "{t}");
    assert!(!t.contains("detected: yes"), "{t}");

    let o = si(&[
        "--json",
        "ports",
        "--check",
        &pair.a,
        "--loopback-peer",
        &pair.b,
    ]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    let report: serde_json::Value =
        serde_json::from_str(stdout(&o).lines().last().expect("a line")).expect("JSON");
    assert_eq!(report["parity_errors_detected"], "not testable", "{t}");
    let finding = report["findings"]
        .as_array()
        .expect("findings")
        .iter()
        .find(|f| f["check"] == "parity")
        .unwrap_or_else(|| panic!("no parity finding: {t}"));
    assert_eq!(finding["severity"], "note", "{t}");
    assert!(
        finding["remedy"].as_str().unwrap().contains("null-modem"),
        "{t}"
    );
}

#[test]
fn loopback_without_a_peer_reports_parity_detection_not_testable() {
    let Some((_socat, pty)) = echoing_pty() else {
        return;
    };
    let o = si(&["--json", "ports", "--check", &pty, "--loopback"]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    let report: serde_json::Value =
        serde_json::from_str(stdout(&o).lines().last().expect("a line")).expect("JSON");
    assert_eq!(report["parity_errors_detected"], "not testable", "{t}");
}
