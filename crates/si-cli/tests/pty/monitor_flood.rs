//! Bounded memory: `si monitor --svg` on a live port stays below 64 MB RSS under a 20 s
//! flood (it grew from 12 MB to 312 MB in 25 s, keeping every record for the diagram). The
//! diagram now summarises as the records arrive (si-cli's `svg::Diagram`); this test floods a
//! pty with noise and samples the monitor's `VmRSS` from `/proc`. Skips without socat (fails
//! with `CI` set), and on a system without `/proc`.

use std::io::{Read, Write};
use std::process::Stdio;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use crate::common;

use common::{pty_pair, si_command, test_dir, Kill};

/// The monitor's resident set in kB, from `/proc/PID/status`.
fn rss_kb(pid: u32) -> Option<u64> {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let line = status.lines().find(|l| l.starts_with("VmRSS:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

#[test]
fn monitor_svg_under_a_20_s_flood_stays_below_64_mb() {
    // Not beside another flood (crate::common::noise): it would starve this one's socat.
    let _one = crate::common::noise::one_at_a_time();
    if !std::path::Path::new("/proc/self/status").exists() {
        eprintln!("SKIPPED: no /proc to read the monitor's memory from");
        return;
    }
    let Some(pair) = pty_pair() else {
        return;
    };
    let svg = test_dir("si-monitor-flood").join("flood.svg");
    let mut monitor = Kill(
        si_command()
            .args(["--port", &pair.b, "monitor", "--protocol", "modbus"])
            .args(["--duration", "20", "--svg"])
            .arg(&svg)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("start the monitor"),
    );
    // Drain what it prints, so it never blocks on a full pipe.
    let mut printed = monitor.0.stdout.take().expect("stdout");
    let drain = std::thread::spawn(move || {
        let mut buf = [0u8; 1 << 16];
        let mut total = 0usize;
        while let Ok(n) = printed.read(&mut buf) {
            if n == 0 {
                break;
            }
            total += n;
        }
        total
    });
    // The flood: pseudo-random bytes as fast as the pty takes them.
    let stop = Arc::new(AtomicBool::new(false));
    let flooding = stop.clone();
    let port = pair.a.clone();
    let flood = std::thread::spawn(move || {
        let mut line = std::fs::OpenOptions::new()
            .write(true)
            .open(&port)
            .expect("open the flooding end");
        let mut x: u32 = 0x1234_5678;
        let mut chunk = [0u8; 4096];
        let mut sent = 0usize;
        while !flooding.load(Ordering::Relaxed) {
            for b in &mut chunk {
                x ^= x << 13;
                x ^= x >> 17;
                x ^= x << 5;
                *b = x as u8;
            }
            match line.write(&chunk) {
                Ok(n) => sent += n,
                Err(_) => break,
            }
        }
        sent
    });
    let started = Instant::now();
    let mut most_kb = 0;
    let status = loop {
        if let Some(status) = monitor.0.try_wait().expect("poll the monitor") {
            break status;
        }
        if let Some(kb) = rss_kb(monitor.0.id()) {
            most_kb = most_kb.max(kb);
        }
        assert!(
            started.elapsed() < Duration::from_secs(60),
            "the monitor outlived --duration 20 by 40 s"
        );
        std::thread::sleep(Duration::from_millis(100));
    };
    stop.store(true, Ordering::Relaxed);
    // Nobody reads the line any more: close it, so a write blocked on a full pty fails.
    drop(pair);
    let sent = flood.join().expect("flood thread");
    let printed = drain.join().expect("drain thread");
    let mut err = String::new();
    let _ = monitor
        .0
        .stderr
        .take()
        .map(|mut e| e.read_to_string(&mut err));
    assert!(status.success(), "monitor failed: {err}");
    assert!(sent > 1 << 20, "the flood sent only {sent} bytes");
    assert!(printed > 0, "the monitor printed nothing");
    assert!(
        most_kb < 64 * 1024,
        "the monitor reached {most_kb} kB under a flood of {sent} bytes"
    );
    let drawn = std::fs::read_to_string(&svg).expect("the SVG was written");
    assert!(drawn.contains("(summarised)"), "a flood is summarised");
    eprintln!("monitor under flood: {sent} bytes in, at most {most_kb} kB resident");
}
