//! `--svg` on `si sim` and `si monitor`: the sequence diagrams are well-formed XML, show the
//! lanes and control characters, highlight errors, and stay readable for a long recording by
//! summarising it.

use std::path::PathBuf;

use crate::common;

use common::{si_command, test_dir};

fn tmp(name: &str) -> PathBuf {
    test_dir("si-svg-test").join(name)
}

fn sim_svg(scenario: &str) -> Option<String> {
    let path = tmp(&format!("{scenario}.svg"));
    let o = si_command()
        .args(["sim", scenario, "--svg"])
        .arg(&path)
        .output()
        .unwrap();
    if !o.status.success() {
        return None;
    }
    Some(std::fs::read_to_string(path).unwrap())
}

fn height(svg: &str) -> u32 {
    let i = svg.find("height=\"").unwrap() + 8;
    svg[i..].split('"').next().unwrap().parse().unwrap()
}

/// A minimal well-formedness check: tags nest and close, attributes are quoted, entities are
/// known. Enough to catch a broken writer without an XML crate (used by the tests).
fn well_formed(xml: &str) -> Result<(), String> {
    let mut stack: Vec<&str> = Vec::new();
    let mut rest = xml;
    let mut pos = 0usize;
    while let Some(i) = rest.find('<') {
        check_text(&rest[..i]).map_err(|e| format!("at {}: {e}", pos + i))?;
        let after = &rest[i..];
        let end = if after.starts_with("<!--") {
            after.find("-->").map(|e| e + 3)
        } else {
            after.find('>').map(|e| e + 1)
        }
        .ok_or_else(|| format!("unclosed tag at {}", pos + i))?;
        let tag = &after[..end];
        if tag.starts_with("<?") || tag.starts_with("<!") {
        } else if let Some(name) = tag.strip_prefix("</") {
            let name = name.trim_end_matches('>').trim();
            match stack.pop() {
                Some(open) if open == name => {}
                other => return Err(format!("</{name}> closes {other:?} at {}", pos + i)),
            }
        } else {
            let inner = tag.trim_start_matches('<').trim_end_matches('>');
            let self_closing = inner.ends_with('/');
            let inner = inner.trim_end_matches('/');
            let name = inner.split_whitespace().next().unwrap_or("");
            if name.is_empty() {
                return Err(format!("empty tag at {}", pos + i));
            }
            check_attributes(&inner[name.len()..])
                .map_err(|e| format!("<{name}> at {}: {e}", pos + i))?;
            if !self_closing {
                stack.push(name);
            }
        }
        pos += i + end;
        rest = &after[end..];
    }
    check_text(rest)?;
    if let Some(open) = stack.pop() {
        return Err(format!("<{open}> never closed"));
    }
    Ok(())
}

fn check_text(text: &str) -> Result<(), String> {
    let mut rest = text;
    while let Some(i) = rest.find('&') {
        let after = &rest[i..];
        let end = after.find(';').ok_or("& without ;")?;
        let entity = &after[1..end];
        let known =
            ["amp", "lt", "gt", "quot", "apos"].contains(&entity) || entity.starts_with('#');
        if !known {
            return Err(format!("unknown entity &{entity};"));
        }
        rest = &after[end + 1..];
    }
    if text.contains('>') {
        // Legal in XML, but our writer always escapes it: a raw one means a broken tag.
        return Err("raw > in text".into());
    }
    Ok(())
}

fn check_attributes(attrs: &str) -> Result<(), String> {
    let mut rest = attrs.trim();
    while !rest.is_empty() {
        let eq = rest
            .find('=')
            .ok_or_else(|| format!("attribute without value: {rest}"))?;
        let name = rest[..eq].trim();
        if name.is_empty() || name.contains(char::is_whitespace) {
            return Err(format!("bad attribute name {name:?}"));
        }
        let value = rest[eq + 1..].trim_start();
        let quote = value.chars().next().ok_or("missing value")?;
        if quote != '"' && quote != '\'' {
            return Err(format!("unquoted value of {name}"));
        }
        let close = value[1..].find(quote).ok_or("unterminated value")?;
        let v = &value[1..1 + close];
        if v.contains('<') {
            return Err(format!("< in the value of {name}"));
        }
        check_text(v)?;
        rest = value[close + 2..].trim_start();
    }
    Ok(())
}

#[test]
fn the_checker_accepts_good_and_rejects_broken_xml() {
    assert!(well_formed(r#"<?xml version="1.0"?><a x="1"><b/>t &amp; u</a>"#).is_ok());
    assert!(well_formed("<a><b></a>").is_err());
    assert!(well_formed("<a x=1></a>").is_err());
    assert!(well_formed("<a>&nbsp;</a>").is_err());
    assert!(well_formed("<a>").is_err());
}

#[test]
fn et200s_3964r_initialization_conflict_diagram() {
    let svg = sim_svg("3964r-conflict").expect("si sim 3964r-conflict --svg");
    assert_eq!(well_formed(&svg), Ok(()));
    assert!(svg.starts_with("<?xml"));
    for lane in [">A</text>", ">B</text>"] {
        assert!(svg.contains(lane), "lane {lane}");
    }
    assert_eq!(
        svg.matches(">STX</text>").count(),
        3,
        "both STX and the later one"
    );
    assert!(svg.matches(">DLE</text>").count() >= 4);
    assert!(svg.contains("initialization conflict"));
    assert!(svg.contains("block 13 B"));
}

#[test]
fn errors_are_drawn_in_red_with_their_reason() {
    let svg = sim_svg("3964r-bcc-error").unwrap();
    assert_eq!(well_formed(&svg), Ok(()));
    assert!(svg.contains(">NAK</text>"));
    assert!(svg.contains("BCC error"));
    assert!(svg.contains("arrow-red"));
}

#[test]
fn every_protocol_scenario_draws_well_formed_svg() {
    for scenario in [
        "3964r",
        "3964r-nak-retry",
        "3964r-timeout",
        "rk512",
        "ascii",
        "ascii-xon-xoff",
        "modbus",
        "modbus-timeout",
        "modbus-crc-error",
        "uss-cycle",
        "uss-param",
        "line-timing",
        "rs485-collision",
    ] {
        let svg = sim_svg(scenario).unwrap_or_else(|| panic!("{scenario}"));
        assert_eq!(well_formed(&svg), Ok(()), "{scenario}");
    }
}

#[test]
fn dp_coord_send_job_diagram_when_the_scenario_exists() {
    let list =
        String::from_utf8_lossy(&si_command().args(["sim"]).output().unwrap().stdout).to_string();
    if !list.contains("dp-coord-send") {
        eprintln!("SKIPPED: no dp-coord-send scenario yet");
        return;
    }
    // Table 2-23: 22 characters through an 8-byte window, one arrow per DP cycle and
    // direction, labelled with the coordination byte's reading.
    let svg = sim_svg("dp-coord-send").expect("si sim dp-coord-send --svg");
    assert_eq!(well_formed(&svg), Ok(()));
    assert!(
        svg.contains("dp-coord — 24 records"),
        "12 cycles, two windows each"
    );
    let host = svg.find(">host</text>").expect("host lane");
    let module = svg.find(">module</text>").expect("module lane");
    assert!(host < module, "the host lane is drawn first (left)");
    for label in [
        ">10H send req</text>",
        ">10H accepted</text>",
        ">11H seg 1, len 22: abcde</text>",
        ">12H seg 2: fghijkl</text>",
        ">13H seg 3: mnopqrs</text>",
        ">14H seg 4: tuv</text>",
        ">14H ack seg 4</text>",
        ">74H done</text>",
    ] {
        assert!(svg.contains(label), "label {label}");
    }
    assert!(svg.contains("jobs ok: 1"));
    assert_eq!(svg.matches("marker-end=\"url(#arrow-black)\"").count(), 24);
    assert!(
        !svg.contains("url(#arrow-red)"),
        "a clean job has no red arrow"
    );
}

#[test]
fn dp_coord_send_records_a_window_trace_the_monitor_reads() {
    let trace = tmp("dp-coord-send.trace");
    let plain = si_command()
        .args(["sim", "dp-coord-send"])
        .output()
        .unwrap();
    let o = si_command()
        .args(["--record"])
        .arg(&trace)
        .args(["sim", "dp-coord-send"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(
        o.stdout, plain.stdout,
        "recording leaves the output as it was"
    );
    let text = std::fs::read_to_string(&trace).unwrap();
    assert!(text
        .lines()
        .next()
        .unwrap()
        .contains(r#""protocol":"dp-coord""#));
    let o = si_command()
        .args(["monitor", "--protocol", "dp-coord", "--trace"])
        .arg(&trace)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        out.contains("host → module   11H seg 1, len 22: abcde"),
        "{out}"
    );
    assert!(out.contains("module → host     74H done"), "{out}");
    assert!(out.contains("STATUS 16#0000 no error"), "{out}");
}

#[test]
fn dp_coord_error_bit_and_status_are_drawn_in_red() {
    // A host whose segment 3 the module saw out of order (error bit, last valid 2), and a
    // job that ends with STATUS 0501H.
    let header = r#"{"format":"si-trace","version":1,"source":"sim","protocol":"dp-coord","stations":["host","module"]}"#;
    let windows: [(u64, &str, [u8; 8]); 4] = [
        (10_000, "host", [0x13, 1, 2, 3, 4, 5, 6, 7]),
        (20_000, "module", [0x1A, 0, 0, 0, 0, 0, 0, 0]),
        (30_000, "module", [0x71, 0x05, 0x01, 0, 0, 0, 0, 0]),
        (40_000, "host", [0, 0, 0, 0, 0, 0, 0, 0]),
    ];
    let mut text = format!("{header}\n");
    for (at, station, bytes) in windows {
        let bytes: Vec<String> = bytes.iter().map(u8::to_string).collect();
        text.push_str(&format!(
            r#"{{"at":{at},"station":"{station}","kind":"tx","bytes":[{}]}}"#,
            bytes.join(",")
        ));
        text.push('\n');
    }
    let trace = tmp("dp-coord-errors.trace");
    std::fs::write(&trace, text).unwrap();
    let svg_path = tmp("dp-coord-errors.svg");
    let o = si_command()
        .args(["monitor", "--trace"])
        .arg(&trace)
        .arg("--svg")
        .arg(&svg_path)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let svg = std::fs::read_to_string(&svg_path).unwrap();
    assert_eq!(well_formed(&svg), Ok(()));
    assert_eq!(svg.matches("marker-end=\"url(#arrow-red)\"").count(), 2);
    assert!(svg.contains(">1AH error, last 2</text>"));
    assert!(svg.contains("error bit: segment out of order, last valid 2"));
    assert!(svg.contains(">71H STATUS 0501H</text>"));
    assert!(svg.contains("STATUS errors: 1"));
}

#[test]
fn dp_coord_e2e_diagram_decodes_the_3964r_line() {
    let list =
        String::from_utf8_lossy(&si_command().args(["sim"]).output().unwrap().stdout).to_string();
    if !list.contains("dp-coord-e2e") {
        eprintln!("SKIPPED: no dp-coord-e2e scenario yet");
        return;
    }
    // S_SEND through module A's window, 3964(R) on the line between the modules, S_RCV at B:
    // the line part is decoded as 3964(R).
    let svg = sim_svg("dp-coord-e2e").expect("si sim dp-coord-e2e --svg");
    assert_eq!(well_formed(&svg), Ok(()));
    assert!(svg.contains(">STX</text>"));
    assert!(svg.contains("block 16 B"));
    assert!(svg.contains("blocks ok: 1"));
}

/// Ten minutes of 3964(R) traffic (a block every 100 ms, one with a flipped BCC) as a trace
/// file, written the way the simulator writes it.
fn ten_minutes() -> PathBuf {
    let header = r#"{"format":"si-trace","version":1,"source":"sim","protocol":"3964r","settings":{"baud":9600,"data_bits":8,"parity":"even","stop_bits":1},"stations":["A","B"]}"#;
    let mut text = format!("{header}\n");
    let ct = 1_146u64; // 9600 8E1: 11 bits
    let block = [0x31u8, 0x32, 0x33, 0x10, 0x03];
    let bcc = block.iter().fold(0, |a, b| a ^ b);
    let mut rx = |at: u64, station: &str, byte: u8| {
        text.push_str(&format!(
            "{{\"at\":{at},\"station\":\"{station}\",\"kind\":\"rx\",\"byte\":{byte}}}\n"
        ));
    };
    for k in 0..6_000u64 {
        let t = k * 100_000;
        rx(t + ct, "B", 0x02);
        rx(t + 2 * ct, "A", 0x10);
        for (i, &b) in block.iter().enumerate() {
            rx(t + (3 + i as u64) * ct, "B", b);
        }
        let bad = k == 3_000;
        rx(t + 8 * ct, "B", if bad { bcc ^ 0x08 } else { bcc });
        rx(t + 9 * ct, "A", if bad { 0x15 } else { 0x10 });
    }
    let path = tmp("ten-minutes.jsonl");
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn a_ten_minute_recording_is_summarised_and_keeps_its_error() {
    let trace = ten_minutes();
    let svg_path = tmp("ten-minutes.svg");
    let o = si_command()
        .args(["--json", "monitor", "--trace"])
        .arg(&trace)
        .arg("--svg")
        .arg(&svg_path)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let last = String::from_utf8_lossy(&o.stdout)
        .lines()
        .last()
        .unwrap()
        .to_owned();
    let counters: serde_json::Value = serde_json::from_str(&last).unwrap();
    assert_eq!(counters["counters"]["blocks ok"], 5_999);
    assert_eq!(counters["counters"]["BCC errors"], 1);
    let svg = std::fs::read_to_string(svg_path).unwrap();
    assert_eq!(well_formed(&svg), Ok(()));
    assert!(svg.contains("(summarised)"));
    assert!(svg.contains("records without remarks"));
    assert!(
        svg.contains("BCC error"),
        "the one error survives the summary"
    );
    assert!(svg.contains("5:00."), "its time is shown in minutes");
    assert!(height(&svg) < 8_000, "a summary stays a page or two");
}
