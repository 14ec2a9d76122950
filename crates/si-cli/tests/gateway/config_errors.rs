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

#[test]
fn the_timing_flags_name_their_unit_and_are_checked_as_the_file_keys() {
    let line = ["gateway", "--line", "/dev/null", "--units", "1"];
    let o = si(&[&line[..], &["--response-timeout-ms", "10"]].concat());
    assert!(
        stderr(&o).contains("response_timeout_ms = 10 ms is out of range"),
        "{}",
        stderr(&o)
    );
    let o = si(&[&line[..], &["--pause-ms", "20000"]].concat());
    assert!(
        stderr(&o).contains("pause_ms = 20000 ms is out of range"),
        "{}",
        stderr(&o)
    );
    // The names before the naming rule are gone (nothing was released with them).
    for old in ["--timeout", "--pause"] {
        let o = si(&[&line[..], &[old, "100"]].concat());
        assert!(!o.status.success());
        assert!(
            stderr(&o).contains("unexpected argument"),
            "{old}: {}",
            stderr(&o)
        );
    }
}

#[test]
fn a_50_mb_bad_value_gives_a_short_error_naming_the_file_and_the_key() {
    let path = test_dir("gateway-config").join("huge.toml");
    // 50 MB: over the cap of every file si reads, refused before parsing, naming the file.
    // 3 MB: within the cap, parsed, and the bad value's excerpt cut to a line's worth.
    for (size, names) in [(50 << 20, "4 MiB"), (3 << 20, "")] {
        let huge = "9".repeat(size);
        for (key, value) in [("units", format!("\"{huge}\"")), ("pause_ms", huge.clone())] {
            std::fs::write(
                &path,
                format!(
                    "[[line]]\nname = \"m\"\ndevice = \"/dev/null\"\nunits = \"1\"\n{key} = {value}\n"
                )
                .replace("units = \"1\"\nunits", "units"),
            )
            .unwrap();
            let o = si(&["gateway", "--config", path.to_str().unwrap()]);
            assert!(!o.status.success());
            let e = stderr(&o);
            assert!(e.len() < 1000, "{key}: a {} byte message", e.len());
            assert!(
                e.contains(path.to_str().unwrap()),
                "{key}: names the file: {e}"
            );
            let named = if names.is_empty() { key } else { names };
            assert!(
                e.contains(named),
                "{key} of {size} bytes: names {named}: {e}"
            );
        }
    }
}

#[test]
fn two_lines_of_one_name_are_refused_naming_file_line_and_key() {
    let path = test_dir("gateway-config").join("twice.toml");
    std::fs::write(
        &path,
        "[[line]]\nname = \"meters\"\ndevice = \"/dev/null\"\nunits = \"1\"\n\
         [[line]]\nname = \"meters\"\ndevice = \"/dev/null\"\nunits = \"2\"\n",
    )
    .unwrap();
    let o = si(&["gateway", "--config", path.to_str().unwrap()]);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(e.contains(path.to_str().unwrap()), "{e}");
    assert!(
        e.contains("line 2 (meters): name = \"meters\""),
        "the second line, its key and value: {e}"
    );
}

#[test]
fn a_toml_error_names_the_file_and_where_in_it() {
    let path = test_dir("gateway-config").join("syntax.toml");
    std::fs::write(
        &path,
        "[[line]]\nname = \"m\"\ndevice = \"/dev/null\"\nunits = \"1\"\nspeed = 1\n",
    )
    .unwrap();
    let o = si(&["gateway", "--config", path.to_str().unwrap()]);
    let e = stderr(&o);
    assert!(e.contains(path.to_str().unwrap()), "{e}");
    let at_line_5 = format!("{}:5", path.display());
    assert!(e.contains(&at_line_5) && e.contains("speed"), "{e}");
}

#[test]
fn check_exits_0_for_a_valid_file_and_2_naming_file_line_and_key_for_an_invalid_one() {
    let dir = test_dir("gateway-check");
    let good = dir.join("good.toml");
    std::fs::write(
        &good,
        "[[line]]\nname = \"meters\"\ndevice = \"/dev/nonexistent-si-port\"\nunits = \"1\"\n",
    )
    .unwrap();
    let o = si(&["gateway", "--check", good.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(
        crate::common::stdout(&o).contains("valid, 1 line(s): meters"),
        "nothing opened, the device need not exist: {}",
        crate::common::stdout(&o)
    );
    let bad = dir.join("bad.toml");
    std::fs::write(
        &bad,
        "[[line]]\nname = \"meters\"\ndevice = \"/dev/null\"\nunits = \"1\"\nretries = 99\n",
    )
    .unwrap();
    let o = si(&["gateway", "--check", bad.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(e.contains(bad.to_str().unwrap()), "{e}");
    assert!(e.contains("line 1 (meters): retries = 99"), "{e}");
    let unknown = dir.join("unknown.toml");
    std::fs::write(
        &unknown,
        "[[line]]\nname = \"meters\"\ndevice = \"/dev/null\"\nunits = \"1\"\nspeed = 1\n",
    )
    .unwrap();
    let o = si(&["gateway", "--check", unknown.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    let at = format!("{}:5: unknown field `speed`", unknown.display());
    assert!(stderr(&o).contains(&at), "{}", stderr(&o));
}
