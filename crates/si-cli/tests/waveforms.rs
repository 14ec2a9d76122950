//! `si trace export --sr/--vcd`: the waveforms decode to what `si monitor` decodes.
//!
//! - sigrok-cli's own `uart` + `modbus` decoders on the `.sr` find the Modbus frames (unit,
//!   function code, register values, CRC verdict) the monitor finds in the same trace;
//! - si's decoders in `contrib/sigrok` (`si_3964r`, `si_rk512`, `si_uss`, loaded through
//!   `SIGROKDECODE_DIR`) give the monitor's records: the 3964(R) control characters and blocks
//!   with their BCC verdict (a BCC error and a NAK included), the USS telegrams' address and net
//!   data, the RK 512 telegrams' data counts;
//! - the VCD, read back by a small UART receiver here, holds the trace's characters at their
//!   bit times.
//!
//! sigrok-cli missing is a skip, or a failure with `CI` set.

mod common;

use common::{monitor_json, si_command, test_dir};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;

fn tmp(name: &str) -> PathBuf {
    test_dir("si-waveforms-test").join(name)
}

fn have_sigrok_cli() -> bool {
    common::peer(
        "sigrok-cli",
        Command::new("sigrok-cli").arg("--version"),
        "apt-get install sigrok-cli",
    )
}

/// The repository's `contrib/sigrok`, for `SIGROKDECODE_DIR`.
fn decoders_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../contrib/sigrok")
}

/// `si sim <scenario> --record`, then `si trace export` to `.sr` and `.vcd`; returns the
/// trace and the two exports. `test` names the files apart from those of tests running
/// alongside with the same scenario.
fn export(test: &str, scenario: &str) -> (PathBuf, PathBuf, PathBuf) {
    let trace = tmp(&format!("{test}-{scenario}.trace"));
    let o = si_command()
        .args(["sim", scenario, "--record"])
        .arg(&trace)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "si sim {scenario}: {}",
        common::text(&o)
    );
    let sr = tmp(&format!("{test}-{scenario}.sr"));
    let vcd = tmp(&format!("{test}-{scenario}.vcd"));
    let o = si_command()
        .args(["trace", "export"])
        .arg(&trace)
        .arg("--sr")
        .arg(&sr)
        .arg("--vcd")
        .arg(&vcd)
        .output()
        .unwrap();
    assert!(o.status.success(), "si trace export: {}", common::text(&o));
    (trace, sr, vcd)
}

/// The monitor's frame and control records of a trace.
fn monitor(trace: &Path) -> Vec<Value> {
    let (records, _) = monitor_json(&[std::ffi::OsStr::new("--trace"), trace.as_os_str()]);
    records
}

/// `sigrok-cli -i SR -P uart:…,STACK -A ANN` with the trace's first station on the uart's TX
/// and the second on RX: the annotations as (start µs, row, text), in time order.
fn sigrok(sr: &Path, stations: [&str; 2], stack: &str, ann: &str) -> Vec<(f64, String, String)> {
    let uart = format!(
        "uart:baudrate=9600:parity=even:tx={}_TxD:rx={}_TxD,{stack}",
        stations[0], stations[1]
    );
    let o = Command::new("sigrok-cli")
        .env("SIGROKDECODE_DIR", decoders_dir())
        .arg("-i")
        .arg(sr)
        .args(["-P", &uart, "-A", ann, "--protocol-decoder-jsontrace"])
        .output()
        .expect("run sigrok-cli");
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "sigrok-cli: {text}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let json: Value = serde_json::from_str(&text).unwrap_or_else(|e| panic!("{e}: {text}"));
    let mut v: Vec<(f64, String, String)> = json["traceEvents"]
        .as_array()
        .expect("traceEvents")
        .iter()
        .filter(|e| e["ph"] == "B")
        .map(|e| {
            (
                e["ts"].as_f64().unwrap(),
                e["tid"].as_str().unwrap().to_owned(),
                e["name"].as_str().unwrap().to_owned(),
            )
        })
        .collect();
    // At one instant (both stations' STX in an initialization conflict) the first station's,
    // on TX, comes first, as the monitor lists its stations in order.
    v.sort_by(|a, b| {
        a.0.total_cmp(&b.0)
            .then(b.1.starts_with("TX").cmp(&a.1.starts_with("TX")))
    });
    v
}

/// "TX" for the first station, "RX" for the second: the uart channel its characters are on.
fn side(record: &Value, first: &str) -> &'static str {
    if record["from"] == first {
        "TX"
    } else {
        "RX"
    }
}

fn flagged(record: &Value, what: &str) -> bool {
    record["flags"]
        .as_array()
        .is_some_and(|f| f.iter().any(|f| f["text"].as_str().unwrap().contains(what)))
}

#[test]
fn sigrok_modbus_decodes_the_frames_the_monitor_decodes() {
    if !have_sigrok_cli() {
        return;
    }
    for scenario in ["modbus", "modbus-crc-error"] {
        let (trace, sr, _) = export("modbus", scenario);
        // Per frame: unit, function code (an exception's without its 80H bit), CRC verdict.
        let expected: Vec<(u8, u8, bool)> = monitor(&trace)
            .iter()
            .filter(|r| r["kind"] == "frame")
            .map(|r| {
                let b = si_core::hex::parse(r["bytes"].as_str().unwrap()).unwrap();
                (b[0], b[1] & 0x7F, !flagged(r, "CRC error"))
            })
            .collect();
        let notes = sigrok(&sr, ["master", "slave"], "modbus", "modbus");
        let mut found = Vec::new();
        let mut unit = None;
        let mut function = None;
        for (_, _, text) in &notes {
            if let Some(n) = text.strip_prefix("Slave ID: ") {
                unit = n.parse::<u8>().ok();
            } else if let Some(rest) = text
                .strip_prefix("Function ")
                .or_else(|| text.strip_prefix("Error for function "))
            {
                function = rest.split(':').next().and_then(|f| f.parse::<u8>().ok());
            } else if text == "CRC correct" || text.starts_with("CRC should be") {
                found.push((
                    unit.take().expect("unit before CRC"),
                    function.take().expect("function before CRC"),
                    text == "CRC correct",
                ));
            }
        }
        assert_eq!(found, expected, "{scenario}: {notes:?}");
        assert!(expected.len() >= 2, "{scenario}: {expected:?}");
        if scenario == "modbus" {
            // The registers read back: 1234H and 5678H, as the monitor prints them.
            let values: Vec<&str> = notes
                .iter()
                .filter(|n| n.2.starts_with("0x"))
                .map(|n| n.2.as_str())
                .collect();
            assert_eq!(values, ["0x1234 / 4660", "0x5678 / 22136"], "{notes:?}");
        } else {
            assert!(expected.iter().any(|f| !f.2), "a CRC error: {expected:?}");
        }
    }
}

#[test]
fn si_3964r_decoder_gives_the_monitors_records_bcc_error_and_nak_included() {
    if !have_sigrok_cli() {
        return;
    }
    for scenario in [
        "3964r-bcc-error",
        "3964r-nak-retry",
        "3964r",
        "3964r-conflict",
    ] {
        let (trace, sr, _) = export("3964r", scenario);
        let expected: Vec<(String, String)> = monitor(&trace)
            .iter()
            .map(|r| {
                let dir = side(r, "A").to_owned();
                if r["kind"] == "control" {
                    (dir, r["label"].as_str().unwrap().to_owned())
                } else {
                    let verdict = if flagged(r, "BCC error") {
                        "BCC error"
                    } else {
                        "BCC ok"
                    };
                    (
                        dir,
                        format!("block {} {verdict}", r["bytes"].as_str().unwrap()),
                    )
                }
            })
            .collect();
        let found: Vec<(String, String)> = sigrok(&sr, ["A", "B"], "si_3964r", "si_3964r")
            .into_iter()
            .filter(|(_, _, text)| {
                ["STX", "DLE", "NAK"].contains(&text.as_str()) || text.starts_with("block ")
            })
            .map(|(_, row, text)| (row[..2].to_owned(), text))
            .collect();
        assert_eq!(found, expected, "{scenario}");
        if scenario == "3964r-bcc-error" {
            assert!(found.iter().any(|f| f.1.ends_with("BCC error")));
            assert!(found.iter().any(|f| f.1 == "NAK"));
        }
    }
}

#[test]
fn si_uss_decoder_gives_the_monitors_telegrams() {
    if !have_sigrok_cli() {
        return;
    }
    let (trace, sr, _) = export("uss", "uss-param");
    let expected: Vec<(String, String)> = monitor(&trace)
        .iter()
        .filter(|r| r["kind"] == "frame")
        .map(|r| {
            let mut text = r["text"].as_str().unwrap().to_owned();
            if flagged(r, "BCC") {
                text += " BCC error";
            }
            (side(r, "master").to_owned(), text)
        })
        .collect();
    let found: Vec<(String, String)> = sigrok(&sr, ["master", "drive1"], "si_uss", "si_uss")
        .into_iter()
        .filter(|(_, row, _)| row.ends_with("telegrams"))
        .map(|(_, row, text)| (row[..2].to_owned(), text))
        .collect();
    assert!(expected.len() >= 4, "{expected:?}");
    assert_eq!(found, expected);
    // The parameter channel is taken apart: PKE with AK and PNU.
    let fields = sigrok(&sr, ["master", "drive1"], "si_uss", "si_uss");
    assert!(
        fields
            .iter()
            .any(|f| f.2 == "PKE 143A: AK 1, SPM 0, PNU 1082"),
        "{fields:?}"
    );
}

#[test]
fn si_rk512_decoder_finds_the_monitors_telegrams() {
    if !have_sigrok_cli() {
        return;
    }
    let (trace, sr, _) = export("rk512", "rk512");
    // Per telegram: its side and how many data bytes it carries.
    let expected: Vec<(String, String)> = monitor(&trace)
        .iter()
        .filter(|r| r["kind"] == "frame")
        .map(|r| {
            let text = r["text"].as_str().unwrap();
            let data = text.rsplit(", ").next().unwrap().to_owned();
            (side(r, "host").to_owned(), data)
        })
        .collect();
    let found: Vec<(String, String)> =
        sigrok(&sr, ["host", "PLC"], "si_3964r,si_rk512", "si_rk512")
            .into_iter()
            .filter(|(_, row, _)| row.ends_with("telegrams"))
            .map(|(_, row, text)| {
                let data = text.rsplit(", ").next().unwrap().to_owned();
                (row[..2].to_owned(), data)
            })
            .collect();
    assert!(expected.len() >= 4, "{expected:?}");
    assert_eq!(found, expected);
}

/// The VCD's value changes per signal: (time ns, level).
fn vcd_changes(path: &Path) -> Vec<(String, Vec<(u64, bool)>)> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut names: Vec<(String, String)> = Vec::new(); // (code, name)
    let mut changes: Vec<Vec<(u64, bool)>> = Vec::new();
    let mut now = 0;
    for line in text.lines() {
        let words: Vec<&str> = line.split_whitespace().collect();
        if words.first() == Some(&"$var") {
            names.push((words[3].to_owned(), words[4].to_owned()));
            changes.push(Vec::new());
        } else if let Some(t) = line.strip_prefix('#') {
            now = t.parse().unwrap();
        } else if let Some(level) = line.strip_prefix(['0', '1']) {
            let k = names.iter().position(|(c, _)| c == level).unwrap();
            changes[k].push((now, line.starts_with('1')));
        }
    }
    names.into_iter().map(|(_, n)| n).zip(changes).collect()
}

/// A UART receiver over value changes: 9600 bit/s 8E1, each character sampled mid-bit.
fn uart_read(changes: &[(u64, bool)]) -> Vec<u8> {
    let bit = 1e9 / 9600.0;
    let level_at = |t: f64| {
        changes
            .iter()
            .take_while(|c| c.0 as f64 <= t)
            .last()
            .is_none_or(|c| c.1)
    };
    let mut out = Vec::new();
    let mut t = 0.0;
    for &(at, high) in changes {
        if high || (at as f64) < t {
            continue;
        }
        // A falling edge after the last character: a start bit.
        let start = at as f64;
        assert!(!level_at(start + bit / 2.0), "start bit low at mid-bit");
        let mut byte = 0u8;
        let mut ones = 0;
        for k in 0..8 {
            if level_at(start + (1.5 + k as f64) * bit) {
                byte |= 1 << k;
                ones += 1;
            }
        }
        // Every edge inside the character falls on a bit boundary (±1 ns: the VCD's rounding).
        for &(e, _) in changes
            .iter()
            .filter(|c| c.0 >= at && (c.0 as f64) < start + 11.0 * bit)
        {
            let bits = (e as f64 - start) / bit;
            assert!(
                (bits - bits.round()).abs() * bit <= 1.0,
                "edge at {e} ns is {bits} bits into the character"
            );
        }
        let parity = level_at(start + 9.5 * bit);
        assert_eq!(parity, ones % 2 == 1, "even parity of {byte:02X}");
        assert!(level_at(start + 10.5 * bit), "stop bit of {byte:02X}");
        out.push(byte);
        t = start + 10.5 * bit;
    }
    out
}

#[test]
fn the_vcd_holds_the_traces_characters_at_their_bit_times() {
    // No external tool: the VCD is read back here.
    let (trace, _, vcd) = export("vcd", "modbus");
    let signals = vcd_changes(&vcd);
    let names: Vec<&str> = signals.iter().map(|s| s.0.as_str()).collect();
    assert_eq!(names, ["master_TxD", "slave_TxD"]);
    let bit = 1e9 / 9600.0;
    for (name, changes) in &signals {
        assert!(changes.len() > 10, "{name}: {changes:?}");
    }
    // The characters read back are what the monitor saw each station send.
    let records = monitor(&trace);
    for (station, changes) in &signals {
        let station = station.trim_end_matches("_TxD");
        let sent: Vec<u8> = records
            .iter()
            .filter(|r| r["from"] == station)
            .flat_map(|r| si_core::hex::parse(r["bytes"].as_str().unwrap()).unwrap())
            .collect();
        assert_eq!(uart_read(&changes[1..]), sent, "{station}");
    }
    // Master's first start bit begins at the trace's time 0 plus the lead-in of two 11-bit
    // characters (22 bit times): the waveform keeps the trace's timing.
    let first_fall = signals[0].1[1];
    assert!(!first_fall.1);
    assert!(
        (first_fall.0 as f64 - 22.0 * bit).abs() <= 1.0,
        "{first_fall:?}"
    );
}

#[test]
fn a_capture_longer_than_one_chunk_decodes_across_the_chunk_boundary() {
    if !have_sigrok_cli() {
        return;
    }
    // libsigrok's chunks hold 4 MiB samples: 27.3 s at 153 600 samples/s. Characters before,
    // around and after the boundary (sample 4 194 304 is 27.30438 s after the 2.29 ms lead-in).
    let trace = tmp("chunks.trace");
    let mut text = String::from(
        r#"{"format":"si-trace","version":1,"source":"sim","protocol":"modbus","settings":{"baud":9600,"data_bits":8,"parity":"even","stop_bits":1},"stations":["A"]}"#,
    );
    let times = [
        0, 27_300_000, 27_302_000, 27_304_000, 27_306_000, 30_000_000,
    ];
    let mut sent = Vec::new();
    for (k, at) in times.iter().enumerate() {
        let bytes = [0x55 + k as u8, 0xA0 + k as u8];
        sent.extend(bytes.iter().map(|b| format!("{b:02X}")));
        text += &format!(
            "\n{{\"at\":{at},\"station\":\"A\",\"kind\":\"tx\",\"bytes\":[{},{}]}}",
            bytes[0], bytes[1]
        );
    }
    std::fs::write(&trace, text + "\n").unwrap();
    let sr = tmp("chunks.sr");
    let o = si_command()
        .args(["trace", "export"])
        .arg(&trace)
        .arg("--sr")
        .arg(&sr)
        .output()
        .unwrap();
    assert!(o.status.success(), "si trace export: {}", common::text(&o));
    let o = Command::new("sigrok-cli")
        .arg("-i")
        .arg(&sr)
        .args([
            "-P",
            "uart:baudrate=9600:parity=even:tx=A_TxD",
            "-A",
            "uart=tx-data",
        ])
        .output()
        .unwrap();
    let got: Vec<String> = String::from_utf8_lossy(&o.stdout)
        .lines()
        .filter_map(|l| l.strip_prefix("uart-1: ").map(str::to_owned))
        .collect();
    assert_eq!(got, sent, "{}", String::from_utf8_lossy(&o.stderr));
    // Two chunks: the file holds more than 4 MiB of samples.
    assert!(std::fs::metadata(&sr).unwrap().len() > 4 * 1024 * 1024);
}
