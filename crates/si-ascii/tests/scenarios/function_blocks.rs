//! [ET200S SI] §2.10: S_SEND and S_RCV called cycle by cycle on the simulator, with the
//! S7 semantics: REQ edge, DONE / ERROR / STATUS valid for one call, R resets.

use crate::common;

use common::{settings, Bench, Partner};
use si_ascii::fb::{SRcv, SSend};
use si_ascii::{status, Config, EndCriterion, FlowControl, Link};
use si_core::{Duration, Status};
use si_sim::Simulator;

fn config() -> Config {
    Config {
        settings: settings(9_600),
        end: EndCriterion::DEFAULT_END_CHARS,
        ..Config::default()
    }
}

#[test]
fn s8_2_s_send_starts_on_the_req_edge_and_reports_done_for_one_call() {
    let mut b = Bench::new(config());
    let mut s_send = SSend::default();
    let data = b"quick start\x03";
    let mut done_calls = 0;
    // A PLC program calls the FB every 1 ms with REQ held high: one job only.
    for _ in 0..100 {
        let out = b
            .sim
            .with(b.link, |l, now| s_send.call(l, now, true, false, data));
        assert!(!out.error, "{out:?}");
        if out.done {
            assert_eq!(out.status, Status::OK);
            done_calls += 1;
        }
        b.run_for_ms(1);
    }
    assert_eq!(done_calls, 1);
    assert_eq!(b.sim.engine(b.partner).bytes(), data);
    assert!(!s_send.busy());
}

#[test]
fn s8_2_s_send_len_out_of_range_is_1e41() {
    let mut b = Bench::new(config());
    let mut s_send = SSend::default();
    let out = b
        .sim
        .with(b.link, |l, now| s_send.call(l, now, true, false, &[]));
    assert_eq!((out.error, out.status), (true, status::INVALID_LEN));
    b.sim
        .with(b.link, |l, now| s_send.call(l, now, false, false, &[]));
    let long = [0x41u8; 201];
    let out = b
        .sim
        .with(b.link, |l, now| s_send.call(l, now, true, false, &long));
    assert_eq!((out.error, out.status), (true, status::INVALID_LEN));
}

#[test]
fn s8_2_s_send_reset_during_a_job_is_1e0d_and_the_data_still_go_out() {
    let mut b = Bench::new(config());
    let mut s_send = SSend::default();
    b.sim.with(b.link, |l, now| {
        s_send.call(l, now, true, false, b"abc\x03")
    });
    let out = b.sim.with(b.link, |l, now| {
        s_send.call(l, now, false, true, b"abc\x03")
    });
    assert_eq!((out.error, out.status), (true, status::ABORTED_BY_RESET));
    b.run_for_ms(50);
    // "Data the module has already received is still sent to the partner."
    assert_eq!(b.sim.engine(b.partner).bytes(), b"abc\x03");
    // After the reset nothing more is reported.
    let out = b
        .sim
        .with(b.link, |l, now| s_send.call(l, now, false, false, b""));
    assert!(!out.done && !out.error);
}

#[test]
fn s8_2_s_send_reports_the_send_error_0708() {
    let c = Config {
        flow_control: FlowControl::RtsCts,
        ..config()
    };
    let mut b = Bench::with_partner(c, Partner::default()); // never raises CTS
    let mut s_send = SSend::default();
    let mut seen = Vec::new();
    for _ in 0..30 {
        let out = b
            .sim
            .with(b.link, |l, now| s_send.call(l, now, true, false, b"x"));
        if out.done || out.error {
            seen.push(out.status);
        }
        b.run_for_ms(100);
    }
    assert_eq!(seen, vec![status::XON_CTS_TIMEOUT]);
}

#[test]
fn quick_start_s2_two_modules_s_send_to_s_rcv() {
    // [ET200S SI] §2.2: 4800 bit/s 8N1, CDT 10 ms, no flow control; 24 characters arrive as LEN 24.
    let c = Config {
        settings: si_core::SerialSettings::new(4_800, 8, si_core::Parity::None, 1).unwrap(),
        char_delay: si_core::Duration::from_millis(10),
        dynamic_frames: false,
        ..Config::default()
    };
    let mut sim = Simulator::new(2);
    let a = sim.add_station("256", c.settings, Link::new(c).unwrap());
    let b = sim.add_station("264", c.settings, Link::new(c).unwrap());
    sim.connect(a, b);
    let message = b"ET 200S SI quick start!!";
    assert_eq!(message.len(), 24);
    let (mut s_send, mut s_rcv) = (SSend::default(), SRcv::default());
    let mut db15 = [0u8; 200];
    let (mut send_done, mut received) = (false, None);
    for cycle in 0..200 {
        let req = cycle > 0; // M0.0 set in the second cycle
        let out = sim.with(a, |l, now| s_send.call(l, now, req, false, message));
        send_done |= out.done;
        assert!(!out.error);
        let r = sim.with(b, |l, now| s_rcv.call(l, now, true, false, &mut db15));
        assert!(!r.error);
        if r.ndr {
            received = Some(r.len);
        }
        sim.run_for(Duration::from_millis(1));
    }
    assert!(send_done);
    assert_eq!(received, Some(24));
    assert_eq!(&db15[..24], message);
}
