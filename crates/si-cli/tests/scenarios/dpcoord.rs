//! `si dp-coord host|trace` and the dp-coord scenarios of `si sim`, run as the built binary with
//! the test playing the module through a pipe ([ET200S SI 2005] §2.12.2–§2.12.6: the
//! manual's example tables give the input windows; `xx` bytes are written as 00).

use std::io::Write;
use std::process::{Output, Stdio};

use crate::common;

use common::si_command;

/// Runs `si dp-coord host ARGS` with `inputs` as the module's input windows, one per line
/// (also used by `bounds`).
pub(crate) fn host(args: &[&str], inputs: &[&str]) -> Output {
    let mut child = si_command()
        .args(["dp-coord", "host"])
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start si");
    let mut stdin = child.stdin.take().expect("piped stdin");
    for line in inputs {
        // The host may stop reading once its job has ended.
        if writeln!(stdin, "{line}").is_err() {
            break;
        }
    }
    drop(stdin);
    child.wait_with_output().expect("si runs")
}

fn stdout_lines(out: &Output) -> Vec<String> {
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(str::to_owned)
        .collect()
}

/// Table 2-23 (reconstructed, `[derived]`): the IN column.
const TABLE_2_23_IN: &[&str] = &[
    "00 00 00 00 00 00 00 00",
    "00 00 00 00 00 00 00 00",
    "10 00 00 00 00 00 00 00",
    "10 00 00 00 00 00 00 00",
    "11 00 00 00 00 00 00 00",
    "12 00 00 00 00 00 00 00",
    "13 00 00 00 00 00 00 00",
    "13 00 00 00 00 00 00 00",
    "14 00 00 00 00 00 00 00",
    "14 00 00 00 00 00 00 00",
    "74 00 00 00 00 00 00 00",
    // Never read: the job has ended.
    "00 00 00 00 00 00 00 00",
];

#[test]
fn table_2_23_host_send_prints_the_out_column_then_done() {
    let out = host(
        &[
            "--window",
            "8",
            "send",
            "6162636465666768696A6B6C6D6E6F707172737475 76",
        ],
        TABLE_2_23_IN,
    );
    assert!(out.status.success(), "{out:?}");
    assert_eq!(
        stdout_lines(&out),
        [
            "10 00 00 00 00 00 00 00",
            "10 00 00 00 00 00 00 00",
            "11 00 16 61 62 63 64 65",
            "11 00 16 61 62 63 64 65",
            "12 66 67 68 69 6A 6B 6C",
            "13 6D 6E 6F 70 71 72 73",
            "14 74 75 76 00 00 00 00",
            "14 74 75 76 00 00 00 00",
            "14 74 75 76 00 00 00 00",
            "14 74 75 76 00 00 00 00",
            "00 00 00 00 00 00 00 00",
            "done STATUS=0000",
        ]
    );
}

#[test]
fn section_2_8_send_ended_with_a_status_prints_error_and_exits_1() {
    // 4-byte window, "abc" = length word + 3 bytes = 2 segments; the module reports 0703H.
    let out = host(
        &["--window", "4", "send", "61 62 63"],
        &[
            "00 00 00 00",
            "10 00 00 00",
            "11 00 00 00",
            "12 00 00 00",
            "72 07 03 00",
        ],
    );
    assert_eq!(out.status.code(), Some(1), "{out:?}");
    assert_eq!(
        stdout_lines(&out),
        [
            "10 00 00 00",
            "11 00 03 61",
            "12 62 63 00",
            "12 62 63 00",
            "00 00 00 00",
            "error STATUS=0703",
        ]
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("16#0703"), "{stderr}");
}

#[test]
fn table_2_24_receive_prints_the_frame_before_done() {
    // [derived]: the receive request is 20H. 6 bytes in a 4-byte window: 21H carries the length
    // word.
    let out = host(
        &["--window", "4", "receive"],
        &[
            "00 00 01 00",
            "21 00 06 61",
            "22 62 63 64",
            "23 65 66 00",
            "00 00 00 00",
        ],
    );
    assert!(out.status.success(), "{out:?}");
    assert_eq!(
        stdout_lines(&out),
        [
            "20 00 00 00",
            "21 00 00 00",
            "22 00 00 00",
            "23 00 00 00",
            "00 00 00 00",
            "frame 61 62 63 64 65 66",
            "done STATUS=0000",
        ]
    );
}

#[test]
fn receive_with_nothing_buffered_is_done_with_0101() {
    let out = host(
        &["--window", "4", "receive"],
        &["00 00 00 00", "20 01 01 00", "00 00 00 00"],
    );
    assert!(out.status.success(), "{out:?}");
    assert_eq!(
        stdout_lines(&out).last().map(String::as_str),
        Some("done STATUS=0101")
    );
}

#[test]
fn table_2_25_read_v24_prints_the_signal_word() {
    let out = host(
        &["--window", "4", "read-v24"],
        &["00 00 00 00", "31 00 1F 00", "00 00 00 00"],
    );
    assert!(out.status.success(), "{out:?}");
    assert_eq!(
        stdout_lines(&out),
        [
            "30 00 00 00",
            "31 00 00 00",
            "00 00 00 00",
            "signals 00 1F",
            "done STATUS=0000"
        ]
    );
}

#[test]
fn table_2_26_write_v24_carries_rts_and_dtr_in_the_request() {
    let out = host(
        &["--window", "4", "write-v24", "--rts", "1", "--dtr", "1"],
        &["00 00 00 00", "40 00 00 00"],
    );
    assert!(out.status.success(), "{out:?}");
    // [derived]: DCD CTS RTS DSR DTR in bits 4…0 of byte 2: RTS + DTR = 05H.
    assert_eq!(
        stdout_lines(&out),
        ["40 00 05 00", "00 00 00 00", "done STATUS=0000"]
    );
}

#[test]
fn table_2_28_params_xon_xoff_sends_block_20h() {
    let out = host(
        &["--window", "4", "params", "xon-xoff", "--wait-ms", "2000"],
        &[
            "00 00 00 00",
            "50 00 00 00",
            "51 00 00 00",
            "52 00 00 00",
            "53 00 00 00",
            "73 00 00 00",
        ],
    );
    assert!(out.status.success(), "{out:?}");
    assert_eq!(
        stdout_lines(&out),
        [
            "50 00 00 00",
            "51 20 00 04",
            "52 11 13 00",
            "53 C8 00 00",
            "53 C8 00 00",
            "00 00 00 00",
            "done STATUS=0000",
        ]
    );
}

#[test]
fn wrong_window_length_and_early_eof_are_errors_with_nothing_but_windows_on_stdout() {
    let out = host(&["--window", "4", "receive"], &["00 00 00"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(out.stdout.is_empty());
    assert!(String::from_utf8_lossy(&out.stderr).contains("the window has 4"));

    let out = host(&["--window", "4", "receive"], &["00 00 01 00"]);
    assert_eq!(out.status.code(), Some(1));
    assert_eq!(stdout_lines(&out), ["20 00 00 00"]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("ended before the job"));
}

#[test]
fn trace_annotates_a_host_transcript_cycle_by_cycle() {
    let dir = std::env::temp_dir().join(format!("si-dpcoord-trace-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("trace.txt");
    std::fs::write(
        &file,
        "# a transcript: input, output, input, output …\n\
         00 00 00 00\n40 00 05 00\n40 00 00 00\n00 00 00 00\ndone STATUS=0000\n\
         < 31 00 1F 00\n> 31 00 00 00\n",
    )
    .unwrap();
    let out = si_command()
        .args(["dp-coord", "trace"])
        .arg(&file)
        .output()
        .unwrap();
    assert!(out.status.success(), "{out:?}");
    let lines = stdout_lines(&out);
    assert_eq!(lines.len(), 7, "{lines:?}");
    assert!(lines[0].starts_with("   1 < 00 00 00 00"), "{lines:?}");
    assert!(lines[1].starts_with("   1 > 40 00 05 00") && lines[1].contains("set RTS=1 DTR=1"));
    assert!(lines[2].starts_with("   2 < 40 00 00 00") && lines[2].contains("STATUS 16#0000"));
    assert_eq!(lines[4].trim(), "done STATUS=0000");
    assert!(
        lines[5].contains("DCD=1 CTS=1 RTS=1 DSR=1 DTR=1"),
        "{lines:?}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn sim_dp_coord_send_prints_table_2_23_and_ends_done() {
    let out = si_command()
        .args(["sim", "dp-coord-send"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{out:?}");
    let lines = stdout_lines(&out);
    assert!(
        lines[5].starts_with("   3 > 11 00 16 61 62 63 64 65"),
        "{lines:?}"
    );
    assert!(lines.iter().any(|l| l.contains("< 74 00 00")), "{lines:?}");
    assert_eq!(lines.last().map(String::as_str), Some("done STATUS=0000"));
}

/// Runs `si sim NAME`, a scenario ending with S_SEND's and S_RCV's results; asserts it
/// succeeded and S_SEND on A was done without error; its lines.
fn sim_fb_scenario(name: &str) -> Vec<String> {
    let out = si_command().args(["sim", name]).output().unwrap();
    assert!(out.status.success(), "{out:?}");
    let lines = stdout_lines(&out);
    let n = lines.len();
    assert!(
        lines[n - 2].ends_with("A S_SEND done=true error=false STATUS=0000"),
        "{lines:?}"
    );
    lines
}

#[test]
fn sim_dp_coord_e2e_delivers_the_frame_through_both_windows() {
    let lines = sim_fb_scenario("dp-coord-e2e");
    let n = lines.len();
    // "temperature=21.5"
    assert!(lines[n - 1].ends_with(
        "B S_RCV ndr=true error=false STATUS=0000 LEN=16 74 65 6D 70 65 72 61 74 75 72 65 3D 32 31 2E 35"
    ));
    // The 3964(R) block crossed the line: STX from A.
    assert!(
        lines.iter().any(|l| l.contains("B") && l.contains("rx 02")),
        "{lines:?}"
    );
}

#[test]
fn json_lines_carry_the_same_windows_and_result() {
    let out = host(
        &["--json", "--window", "4", "read-v24"],
        &["00 00 00 00", "31 00 1F 00", "00 00 00 00"],
    );
    assert!(out.status.success(), "{out:?}");
    let lines: Vec<serde_json::Value> = stdout_lines(&out)
        .iter()
        .map(|l| serde_json::from_str(l).expect("one JSON value a line"))
        .collect();
    assert_eq!(lines.len(), 5);
    assert_eq!(lines[0]["output"], "30 00 00 00");
    assert_eq!(lines[3]["signals"], "00 1F");
    assert_eq!(lines[3]["cts"], true);
    assert_eq!(lines[4]["done"], true);
    assert_eq!(lines[4]["status"], "0000");
}

#[test]
fn sim_dp_coord_modbus_reads_registers_through_the_window() {
    let lines = sim_fb_scenario("dp-coord-modbus");
    let n = lines.len();
    // FC03, registers 0 and 1 of slave 1: 1234H, 5678H in register order ([Modbus/USS]
    // §3.4.5–§3.4.16).
    assert!(
        lines[n - 1].ends_with("A S_RCV ndr=true error=false STATUS=0000 LEN=4 12 34 56 78"),
        "{lines:?}"
    );
    // The request crossed the line as the ADU with its CRC: 01 03 00 00 00 02 C4 0B.
    let request: Vec<&str> = lines
        .iter()
        .filter(|l| l.contains("slave") && l.contains(" rx "))
        .filter_map(|l| l.split_whitespace().last())
        .collect();
    assert_eq!(request, ["01", "03", "00", "00", "00", "02", "C4", "0B"]);
}

/// `[derived]`: with `--exec-after-7 0` the 8th segment of a send through the 4-byte window carries
/// number 0 (10H) instead of 1 (11H).
#[test]
fn host_exec_after_7_sets_the_number_of_the_8th_segment() {
    let mut inputs = vec!["00 00 00 00".to_owned(), "10 00 00 00".to_owned()];
    inputs.extend((1..=7).map(|e| format!("1{e} 00 00 00")));
    inputs.extend(["10 00 00 00", "70 00 00 00"].map(str::to_owned));
    let inputs: Vec<&str> = inputs.iter().map(String::as_str).collect();
    let job = [
        "--window",
        "4",
        "send",
        "6162636465666768696A6B6C6D6E6F70717273747576",
    ];
    let out = host(&[&["--exec-after-7", "0"][..], &job].concat(), &inputs);
    assert!(out.status.success(), "{out:?}");
    let lines = stdout_lines(&out);
    assert_eq!(lines[7], "17 71 72 73", "{lines:?}");
    assert_eq!(lines[8], "10 74 75 76", "{lines:?}");
    assert_eq!(lines[9], "10 74 75 76");
    assert_eq!(lines.last().map(String::as_str), Some("done STATUS=0000"));
    // The default counts 7 → 1.
    let out = host(&job, &inputs);
    assert_eq!(stdout_lines(&out)[8], "11 74 75 76", "{out:?}");
    let out = host(&[&["--exec-after-7", "2"][..], &job].concat(), &[]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("1 (7 → 1) or 0 (7 → 0)"));
}

#[test]
fn host_max_frame_follows_the_module_type_and_max_frame_overrides_it() {
    let frame = |n: usize| "61".repeat(n);
    // ET 200S 1SI: 200 bytes ([ET200S SI] §2.12); one more is the FB's LEN error before any window.
    let out = host(&["--module", "et200s", "send", &frame(201)], &[]);
    assert_eq!(out.status.code(), Some(1), "{out:?}");
    assert!(out.stdout.is_empty());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("frame length 201 outside 1 … 200"),
        "{stderr}"
    );
    // The 2005 module (the default): 224 bytes, so 201 starts the job.
    for args in [&["send"][..], &["--module", "2005", "send"][..]] {
        let mut args = args.to_vec();
        let data = frame(201);
        args.push(&data);
        let out = host(&args, &["00 00 00 00 00 00 00 00"]);
        assert_eq!(
            stdout_lines(&out).first().map(String::as_str),
            Some("10 00 00 00 00 00 00 00"),
            "{args:?}: {out:?}"
        );
    }
    let out = host(&["--module", "2005", "send", &frame(225)], &[]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("outside 1 … 224"));
    // --max-frame replaces the module's value.
    let out = host(&["--max-frame", "10", "send", &frame(11)], &[]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("outside 1 … 10"));
    // The CP 341 has no coordination window.
    let out = host(&["--module", "cp341", "send", "61"], &[]);
    assert_eq!(out.status.code(), Some(1), "{out:?}");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("module type behind the coordination window = cp341"),
        "{stderr}"
    );
}

/// `dp-coord host --timeout-s 1 receive` given the input windows `lines`, then stdin kept open
/// and silent: the job must end with the watchdog's STATUS (0502H).
fn host_times_out_on_silent_stdin_after(lines: &[&str]) {
    let mut child = si_command()
        .args(["dp-coord", "host", "--timeout-s", "1", "receive"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run si");
    let mut stdin = child.stdin.take().expect("piped stdin");
    for line in lines {
        writeln!(stdin, "{line}").expect("write a window");
    }
    let _stdin_kept_open = stdin;
    let started = std::time::Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().expect("wait for si") {
            break status;
        }
        // A bound, not a timing claim: 1 s of timeout and a loaded machine fit in 20 s.
        if started.elapsed() > std::time::Duration::from_secs(20) {
            let _ = child.kill();
            panic!("dp-coord host still running 20 s after a 1 s timeout");
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    };
    let out = child.wait_with_output().expect("collect output");
    assert!(!status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("16#0502"), "{stderr}");
}

#[test]
fn host_ends_at_its_timeout_while_stdin_stays_open_and_silent() {
    // `--timeout-s 2` once waited until stdin closed. No window ever comes: the job never
    // started, and the limit counts from the start.
    host_times_out_on_silent_stdin_after(&[]);
}

#[test]
fn host_watchdog_runs_when_windows_stop_coming() {
    // Windows came (the job started), then none: the host's own watchdog, from the job's
    // start, ends it.
    host_times_out_on_silent_stdin_after(&["00 00 00 00 00 00 00 00"; 3]);
}
