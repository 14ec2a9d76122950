//! trace → pcap → `--from-pcap` gives the monitor report of the trace itself: the same records
//! with their flags and times, the same counters, the same SVG, for every simulator scenario.

use crate::common::{si, si_command, stdout, test_dir, text};
use std::path::{Path, PathBuf};

/// The scenarios `si sim` offers (its list, first word of each line).
fn scenarios() -> Vec<String> {
    let o = si(&["sim"]);
    assert!(o.status.success(), "si sim: {}", text(&o));
    stdout(&o)
        .lines()
        .filter_map(|l| l.split_whitespace().next().map(str::to_owned))
        .collect()
}

fn run(args: &[&std::ffi::OsStr]) -> String {
    let o = si_command().args(args).output().unwrap();
    assert!(o.status.success(), "si {args:?}: {}", text(&o));
    stdout(&o)
}

/// `si sim SCENARIO --record`, then the trace exported as pcapng; both paths.
pub fn recorded(dir: &Path, scenario: &str) -> (PathBuf, PathBuf) {
    let trace = dir.join(format!("{scenario}.trace"));
    let pcap = dir.join(format!("{scenario}.pcapng"));
    let o = si_command()
        .args(["sim", scenario, "--record"])
        .arg(&trace)
        .output()
        .unwrap();
    assert!(o.status.success(), "si sim {scenario}: {}", text(&o));
    run(&[
        "trace".as_ref(),
        "export".as_ref(),
        trace.as_os_str(),
        "--pcap".as_ref(),
        pcap.as_os_str(),
    ]);
    (trace, pcap)
}

#[test]
fn every_scenario_reads_back_from_its_capture_with_the_same_report() {
    let dir = test_dir("si-capture-round-trip");
    let list = scenarios();
    assert!(list.len() >= 19, "{list:?}");
    for scenario in &list {
        let (trace, pcap) = recorded(&dir, scenario);
        let (svg_a, svg_b) = (dir.join("a.svg"), dir.join("b.svg"));
        for json in [false, true] {
            let report = |input: &str, file: &Path, svg: &Path| {
                let mut args: Vec<&std::ffi::OsStr> = Vec::new();
                if json {
                    args.push("--json".as_ref());
                }
                args.extend([
                    "monitor".as_ref(),
                    input.as_ref(),
                    file.as_os_str(),
                    "--svg".as_ref(),
                    svg.as_os_str(),
                ]);
                run(&args)
            };
            let from_trace = report("--trace", &trace, &svg_a);
            let from_pcap = report("--from-pcap", &pcap, &svg_b);
            assert!(from_trace.lines().count() >= 2, "{scenario}: {from_trace}");
            assert_eq!(from_pcap, from_trace, "{scenario} (json {json})");
            assert_eq!(
                std::fs::read_to_string(&svg_b).unwrap(),
                std::fs::read_to_string(&svg_a).unwrap(),
                "{scenario}: the SVG"
            );
        }
    }
}

#[test]
fn a_flagged_frame_keeps_its_raw_bytes_in_the_capture() {
    let dir = test_dir("si-capture-raw");
    let (trace, pcap) = recorded(&dir, "modbus-crc-error");
    let report = run(&[
        "--json".as_ref(),
        "monitor".as_ref(),
        "--trace".as_ref(),
        trace.as_os_str(),
    ]);
    let bad = report
        .lines()
        .find(|l| l.contains("CRC error"))
        .expect("the monitor flags the CRC error");
    let v: serde_json::Value = serde_json::from_str(bad).unwrap();
    let hex: String = v["bytes"].as_str().unwrap().replace(' ', "");
    let raw: Vec<u8> = (0..hex.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&hex[i..i + 2], 16).unwrap())
        .collect();
    let capture = std::fs::read(&pcap).unwrap();
    assert!(
        capture.windows(raw.len()).any(|w| w == raw),
        "the flagged frame {hex} is in the capture as it was on the line"
    );
}

#[test]
fn a_capture_that_is_not_one_is_refused_by_name() {
    let dir = test_dir("si-capture-bad");
    let path = dir.join("not.pcapng");
    std::fs::write(&path, b"hello, world").unwrap();
    let o = si_command()
        .args(["monitor", "--from-pcap"])
        .arg(&path)
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(
        text(&o).contains("not a pcapng or pcap file"),
        "{}",
        text(&o)
    );
}
