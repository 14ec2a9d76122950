//! The FB equivalents ([ET200S SI 2005] §2.10) running over the window protocol
//! against a simulated module: S7 call semantics (REQ edge, R, EN_R, outputs valid one call),
//! several FBs sharing one host.

use crate::common;

use common::Link;
use si_core::{Duration, Instant, Status};
use si_dp_coord::fb::{SRcv, SRts, SSend, SVset, SVstat, SXon, SV24};
use si_dp_coord::status::{
    ABORTED_BY_RESET, FLOW_CONTROL_MISMATCH, INVALID_LEN, PARAMETER_OUT_OF_RANGE,
};
use si_dp_coord::{HostConfig, ModuleConfig, WindowSize};

/// S_SEND / S_RCV take the time of the call; the window host runs its jobs in its DP cycles
/// and does not use it.
const NOW: Instant = Instant::ZERO;

fn link(window: WindowSize) -> Link {
    common::link(HostConfig::new(window), ModuleConfig::new(window), 17).without_event_collection()
}

/// One user cycle's worth of DP activity between two FB calls.
fn run(l: &mut Link) {
    for _ in 0..5 {
        l.step();
    }
}

#[test]
fn s_send_done_is_valid_for_one_call() {
    let mut l = link(WindowSize::Eight);
    let mut fb = SSend::default();
    let data = b"hello, partner";
    let mut dones = 0;
    for _ in 0..500 {
        let out = fb.call(&mut l.host, NOW, true, false, data);
        assert!(!out.error, "{:?}", out.status);
        dones += usize::from(out.done);
        run(&mut l);
    }
    // REQ stayed 1: one edge, one job, one DONE.
    assert_eq!(dones, 1);
    assert_eq!(
        l.module
            .serial()
            .sent()
            .map(|f| f.to_vec())
            .collect::<Vec<_>>(),
        [data.to_vec()]
    );
}

#[test]
fn s_send_refuses_len_0_and_r_aborts_with_1e0d() {
    let mut l = link(WindowSize::Four);
    let mut fb = SSend::default();
    let out = fb.call(&mut l.host, NOW, true, false, &[]);
    assert!(out.error && out.status == INVALID_LEN);
    fb.call(&mut l.host, NOW, false, false, &[]);
    // A long send, reset half-way.
    let big = [0x55u8; 224];
    fb.call(&mut l.host, NOW, true, false, &big);
    for _ in 0..30 {
        run(&mut l);
        assert!(!fb.call(&mut l.host, NOW, true, false, &big).done);
    }
    assert!(fb.busy());
    let out = fb.call(&mut l.host, NOW, false, true, &big);
    assert!(out.error && out.status == ABORTED_BY_RESET);
    assert!(!fb.busy());
    // The module's side is aborted (idle written); nothing reached the line.
    assert!(l.run_until(1_000, |l| l.module.is_idle()));
    assert_eq!(l.module.serial().sent().count(), 0);
    // A new edge sends again.
    let mut done = false;
    for _ in 0..1_000 {
        done |= fb.call(&mut l.host, NOW, true, false, b"again").done;
        run(&mut l);
    }
    assert!(done);
}

#[test]
fn s_rcv_ndr_len_and_data_for_one_call() {
    let mut l = link(WindowSize::Eight);
    let mut fb = SRcv::default();
    let mut db = [0u8; 224];
    l.module.serial_mut().inject_frame(&b"frame one"[..]);
    l.module.serial_mut().inject_frame(&b"two"[..]);
    let mut got = Vec::new();
    for _ in 0..1_000 {
        let out = fb.call(&mut l.host, NOW, true, false, &mut db);
        assert!(!out.error, "{:?}", out.status);
        if out.ndr {
            got.push(db[..out.len].to_vec());
        }
        run(&mut l);
    }
    assert_eq!(got, [b"frame one".to_vec(), b"two".to_vec()]);
}

#[test]
fn s_rcv_reports_a_too_small_destination_and_en_r_0_blocks() {
    let mut l = link(WindowSize::Eight);
    let mut fb = SRcv::default();
    let mut small = [0u8; 4];
    // EN_R = 0: nothing is fetched.
    l.module.serial_mut().inject_frame(&b"longer than four"[..]);
    for _ in 0..200 {
        fb.call(&mut l.host, NOW, false, false, &mut small);
        run(&mut l);
    }
    assert_eq!(l.module.buffered(), 1);
    let mut errors = Vec::new();
    for _ in 0..500 {
        let out = fb.call(&mut l.host, NOW, true, false, &mut small);
        if out.error {
            errors.push(out.status);
        }
        assert!(!out.ndr);
        run(&mut l);
    }
    assert_eq!(errors, [PARAMETER_OUT_OF_RANGE]);
}

#[test]
fn s_vset_then_s_vstat() {
    let mut l = link(WindowSize::Four);
    let (mut set, mut stat) = (SVset::default(), SVstat::default());
    let mut done = false;
    for _ in 0..300 {
        done |= set.call(&mut l.host, true, false, true, false).done;
        run(&mut l);
    }
    assert!(done);
    let mut last = None;
    for _ in 0..300 {
        let out = stat.call(&mut l.host, true, false);
        if out.result.done {
            last = Some(out.signals());
        }
        run(&mut l);
    }
    let s = last.expect("S_VSTAT done");
    assert!(s.rts && !s.dtr);
}

#[test]
fn parameter_fbs_match_the_configured_flow_control() {
    let mut l = link(WindowSize::Four);
    let (mut xon, mut rts, mut v24) = (SXon::default(), SRts::default(), SV24::default());
    let mut results: Vec<(&str, Status)> = Vec::new();
    for _ in 0..600 {
        let a = xon.call(&mut l.host, true, false, 0x11, 0x13, Duration::from_secs(2));
        let b = rts.call(&mut l.host, true, false, Duration::from_secs(2));
        let c = v24.call(
            &mut l.host,
            true,
            false,
            Duration::from_millis(10),
            Duration::from_secs(700),
        );
        for (name, d) in [("xon", a), ("rts", b), ("v24", c)] {
            if d.done || d.error {
                results.push((name, d.status));
            }
        }
        run(&mut l);
    }
    results.sort_by_key(|(n, _)| *n);
    assert_eq!(
        results,
        [
            ("rts", FLOW_CONTROL_MISMATCH),
            // 700 s is beyond 10 min 55 s 350 ms: refused at once.
            ("v24", PARAMETER_OUT_OF_RANGE),
            ("xon", Status::OK),
        ]
    );
    assert_eq!(
        l.module.serial().flow_control,
        Some(si_dp_coord::ParamBlock::XON_XOFF_DEFAULT)
    );
}

/// Several FBs on one host: the arbiter serializes their jobs ([ET200S SI 2005] §2.12.1), each gets
/// its own result.
#[test]
fn fbs_share_one_host() {
    for window in WindowSize::ALL {
        let mut l = link(window);
        let (mut send, mut rcv, mut stat) = (SSend::default(), SRcv::default(), SVstat::default());
        let mut db = [0u8; 224];
        let frame: Vec<u8> = (0..100).collect();
        let (mut sent, mut received, mut statted) = (0, Vec::new(), 0);
        for i in 0..3_000 {
            // Loopback: every frame sent comes back and S_RCV picks it up.
            let req = i % 600 < 300;
            sent += usize::from(send.call(&mut l.host, NOW, req, false, &frame).done);
            let r = rcv.call(&mut l.host, NOW, true, false, &mut db);
            if r.ndr {
                received.push(db[..r.len].to_vec());
            }
            statted += usize::from(stat.call(&mut l.host, req, false).result.done);
            run(&mut l);
        }
        assert_eq!(sent, 5, "{window}");
        assert_eq!(statted, 5, "{window}");
        assert_eq!(received, vec![frame.clone(); 5], "{window}");
    }
}
