//! `si ascii recv` with the character delay time ([ET200S SI] §2.8) behind a pacing, chunking
//! relay that behaves like a 16 ms / 62-byte USB-serial adapter and announces nothing (as a
//! CH340, a device server or any pty): with default settings, a new process, three 100-byte
//! frames arrive whole. The engine takes the unknown port for a 16 ms adapter until its reads
//! show single bytes at wire pace, so the first frame is not cut at the first packet's hole.
//! Skips with a message when socat is missing; with `CI` set it fails instead.

use std::process::Stdio;
use std::time::Duration;

use crate::common;

use common::relay::{usb_relay, Adapter};
use common::{have_socat, opened, pty_pair_ignoreeof, si_command};

#[test]
fn si_ascii_recv_gets_three_100_byte_frames_whole_behind_an_unannounced_16ms_adapter() {
    if !have_socat() {
        return;
    }
    let (Some(near), Some(far)) = (pty_pair_ignoreeof(), pty_pair_ignoreeof()) else {
        return;
    };
    usb_relay(&near.b, &far.a, Adapter::ftdi_default(9_600, 11));
    let recv = si_command()
        .args(["--json", "ascii", "recv", "--port", &near.a])
        .args(["--end", "delay", "--count", "3", "--timeout", "30"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start si ascii recv");
    opened(&recv, &near.a);
    let frame: Vec<String> = (0..100u32)
        .map(|i| format!("{:02X}", b'A' + (i % 26) as u8))
        .collect();
    let frame = frame.join(" ");
    for _ in 0..3 {
        let out = si_command()
            .args(["ascii", "send", "--port", &far.b, &frame])
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
    assert_eq!(frames, vec![frame.clone(), frame.clone(), frame]);
}
