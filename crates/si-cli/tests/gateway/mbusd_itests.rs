//! mbusd's own integration tests (its tests/run_itests.py, ported to pymodbus 3.16 in
//! `mbusd_itests.py` beside this file: the six tests and their assertions) against `si gateway`.
//! CI (`.ci/run`) also runs the script against mbusd built from source, as the control.

use crate::common::have_socat;
use crate::common::modbus::have_pymodbus;

#[test]
fn mbusds_integration_tests_pass_against_si_gateway() {
    if !(have_socat() && have_pymodbus()) {
        return;
    }
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/gateway/mbusd_itests.py");
    let out = std::process::Command::new("python3")
        .args([script, "si", env!("CARGO_BIN_EXE_si")])
        .output()
        .expect("run python3");
    let text = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{text}");
    assert!(
        text.contains("Ran 6 tests") && text.contains("\nOK"),
        "{text}"
    );
}
