//! [ET200S SI] §2.8: the 1024-byte receive frame buffer and its options
//! (dynamic frames, prevent overwrite, clear at startup, the 2/3-full warning, overflow).

use crate::common;

use common::{errors, received, settings, Bench};
use si_ascii::fb::SRcv;
use si_ascii::{status, Config, EndCriterion};

/// Fixed-length frames of 100 bytes at 19 200 bit/s; frame k is filled with byte k.
fn config(dynamic_frames: bool, prevent_overwrite: bool) -> Config {
    Config {
        settings: settings(19_200),
        end: EndCriterion::FixedLength { len: 100 },
        dynamic_frames,
        prevent_overwrite,
        ..Config::default()
    }
}

fn send_frames(b: &mut Bench, range: std::ops::RangeInclusive<u8>) {
    for k in range {
        b.partner_sends(&[k; 100]);
        b.run_for_ms(100);
    }
}

fn firsts(frames: &[Vec<u8>]) -> Vec<u8> {
    frames
        .iter()
        .map(|f| {
            assert_eq!(f.len(), 100);
            assert!(f.iter().all(|&x| x == f[0]));
            f[0]
        })
        .collect()
}

#[test]
fn s6_6_dynamic_frames_buffer_several_and_deliver_the_oldest_first() {
    let mut b = Bench::new(config(true, true));
    send_frames(&mut b, 1..=5);
    assert_eq!(received(&b.events()).len(), 5);
    assert_eq!(firsts(&b.frames()), vec![1, 2, 3, 4, 5]);
}

#[test]
fn s6_6_overflow_with_overwrite_prevented_loses_the_newest_frame_with_080a() {
    let mut b = Bench::new(config(true, true));
    // 10 frames fill 1000 of 1024 bytes; the 11th does not fit.
    send_frames(&mut b, 1..=11);
    let events = b.events();
    assert_eq!(received(&events).len(), 10);
    assert_eq!(
        errors(&events).iter().map(|e| e.0).collect::<Vec<_>>(),
        vec![status::NO_FREE_RECEIVE_BUFFER.code()]
    );
    assert_eq!(firsts(&b.frames()), (1..=10).collect::<Vec<_>>());
    // After reading, the buffer takes frames again.
    send_frames(&mut b, 12..=12);
    assert_eq!(firsts(&b.frames()), vec![12]);
}

#[test]
fn s6_6_overflow_with_overwrite_allowed_drops_the_oldest_frame() {
    let mut b = Bench::new(config(true, false));
    send_frames(&mut b, 1..=11);
    let events = b.events();
    assert_eq!(received(&events).len(), 11);
    // The loss is reported (the manual's diagnostic interrupt).
    assert_eq!(
        errors(&events).iter().map(|e| e.0).collect::<Vec<_>>(),
        vec![0x080A]
    );
    assert_eq!(firsts(&b.frames()), (2..=11).collect::<Vec<_>>());
}

#[test]
fn s6_6_one_frame_without_dynamic_frames_and_prevent_overwrite_keeps_the_old_one() {
    let mut b = Bench::new(config(false, true));
    send_frames(&mut b, 1..=2);
    let events = b.events();
    assert_eq!(errors(&events), vec![(0x080A, errors(&events)[0].1)]);
    assert_eq!(firsts(&b.frames()), vec![1]);
}

#[test]
fn s6_6_only_the_newest_frame_without_dynamic_frames_and_overwrite() {
    let mut b = Bench::new(config(false, false));
    send_frames(&mut b, 1..=3);
    assert!(errors(&b.events()).is_empty());
    assert_eq!(firsts(&b.frames()), vec![3]);
}

#[test]
fn s6_6_warning_0b01_above_two_thirds_on_every_s_rcv_call_without_error() {
    let mut b = Bench::new(config(true, true));
    send_frames(&mut b, 1..=6); // 600 bytes: below 2/3 of 1024 (682.7)
    let mut rcv = SRcv::default();
    let mut db = [0u8; 200];
    let status_now = |b: &mut Bench| b.sim.with(b.link, |l, _| l.receive_status());
    assert_eq!(status_now(&mut b), si_core::Status::OK);
    send_frames(&mut b, 7..=7); // 700 bytes
    for _ in 0..3 {
        // Every enabled call that leaves the buffer above 2/3 carries the warning.
        let out = b
            .sim
            .with(b.link, |l, now| rcv.call(l, now, true, false, &mut db));
        assert!(out.ndr && !out.error);
        assert_eq!(out.len, 100);
        if b.sim.engine(b.link).buffer().above_two_thirds() {
            assert_eq!(out.status, status::BUFFER_TWO_THIRDS_FULL);
        }
    }
    // 400 bytes left: no warning.
    let out = b
        .sim
        .with(b.link, |l, now| rcv.call(l, now, true, false, &mut db));
    assert_eq!(out.status, si_core::Status::OK);
}

#[test]
fn s6_6_warning_while_idle_and_after_the_read_that_leaves_it_above() {
    let mut b = Bench::new(config(true, true));
    send_frames(&mut b, 1..=8); // 800 bytes
    let mut rcv = SRcv::default();
    let mut db = [0u8; 200];
    let first = b
        .sim
        .with(b.link, |l, now| rcv.call(l, now, true, false, &mut db));
    // 700 bytes remain: still above 2/3, so NDR comes with the warning, ERROR stays 0 ([derived]).
    assert!(first.ndr && !first.error);
    assert_eq!(first.status, status::BUFFER_TWO_THIRDS_FULL);
    let second = b
        .sim
        .with(b.link, |l, now| rcv.call(l, now, true, false, &mut db));
    assert_eq!(second.status, si_core::Status::OK); // 600 bytes
}

#[test]
fn s10_clear_at_startup_empties_the_buffer_on_cpu_restart() {
    let mut b = Bench::new(config(true, true));
    send_frames(&mut b, 1..=2);
    b.sim.with(b.link, |l, now| l.restart(now));
    assert!(b.frames().is_empty());

    let keep = Config {
        clear_at_startup: false,
        ..config(true, true)
    };
    let mut b = Bench::new(keep);
    send_frames(&mut b, 1..=2);
    b.sim.with(b.link, |l, now| l.restart(now));
    assert_eq!(firsts(&b.frames()), vec![1, 2]);
}

#[test]
fn s8_3_s_rcv_reports_a_receive_error_once_then_the_frames() {
    let c = Config {
        settings: settings(9_600),
        end: EndCriterion::DEFAULT_END_CHARS,
        ..Config::default()
    };
    let mut b = Bench::new(c);
    b.partner_sends(b"ok\x03bro");
    b.run_for_ms(100);
    let mut rcv = SRcv::default();
    let mut db = [0u8; 200];
    let out = b
        .sim
        .with(b.link, |l, now| rcv.call(l, now, true, false, &mut db));
    assert!(out.error && !out.ndr);
    assert_eq!(out.status, status::CHAR_DELAY_EXCEEDED);
    let out = b
        .sim
        .with(b.link, |l, now| rcv.call(l, now, true, false, &mut db));
    assert!(out.ndr && !out.error);
    assert_eq!(&db[..out.len], b"ok\x03");
    // EN_R = 0: nothing received; R = 1: nothing received.
    b.partner_sends(b"x\x03");
    b.run_for_ms(100);
    assert!(
        !b.sim
            .with(b.link, |l, now| rcv.call(l, now, false, false, &mut db))
            .ndr
    );
    assert!(
        !b.sim
            .with(b.link, |l, now| rcv.call(l, now, true, true, &mut db))
            .ndr
    );
    assert!(
        b.sim
            .with(b.link, |l, now| rcv.call(l, now, true, false, &mut db))
            .ndr
    );
}
