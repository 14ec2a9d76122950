//! `--record` on real commands over a pseudo-terminal pair (socat; `apt-get install socat`),
//! read back by `si monitor --trace`; and `si monitor` watching a live port without ever
//! transmitting. Skips with a message when socat is missing; with `CI` set it fails instead.

use serde_json::Value;
use std::io::{Read, Write};
use std::path::PathBuf;
use std::process::Stdio;
use std::time::Duration;

use crate::common;

use common::{monitor_json, opened, pty_pair_ignoreeof, si_command, test_dir, Kill};

fn tmp(name: &str) -> PathBuf {
    test_dir("si-monitor-pty").join(name)
}

#[test]
fn record_on_3964r_send_and_recv_reads_back_in_the_monitor() {
    let Some(pair) = pty_pair_ignoreeof() else {
        return;
    };
    let (a, b) = (&pair.a, &pair.b);
    let recv_trace = tmp("recv.jsonl");
    let send_trace = tmp("send.jsonl");
    let recv = si_command()
        .args(["--port", b, "--record"])
        .arg(&recv_trace)
        .args(["3964r", "recv", "--count", "1", "--priority", "low"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start recv");
    let recv = Kill(recv);
    opened(&recv.0, b);
    let o = si_command()
        .args(["--port", a, "--record"])
        .arg(&send_trace)
        .args(["3964r", "send", "--priority", "high", "--text", "pty"])
        .output()
        .expect("run send");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut recv = recv;
    let status = recv.0.wait().unwrap();
    assert!(status.success());

    // The sender's side: it wrote STX, the block and read the partner's two DLEs. (Each link
    // may send a NAK when it starts; those are remarks, not part of the exchange.)
    let exchange = |records: &[Value]| -> Vec<(String, String)> {
        records
            .iter()
            .filter(|r| r["label"] != "NAK")
            .map(|r| {
                (
                    r["label"].as_str().unwrap().to_owned(),
                    r["from"].as_str().unwrap().to_owned(),
                )
            })
            .collect()
    };
    let pairs = |v: [(&str, &str); 4]| -> Vec<(String, String)> {
        v.iter()
            .map(|(a, b)| (a.to_string(), b.to_string()))
            .collect()
    };
    let (records, counters) = monitor_json(&["--trace", send_trace.to_str().unwrap()]);
    assert_eq!(
        exchange(&records),
        pairs([
            ("STX", "si"),
            ("DLE", "partner"),
            ("block 3 B \"pty\"", "si"),
            ("DLE", "partner")
        ]),
        "{records:?}"
    );
    assert!(records.iter().all(|r| r["flags"]
        .as_array()
        .unwrap()
        .iter()
        .all(|f| f["severity"] != "error")));
    assert_eq!(counters["blocks ok"], 1);

    // The receiver's side sees the same exchange from the other end.
    let (records, counters) = monitor_json(&["--trace", recv_trace.to_str().unwrap()]);
    assert_eq!(
        exchange(&records),
        pairs([
            ("STX", "partner"),
            ("DLE", "si"),
            ("block 3 B \"pty\"", "partner"),
            ("DLE", "si")
        ]),
        "{records:?}"
    );
    assert_eq!(counters["blocks ok"], 1);

    // The header names the protocol and the line.
    let header: Value = serde_json::from_str(
        std::fs::read_to_string(&send_trace)
            .unwrap()
            .lines()
            .next()
            .unwrap(),
    )
    .unwrap();
    assert_eq!(header["source"], "port");
    assert_eq!(header["protocol"], "3964r");
    assert_eq!(header["settings"]["baud"], 9600);
    // And when the recording started, in UTC, which the text monitor shows first.
    let start = header["start"].as_str().expect("a start time");
    assert!(start.ends_with('Z') && start.len() == 27, "{start}");
    let text = si_command()
        .args(["monitor", "--trace", send_trace.to_str().unwrap()])
        .output()
        .unwrap();
    let first = String::from_utf8_lossy(&text.stdout)
        .lines()
        .next()
        .map(str::to_owned);
    assert_eq!(first, Some(format!("recorded from {start}")));
}

#[test]
fn live_monitor_decodes_and_never_transmits() {
    let Some(pair) = pty_pair_ignoreeof() else {
        return;
    };
    let (a, b) = (&pair.a, &pair.b);
    let mut monitor = Kill(
        si_command()
            .args(["--json", "--port", b, "monitor", "--protocol", "modbus"])
            .args(["--duration", "1.5"])
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap(),
    );
    opened(&monitor.0, b);
    let mut port = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .open(a)
        .unwrap();
    let mut back = port.try_clone().unwrap();
    let (tx, reader) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let mut byte = [0u8; 1];
        if let Ok(1) = back.read(&mut byte) {
            let _ = tx.send(byte[0]);
        }
    });
    // FC03 request to slave 1 (the Modbus spec's example CRC 84 0A), then one with a bad CRC.
    port.write_all(&[0x01, 0x03, 0x00, 0x00, 0x00, 0x01, 0x84, 0x0A])
        .unwrap();
    std::thread::sleep(Duration::from_millis(100));
    port.write_all(&[0x01, 0x03, 0x00, 0x00, 0x00, 0x01, 0x84, 0x0B])
        .unwrap();
    let mut out = String::new();
    monitor
        .0
        .stdout
        .take()
        .unwrap()
        .read_to_string(&mut out)
        .unwrap();
    assert!(monitor.0.wait().unwrap().success());
    let lines: Vec<Value> = out
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let labels: Vec<&str> = lines.iter().filter_map(|l| l["label"].as_str()).collect();
    assert_eq!(labels, ["FC03 req → 1", "CRC error 8 B"], "{out}");
    let counters = &lines.last().unwrap()["counters"];
    assert_eq!(counters["bus communication errors (CRC)"], 1);
    assert_eq!(counters["bus messages"], 2);

    // Nothing came back on the watched line: a reader on the other end got no byte while the
    // monitor ran (it was started before the monitor ended and is checked after).
    let got = reader.recv_timeout(Duration::from_millis(300));
    assert!(got.is_err(), "the monitor transmitted {got:?}");
}

#[test]
fn a_monitor_cable_with_two_ports_shows_both_directions() {
    let (Some(p1), Some(p2)) = (pty_pair_ignoreeof(), pty_pair_ignoreeof()) else {
        return;
    };
    let (a1, b1, a2, b2) = (&p1.a, &p1.b, &p2.a, &p2.b);
    let mut monitor = Kill(
        si_command()
            .args(["--json", "--port", b1, "monitor", "--protocol", "3964r"])
            .args(["--tap", b2, "--duration", "1.5"])
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap(),
    );
    opened(&monitor.0, b1);
    let open = |p: &str| std::fs::OpenOptions::new().write(true).open(p).unwrap();
    let (mut a, mut b) = (open(a1), open(a2));
    // Station A sends "AB" with 3964(R) (BCC 10H); station B answers on its own wire.
    for (to_a, bytes) in [
        (true, &[0x02][..]),
        (false, &[0x10][..]),
        (true, &[0x41, 0x42, 0x10, 0x03, 0x10][..]),
        (false, &[0x10][..]),
    ] {
        let port = if to_a { &mut a } else { &mut b };
        port.write_all(bytes).unwrap();
        std::thread::sleep(Duration::from_millis(30));
    }
    let mut out = String::new();
    monitor
        .0
        .stdout
        .take()
        .unwrap()
        .read_to_string(&mut out)
        .unwrap();
    assert!(monitor.0.wait().unwrap().success());
    let lines: Vec<Value> = out
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let seen: Vec<(String, String)> = lines
        .iter()
        .filter(|l| l["label"].is_string())
        .map(|l| {
            (
                l["label"].as_str().unwrap().to_owned(),
                l["from"].as_str().unwrap().to_owned(),
            )
        })
        .collect();
    let name = |p: &str| p.rsplit('/').next().unwrap().to_owned();
    assert_eq!(
        seen,
        vec![
            ("STX".to_owned(), name(b1)),
            ("DLE".to_owned(), name(b2)),
            ("block 2 B \"AB\"".to_owned(), name(b1)),
            ("DLE".to_owned(), name(b2)),
        ],
        "{out}"
    );
    assert_eq!(lines.last().unwrap()["counters"]["blocks ok"], 1);
}

/// `si monitor --pcap` on a live port: a request and its answer written into the watched pty
/// come out of the capture as two exported PDUs for Wireshark's `mbrtu`, each frame's bytes
/// exactly as they crossed the line, in order; our own pcapng reader checks them, and
/// `tshark -r` too where it is installed (Debian's `tshark`).
#[test]
fn live_monitor_writes_the_frames_as_a_wireshark_capture() {
    use si_capture::pcapng::{Block, Reader};
    use si_capture::upper_pdu;
    let Some(pair) = pty_pair_ignoreeof() else {
        return;
    };
    let (a, b) = (&pair.a, &pair.b);
    let dir = test_dir("si-live-pcap");
    let pcap = dir.join("live.pcapng");
    let monitor = si_command()
        .args(["--port", b, "monitor", "--protocol", "modbus", "--pcap"])
        .arg(&pcap)
        .args(["--duration", "1.5"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    opened(&monitor, b);
    let mut port = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .open(a)
        .unwrap();
    // FC03 of one register from slave 1 (the Modbus spec's example CRC 84 0A), and its answer.
    let request = [0x01, 0x03, 0x00, 0x00, 0x00, 0x01, 0x84, 0x0A];
    let response = [0x01, 0x03, 0x02, 0x12, 0x34, 0xB5, 0x33];
    port.write_all(&request).unwrap();
    std::thread::sleep(Duration::from_millis(100));
    port.write_all(&response).unwrap();
    let o = monitor.wait_with_output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));

    let file = std::fs::File::open(&pcap).expect("the capture");
    let mut reader = Reader::new(std::io::BufReader::new(file)).expect("a pcapng file");
    let mut frames: Vec<(Option<String>, Vec<u8>)> = Vec::new();
    let mut linktypes = Vec::new();
    while let Some(block) = reader.next_block().expect("readable blocks") {
        match block {
            Block::Interface { linktype, .. } => linktypes.push(linktype),
            Block::Packet {
                interface, data, ..
            } if linktypes.get(interface as usize) == Some(&upper_pdu::LINKTYPE) => {
                let pdu = upper_pdu::decode(data).expect("an exported PDU");
                frames.push((pdu.dissector.map(str::to_owned), pdu.payload.to_vec()));
            }
            _ => {}
        }
    }
    let mbrtu = Some("mbrtu".to_owned());
    assert_eq!(
        frames,
        [
            (mbrtu.clone(), request.to_vec()),
            (mbrtu, response.to_vec())
        ],
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );

    // Wireshark itself reads it with no options: Modbus RTU, unit 1, FC03, the register.
    if let Ok(t) = std::process::Command::new("tshark")
        .arg("-r")
        .arg(&pcap)
        .args([
            "-T",
            "fields",
            "-e",
            "mbrtu.unit_id",
            "-e",
            "modbus.func_code",
        ])
        .output()
    {
        if t.status.success() {
            let fields = String::from_utf8_lossy(&t.stdout);
            let rows: Vec<&str> = fields.lines().filter(|l| !l.trim().is_empty()).collect();
            assert_eq!(rows, ["1\t3", "1\t3"], "{fields}");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}
