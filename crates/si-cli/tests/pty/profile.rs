//! A profile supplies the port settings: `si modbus read --profile plc1` reads from
//! `si modbus serve` over a pseudo-terminal pair (socat: `apt-get install socat`; a skip with a
//! message when it is missing, a failure with `CI` set) with the port and line given only by the
//! profile in `SI_CONFIG`, and records them in its trace header.

use crate::common;

use common::modbus;
use common::{si_command, stderr, stdout, test_dir};

#[test]
fn modbus_read_takes_port_and_line_from_the_profile() {
    let Some((pair, _serve, _log, _)) = modbus::serving_8n1() else {
        return;
    };
    // The profile names the master's end and the server's 19 200 bit/s 8N1; no line flag given.
    let dir = test_dir("si-profile-pty");
    let config = dir.join("config.toml");
    std::fs::write(
        &config,
        format!(
            "[profile.plc1]\nport = \"{}\"\nbaud = 19200\nparity = \"none\"\n",
            pair.b
        ),
    )
    .unwrap();
    let trace = dir.join("read.jsonl");
    let o = si_command()
        .env("SI_CONFIG", &config)
        .args(["--json", "--profile", "plc1", "modbus", "read", "holding"])
        .args(["--unit", "1", "--count", "2", "--record"])
        .arg(&trace)
        .output()
        .expect("run si");
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("\"values\":[0,0]"), "{}", stdout(&o));
    let header = std::fs::read_to_string(&trace).unwrap();
    let header = header.lines().next().unwrap_or_default();
    assert!(
        header.contains(r#""settings":{"baud":19200,"data_bits":8,"parity":"none","stop_bits":1}"#),
        "{header}"
    );
}
