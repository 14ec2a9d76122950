//! A wrong configuration value is refused before anything opens, naming the line, the key and
//! the value.

use crate::common::{si, stderr, test_dir};

#[test]
fn a_bad_value_in_the_file_names_line_key_and_value() {
    let path = test_dir("gateway-config").join("gw.toml");
    std::fs::write(
        &path,
        "listen = \"127.0.0.1:0\"\n[[line]]\nname = \"meters\"\ndevice = \"/dev/null\"\nunits = \"1-4\"\n\
         [[line]]\nname = \"drives\"\ndevice = \"tcp:127.0.0.1:1\"\nunits = \"5\"\npause_ms = 20000\n",
    )
    .unwrap();
    let o = si(&["gateway", "--config", path.to_str().unwrap()]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("line 2 (drives): pause_ms = 20000 ms is out of range: 0 … 10000"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn a_bad_flag_names_key_and_value() {
    let o = si(&["gateway", "--line", "/dev/null", "--units", "1-300"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("units = \"1-300\""), "{}", stderr(&o));
    let o = si(&[
        "gateway",
        "--line",
        "/dev/null",
        "--units",
        "1",
        "--retries",
        "16",
    ]);
    assert!(
        stderr(&o).contains("retries = 16 is out of range: 0 … 15"),
        "{}",
        stderr(&o)
    );
}
