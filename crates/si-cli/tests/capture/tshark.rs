//! `tshark` reads what `si trace export --pcap` writes: Modbus RTU with Wireshark's own `mbrtu`
//! dissector and no options at all.

use crate::common::{peer, si, si_command, stdout, test_dir, text};
use crate::round_trip::recorded;
use std::process::Command;

pub fn have_tshark() -> bool {
    peer(
        "tshark",
        Command::new("tshark").arg("-v"),
        "DEBIAN_FRONTEND=noninteractive apt-get install -y tshark",
    )
}

/// `tshark -r FILE ARGS`: its stdout, one string per line.
pub fn tshark(file: &std::path::Path, args: &[&str]) -> Vec<String> {
    let o = Command::new("tshark")
        .arg("-r")
        .arg(file)
        .args(args)
        .output()
        .unwrap();
    assert!(o.status.success(), "tshark: {}", text(&o));
    stdout(&o).lines().map(str::to_owned).collect()
}

/// The register values `si frame decode modbus` found in a frame (written or read), if any.
fn registers(decoded: &serde_json::Value) -> Option<Vec<u64>> {
    let side = if decoded["reading"] == "request" {
        &decoded["request"]["fields"]
    } else {
        &decoded["response"]["fields"]
    };
    let pdu = decoded[decoded["reading"].as_str()?]["pdu"].as_str()?;
    if !pdu.contains("register") {
        return None;
    }
    let values = if side.is_array() {
        side
    } else {
        &side["values"]
    };
    values
        .as_array()
        .map(|v| v.iter().filter_map(|x| x.as_u64()).collect())
}

#[test]
fn tshark_decodes_every_modbus_frame_as_si_frame_decode_does() {
    if !have_tshark() {
        return;
    }
    let dir = test_dir("si-capture-tshark-modbus");
    let (trace, pcap) = recorded(&dir, "modbus");
    // The frames the monitor delimited, in order.
    let o = si_command()
        .args(["--json", "monitor", "--trace"])
        .arg(&trace)
        .output()
        .unwrap();
    let frames: Vec<String> = stdout(&o)
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .filter(|v| v["kind"] == "frame")
        .map(|v| v["bytes"].as_str().unwrap().to_owned())
        .collect();
    // No options: Wireshark finds `mbrtu` by the name in each packet.
    let shown = tshark(
        &pcap,
        &[
            "-Y",
            "mbrtu",
            "-T",
            "fields",
            "-E",
            "separator=;",
            "-e",
            "mbrtu.unit_id",
            "-e",
            "modbus.func_code",
            "-e",
            "modbus.regval_uint16",
        ],
    );
    assert_eq!(shown.len(), frames.len(), "{shown:?}\n{frames:?}");
    let mut with_registers = 0;
    for (line, hex) in shown.iter().zip(&frames) {
        let o = si(&["--json", "frame", "decode", "modbus", hex]);
        assert!(o.status.success(), "{}", text(&o));
        let decoded: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap();
        let fields: Vec<&str> = line.split(';').collect();
        assert_eq!(
            fields[0],
            decoded["unit"].to_string(),
            "unit of {hex}: {line}"
        );
        // Wireshark shows an exception response's function code without its 80H bit.
        let function = decoded["function"].as_u64().unwrap();
        assert_eq!(
            fields[1],
            (function & 0x7F).to_string(),
            "function of {hex}: {line}"
        );
        // FC05/FC06 answers repeat their requests byte for byte: without a port to say which
        // way a frame went, Wireshark leaves them unclassified and shows no values.
        if let Some(values) = registers(&decoded).filter(|_| function != 5 && function != 6) {
            let tshark_values: Vec<u64> = fields[2]
                .split(',')
                .filter(|s| !s.is_empty())
                .map(|s| s.parse().unwrap())
                .collect();
            if !values.is_empty() {
                with_registers += 1;
            }
            assert_eq!(tshark_values, values, "registers of {hex}: {line}");
        }
    }
    assert!(
        with_registers >= 2,
        "register values compared: {with_registers}"
    );
}

/// `tshark -X lua_script:contrib/wireshark/si.lua -r FILE -T fields -e …`, one `Vec` per
/// packet of the line (the RTAC interface's end-of-recording mark left out).
fn lua_fields(file: &std::path::Path, fields: &[&str]) -> Vec<Vec<String>> {
    let script = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../contrib/wireshark/si.lua"
    );
    let mut args = vec!["-X".to_owned(), format!("lua_script:{script}")];
    args.extend(
        [
            "-Y",
            "exported_pdu",
            "-T",
            "fields",
            "-E",
            "separator=;",
            "-E",
            "occurrence=a",
            "-E",
            "aggregator=|",
        ]
        .map(str::to_owned),
    );
    for f in fields {
        args.push("-e".into());
        args.push((*f).to_owned());
    }
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    tshark(file, &args)
        .into_iter()
        .map(|l| l.split(';').map(str::to_owned).collect())
        .collect()
}

/// The monitor's records that are on the line (frames and control characters), as JSON.
fn line_records(trace: &std::path::Path) -> Vec<serde_json::Value> {
    let o = si_command()
        .args(["--json", "monitor", "--trace"])
        .arg(trace)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
    stdout(&o)
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .filter(|v| v["kind"] == "frame" || v["kind"] == "control")
        .collect()
}

fn flagged(r: &serde_json::Value, what: &str) -> bool {
    r["flags"].as_array().is_some_and(|f| {
        f.iter()
            .any(|f| f["text"].as_str().unwrap_or("").contains(what))
    })
}

/// The first number after `prefix` in `label`.
fn number_after(label: &str, prefix: &str) -> Option<u64> {
    let rest = &label[label.find(prefix)? + prefix.len()..];
    let digits: String = rest.chars().take_while(char::is_ascii_digit).collect();
    digits.parse().ok()
}

/// 3964(R) and RK 512: the control character or the block length, the BCC verdict, NAK and
/// retry, and RK 512's command, DB and DW, for every frame the monitor printed.
#[test]
fn the_lua_dissectors_show_what_the_monitor_shows_for_3964r_and_rk512() {
    if !have_tshark() {
        return;
    }
    let dir = test_dir("si-capture-tshark-3964r");
    let mut bcc_errors = 0;
    let mut naks = 0;
    let mut retries = 0;
    let mut telegrams = 0;
    for scenario in [
        "3964r-bcc-error",
        "3964r-nak-retry",
        "3964r",
        "rk512",
        "rk512-locked",
    ] {
        let (trace, pcap) = recorded(&dir, scenario);
        let records = line_records(&trace);
        let shown = lua_fields(
            &pcap,
            &[
                "si_3964r.control",
                "si_3964r.length",
                "si_3964r.bcc_ok",
                "_ws.expert.message",
                "si_rk512.command",
                "si_rk512.db",
                "si_rk512.dw",
            ],
        );
        assert_eq!(shown.len(), records.len(), "{scenario}: {shown:?}");
        for (r, f) in records.iter().zip(&shown) {
            let label = r["label"].as_str().unwrap();
            let what = format!("{scenario}: {r} ↔ {f:?}");
            match label {
                "STX" => assert_eq!(f[0], "0x02", "{what}"),
                "DLE" => assert_eq!(f[0], "0x10", "{what}"),
                "NAK" => assert_eq!(f[0], "0x15", "{what}"),
                _ => {}
            }
            if r["kind"] == "frame" {
                let len = r["text"]
                    .as_str()
                    .and_then(|t| number_after(t, "block, "))
                    .or_else(|| number_after(label, "block "));
                if let Some(len) = len {
                    assert_eq!(f[1], len.to_string(), "{what}");
                }
                let bad = flagged(r, "BCC error");
                assert_eq!(f[2], if bad { "0" } else { "1" }, "{what}");
                bcc_errors += usize::from(bad);
            }
            if flagged(r, "NAK") {
                assert!(f[3].contains("NAK: block rejected"), "{what}");
                naks += 1;
            }
            if r["flags"]
                .as_array()
                .is_some_and(|fl| fl.iter().any(|x| x["text"] == "retry"))
            {
                assert!(f[3].contains("Retry"), "{what}");
                retries += 1;
            }
            if let (Some(db), Some(dw)) = (number_after(label, " DB"), number_after(label, ".DW")) {
                let letter = if label.starts_with("Send") {
                    "0x41"
                } else {
                    "0x45"
                };
                assert_eq!(f[4], letter, "{what}");
                assert_eq!(
                    (f[5].as_str(), f[6].as_str()),
                    (db.to_string().as_str(), dw.to_string().as_str()),
                    "{what}"
                );
                telegrams += 1;
            }
        }
    }
    assert!(
        bcc_errors >= 1 && naks >= 2 && retries >= 1 && telegrams >= 2,
        "BCC errors {bcc_errors}, NAKs {naks}, retries {retries}, telegrams {telegrams}"
    );
}

/// USS: address and net length of every telegram; DP windows: every coordination byte.
#[test]
fn the_lua_dissectors_show_what_the_monitor_shows_for_uss_and_windows() {
    if !have_tshark() {
        return;
    }
    let dir = test_dir("si-capture-tshark-uss");
    let mut telegrams = 0;
    for scenario in ["uss-param", "uss-cycle"] {
        let (trace, pcap) = recorded(&dir, scenario);
        let records = line_records(&trace);
        let shown = lua_fields(
            &pcap,
            &["si_uss.adr.address", "si_uss.lge", "si_uss.bcc_ok"],
        );
        assert_eq!(shown.len(), records.len(), "{scenario}: {shown:?}");
        for (r, f) in records.iter().zip(&shown) {
            let label = r["label"].as_str().unwrap();
            let what = format!("{scenario}: {r} ↔ {f:?}");
            let adr = number_after(label, "to ").or_else(|| number_after(label, "answer "));
            let net = number_after(label, "(");
            if let (Some(adr), Some(net)) = (adr, net) {
                assert_eq!(f[0], adr.to_string(), "{what}");
                assert_eq!(f[1], (net + 2).to_string(), "{what}");
                assert_eq!(f[2], if flagged(r, "BCC") { "0" } else { "1" }, "{what}");
                telegrams += 1;
            }
        }
    }
    assert!(telegrams >= 10, "USS telegrams compared: {telegrams}");
    // The window traces (the other dp-coord scenarios record the serial line behind them).
    for scenario in ["dp-coord-send"] {
        let (trace, pcap) = recorded(&dir, scenario);
        let records = line_records(&trace);
        let shown = lua_fields(&pcap, &["si_dpcoord.coord"]);
        assert_eq!(shown.len(), records.len(), "{scenario}");
        for (r, f) in records.iter().zip(&shown) {
            let first = &r["bytes"].as_str().unwrap()[..2];
            assert_eq!(
                f[0],
                format!("0x{}", first.to_ascii_lowercase()),
                "{scenario}: {r} ↔ {f:?}"
            );
        }
    }
}
