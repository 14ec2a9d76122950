//! The rules of [ET200S SI 2005] §2.12.1, §2.12.7 byte by
//! byte, one side at a time: error bit and go-back, aborts on 000/111, foreign codes, back-off,
//! the watchdog, reset and restart.

use crate::common;

use bytes::Bytes;
use common::{assert_window, bytes, ms};
use si_core::{Duration, Instant};
use si_dp_coord::config::ReceiveErrorPolicy;
use si_dp_coord::coord::{CoordByte, JobCode};
use si_dp_coord::host::{Host, HostEvent, Job, Outcome};
use si_dp_coord::module::{LoopbackSerial, Module};
use si_dp_coord::status::{ABORTED_BY_RESET, NOT_POSSIBLE_IN_MODE, TRANSFER_ERROR_TO_CPU};
use si_dp_coord::{HostConfig, ModuleConfig, WindowSize};

fn module(window: WindowSize) -> Module<LoopbackSerial> {
    let mut serial = LoopbackSerial::new();
    serial.loopback = false;
    Module::new(ModuleConfig::new(window), serial).unwrap()
}

fn step_module(m: &mut Module<LoopbackSerial>, cycle: u64, out: &str, expected_in: &str) {
    let input = m.cycle(ms(cycle), &bytes(out)).to_vec();
    assert_window(&format!("module, OUT {out}"), &input, expected_in);
}

fn step_host(h: &mut Host, cycle: u64, input: &str, expected_out: &str) -> Vec<HostEvent> {
    let out = h.cycle(ms(cycle), &bytes(input)).to_vec();
    assert_window(&format!("host, IN {input}"), &out, expected_out);
    std::iter::from_fn(|| h.poll_event()).collect()
}

const ALPHABET: &[u8] = b"abcdefghijklmnopqrstuv";

/// Exec number out of sequence: the module sets the error bit with the last valid number and
/// accepts the segment after it; a repeated segment (the host holds it) is not an error.
#[test]
fn module_reports_out_of_order_send_segment_with_last_valid_number() {
    let mut m = module(WindowSize::Eight);
    step_module(
        &mut m,
        0,
        "10 xx xx xx xx xx xx xx",
        "10 xx xx xx xx xx xx xx",
    );
    step_module(
        &mut m,
        1,
        "11 00 16 'a' 'b' 'c' 'd' 'e'",
        "11 xx xx xx xx xx xx xx",
    );
    step_module(
        &mut m,
        2,
        "11 00 16 'a' 'b' 'c' 'd' 'e'",
        "11 xx xx xx xx xx xx xx",
    );
    // Segment 2 lost: 13H arrives. Error bit, last valid 1 → 19H.
    step_module(
        &mut m,
        3,
        "13 'm' 'n' 'o' 'p' 'q' 'r' 's'",
        "19 xx xx xx xx xx xx xx",
    );
    // The host goes back to segment 2.
    step_module(
        &mut m,
        4,
        "12 'f' 'g' 'h' 'i' 'j' 'k' 'l'",
        "12 xx xx xx xx xx xx xx",
    );
    step_module(
        &mut m,
        5,
        "13 'm' 'n' 'o' 'p' 'q' 'r' 's'",
        "13 xx xx xx xx xx xx xx",
    );
    step_module(
        &mut m,
        6,
        "14 't' 'u' 'v' xx xx xx xx",
        "14 xx xx xx xx xx xx xx",
    );
    step_module(
        &mut m,
        7,
        "14 't' 'u' 'v' xx xx xx xx",
        "74 00 00 xx xx xx xx xx",
    );
    assert_eq!(
        m.serial().sent().next(),
        Some(&Bytes::from_static(ALPHABET))
    );
    assert_eq!(m.stats().out_of_order, 1);
}

/// The sender watches the error bit and resends from the segment after the reported one.
#[test]
fn host_goes_back_after_the_modules_error_bit() {
    let mut h = Host::new(HostConfig::new(WindowSize::Eight)).unwrap();
    h.submit(Job::Send(Bytes::from_static(ALPHABET))).unwrap();
    step_host(
        &mut h,
        0,
        "00 00 00 xx xx xx xx xx",
        "10 xx xx xx xx xx xx xx",
    );
    step_host(
        &mut h,
        1,
        "10 00 00 xx xx xx xx xx",
        "11 00 16 'a' 'b' 'c' 'd' 'e'",
    );
    step_host(
        &mut h,
        2,
        "11 xx xx xx xx xx xx xx",
        "12 'f' 'g' 'h' 'i' 'j' 'k' 'l'",
    );
    step_host(
        &mut h,
        3,
        "12 xx xx xx xx xx xx xx",
        "13 'm' 'n' 'o' 'p' 'q' 'r' 's'",
    );
    // Module: error, last valid 1 → resend segment 2.
    step_host(
        &mut h,
        4,
        "19 xx xx xx xx xx xx xx",
        "12 'f' 'g' 'h' 'i' 'j' 'k' 'l'",
    );
    step_host(
        &mut h,
        5,
        "19 xx xx xx xx xx xx xx",
        "12 'f' 'g' 'h' 'i' 'j' 'k' 'l'",
    );
    // Error with last valid 0 (nothing valid): back to segment 1.
    step_host(
        &mut h,
        6,
        "18 xx xx xx xx xx xx xx",
        "11 00 16 'a' 'b' 'c' 'd' 'e'",
    );
    step_host(
        &mut h,
        7,
        "11 xx xx xx xx xx xx xx",
        "12 'f' 'g' 'h' 'i' 'j' 'k' 'l'",
    );
    step_host(
        &mut h,
        8,
        "12 xx xx xx xx xx xx xx",
        "13 'm' 'n' 'o' 'p' 'q' 'r' 's'",
    );
    step_host(
        &mut h,
        9,
        "13 xx xx xx xx xx xx xx",
        "14 't' 'u' 'v' xx xx xx xx",
    );
    let ev = step_host(
        &mut h,
        10,
        "74 00 00 xx xx xx xx xx",
        "00 xx xx xx xx xx xx xx",
    );
    assert!(matches!(
        ev.as_slice(),
        [HostEvent::Completed {
            result: Ok(Outcome::Sent),
            ..
        }]
    ));
    assert_eq!(h.stats().resends, 2);
}

/// Execution numbers wrap 7 → 1 (`[derived]`): the 8th segment of a send is 11H again.
#[test]
fn exec_numbers_wrap_from_7_to_1() {
    let data: Vec<u8> = (0..60).collect();
    let mut h = Host::new(HostConfig::new(WindowSize::Eight)).unwrap();
    h.submit(Job::Send(Bytes::from(data.clone()))).unwrap();
    let mut m = module(WindowSize::Eight);
    let mut input = m.input().to_vec();
    let mut seen = Vec::new();
    for cycle in 0..40 {
        let out = h.cycle(ms(cycle), &input).to_vec();
        if seen.last() != Some(&out[0]) {
            seen.push(out[0]);
        }
        input = m.cycle(ms(cycle), &out).to_vec();
    }
    // 62-byte stream = 9 segments: 11…17, 11, 12.
    assert_eq!(
        seen,
        [0x10, 0x11, 0x12, 0x13, 0x14, 0x15, 0x16, 0x17, 0x11, 0x12, 0x00]
    );
    assert_eq!(m.serial().sent().next().map(|f| f.to_vec()), Some(data));
}

/// Idle (000) or 111 during a transfer: the receiver aborts and goes idle without the error
/// bit; another job code is ignored together with its data.
#[test]
fn module_aborts_on_000_and_111_and_ignores_foreign_codes() {
    for abort in ["00", "70"] {
        let mut m = module(WindowSize::Four);
        step_module(&mut m, 0, "10 xx xx xx", "10 xx xx xx");
        step_module(&mut m, 1, "11 00 03 'a'", "11 xx xx xx");
        // A foreign code with data: ignored, the echo stays.
        step_module(&mut m, 2, "32 'X' 'Y' 'Z'", "11 xx xx xx");
        step_module(&mut m, 3, &format!("{abort} xx xx xx"), "00 00 00 xx");
        assert!(m.is_idle());
        assert_eq!(m.stats().aborts, 1);
        // A fresh job works, and the aborted data is gone.
        step_module(&mut m, 4, "10 xx xx xx", "10 xx xx xx");
        step_module(&mut m, 5, "11 00 02 'o'", "11 xx xx xx");
        step_module(&mut m, 6, "12 'k' xx xx", "12 xx xx xx");
        step_module(&mut m, 7, "12 'k' xx xx", "72 00 00 xx");
        assert_eq!(m.serial().sent().next(), Some(&Bytes::from_static(b"ok")));
    }
}

/// Only a request byte (job code, exec 0, no error) starts a job; held echoes, the reserved code
/// 6 and the end-of-job code do not.
#[test]
fn module_starts_jobs_only_from_request_bytes() {
    let mut m = module(WindowSize::Eight);
    for (i, out) in ["21", "11", "60", "70", "18", "31", "41"]
        .iter()
        .enumerate()
    {
        step_module(
            &mut m,
            i as u64,
            &format!("{out} xx xx xx xx xx xx xx"),
            "00 00 00 xx xx xx xx xx",
        );
    }
    assert_eq!(m.stats().jobs, 0);
}

/// Table 2-21 (default reading): the host's error bit in a receive job makes the module
/// abort with 20H + 0551H, wait for idle, and offer the same frame again from segment 1.
#[test]
fn module_aborts_delivery_with_0551_and_reoffers_the_frame() {
    let mut m = module(WindowSize::Four);
    m.serial_mut().inject_frame(&b"hello"[..]);
    step_module(&mut m, 0, "00 xx xx xx", "00 00 01 xx");
    step_module(&mut m, 1, "20 xx xx xx", "21 00 05 'h'");
    step_module(&mut m, 2, "21 xx xx xx", "22 'e' 'l' 'l'");
    // Host: out of order, last valid 1.
    step_module(&mut m, 3, "29 xx xx xx", "20 05 51 xx");
    step_module(&mut m, 4, "29 xx xx xx", "20 05 51 xx");
    step_module(&mut m, 5, "00 xx xx xx", "00 00 01 xx");
    step_module(&mut m, 6, "20 xx xx xx", "21 00 05 'h'");
    step_module(&mut m, 7, "21 xx xx xx", "22 'e' 'l' 'l'");
    step_module(&mut m, 8, "22 xx xx xx", "23 'o' xx xx");
    step_module(&mut m, 9, "23 xx xx xx", "00 00 00 xx");
    assert_eq!(m.stats().host_errors, 1);
    assert_eq!(m.stats().frames_delivered, 1);
}

/// The general rule of §2.12.7 as an option: go back to the segment after the last valid one.
#[test]
fn module_go_back_policy_resends_from_last_valid_plus_one() {
    let mut serial = LoopbackSerial::new();
    serial.inject_frame(&b"hello"[..]);
    let cfg = ModuleConfig {
        receive_error_policy: ReceiveErrorPolicy::GoBack,
        ..ModuleConfig::new(WindowSize::Four)
    };
    let mut m = Module::new(cfg, serial).unwrap();
    step_module(&mut m, 0, "20 xx xx xx", "21 00 05 'h'");
    step_module(&mut m, 1, "21 xx xx xx", "22 'e' 'l' 'l'");
    step_module(&mut m, 2, "28 xx xx xx", "21 00 05 'h'");
    step_module(&mut m, 3, "21 xx xx xx", "22 'e' 'l' 'l'");
    step_module(&mut m, 4, "22 xx xx xx", "23 'o' xx xx");
    step_module(&mut m, 5, "23 xx xx xx", "00 00 00 xx");
}

/// The host as receiver: an out-of-order segment gets the error bit with the last valid number;
/// the module's 20H + 0551H then ends the job with that STATUS.
#[test]
fn host_signals_out_of_order_receive_segment() {
    let mut h = Host::new(HostConfig::new(WindowSize::Four)).unwrap();
    let id = h.submit(Job::Receive).unwrap();
    step_host(&mut h, 0, "00 00 01 xx", "20 xx xx xx");
    step_host(&mut h, 1, "21 00 05 'h'", "21 xx xx xx");
    step_host(&mut h, 2, "21 00 05 'h'", "21 xx xx xx");
    // 23H where 22H was due.
    step_host(&mut h, 3, "23 'o' xx xx", "29 xx xx xx");
    step_host(&mut h, 4, "23 'o' xx xx", "29 xx xx xx");
    let ev = step_host(&mut h, 5, "20 05 51 xx", "00 xx xx xx");
    assert_eq!(
        ev,
        [HostEvent::Completed {
            id,
            code: JobCode::Receive,
            result: Err(TRANSFER_ERROR_TO_CPU)
        }]
    );
    assert_eq!(h.stats().errors_signalled, 1);
}

/// [ET200S SI 2005] §2.12.1 rule 3: the acknowledgement of another job code → write idle, wait for
/// idle, repeat.
#[test]
fn host_backs_off_on_a_foreign_acknowledgement() {
    let mut h = Host::new(HostConfig::new(WindowSize::Eight)).unwrap();
    let id = h.submit(Job::Send(Bytes::from_static(b"x"))).unwrap();
    step_host(
        &mut h,
        0,
        "00 00 00 xx xx xx xx xx",
        "10 xx xx xx xx xx xx xx",
    );
    let ev = step_host(
        &mut h,
        1,
        "20 01 01 xx xx xx xx xx",
        "00 xx xx xx xx xx xx xx",
    );
    assert_eq!(
        ev,
        [HostEvent::BackedOff {
            id,
            seen: CoordByte::new(JobCode::Receive, 0)
        }]
    );
    step_host(
        &mut h,
        2,
        "20 01 01 xx xx xx xx xx",
        "00 xx xx xx xx xx xx xx",
    );
    step_host(
        &mut h,
        3,
        "00 00 00 xx xx xx xx xx",
        "10 xx xx xx xx xx xx xx",
    );
    step_host(
        &mut h,
        4,
        "10 00 00 xx xx xx xx xx",
        "11 00 01 'x' xx xx xx xx",
    );
    // A foreign code mid-transfer: cancel and repeat the whole job ([ET200S SI 2005] §2.12.7).
    step_host(
        &mut h,
        5,
        "31 00 00 xx xx xx xx xx",
        "00 xx xx xx xx xx xx xx",
    );
    step_host(
        &mut h,
        6,
        "00 00 00 xx xx xx xx xx",
        "10 xx xx xx xx xx xx xx",
    );
    step_host(
        &mut h,
        7,
        "10 00 00 xx xx xx xx xx",
        "11 00 01 'x' xx xx xx xx",
    );
    let ev = step_host(
        &mut h,
        8,
        "71 00 00 xx xx xx xx xx",
        "00 xx xx xx xx xx xx xx",
    );
    assert_eq!(
        ev,
        [HostEvent::Completed {
            id,
            code: JobCode::Send,
            result: Ok(Outcome::Sent)
        }]
    );
    assert_eq!(h.stats().backoffs, 2);
}

/// `[derived]`: the manual has no timeout; the host's watchdog (default 30 s) ends a job the module
/// never answers, with the configured STATUS (default 0502H), and the next job runs.
#[test]
fn host_watchdog_ends_an_unanswered_job_once() {
    let mut h = Host::new(HostConfig::new(WindowSize::Eight)).unwrap();
    let a = h.submit(Job::ReadV24).unwrap();
    let b = h.submit(Job::ReadV24).unwrap();
    let idle = bytes("00 00 00 00 00 00 00 00");
    let t0 = Instant::ZERO;
    assert_eq!(h.cycle(t0, &idle)[0], 0x30);
    h.cycle(t0 + Duration::from_millis(29_999), &idle);
    assert_eq!(h.poll_event(), None);
    let out = h.cycle(t0 + Duration::from_secs(30), &idle).to_vec();
    assert_eq!(out[0], 0x00, "the host writes idle after the watchdog");
    assert_eq!(
        h.poll_event(),
        Some(HostEvent::Completed {
            id: a,
            code: JobCode::ReadV24,
            result: Err(NOT_POSSIBLE_IN_MODE)
        })
    );
    assert_eq!(h.poll_event(), None);
    // Job b starts from the next clean idle and completes normally.
    let t1 = t0 + Duration::from_secs(31);
    assert_eq!(h.cycle(t1, &idle)[0], 0x30);
    assert_eq!(h.cycle(t1, &bytes("31 00 02 00 00 00 00 00"))[0], 0x31);
    h.cycle(t1, &idle);
    assert!(matches!(
        h.poll_event(),
        Some(HostEvent::Completed { id, result: Ok(Outcome::Signals(s)), .. }) if id == b && s.dsr
    ));
}

/// The FB's R input / a host restart: every queued and running job ends with 1E0DH, the host
/// writes idle. A restarted host writes 00H first, which aborts the module's half-done job.
#[test]
fn reset_and_restart_abort_cleanly() {
    let mut h = Host::new(HostConfig::new(WindowSize::Four)).unwrap();
    let mut m = module(WindowSize::Four);
    let a = h.submit(Job::Send(Bytes::from_static(ALPHABET))).unwrap();
    let b = h.submit(Job::ReadV24).unwrap();
    let mut input = m.input().to_vec();
    for cycle in 0..4 {
        let out = h.cycle(ms(cycle), &input).to_vec();
        input = m.cycle(ms(cycle), &out).to_vec();
    }
    assert!(!m.is_idle(), "the module is in the middle of the send");
    h.reset();
    let ended: Vec<_> = std::iter::from_fn(|| h.poll_event()).collect();
    assert_eq!(
        ended,
        [
            HostEvent::Completed {
                id: a,
                code: JobCode::Send,
                result: Err(ABORTED_BY_RESET)
            },
            HostEvent::Completed {
                id: b,
                code: JobCode::ReadV24,
                result: Err(ABORTED_BY_RESET)
            }
        ]
    );
    assert_eq!(h.output()[0], 0);

    // A brand-new host (restart) writes idle first: the module aborts its job and the new host
    // then runs its own job to completion.
    let mut h = Host::new(HostConfig::new(WindowSize::Four)).unwrap();
    let c = h.submit(Job::Send(Bytes::from_static(b"hi"))).unwrap();
    for cycle in 10..30 {
        let out = h.cycle(ms(cycle), &input).to_vec();
        input = m.cycle(ms(cycle), &out).to_vec();
    }
    assert_eq!(
        h.poll_event(),
        Some(HostEvent::Completed {
            id: c,
            code: JobCode::Send,
            result: Ok(Outcome::Sent)
        })
    );
    assert_eq!(m.stats().aborts, 1);
    assert_eq!(
        m.serial().sent().cloned().collect::<Vec<_>>(),
        [Bytes::from_static(b"hi")]
    );
}

/// A failed consistent read (wrong window length) is ignored: outputs held, no state change.
#[test]
fn wrong_window_lengths_are_ignored() {
    let mut h = Host::new(HostConfig::new(WindowSize::Eight)).unwrap();
    h.submit(Job::ReadV24).unwrap();
    assert_eq!(h.cycle(ms(0), &bytes("00 00 00 00 00 00 00 00"))[0], 0x30);
    assert_eq!(h.cycle(ms(1), &bytes("31 00 02 00"))[0], 0x30);
    assert_eq!(h.stats().invalid_windows, 1);
    let mut m = module(WindowSize::Four);
    assert_eq!(m.cycle(ms(0), &bytes("30 00 00 00 00 00 00 00"))[0], 0x00);
    assert_eq!(m.stats().invalid_windows, 1);
}

/// The host as receiver: the module going idle, or showing 111, before the frame is complete
/// aborts the receive job ([ET200S SI 2005] §2.12.7) with 0551H, and the host writes idle.
#[test]
fn host_receive_aborted_by_idle_or_111() {
    for abort in ["00 00 01 xx", "71 00 00 xx"] {
        let mut h = Host::new(HostConfig::new(WindowSize::Four)).unwrap();
        let id = h.submit(Job::Receive).unwrap();
        step_host(&mut h, 0, "00 00 01 xx", "20 xx xx xx");
        step_host(&mut h, 1, "21 00 05 'h'", "21 xx xx xx");
        // A foreign code (not 000/111) is ignored by the receiver.
        step_host(&mut h, 2, "31 00 00 xx", "21 xx xx xx");
        let ev = step_host(&mut h, 3, abort, "00 xx xx xx");
        assert_eq!(
            ev,
            [HostEvent::Completed {
                id,
                code: JobCode::Receive,
                result: Err(TRANSFER_ERROR_TO_CPU)
            }]
        );
    }
}

/// The module as sender of a receive job: 000 from the host aborts the delivery without the
/// error bit, and the frame stays first in the buffer, offered again from segment 1.
#[test]
fn module_keeps_the_frame_when_delivery_is_aborted() {
    let mut m = module(WindowSize::Four);
    m.serial_mut().inject_frame(&b"hello"[..]);
    step_module(&mut m, 0, "20 xx xx xx", "21 00 05 'h'");
    step_module(&mut m, 1, "21 xx xx xx", "22 'e' 'l' 'l'");
    step_module(&mut m, 2, "00 xx xx xx", "00 00 01 xx");
    step_module(&mut m, 3, "20 xx xx xx", "21 00 05 'h'");
    assert_eq!(m.stats().aborts, 1);
    assert_eq!(m.buffered(), 1);
}

/// A module restart drops the running job (the host's next window sees idle and its job
/// fails or backs off) and, with "clear receive buffer on startup", the buffered frames.
#[test]
fn module_restart_drops_the_job_and_optionally_the_buffer() {
    for clear in [false, true] {
        let mut m = module(WindowSize::Four);
        m.serial_mut().inject_frame(&b"kept?"[..]);
        step_module(&mut m, 0, "10 xx xx xx", "10 00 01 xx");
        step_module(&mut m, 1, "11 00 02 'o'", "11 xx xx xx");
        m.restart(clear);
        assert!(m.is_idle());
        let expected = if clear { "00 00 00 xx" } else { "00 00 01 xx" };
        assert_window("after restart", m.input(), expected);
        // The host's held segment is not a request: the module stays idle.
        step_module(&mut m, 2, "11 00 02 'o'", expected);
    }
}
