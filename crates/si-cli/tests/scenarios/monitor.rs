//! `si monitor --trace` on simulator traces of every protocol (`si sim <scenario> --record`):
//! the monitor prints the frames the engines exchanged, and flags the injected faults at the
//! instants the trace shows them on the line.

use serde_json::Value;
use std::ffi::OsStr;
use std::path::{Path, PathBuf};

use crate::common;

use common::{monitor_json, si_command, test_dir};

fn tmp(name: &str) -> PathBuf {
    test_dir("si-monitor-test").join(name)
}

/// `si sim <scenario> --record FILE`; returns the file.
fn record(scenario: &str) -> PathBuf {
    let path = tmp(&format!("{scenario}.jsonl"));
    let o = si_command()
        .args(["sim", scenario, "--record"])
        .arg(&path)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "si sim {scenario}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    path
}

/// `si --json monitor --trace FILE [args]`: the records and the counters.
fn monitor(path: &Path, args: &[&str]) -> (Vec<Value>, Value) {
    let mut all = vec![OsStr::new("--trace"), path.as_os_str()];
    all.extend(args.iter().map(OsStr::new));
    monitor_json(&all)
}

fn labels(records: &[Value]) -> Vec<String> {
    records
        .iter()
        .map(|r| r["label"].as_str().unwrap().to_owned())
        .collect()
}

fn errors(r: &Value) -> Vec<String> {
    r["flags"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|f| f["severity"] == "error")
        .map(|f| f["text"].as_str().unwrap().to_owned())
        .collect()
}

/// Entries of the recorded trace (the header skipped).
fn entries(path: &Path) -> Vec<Value> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str::<Value>(l).unwrap())
        .filter(|v| v.get("format").is_none())
        .collect()
}

/// Times at which `station` received `byte`.
fn rx_times(path: &Path, station: &str, byte: u64) -> Vec<u64> {
    entries(path)
        .iter()
        .filter(|e| e["station"] == station && e["kind"] == "rx" && e["byte"] == byte)
        .map(|e| e["at"].as_u64().unwrap())
        .collect()
}

#[test]
fn trace_file_has_a_header_naming_protocol_and_settings() {
    let path = record("3964r");
    let text = std::fs::read_to_string(&path).unwrap();
    let header: Value = serde_json::from_str(text.lines().next().unwrap()).unwrap();
    assert_eq!(header["format"], "si-trace");
    assert_eq!(header["source"], "sim");
    assert_eq!(header["protocol"], "3964r");
    assert_eq!(header["settings"]["baud"], 9600);
    assert_eq!(header["stations"], serde_json::json!(["A", "B"]));
}

#[test]
fn et200s_3964r_5_exchange_both_ways_decodes_every_character() {
    let path = record("3964r");
    let (records, counters) = monitor(&path, &[]);
    let l = labels(&records);
    assert_eq!(l[0], "STX");
    assert_eq!(l[1], "DLE");
    assert!(l[2].starts_with("block 13 B \"temperatu"), "{l:?}");
    assert_eq!(l[3], "DLE");
    assert_eq!(records[0]["from"], "A");
    assert_eq!(records[1]["from"], "B");
    assert_eq!(counters["blocks ok"], 2);
    assert!(records.iter().all(|r| errors(r).is_empty()), "{records:?}");
    // The STX is shown when its last bit arrived at B.
    assert_eq!(
        records[0]["at_us"].as_u64().unwrap(),
        rx_times(&path, "B", 0x02)[0]
    );
}

#[test]
fn et200s_3964r_5_9_initialization_conflict_is_flagged_and_resolved() {
    let path = record("3964r-conflict");
    let (records, counters) = monitor(&path, &[]);
    let l = labels(&records);
    assert_eq!(&l[..3], ["STX", "STX", "DLE"]);
    assert!(records[1]["flags"][0]["text"]
        .as_str()
        .unwrap()
        .contains("initialization conflict"));
    // B (low priority) yields with DLE, A sends its block first.
    assert_eq!(records[2]["from"], "B");
    assert_eq!(records[3]["from"], "A");
    assert_eq!(counters["initialization conflicts"], 1);
    assert_eq!(counters["blocks ok"], 2);
}

#[test]
fn et200s_3964r_bcc_error_nak_and_repetition_at_their_instants() {
    let path = record("3964r-bcc-error");
    let (records, counters) = monitor(&path, &[]);
    let bad = records
        .iter()
        .find(|r| errors(r).iter().any(|e| e.contains("BCC error")))
        .expect("a block flagged with a BCC error");
    let nak = records.iter().find(|r| r["label"] == "NAK").unwrap();
    let nak_at = rx_times(&path, "A", 0x15)[0];
    assert_eq!(nak["at_us"].as_u64().unwrap(), nak_at);
    // The bad block ends with the BCC: the last character B received before it NAKed.
    let b_rx: Vec<u64> = entries(&path)
        .iter()
        .filter(|e| e["station"] == "B" && e["kind"] == "rx")
        .map(|e| e["at"].as_u64().unwrap())
        .filter(|&t| t < nak_at)
        .collect();
    assert_eq!(bad["end_us"].as_u64().unwrap(), *b_rx.last().unwrap());
    let retry = records
        .iter()
        .find(|r| r["label"] == "STX" && r["flags"][0]["text"] == "retry")
        .expect("the repeated STX is marked as a retry");
    assert!(retry["at_us"].as_u64().unwrap() > nak_at);
    assert_eq!(counters["BCC errors"], 1);
    assert_eq!(counters["NAKs"], 1);
    assert_eq!(counters["retries"], 1);
    assert_eq!(counters["blocks ok"], 1);
}

#[test]
fn et200s_3964r_receive_buffer_full_nak_after_400_ms_then_retry() {
    let path = record("3964r-nak-retry");
    let (records, counters) = monitor(&path, &[]);
    let stx = records
        .iter()
        .filter(|r| r["label"] == "STX")
        .nth(1)
        .unwrap()["at_us"]
        .as_u64()
        .unwrap();
    let nak = records.iter().find(|r| r["label"] == "NAK").unwrap();
    let nak_at = nak["at_us"].as_u64().unwrap();
    // Buffer wait 400 ms ([ET200S SI] §2.7, Table 2-11), plus the NAK's own character time.
    assert_eq!(nak_at - stx, 400_000 + 1_146);
    assert!(errors(nak)[0].contains("16#0702"));
    assert_eq!(counters["retries"], 1);
    assert_eq!(counters["blocks ok"], 2);
}

#[test]
fn et200s_3964r_qvz_expiry_is_flagged_two_seconds_after_each_stx() {
    let path = record("3964r-timeout");
    let (records, counters) = monitor(&path, &[]);
    let stx: Vec<u64> = records
        .iter()
        .filter(|r| r["label"] == "STX")
        .map(|r| r["at_us"].as_u64().unwrap())
        .collect();
    let notes: Vec<u64> = records
        .iter()
        .filter(|r| r["kind"] == "note")
        .map(|r| r["at_us"].as_u64().unwrap())
        .collect();
    assert_eq!(stx.len(), 6, "six connection attempts");
    assert_eq!(notes.len(), 6);
    for (s, n) in stx.iter().zip(&notes) {
        assert_eq!(n - s, 2_000_000, "QVZ 2000 ms after the STX");
    }
    assert_eq!(counters["QVZ exceeded"], 6);
    assert_eq!(counters["retries"], 5);
}

#[test]
fn rk512_telegrams_are_decoded_inside_the_3964r_blocks() {
    let path = record("rk512");
    let (records, counters) = monitor(&path, &[]);
    assert!(labels(&records).iter().any(|l| l.starts_with("Send DB10")));
    assert!(labels(&records).iter().any(|l| l.starts_with("Fetch DB10")));
    assert_eq!(counters["RK 512 errors"], 0);
    assert_eq!(counters["RK 512 telegrams"], counters["blocks ok"]);
}

#[test]
fn modbus_requests_responses_and_the_exception_are_decoded() {
    let path = record("modbus");
    let (records, counters) = monitor(&path, &[]);
    let l = labels(&records);
    assert_eq!(l[0], "FC16 req → 1");
    assert_eq!(l[1], "FC16 resp");
    assert_eq!(records[0]["from"], "master");
    assert_eq!(records[1]["from"], "slave");
    assert_eq!(l.last().unwrap(), "FC06 exception 02");
    assert_eq!(counters["bus messages"], 10);
    assert_eq!(counters["exception responses"], 1);
    assert_eq!(counters["bus communication errors (CRC)"], 0);
}

#[test]
fn modbus_crc_error_is_flagged_on_the_corrupted_response() {
    let path = record("modbus-crc-error");
    let (records, counters) = monitor(&path, &[]);
    let bad = &records[1];
    assert_eq!(bad["from"], "slave");
    assert!(errors(bad)[0].contains("CRC"), "{bad}");
    // It ends with the response's last character at the master.
    let last_rx = entries(&path)
        .iter()
        .filter(|e| e["station"] == "master" && e["kind"] == "rx")
        .map(|e| e["at"].as_u64().unwrap())
        .max()
        .unwrap();
    assert_eq!(bad["end_us"].as_u64().unwrap(), last_rx);
    assert_eq!(counters["bus communication errors (CRC)"], 1);
}

#[test]
fn modbus_no_response_is_flagged_at_the_response_timeout() {
    let path = record("modbus-timeout");
    let (records, counters) = monitor(&path, &[]);
    let request_end = records[0]["end_us"].as_u64().unwrap();
    let note = records.iter().find(|r| r["kind"] == "note").unwrap();
    assert_eq!(note["at_us"].as_u64().unwrap(), request_end + 2_000_000);
    assert!(note["label"].as_str().unwrap().contains("no response"));
    assert_eq!(counters["no response"], 1);
}

#[test]
fn uss_cycle_telegrams_and_the_missing_drive_on_the_bus() {
    let path = record("uss-cycle");
    let (records, counters) = monitor(&path, &[]);
    assert_eq!(records[0]["label"], "to 1 (12 B)");
    assert_eq!(records[0]["from"], "master");
    assert_eq!(records[1]["label"], "answer 1 (12 B)");
    assert_eq!(records[1]["from"], "drive1");
    let silent: Vec<&Value> = records.iter().filter(|r| r["kind"] == "note").collect();
    assert!(!silent.is_empty());
    assert!(silent.iter().all(|n| n["label"]
        .as_str()
        .unwrap()
        .starts_with("node 2 does not answer")));
    assert_eq!(counters["monitoring time (no answer)"], silent.len() as u64);
    assert_eq!(counters["telegrams rejected"], 0);
    assert_eq!(counters["BCC errors"], 0);
}

#[test]
fn ascii_frames_cut_at_cr_lf_like_the_receiver() {
    let path = record("ascii");
    let (records, counters) = monitor(&path, &["--end-char", "0D0A"]);
    let texts: Vec<&str> = records
        .iter()
        .map(|r| r["text"].as_str().unwrap())
        .collect();
    assert_eq!(texts, ["HELLO<CR><LF>", "SECOND LINE<CR><LF>"]);
    assert_eq!(counters["frames"], 2);
}

#[test]
fn ascii_xon_xoff_are_shown_as_flow_control() {
    let path = record("ascii-xon-xoff");
    let (records, counters) = monitor(&path, &["--protocol", "ascii"]);
    let l = labels(&records);
    assert_eq!(&l[..2], ["XOFF", "XON"]);
    assert_eq!(counters["XOFF"], counters["XON"]);
}

#[test]
fn auto_detects_the_protocol_of_a_headerless_trace() {
    for (scenario, protocol) in [
        ("3964r", "3964r"),
        ("modbus", "modbus"),
        ("uss-param", "uss"),
    ] {
        let path = record(scenario);
        // Drop the header: the monitor must recognise the protocol from the bytes.
        let body: String = std::fs::read_to_string(&path)
            .unwrap()
            .lines()
            .skip(1)
            .map(|l| format!("{l}\n"))
            .collect();
        let bare = tmp(&format!("{scenario}-bare.jsonl"));
        std::fs::write(&bare, body).unwrap();
        let o = si_command()
            .args(["--json", "monitor", "--trace"])
            .arg(&bare)
            .output()
            .unwrap();
        let last = String::from_utf8_lossy(&o.stdout)
            .lines()
            .last()
            .map(|l| serde_json::from_str::<Value>(l).unwrap())
            .unwrap();
        assert_eq!(last["protocol"], protocol, "{scenario}");
    }
}

#[test]
fn a_broken_trace_is_one_clear_error() {
    let path = tmp("broken.jsonl");
    std::fs::write(
        &path,
        "{\"at\":0,\"station\":\"A\",\"kind\":\"tx\",\"bytes\":[2]}\nnot json\n",
    )
    .unwrap();
    let o = si_command()
        .args(["monitor", "--trace"])
        .arg(&path)
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("trace line 2"), "{err}");
    assert_eq!(err.lines().count(), 1);
}

#[test]
fn a_closed_pipe_ends_the_output_quietly() {
    use std::io::Read;
    use std::process::Stdio;
    // Far more output than a pipe buffers: 5000 stray NAKs, one line each.
    let path = tmp("many-naks.jsonl");
    let body: String = (1..=5000u64)
        .map(|k| {
            format!(
                "{{\"at\":{},\"station\":\"B\",\"kind\":\"rx\",\"byte\":21}}\n",
                k * 10_000
            )
        })
        .collect();
    std::fs::write(&path, format!("{{\"format\":\"si-trace\",\"version\":1,\"source\":\"sim\",\"protocol\":\"3964r\",\"stations\":[\"A\",\"B\"]}}\n{body}")).unwrap();
    let mut child = si_command()
        .args(["monitor", "--trace"])
        .arg(&path)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Read one byte, then hang up, like `| head -c1`.
    let mut stdout = child.stdout.take().unwrap();
    let mut one = [0u8; 1];
    stdout.read_exact(&mut one).unwrap();
    drop(stdout);
    let status = child.wait().unwrap();
    let mut err = String::new();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    assert!(!err.contains("panicked"), "{err}");
    assert!(status.success(), "{err}");
}

#[test]
fn events_show_what_the_engines_concluded_beside_the_line() {
    let path = record("3964r-bcc-error");
    let (records, _) = monitor(&path, &["--events"]);
    let events: Vec<&Value> = records.iter().filter(|r| r["kind"] == "event").collect();
    assert!(!events.is_empty());
    // B reports the block when its BCC arrives; A reports the job done when B's DLE arrives.
    let good = records
        .iter()
        .rfind(|r| r["kind"] == "frame" && errors(r).is_empty())
        .unwrap();
    let received = events
        .iter()
        .find(|e| e["from"] == "B" && e["label"].as_str().unwrap().starts_with("Received"))
        .expect("B reports the block");
    assert_eq!(received["at_us"], good["end_us"]);
    let last_dle = records.iter().rfind(|r| r["label"] == "DLE").unwrap();
    let sent = events
        .iter()
        .find(|e| e["from"] == "A" && e["label"].as_str().unwrap().starts_with("Sent"))
        .expect("A reports the job done");
    assert_eq!(sent["at_us"], last_dle["at_us"]);
    // Without --events, only the line.
    let (plain, _) = monitor(&path, &[]);
    assert!(plain.iter().all(|r| r["kind"] != "event"));
}
