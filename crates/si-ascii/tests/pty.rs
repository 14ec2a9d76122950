//! The library's async ASCII handle on a pseudo-terminal against raw bytes: the test writes
//! and reads the other end of a socat pty pair itself, as a terminal or a barcode reader would.
//! Frames end with CR LF; what the handle sends arrives byte for byte.
//!
//! Peer: `apt-get install socat`. Missing, the test is skipped with a message; with `CI` set it
//! fails instead.
#![cfg(all(feature = "tokio", target_os = "linux"))]

use std::io::{Read, Write};
use std::sync::mpsc;
use std::time::Duration;

use si_ascii::tokio::Handle;
use si_ascii::{Config, EndCriterion};
use si_core::port::{self, PortOptions};
use si_testkit::pty::pty_pair;
use tokio::time::timeout;

#[tokio::test]
async fn the_handle_receives_raw_lines_and_sends_bytes_exactly_on_a_pty() {
    let Some(pair) = pty_pair() else { return };
    let config = Config {
        end: EndCriterion::EndChars {
            first: b'\r',
            second: b'\n',
        },
        ..Config::default()
    };
    let line = port::open(&pair.a, &config.settings, &PortOptions::default()).unwrap();
    let mut handle = Handle::spawn(config, line).unwrap();
    // The raw end in raw mode now (socat may set its own termios a moment after naming the
    // pty): no CR before LF added to what the test writes.
    let stty = std::process::Command::new("stty")
        .args(["-F", &pair.b, "raw", "-echo"])
        .status()
        .expect("run stty");
    assert!(stty.success(), "stty raw on {}", pair.b);
    let mut raw = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .open(&pair.b)
        .expect("open the raw end");
    let mut reader = raw.try_clone().unwrap();
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let mut buf = [0u8; 256];
        while let Ok(n) = reader.read(&mut buf) {
            if n == 0 || tx.send(buf[..n].to_vec()).is_err() {
                break;
            }
        }
    });

    // Two lines in one write: two frames, each with its end characters.
    raw.write_all(b"first\r\nsecond line\r\n").unwrap();
    let limit = Duration::from_secs(5);
    let one = timeout(limit, handle.recv())
        .await
        .expect("a frame")
        .unwrap();
    let two = timeout(limit, handle.recv())
        .await
        .expect("a frame")
        .unwrap();
    assert_eq!(&one[..], b"first\r\n");
    assert_eq!(&two[..], b"second line\r\n");

    // 200 bytes, the maximum frame, every value but XON and XOFF among them.
    let frame: Vec<u8> = (0..=255u8)
        .filter(|b| *b != 0x11 && *b != 0x13)
        .take(200)
        .collect();
    timeout(limit, handle.send(frame.clone()))
        .await
        .expect("sent in time")
        .unwrap();
    let mut got = Vec::new();
    while got.len() < frame.len() {
        got.extend(rx.recv_timeout(limit).expect("the bytes arrive"));
    }
    assert_eq!(got, frame);
}
