//! `si uss scan` on a pty pair: `si uss sim-slave`'s node is found among nodes 0–31 (two
//! polling-list batches, the port opened twice), nothing else is reported, and the scan ends
//! within the time it announced before it started.

use crate::common;

use common::{pty_pair_ignoreeof, si_command, stdout, text, Kill};
use std::io::{BufRead, BufReader};
use std::process::Stdio;

#[test]
fn a_scan_finds_the_simulated_drive_and_nothing_else_within_the_announced_time() {
    // ignoreeof: the scan closes and reopens its end between the two batches.
    let Some(pair) = pty_pair_ignoreeof() else {
        return;
    };
    let mut drive = si_command()
        .args(["--port", &pair.b, "uss", "sim-slave", "--address", "5"])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("spawn si uss sim-slave");
    let mut said = BufReader::new(drive.stdout.take().expect("stdout")).lines();
    let first = said
        .next()
        .expect("the drive says it answers")
        .expect("a line");
    assert!(first.contains("drive 5 answering"), "{first}");
    // Keep reading what the drive prints, so it never writes into a closed pipe.
    std::thread::spawn(move || for _ in said {});
    let _drive = Kill(drive);
    let started = std::time::Instant::now();
    let o = si_command()
        .args(["--json", "--port", &pair.a, "uss", "scan"])
        .output()
        .expect("run si");
    let took = started.elapsed();
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    let lines: Vec<serde_json::Value> = stdout(&o)
        .lines()
        .map(|l| serde_json::from_str(l).expect("JSON line"))
        .collect();
    assert_eq!(lines[0]["nodes"], 32, "{t}");
    let bound_ms = lines[0]["bound_ms"].as_u64().expect("the announced bound");
    let found: Vec<_> = lines[1..]
        .iter()
        .map(|l| (l["node"].clone(), l["answered"].clone()))
        .collect();
    assert_eq!(found, vec![(5.into(), true.into())], "{t}");
    assert!(
        took.as_millis() as u64 <= bound_ms,
        "took {took:?}, announced {bound_ms} ms"
    );
}
