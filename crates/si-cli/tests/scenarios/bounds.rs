//! Bounded memory and smaller gaps: sizes a user gives are checked against a
//! documented maximum before anything is allocated, stdin lines are capped, and the decoders
//! and readers refuse what is out of range with the value, the range and where it was.

use std::time::{Duration, Instant};

use crate::common;
use crate::dpcoord::host;
use crate::module::temp_file as file;

use common::{si, stderr, stdout};

/// Runs `si ARGS`, which must fail with exit code 1; what it printed (stdout, then stderr).
fn fails(args: &[&str]) -> String {
    fails_with(1, args)
}

/// Runs `si ARGS`, which must fail with exit code `code` (2: a usage error, before any port
/// is opened); what it printed (stdout, then stderr).
fn fails_with(code: i32, args: &[&str]) -> String {
    let o = si(args);
    assert_eq!(o.status.code(), Some(code), "{args:?}: {o:?}");
    format!("{}{}", stdout(&o), stderr(&o))
}

/// `modbus serve --config` with a 4 GiB area (or DB) is refused with a range error, exit 1,
/// before the port is opened (there is none: /dev/null) and before any allocation (the
/// library-level proof is si-modbus's tests/memory_bounds.rs, under a counting allocator).
#[test]
fn modbus_serve_refuses_a_4_gib_memory_area_with_a_range_error() {
    for (name, text, named) in [
        (
            "flags.toml",
            "[memory]\nflags = 4294967295\n",
            "memory.flags = 4294967295 bytes is out of range: 0 … 65536 bytes",
        ),
        (
            "db.toml",
            "[memory]\ndbs = [{ number = 1, length = 4294967295 }]\n",
            "DB length = 4294967295 bytes is out of range: 0 … 65536 bytes (DB1)",
        ),
        (
            "total.toml",
            &format!(
                "[memory]\ndbs = [{}]\n",
                (1..=300)
                    .map(|n| format!("{{ number = {n}, length = 65536 }}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            "memory in all areas = ",
        ),
    ] {
        let path = file(name, text);
        let started = Instant::now();
        let err = fails(&[
            "--port",
            "/dev/null",
            "modbus",
            "serve",
            "--unit",
            "1",
            "--config",
            path.to_str().unwrap(),
        ]);
        assert!(err.contains(named) && err.contains(name), "{name}: {err}");
        assert!(started.elapsed() < Duration::from_secs(20), "{name}: quick");
    }
}

/// A stdin line longer than the cap stops `dp-coord host` with the line's number and the
/// cap, instead of reading it whole.
#[test]
fn dp_coord_host_refuses_an_overlong_stdin_line() {
    // 16 MiB in one line: the host stops reading after 4 KiB of it.
    let long = "0".repeat(16 << 20);
    let o = host(
        &["--window", "8", "send", "41"],
        &["00 00 00 00 00 00 00 00", &long],
    );
    assert_eq!(o.status.code(), Some(1), "{o:?}");
    let err = stderr(&o);
    assert!(
        err.contains("input line 2 is longer than 4096 bytes"),
        "{err}"
    );
}

/// [CP 341] §2.2.3: at most 128 data bytes per telegram, reactions included (a 59,996-byte reaction
/// was accepted).
#[test]
fn frame_decode_rk512_refuses_a_reaction_beyond_128_data_bytes() {
    let ok = format!("00 00 00 00{}", " 11".repeat(128));
    let o = si(&["frame", "decode", "rk512", &ok]);
    assert!(o.status.success(), "{}", stderr(&o));
    // Without spaces: one argument may not exceed 128 KiB (Linux MAX_ARG_STRLEN).
    let long = format!("00000000{}", "11".repeat(59_996));
    let err = fails(&["frame", "decode", "rk512", &long]);
    assert!(
        err.contains("expected at most 128 data bytes per telegram, found 59996"),
        "{err}"
    );
}

/// A trace header with `baud` 0 is refused with a range error naming the line.
#[test]
fn monitor_refuses_a_trace_header_with_baud_0() {
    let path = file(
        "baud0.jsonl",
        "{\"format\":\"si-trace\",\"version\":1,\"source\":\"port\",\"settings\":{\"baud\":0,\"data_bits\":8,\"parity\":\"even\",\"stop_bits\":1}}\n",
    );
    let err = fails(&["monitor", "--trace", path.to_str().unwrap()]);
    assert!(
        err.contains("trace line 1: baud = 0 bit/s is out of range: 110, 300"),
        "{err}"
    );
}

/// `params check`: a quoted number is a type error with its key and line; an integer beyond
/// 64 bits names its line.
#[test]
fn params_check_names_type_errors_and_oversized_integers_with_their_line() {
    let path = file("quoted.toml", "driver = \"3964r\"\nbaud = \"9600\"\n");
    let text = fails(&["params", "check", path.to_str().unwrap()]);
    assert!(
        text.contains("baud = \"9600\" must be a number") && text.contains("(line 2)"),
        "{text}"
    );
    let path = file(
        "huge.toml",
        "driver = \"3964r\"\n\nchar_delay_ms = 99999999999999999999999\n",
    );
    let text = fails(&["params", "check", path.to_str().unwrap()]);
    assert!(text.contains("(line 3)"), "{text}");
}

/// `--addr 65535 --count 2` runs past the 16-bit address space: refused on read and write.
#[test]
fn an_address_span_past_65535_is_refused() {
    for args in [
        &["read", "holding", "--addr", "65535", "--count", "2"][..],
        &["read", "coils", "--addr", "65535", "--count", "2"][..],
        &["write", "registers", "--addr", "65535", "1", "2"][..],
        &["write", "coils", "--addr", "65535", "1", "0"][..],
    ] {
        let err = fails_with(2, &[&["modbus"][..], args, &["--unit", "1"]].concat());
        assert!(err.contains("65536"), "{args:?}: {err}");
    }
}

/// `rk512 serve --config` caps each area at 1 MiB and all of them together at 16 MiB: twenty
/// DBs of 1 MiB are refused before the port is opened.
#[test]
fn rk512_serve_refuses_blocks_that_add_up_beyond_the_total() {
    let blocks: Vec<String> = (1..=20)
        .map(|n| format!("[[db]]\nnumber = {n}\nlength = 1048576\n"))
        .collect();
    let path = file("rk512-total.toml", &blocks.join(""));
    let err = fails(&[
        "--port",
        "/dev/null",
        "rk512",
        "serve",
        "--config",
        path.to_str().unwrap(),
    ]);
    assert!(
        err.contains("memory in all areas = 20974848 bytes is out of range: 0 … 16777216 bytes"),
        "{err}"
    );
}
