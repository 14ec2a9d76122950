//! SIGHUP reads the configuration file again: a file that does not check is refused with the
//! error it would give at start and the running configuration stays; a valid one is applied
//! (lines kept, restarted, added, removed).

use super::harness::{stdout_lines, wait_for_event};
use crate::common::{si_command, test_dir, Kill};
use std::io::Read;
use std::process::Stdio;
use std::time::Duration;

/// Two lines whose devices are missing: they start down (`allow_down_at_start`), no peer
/// needed.
const TWO_LINES: &str = "listen = \"127.0.0.1:0\"\nallow_down_at_start = true\n\
    [[line]]\nname = \"a\"\ndevice = \"/dev/nonexistent-si-reload-a\"\nunits = \"1\"\n\
    [[line]]\nname = \"b\"\ndevice = \"/dev/nonexistent-si-reload-b\"\nunits = \"2\"\n";

fn hangup(gateway: &Kill) {
    let pid = gateway.0.id().to_string();
    let ok = std::process::Command::new("kill")
        .args(["-HUP", &pid])
        .status()
        .is_ok_and(|s| s.success());
    assert!(ok, "kill -HUP {pid}");
}

#[test]
fn sighup_applies_a_valid_file_and_refuses_an_invalid_one_with_its_start_error() {
    let path = test_dir("gateway-reload").join("gw.toml");
    std::fs::write(&path, TWO_LINES).unwrap();
    let mut child = si_command()
        .args(["--json", "gateway", "--config"])
        .arg(&path)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn si gateway");
    let log = stdout_lines(&mut child);
    let mut gateway = Kill(child);
    wait_for_event(&log, "listening", Duration::from_secs(20));

    // Invalid: refused with the error the file would give at start.
    std::fs::write(
        &path,
        TWO_LINES.replace("units = \"2\"", "units = \"2\"\nretries = 99"),
    )
    .unwrap();
    let start_error = si_command()
        .args(["gateway", "--check"])
        .arg(&path)
        .output()
        .unwrap();
    let start_error = String::from_utf8_lossy(&start_error.stderr)
        .trim()
        .to_owned();
    let start_error = start_error.trim_start_matches("si: error: ").to_owned();
    assert!(start_error.contains("retries = 99"), "{start_error}");
    hangup(&gateway);

    // Valid: b changed, a kept, c added.
    std::thread::sleep(Duration::from_millis(500));
    let changed = format!(
        "{}pause_ms = 5\n[[line]]\nname = \"c\"\ndevice = \"/dev/nonexistent-si-reload-c\"\nunits = \"3\"\n",
        TWO_LINES
    );
    std::fs::write(&path, changed).unwrap();
    hangup(&gateway);
    let v = wait_for_event(&log, "reloaded", Duration::from_secs(20));
    assert_eq!(v["kept"], serde_json::json!(["a"]), "{v}");
    assert_eq!(v["restarted"], serde_json::json!(["b"]), "{v}");
    assert_eq!(v["added"], serde_json::json!(["c"]), "{v}");
    assert!(gateway.0.try_wait().unwrap().is_none(), "still serving");

    let _ = gateway.0.kill();
    let _ = gateway.0.wait();
    let mut err = String::new();
    gateway
        .0
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    assert!(
        err.contains(&format!(
            "reload refused, the running configuration stays: {start_error}"
        )),
        "the start error, said on stderr: {err}"
    );
}
