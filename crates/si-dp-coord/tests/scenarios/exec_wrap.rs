//! The execution number after 7 (`[derived]`, [ET200S SI 2005] §2.12.1, Table 2-21): 7 → 1 by
//! default or 7 → 0, a setting of both the host and the module. Jobs long enough to wrap (a
//! 224-byte frame is 76 segments in the 4-byte window) succeed when both sides agree, and show what
//! the host reports when they do not ([ET200S SI 2005] §2.12.7: the receiver flags the first
//! segment after 7 as out of order).

use crate::common;

use bytes::Bytes;
use common::{Link, RunJob};
use si_core::Duration;
use si_dp_coord::coord::{CoordByte, ExecWrap, JobCode};
use si_dp_coord::host::{Job, Outcome};
use si_dp_coord::status::{NOT_POSSIBLE_IN_MODE, TRANSFER_ERROR_TO_CPU};
use si_dp_coord::{HostConfig, ModuleConfig, WindowSize};

/// Host and module with their own wrap settings, the 4-byte window, a 2 s job watchdog (virtual
/// time), and the host's view of every cycle recorded.
fn link(host: ExecWrap, module: ExecWrap) -> Link {
    let host = HostConfig {
        exec_wrap: host,
        job_timeout: Some(Duration::from_secs(2)),
        ..HostConfig::new(WindowSize::Four)
    };
    let module = ModuleConfig {
        exec_wrap: module,
        ..ModuleConfig::new(WindowSize::Four)
    };
    common::link(host, module, 0x75).with_record()
}

/// 224 bytes, the longest frame: 76 segments of the 4-byte window, ten wraps.
fn long_frame() -> Bytes {
    (0..224u16).map(|i| i as u8).collect()
}

/// Coordination bytes the host read, in order, without repeats.
fn inputs_seen(l: &Link) -> Vec<u8> {
    let mut seen: Vec<u8> = l.records().iter().map(|r| r.input.as_bytes()[0]).collect();
    seen.dedup();
    seen
}

#[test]
fn matching_settings_send_and_receive_the_longest_frame() {
    for wrap in [ExecWrap::ToOne, ExecWrap::ToZero] {
        let mut l = link(wrap, wrap);
        let f = long_frame();
        assert_eq!(
            l.run(Job::Send(f.clone()), 50_000),
            Ok(Outcome::Sent),
            "{wrap:?}"
        );
        assert_eq!(l.module.serial().sent().last(), Some(&f));
        assert_eq!(
            l.run(Job::Receive, 50_000),
            Ok(Outcome::Received(f)),
            "{wrap:?}"
        );
        assert_eq!(l.host.stats().resends, 0);
        assert_eq!(l.module.stats().out_of_order, 0);
        assert_eq!(l.host.stats().errors_signalled, 0);
        // The 8th segment's number: 1 (11H) with 7 → 1, 0 (10H, the request byte's value) with
        // 7 → 0; the module echoes it.
        let eighth = match wrap {
            ExecWrap::ToOne => 0x11,
            ExecWrap::ToZero => 0x10,
        };
        let seen = inputs_seen(&l);
        let after_17 = seen.iter().position(|&b| b == 0x17).unwrap();
        assert_eq!(seen[after_17 + 1], eighth, "{wrap:?}: {seen:02X?}");
    }
}

/// Host 7 → 1, module 7 → 0: the module expects 10H after 17H, gets 11H and shows its error bit
/// with the last valid number 7 (1FH). The host resends segment 8 as 11H again and again (the
/// [ET200S SI 2005] §2.12.7 go-back rule cannot make progress), nothing reaches the line, and the
/// job ends by the host's watchdog with 0502H.
#[test]
fn host_7_to_1_against_module_7_to_0_ends_a_send_by_the_watchdog() {
    let mut l = link(ExecWrap::ToOne, ExecWrap::ToZero);
    let started = l.now();
    assert_eq!(
        l.run(Job::Send(long_frame()), 50_000),
        Err(NOT_POSSIBLE_IN_MODE)
    );
    assert!(l.now().saturating_since(started) >= Duration::from_secs(2));
    assert_eq!(l.host.stats().timeouts, 1);
    assert_eq!(
        l.host.stats().segments_sent,
        7,
        "segments 1 … 7 were echoed"
    );
    assert_eq!(l.host.stats().resends, 1, "one go-back, repeated unchanged");
    assert!(l.module.stats().out_of_order > 0);
    assert_eq!(
        l.module.serial().sent().count(),
        0,
        "no frame left the module"
    );
    let error = CoordByte::error(JobCode::Send, 7).encode();
    assert_eq!(error, 0x1F);
    assert!(inputs_seen(&l).contains(&error));
    // The watchdog's idle aborted the module's side: the next job starts clean.
    assert!(l.run_until(10_000, |l| l.module.is_idle()));
}

/// Host 7 → 0, module 7 → 1: the host's segment 8 is 10H, which the module (expecting 11H)
/// flags the same way; the job ends by the watchdog with 0502H.
#[test]
fn host_7_to_0_against_module_7_to_1_ends_a_send_by_the_watchdog() {
    let mut l = link(ExecWrap::ToZero, ExecWrap::ToOne);
    assert_eq!(
        l.run(Job::Send(long_frame()), 50_000),
        Err(NOT_POSSIBLE_IN_MODE)
    );
    assert_eq!(l.host.stats().segments_sent, 7);
    assert_eq!(l.host.stats().resends, 1);
    assert!(l.module.stats().out_of_order > 0);
    assert_eq!(l.module.serial().sent().count(), 0);
    assert!(inputs_seen(&l).contains(&0x1F));
    let outputs: Vec<u8> = l.records().iter().map(|r| r.output.as_bytes()[0]).collect();
    assert!(outputs.contains(&0x10) && !outputs.contains(&0x18));
}

/// Receive direction, host 7 → 0, module 7 → 1: the module's 8th segment is 21H where the host
/// expects 20H; the host sets its error bit (28H + 7 = 2FH) and the module aborts with 20H +
/// 0551H (Table 2-21), which is what the host reports. The frame stays in the module.
#[test]
fn host_7_to_0_against_module_7_to_1_reports_0551h_on_a_receive() {
    let mut l = link(ExecWrap::ToZero, ExecWrap::ToOne);
    l.module.serial_mut().inject_frame(long_frame());
    assert_eq!(l.run(Job::Receive, 50_000), Err(TRANSFER_ERROR_TO_CPU));
    assert_eq!(l.host.stats().errors_signalled, 1);
    assert_eq!(l.module.stats().host_errors, 1);
    assert_eq!(l.module.buffered(), 1, "the frame is offered again later");
}

/// Receive direction, host 7 → 1, module 7 → 0: the module's 8th segment is 20H, which a host
/// counting 7 → 1 can only read as the module's 20H + STATUS answer; bytes 1–2 of that segment
/// (frame bytes 19 and 20, 13H 14H) become the STATUS it reports.
#[test]
fn host_7_to_1_against_module_7_to_0_misreads_segment_8_as_a_status() {
    let mut l = link(ExecWrap::ToOne, ExecWrap::ToZero);
    l.module.serial_mut().inject_frame(long_frame());
    let r = l.run(Job::Receive, 50_000);
    assert_eq!(r.map_err(|s| s.code()), Err(0x1314));
    assert_eq!(l.module.buffered(), 1, "the module keeps the frame");
}

/// Why 7 → 1 is the default: with 7 → 0 the host's echo of an 8th segment is 20H, the receive
/// request itself. A module that has just finished the delivery and still reads that held echo
/// (the host writes 00H only after it has seen the module idle, `[derived]`) starts a new receive
/// job. Here nothing more is buffered, so it answers 20H + 0101H ("no message") until the host's
/// idle.
#[test]
fn with_7_to_0_a_held_echo_of_segment_8_reads_as_a_new_receive_request() {
    use si_core::Instant;
    use si_dp_coord::module::{LoopbackSerial, Module};
    let cfg = ModuleConfig {
        exec_wrap: ExecWrap::ToZero,
        ..ModuleConfig::new(WindowSize::Four)
    };
    let mut m = Module::new(cfg, LoopbackSerial::new()).unwrap();
    // 22 bytes: length + 1 byte, then 7 segments of 3: 8 segments, the last numbered 0.
    m.serial_mut().inject_frame(Bytes::from_static(&[0x61; 22]));
    let now = Instant::ZERO;
    m.cycle(now, &[0, 0, 0, 0]);
    let mut input = m.cycle(now, &[0x20, 0, 0, 0]).to_vec();
    let mut published = vec![input[0]];
    while input[0] != 0 {
        input = m.cycle(now, &[input[0], 0, 0, 0]).to_vec();
        published.push(input[0]);
    }
    assert_eq!(
        published,
        [0x21, 0x22, 0x23, 0x24, 0x25, 0x26, 0x27, 0x20, 0x00]
    );
    assert_eq!(m.stats().frames_delivered, 1);
    // The host still holds its last echo, 20H.
    assert_eq!(m.cycle(now, &[0x20, 0, 0, 0]), [0x20, 0x01, 0x01, 0x00]);
    assert_eq!(m.stats().jobs, 2, "a second, unrequested receive job");
    assert_eq!(m.cycle(now, &[0, 0, 0, 0])[0], 0x00);
}
