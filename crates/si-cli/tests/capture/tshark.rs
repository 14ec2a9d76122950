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
        assert_eq!(fields[0], decoded["unit"].to_string(), "unit of {hex}: {line}");
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
    assert!(with_registers >= 2, "register values compared: {with_registers}");
}
