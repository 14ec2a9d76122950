//! Every file the user hands `si` is read through one bounded reader (si-cli `config_file`):
//! `/dev/zero` is refused with the cap instead of filling the memory, a huge bad value gives a
//! short error, errors name the file, line and key, and contradictory keys are refused.

use crate::common;

use common::{si, si_command, stderr, test_dir};
use std::path::PathBuf;
use std::process::Output;

/// A file named `name` in this module's directory, holding `text`.
fn file(name: &str, text: &str) -> PathBuf {
    let path = test_dir("si-config-files").join(name);
    std::fs::write(&path, text).unwrap();
    path
}

fn fails_with(o: &Output, want: &str) -> String {
    let err = stderr(o);
    assert!(!o.status.success(), "{err}");
    assert!(err.contains(want), "{err}");
    err
}

const CAP: &str = "cannot read /dev/zero: longer than 4 MiB, the most a file given to si may hold";

#[test]
fn dev_zero_as_a_config_is_refused_with_the_cap() {
    let serve = si(&["modbus", "serve", "--unit", "1", "--config", "/dev/zero"]);
    fails_with(&serve, CAP);
    fails_with(&si(&["gateway", "--config", "/dev/zero"]), CAP);
    fails_with(&si(&["rk512", "serve", "--config", "/dev/zero"]), CAP);
    fails_with(&si(&["params", "check", "/dev/zero"]), CAP);
    let profile = si_command()
        .env("SI_CONFIG", "/dev/zero")
        .args(["--profile", "x", "sim", "line-timing"])
        .output()
        .unwrap();
    fails_with(&profile, &format!("--profile x: {CAP}"));
}

#[test]
fn a_50_mb_file_and_a_long_bad_value_give_errors_under_1_kib() {
    let huge = format!("mode = \"{}\"\n", "A".repeat(50 << 20));
    let path = file("huge.toml", &huge);
    let o = si(&[
        "modbus",
        "serve",
        "--unit",
        "1",
        "--config",
        path.to_str().unwrap(),
    ]);
    let err = fails_with(&o, "longer than 4 MiB");
    assert!(err.len() < 1024, "{} bytes", err.len());

    let long = format!("mode = \"{}\"\n", "A".repeat(1 << 20));
    let path = file("long.toml", &long);
    let o = si(&[
        "modbus",
        "serve",
        "--unit",
        "1",
        "--config",
        path.to_str().unwrap(),
    ]);
    let err = fails_with(&o, "long.toml:1: mode: operating mode = \"AAAA");
    assert!(err.contains("A…\""), "{err}");
    assert!(err.len() < 1024, "{} bytes", err.len());

    let gateway = format!(
        "[[line]]\ndevice = \"{}\"\nunits = 5\n",
        "B".repeat(1 << 20)
    );
    let path = file("gateway-long.toml", &gateway);
    let o = si(&["gateway", "--config", path.to_str().unwrap()]);
    fails_with(
        &o,
        "gateway-long.toml:3: [[line]] units: invalid type: integer `5`",
    );
    assert!(stderr(&o).len() < 1024);
}

#[test]
fn modbus_serve_config_errors_name_file_line_and_key() {
    let path = file(
        "serve-type.toml",
        "mode = \"normal\"\n\n[memory]\ninputs = \"x\"\n",
    );
    let o = si(&[
        "modbus",
        "serve",
        "--unit",
        "1",
        "--config",
        path.to_str().unwrap(),
    ]);
    fails_with(
        &o,
        "serve-type.toml:4: [memory] inputs: invalid type: string \"x\", expected u32",
    );

    let path = file(
        "serve-range.toml",
        "[memory]\nflags = 1\ninputs = 99999999\n",
    );
    let o = si(&[
        "modbus",
        "serve",
        "--unit",
        "1",
        "--config",
        path.to_str().unwrap(),
    ]);
    fails_with(
        &o,
        "serve-range.toml:3: memory.inputs = 99999999 bytes is out of range",
    );

    let path = file("serve-unknown.toml", "mode = \"normal\"\nbogus = 1\n");
    let o = si(&[
        "modbus",
        "serve",
        "--unit",
        "1",
        "--config",
        path.to_str().unwrap(),
    ]);
    fails_with(&o, "serve-unknown.toml:2: unknown field `bogus`");
}

#[test]
fn a_profile_with_both_port_and_tcp_is_refused() {
    let path = file(
        "both.toml",
        "[profile.x]\nport = \"/dev/null\"\nbaud = 19200\ntcp = \"192.0.2.10:4001\"\n",
    );
    let o = si_command()
        .env("SI_CONFIG", &path)
        .args(["--profile", "x", "sim", "line-timing"])
        .output()
        .unwrap();
    fails_with(
        &o,
        "both.toml:4: [profile.x] tcp: port and tcp exclude each other",
    );
}
