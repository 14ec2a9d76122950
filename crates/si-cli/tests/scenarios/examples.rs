//! The root package's examples that need no hardware: each runs to its end and
//! prints what its doc comment promises. They are the binaries `cargo test --workspace
//! --all-features` builds beside `si` (common::example); the serial ones have their pty tests
//! (pty/modbus_serial_example.rs, pty/three_protocols_example.rs), and `latency` is a
//! measurement (BENCHMARKS.md).

use crate::common::{example, stderr, stdout};
use std::process::Command;
use std::time::{Duration, Instant};

/// Each example and lines its comments promise in its output.
const PROMISES: &[(&str, &[&str])] = &[
    // An initialization conflict (both send STX), then a corrupted character: NAK and the
    // repetition, and every block arrives.
    (
        "3964r_sim",
        &[
            "host: received \"tank level 73 %\"",
            "PLC: received \"valve 4 open\"",
            "host     tx 15",
            "host: received \"pump 2 running\"",
        ],
    ),
    (
        "ascii_sim",
        &[
            "S_RCV NDR LEN=9 \"LOT 4711\\u{3}\"",
            "S_RCV NDR LEN=4 \"END\\u{3}\"",
        ],
    ),
    (
        "dpcoord_sim",
        &[
            "-- directly on the 3964(R) links",
            "B: S_RCV NDR LEN=4 \"ping\"",
            "-- through the DP windows of two modules running 3964(R)",
            "A: S_RCV NDR LEN=4 \"pong\"",
        ],
    ),
    (
        "dpcoord_tokio",
        &[
            "partner received Some(\"hello from the PLC side\")",
            "S_RCV NDR \"hello from the partner\"",
        ],
    ),
    // Register 512 is beyond DB_Max: exception 02, decoded by the master as STATUS 16#0E62
    // ([Modbus/USS] §3.3.6, Table 3-12).
    (
        "modbus_sim",
        &[
            "ReadHoldingRegisters([1234, 5678])",
            "failed 16#0E62 exception 02",
            "DB6.DBW0 = 1234, M500.3 = true",
        ],
    ),
    (
        "rk512_sim",
        &[
            "host: job 2 fetched 200 bytes",
            "16#0909 target DB/DX locked at the partner by a coordination flag",
            "DB10.DBW0 = AA55",
        ],
    ),
    // Drive 2 is switched off and the cycle goes on; drive 3's parameter is written.
    (
        "uss_sim",
        &[
            "cycle 3: node 2 does not answer",
            "cycle 3: drive 1 ZSW 0737 HIW 1500",
            "drive 3: P1082 = 120 written",
        ],
    ),
];

#[test]
fn every_example_without_hardware_prints_what_its_comments_promise() {
    for (name, lines) in PROMISES {
        let Some(path) = example(name) else { continue };
        let mut child = Command::new(&path)
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .expect("start the example");
        // A bound, not a claim: the simulated ones run in virtual time and end at once.
        let deadline = Instant::now() + Duration::from_secs(60);
        while child.try_wait().expect("wait").is_none() {
            if Instant::now() > deadline {
                let _ = child.kill();
                panic!("{name} did not end within 60 s");
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        let out = child.wait_with_output().expect("output");
        let text = stdout(&out);
        assert!(
            out.status.success(),
            "{name} failed:\n{text}{}",
            stderr(&out)
        );
        for line in *lines {
            assert!(
                text.contains(line),
                "{name} does not print {line:?}:\n{text}"
            );
        }
    }
}
