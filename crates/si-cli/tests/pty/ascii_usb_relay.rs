//! `si ascii recv` with the character delay time ([ET200S SI] §2.8) behind a pacing, chunking
//! relay that behaves like a 16 ms / 62-byte USB-serial adapter and announces nothing (as a
//! CH340, a device server or any pty): with default settings, a new process, three 100-byte
//! frames arrive whole. The engine takes the unknown port for a 16 ms adapter until its reads
//! show single bytes at wire pace, so the first frame is not cut at the first packet's hole.
//! A run in which the machine stalled the line (the relay or the pseudo-terminals' socat: holes
//! no adapter makes, seen in the receiver's recording) is run again
//! (`si_testkit::relay::retry_if_late`).
//! Skips with a message when socat is missing; with `CI` set it fails instead.

use std::process::Stdio;
use std::time::Duration;

use crate::common;

use common::{have_socat, opened, pty_pair_ignoreeof, si_command, test_dir};
use si_testkit::relay::{retry_if_late, usb_relay, Adapter};

#[test]
fn si_ascii_recv_gets_three_100_byte_frames_whole_behind_an_unannounced_16ms_adapter() {
    if !have_socat() {
        return;
    }
    let adapter = Adapter::ftdi_default(9_600, 11);
    let dir = test_dir("si-ascii-usb-relay");
    let trace = dir.join("recv.trace");
    retry_if_late(5, || {
        let (Some(near), Some(far)) = (pty_pair_ignoreeof(), pty_pair_ignoreeof()) else {
            panic!("socat is there but made no pty pair");
        };
        let relay = usb_relay(&near.b, &far.a, adapter);
        let outcome = three_frames(&near.a, &far.b, &trace);
        // How much longer than the adapter's own the longest hole inside a frame was, as
        // the receiver saw it: a stalled socat makes such holes as a stalled relay does.
        let text = std::fs::read_to_string(&trace).unwrap_or_default();
        let stalled = longest_hole_in_a_frame(&text).saturating_sub(adapter.latency);
        (outcome, relay.max_late().max(stalled))
    });
    let _ = std::fs::remove_dir_all(&dir);
}

/// The longest time between two reads in the recording shorter than the pause between the
/// test's frames (so inside a frame).
fn longest_hole_in_a_frame(trace: &str) -> Duration {
    let reads: Vec<u64> = trace
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .filter(|v| v["kind"] == "rx_chunk" || v["kind"] == "rx")
        .filter_map(|v| v["at"].as_u64())
        .collect();
    let hole = reads
        .windows(2)
        .map(|w| w[1].saturating_sub(w[0]))
        .filter(|&us| us < 300_000)
        .max()
        .unwrap_or(0);
    Duration::from_micros(hole)
}

/// `si ascii recv` on `recv_port` (recording to `trace`), three 100-byte frames sent from
/// `send_port`: all three whole, or what came instead.
fn three_frames(recv_port: &str, send_port: &str, trace: &std::path::Path) -> Result<(), String> {
    let recv = si_command()
        .arg("--record")
        .arg(trace)
        .args(["--json", "ascii", "recv", "--port", recv_port])
        .args(["--end", "delay", "--count", "3", "--timeout", "30"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start si ascii recv");
    opened(&recv, recv_port);
    let frame: Vec<String> = (0..100u32)
        .map(|i| format!("{:02X}", b'A' + (i % 26) as u8))
        .collect();
    let frame = frame.join(" ");
    for _ in 0..3 {
        let out = si_command()
            .args(["ascii", "send", "--port", send_port, &frame])
            .output()
            .expect("run si ascii send");
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        // The frame takes 115 ms on the wire; then a pause far above the CDT.
        std::thread::sleep(Duration::from_millis(600));
    }
    let out = recv.wait_with_output().expect("recv ends");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let frames: Vec<String> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| {
            let v: serde_json::Value = serde_json::from_str(l).expect("a JSON line");
            v["frame"].as_str().expect("a frame").to_owned()
        })
        .collect();
    if frames == [frame.clone(), frame.clone(), frame] {
        Ok(())
    } else {
        Err(format!("frames received: {frames:?}"))
    }
}
