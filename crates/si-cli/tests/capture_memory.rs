//! Traces and captures are read and written record by record: a trace of 1,000,000 Modbus
//! frames (over 100 MB) is monitored, exported to pcapng and read back from the capture, and a
//! trace of 200,000 frames (some 30 MB, which whole in memory took over ten times that) is
//! exported as UART levels (VCD), each by a child `si` whose peak memory stays under 64 MB;
//! `/dev/zero` is refused at its first line instead of being read into memory.
//!
//! Its own test binary: the peak is the kernel's maximum resident set of this process's
//! waited-for children (`getrusage(RUSAGE_CHILDREN)`), so no other test's child may count.
//! Not a timing claim: only memory is asserted.

mod common;

use common::{si_command, test_dir, text};
use std::io::Write;
use std::process::Stdio;

/// Peak resident set of any child waited for so far, in bytes.
fn children_peak() -> u64 {
    let usage = nix::sys::resource::getrusage(nix::sys::resource::UsageWho::RUSAGE_CHILDREN)
        .expect("getrusage");
    // Linux reports ru_maxrss in KiB.
    usage.max_rss() as u64 * 1024
}

fn crc16(bytes: &[u8]) -> [u8; 2] {
    let mut crc = 0xFFFFu16;
    for &b in bytes {
        crc ^= u16::from(b);
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xA001
            } else {
                crc >> 1
            };
        }
    }
    crc.to_le_bytes()
}

/// A port's recording of `pairs` FC03 polls and answers, with the engine's events: over
/// 100 bytes a frame.
fn write_trace(path: &std::path::Path, pairs: u64) {
    let mut req = vec![1u8, 3, 0, 0, 0, 2];
    req.extend(crc16(&req));
    let mut resp = vec![1u8, 3, 4, 0x12, 0x34, 0x56, 0x78];
    resp.extend(crc16(&resp));
    let list = |b: &[u8]| {
        let v: Vec<String> = b.iter().map(u8::to_string).collect();
        format!("[{}]", v.join(","))
    };
    let (req, resp) = (list(&req), list(&resp));
    let mut f = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    writeln!(
        f,
        r#"{{"format":"si-trace","version":1,"source":"port","protocol":"modbus","settings":{{"baud":19200,"data_bits":8,"parity":"even","stop_bits":1}},"stations":["si"]}}"#
    )
    .unwrap();
    let mut at = 0u64;
    for _ in 0..pairs {
        writeln!(
            f,
            r#"{{"at":{at},"station":"si","kind":"tx","bytes":{req}}}"#
        )
        .unwrap();
        writeln!(
            f,
            r#"{{"at":{},"station":"si","kind":"event","text":"Sent"}}"#,
            at + 1
        )
        .unwrap();
        at += 10_000;
        writeln!(
            f,
            r#"{{"at":{at},"station":"si","kind":"rx_chunk","bytes":{resp}}}"#
        )
        .unwrap();
        writeln!(
            f,
            r#"{{"at":{},"station":"si","kind":"event","text":"Response {{ registers: [4660, 22136] }}"}}"#,
            at + 1
        )
        .unwrap();
        at += 10_000;
    }
    f.flush().unwrap();
}

/// Run `si ARGS` with its stdout counted, not kept; the counters line (its last).
fn run_counting(args: &[&std::ffi::OsStr]) -> String {
    let mut child = si_command()
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let stdout = child.stdout.take().unwrap();
    let reader = std::thread::spawn(move || {
        use std::io::BufRead;
        let mut last = String::new();
        for line in std::io::BufReader::new(stdout).lines() {
            let line = line.unwrap();
            if line.starts_with("{\"counters\"") {
                last = line;
            }
        }
        last
    });
    let o = child.wait_with_output().unwrap();
    assert!(o.status.success(), "si {args:?}: {}", text(&o));
    reader.join().unwrap()
}

#[test]
fn a_million_frames_stream_through_monitor_export_and_import_in_bounded_memory() {
    const LIMIT: u64 = 64 << 20;
    let dir = test_dir("si-capture-memory");
    let trace = dir.join("million.trace");
    let pcap = dir.join("million.pcapng");
    write_trace(&trace, 500_000);
    let size = std::fs::metadata(&trace).unwrap().len();
    assert!(size > 100_000_000, "the trace is {size} bytes");

    let counters = run_counting(&[
        "--json".as_ref(),
        "monitor".as_ref(),
        "--trace".as_ref(),
        trace.as_os_str(),
    ]);
    assert!(counters.contains("\"bus messages\":1000000"), "{counters}");
    let peak = children_peak();
    assert!(
        peak < LIMIT,
        "si monitor --trace on a {size}-byte trace peaked at {} MB resident (limit 64 MB)",
        peak >> 20
    );
    eprintln!(
        "si monitor --trace, {size} bytes: peak {} MB resident",
        peak >> 20
    );

    let o = si_command()
        .args(["trace", "export"])
        .arg(&trace)
        .arg("--pcap")
        .arg(&pcap)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
    let peak = children_peak();
    assert!(
        peak < LIMIT,
        "si trace export of 1,000,000 frames peaked at {} MB resident (limit 64 MB)",
        peak >> 20
    );

    let counters = run_counting(&[
        "--json".as_ref(),
        "monitor".as_ref(),
        "--from-pcap".as_ref(),
        pcap.as_os_str(),
    ]);
    assert!(counters.contains("\"bus messages\":1000000"), "{counters}");
    let peak = children_peak();
    assert!(
        peak < LIMIT,
        "si monitor --from-pcap of 1,000,000 frames peaked at {} MB resident (limit 64 MB)",
        peak >> 20
    );
    eprintln!(
        "export and import of 1,000,000 frames: peak {} MB resident",
        peak >> 20
    );

    // The UART levels: two passes over the trace, nothing of it held (the VCD goes to
    // /dev/null; the levels of 200,000 frames are some 300 MB of text).
    let levels = dir.join("levels.trace");
    write_trace(&levels, 100_000);
    let size = std::fs::metadata(&levels).unwrap().len();
    let o = si_command()
        .args(["trace", "export"])
        .arg(&levels)
        .args(["--vcd", "/dev/null"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
    let peak = children_peak();
    assert!(
        peak < LIMIT,
        "si trace export --vcd of a {size}-byte trace peaked at {} MB resident (limit 64 MB)",
        peak >> 20
    );
    eprintln!(
        "si trace export --vcd, {size} bytes: peak {} MB resident",
        peak >> 20
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn dev_zero_is_refused_at_its_first_line() {
    let o = si_command()
        .args(["monitor", "--trace", "/dev/zero"])
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(
        text(&o).contains("trace line 1: longer than 1048576 bytes"),
        "{}",
        text(&o)
    );
}
