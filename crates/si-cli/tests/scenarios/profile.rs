//! `--profile NAME` from the settings file (`SI_CONFIG`, si-cli `profile`): the profile supplies
//! the line options, a flag wins over it, and a bad file is refused with its path, line and key.
//! `si sim` shows the character format it was given, so these run offline.

use crate::common;

use common::{si_command, stderr, stdout, test_dir};
use std::process::Output;
use std::sync::atomic::{AtomicUsize, Ordering};

const FILE: &str = "\
[profile.plc1]
port = \"/dev/null\"
baud = 19200
parity = \"none\"
stop_bits = 2

[profile.slow]
baud = 1200
";

/// A new settings file holding `toml`: one file per call, as tests run in parallel and a file
/// rewritten while another `si` reads it would read empty.
fn settings_file(toml: &str) -> std::path::PathBuf {
    static NEXT: AtomicUsize = AtomicUsize::new(0);
    let path =
        test_dir("si-profile").join(format!("{}.toml", NEXT.fetch_add(1, Ordering::Relaxed)));
    std::fs::write(&path, toml).unwrap();
    path
}

/// `si ARGS` with `SI_CONFIG` naming a file holding `toml`.
fn si_with(toml: &str, args: &[&str]) -> Output {
    si_command()
        .env("SI_CONFIG", settings_file(toml))
        .args(args)
        .output()
        .expect("run si")
}

/// The character format `si sim line-timing` reports.
fn sim_settings(toml: &str, args: &[&str]) -> String {
    let o = si_with(
        toml,
        &[&["--json"][..], args, &["sim", "line-timing"]].concat(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let last = stdout(&o).lines().last().unwrap_or_default().to_owned();
    let v: serde_json::Value = serde_json::from_str(&last).expect("JSON line");
    v["settings"].as_str().unwrap_or_default().to_owned()
}

#[test]
fn the_profile_supplies_the_line_options() {
    assert_eq!(sim_settings(FILE, &["--profile", "plc1"]), "19200 8N2");
    assert_eq!(sim_settings(FILE, &["--profile", "slow"]), "1200 8E1");
    assert_eq!(sim_settings(FILE, &[]), "9600 8E1");
}

#[test]
fn a_flag_wins_over_the_profile_before_or_after_the_command() {
    assert_eq!(
        sim_settings(FILE, &["--profile", "plc1", "--baud", "9600"]),
        "9600 8N2"
    );
    let o = si_with(
        FILE,
        &[
            "--json",
            "--profile",
            "plc1",
            "sim",
            "line-timing",
            "--parity",
            "odd",
        ],
    );
    assert!(
        stdout(&o).contains("\"settings\":\"19200 8O2\""),
        "{}",
        stdout(&o)
    );
}

#[test]
fn a_flag_port_replaces_the_profiles_line() {
    let o = si_with(
        FILE,
        &[
            "--profile",
            "plc1",
            "modbus",
            "read",
            "holding",
            "-u",
            "1",
            "--port",
            "/nonexistent/tty",
        ],
    );
    assert!(!o.status.success());
    assert!(stderr(&o).contains("/nonexistent/tty"), "{}", stderr(&o));
}

#[test]
fn si_port_counts_as_given_and_wins_over_the_profile() {
    let dir = test_dir("si-profile");
    let path = dir.join("env.toml");
    std::fs::write(&path, FILE).unwrap();
    let o = si_command()
        .env("SI_CONFIG", &path)
        .env("SI_PORT", "/nonexistent/from-env")
        .args(["--profile", "plc1", "modbus", "read", "holding", "-u", "1"])
        .output()
        .expect("run si");
    assert!(
        stderr(&o).contains("/nonexistent/from-env"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn a_bad_value_gives_the_range_error_with_file_line_and_key() {
    let o = si_with(
        "[profile.x]\nport = \"/dev/null\"\nbaud = 12345\n",
        &["--profile", "x", "ports"],
    );
    assert!(!o.status.success());
    let err = stderr(&o);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.contains(".toml:3: [profile.x] baud: baud rate 12345 is not one of"),
        "{err}"
    );
    let o = si_with("[profile.x]\ndata_bits = 9\n", &["--profile", "x", "ports"]);
    assert!(
        stderr(&o).contains(":2: [profile.x] data_bits: data bits 9 out of range: 7 or 8"),
        "{}",
        stderr(&o)
    );
    let o = si_with(
        "[profile.x]\nparity = \"evne\"\n",
        &["--profile", "x", "ports"],
    );
    assert!(
        stderr(&o).contains(":2: [profile.x] parity: parity \"evne\" unknown"),
        "{}",
        stderr(&o)
    );
    let o = si_with(
        "[profile.x]\nport = \"/dev/null\"\nlatency_timer = 300\n",
        &["--profile", "x", "ports"],
    );
    assert!(
        stderr(&o).contains(
            ":3: [profile.x] latency_timer: latency timer 300 ms out of range: 1 … 255 ms"
        ),
        "{}",
        stderr(&o)
    );
}

#[test]
fn a_profiles_rx_latency_is_checked_with_its_line() {
    let o = si_with(
        "[profile.x]\nport = \"/dev/null\"\nrx_latency_ms = 256\n",
        &["--profile", "x", "ports"],
    );
    assert!(
        stderr(&o)
            .contains(":3: [profile.x] rx_latency_ms: rx latency 256 ms out of range: 0 … 255 ms"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn an_unknown_key_is_refused_with_its_line() {
    let o = si_with(
        "[profile.x]\nbaud = 9600\nbuad = 19200\n",
        &["--profile", "x", "ports"],
    );
    assert!(!o.status.success());
    let err = stderr(&o);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains(".toml:3: unknown field `buad`"), "{err}");
}

#[test]
fn an_unknown_profile_names_the_ones_there_are() {
    let o = si_with(FILE, &["--profile", "plc2", "ports"]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("no profile \"plc2\"; the file has: plc1, slow"),
        "{}",
        stderr(&o)
    );
}

/// `si ARGS` (split at spaces), with `SI_PORT` set as a shell set up for one adapter has it
/// when `port_env`, and `SI_CONFIG` naming a file holding [`FILE`].
fn si_words(port_env: bool, args: &str) -> Output {
    let mut c = si_command();
    if port_env {
        c.env("SI_PORT", "/nonexistent/from-env");
    }
    c.env("SI_CONFIG", settings_file(FILE))
        .args(args.split_whitespace())
        .output()
        .expect("run si")
}

/// A Modbus read; nothing listens on loopback port 1, so it fails connecting there.
const READ: &str = "modbus read holding -u 1 --response-timeout-ms 200";

#[test]
fn si_port_or_the_profiles_port_yields_to_a_typed_tcp_line_or_modbus_tcp() {
    for (port_env, args) in [
        (true, format!("--tcp 127.0.0.1:1 {READ}")),
        (true, format!("{READ} --modbus-tcp 127.0.0.1:1")),
        (
            false,
            format!("--profile plc1 {READ} --modbus-tcp 127.0.0.1:1"),
        ),
    ] {
        let o = si_words(port_env, &args);
        // Not a usage error, and not the environment's or the profile's port.
        assert_eq!(o.status.code(), Some(1), "{args}: {}", stderr(&o));
        assert!(stderr(&o).contains("127.0.0.1:1"), "{args}: {}", stderr(&o));
        assert!(!stderr(&o).contains("from-env"), "{args}: {}", stderr(&o));
    }
}

#[test]
fn a_typed_port_with_a_tcp_line_is_a_usage_error() {
    for args in [
        format!("--port /dev/null --tcp 127.0.0.1:1 {READ}"),
        format!("{READ} --tcp 127.0.0.1:1 --port /dev/null"),
    ] {
        let o = si_words(false, &args);
        assert_eq!(o.status.code(), Some(2), "{args}: {}", stderr(&o));
        let why = "'--port <PORT>' cannot be used with '--tcp <HOST:PORT>'";
        assert!(stderr(&o).contains(why), "{}", stderr(&o));
    }
}
