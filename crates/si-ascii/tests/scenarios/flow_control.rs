//! [ET200S SI] §2.8 (XON/XOFF, RTS/CTS) and §2.8 (automatic V.24) on the
//! simulator: a fast sender is stopped and resumed without losing a byte, and the wait-time
//! expiries end the send job with the manual's STATUS.

use crate::common;

use common::{errors, settings, Bench, Partner};
use si_ascii::fb::{SRts, SVset, SVstat, SXon};
use si_ascii::{status, Config, EndCriterion, Event, FlowControl, Link, XonXoff};
use si_core::{Duration, Instant, SerialSettings, SignalUpdate};
use si_sim::{Simulator, StationId, TraceKind};

const FRAMES: u8 = 20;

fn config(flow: FlowControl) -> Config {
    Config {
        settings: settings(19_200),
        end: EndCriterion::FixedLength { len: 100 },
        flow_control: flow,
        ..Config::default()
    }
}

struct Pair {
    sim: Simulator,
    a: StationId<Link>,
    b: StationId<Link>,
}

/// Two links; `tx_chunk` 1 models the module exactly, 16 is the host default.
fn pair(flow: FlowControl, tx_chunk: u8) -> Pair {
    let c = Config {
        tx_chunk,
        ..config(flow)
    };
    let mut sim = Simulator::new(11);
    let a = sim.add_station("A", c.settings, Link::new(c).unwrap());
    let b = sim.add_station("B", c.settings, Link::new(c).unwrap());
    sim.connect(a, b);
    sim.with(a, |l, now| l.restart(now));
    sim.with(b, |l, now| l.restart(now));
    sim.run_for(Duration::from_millis(10));
    Pair { sim, a, b }
}

/// A sends FRAMES frames of 100 bytes as fast as it may; B's program reads nothing until
/// `read_at`, then everything. Returns what B received and A's events.
fn fast_sender(p: &mut Pair, read_at: Instant, limit: Instant) -> (Vec<Vec<u8>>, Vec<Event>) {
    let mut next = 0u8;
    let mut got = Vec::new();
    let mut a_events = Vec::new();
    loop {
        if !p.sim.engine(p.a).is_sending() && next < FRAMES {
            let frame = vec![next + 0x20; 100];
            p.sim.with(p.a, |l, now| l.send(now, frame.into())).unwrap();
            next += 1;
        }
        a_events.extend(p.sim.take_events(p.a));
        if a_events
            .iter()
            .any(|e| matches!(e, Event::SendFailed { .. }))
        {
            break;
        }
        if p.sim.now() >= read_at {
            while let Some(f) = p.sim.with(p.b, |l, now| l.read_frame_vec(now)) {
                got.push(f);
            }
        }
        if p.sim.now() >= limit || (p.sim.is_quiet() && next == FRAMES) {
            break;
        }
        // Half a character time per slice: the sender is served at once, the reader on time.
        p.sim.run_for(Duration::from_micros(250));
    }
    while let Some(f) = p.sim.with(p.b, |l, now| l.read_frame_vec(now)) {
        got.push(f);
    }
    a_events.extend(p.sim.take_events(p.a));
    (got, a_events)
}

fn expected() -> Vec<Vec<u8>> {
    (0..FRAMES).map(|k| vec![k + 0x20; 100]).collect()
}

fn tx_times(sim: &Simulator, station: &str, byte: u8) -> Vec<Instant> {
    sim.trace()
        .of(station)
        .filter(|e| matches!(&e.kind, TraceKind::Tx { bytes } if bytes == &[byte]))
        .map(|e| e.at)
        .collect()
}

#[test]
fn s6_9_xon_xoff_stops_and_resumes_a_fast_sender_without_losing_a_byte() {
    for chunk in [1, 16] {
        xon_xoff_fast_sender(chunk);
    }
}

fn xon_xoff_fast_sender(chunk: u8) {
    let mut p = pair(FlowControl::XonXoff, chunk);
    let read_at = Instant::from_micros(1_500_000);
    let (got, a_events) = fast_sender(&mut p, read_at, Instant::from_micros(10_000_000));
    assert_eq!(got.len(), expected().len());
    assert!(got == expected(), "every byte, in order");
    assert!(a_events
        .iter()
        .all(|e| !matches!(e, Event::SendFailed { .. })));
    assert!(errors(&p.sim.take_events(p.b)).is_empty());
    // B sent XOFF before its buffer was full, and XON after the read.
    let xoff = tx_times(&p.sim, "B", 0x13);
    let xon = tx_times(&p.sim, "B", 0x11);
    assert_eq!(xoff.len(), 1, "{xoff:?}");
    assert!(xoff[0] < read_at);
    assert!(xon.iter().any(|&t| t >= read_at), "{xon:?}");
    // A really stopped: no data byte left A between XOFF reaching A (plus the byte already on
    // the line) and XON.
    let xoff_at_a = p
        .sim
        .trace()
        .received("A")
        .into_iter()
        .find(|r| r.1 == 0x13)
        .unwrap()
        .0;
    let a_tx: Vec<Instant> = p
        .sim
        .trace()
        .of("A")
        .filter(|e| matches!(e.kind, TraceKind::Tx { .. }))
        .map(|e| e.at)
        .collect();
    // Nothing new was handed to the line after XOFF reached A (the character, or with a larger
    // chunk the chunk, already on the line finishes).
    let char_time = config(FlowControl::XonXoff).settings.char_time();
    assert!(
        a_tx.iter()
            .all(|&t| t <= xoff_at_a + char_time || t >= read_at),
        "chunk {chunk}"
    );
}

#[test]
fn s6_9_rts_cts_stops_and_resumes_a_fast_sender_without_losing_a_byte() {
    for chunk in [1, 16] {
        rts_cts_fast_sender(chunk);
    }
}

fn rts_cts_fast_sender(chunk: u8) {
    let mut p = pair(FlowControl::RtsCts, chunk);
    let read_at = Instant::from_micros(1_500_000);
    let (got, a_events) = fast_sender(&mut p, read_at, Instant::from_micros(10_000_000));
    assert_eq!(got.len(), expected().len());
    assert!(got == expected(), "every byte, in order");
    assert!(a_events
        .iter()
        .all(|e| !matches!(e, Event::SendFailed { .. })));
    assert!(errors(&p.sim.take_events(p.b)).is_empty());
    // B dropped RTS before the read and raised it after.
    let rts: Vec<(Instant, Option<bool>)> = p
        .sim
        .trace()
        .of("B")
        .filter_map(|e| match e.kind {
            TraceKind::Signals { update } => Some((e.at, update.rts)),
            _ => None,
        })
        .collect();
    assert!(
        rts.iter().any(|&(t, r)| r == Some(false) && t < read_at),
        "{rts:?}"
    );
    assert!(
        rts.iter().any(|&(t, r)| r == Some(true) && t >= read_at),
        "{rts:?}"
    );
}

#[test]
fn s6_9_no_xon_within_the_wait_time_is_0708() {
    let mut p = pair(FlowControl::XonXoff, 1);
    let (got, a_events) = fast_sender(&mut p, Instant::MAX_TEST, Instant::from_micros(20_000_000));
    let xoff_at_a = p
        .sim
        .trace()
        .received("A")
        .into_iter()
        .find(|r| r.1 == 0x13)
        .unwrap()
        .0;
    let failed: Vec<_> = a_events
        .iter()
        .filter_map(|e| match e {
            Event::SendFailed { status, at, .. } => Some((status.code(), *at)),
            _ => None,
        })
        .collect();
    // Default wait for XON: 2 s from the moment XOFF held the sender.
    assert_eq!(
        failed,
        vec![(0x0708, xoff_at_a + Duration::from_millis(2_000))]
    );
    // What B had stored before the XOFF is intact.
    assert!(got.len() >= 9);
    assert!(got.iter().zip(expected()).all(|(g, e)| *g == e));
}

trait MaxTest {
    const MAX_TEST: Instant;
}
impl MaxTest for Instant {
    const MAX_TEST: Instant = Instant::from_micros(u64::MAX);
}

#[test]
fn s6_9_no_cts_within_the_wait_time_is_0708_with_the_time_set_by_s_rts() {
    let mut b = Bench::new(config(FlowControl::RtsCts));
    // S_RTS: wait time for CTS 500 ms.
    let mut s_rts = SRts::default();
    let out = b.sim.with(b.link, |l, _| {
        s_rts.call(l, true, false, Duration::from_millis(500))
    });
    assert!(out.done && !out.error);
    let t0 = b.sim.now();
    let job = b
        .sim
        .with(b.link, |l, now| l.send(now, "x".into()))
        .unwrap();
    b.run_for_ms(2_000);
    assert_eq!(
        b.events(),
        vec![Event::SendFailed {
            job,
            status: status::XON_CTS_TIMEOUT,
            at: t0 + Duration::from_millis(500)
        }]
    );
    assert!(
        b.sim.engine(b.partner).bytes().is_empty(),
        "nothing was sent"
    );
}

#[test]
fn s6_9_partner_ignoring_xoff_overflows_with_0812() {
    let mut b = Bench::new(config(FlowControl::XonXoff));
    for k in 0..11u8 {
        b.partner_sends(&[k + 0x20; 100]);
    }
    b.run_for_ms(1_000);
    // The module sent XOFF (after its startup XON) ...
    assert!(b.sim.engine(b.partner).bytes().contains(&0x13));
    // ... and the newest frame was lost with 0812H.
    let codes: Vec<u16> = errors(&b.events()).iter().map(|e| e.0).collect();
    assert_eq!(codes, vec![status::RECEIVED_AFTER_XOFF.code()]);
    assert_eq!(b.frames().len(), 10);
}

#[test]
fn s6_9_entering_flow_control_sends_xon_or_sets_rts() {
    let mut b = Bench::new(config(FlowControl::XonXoff));
    b.run_for_ms(10);
    assert_eq!(b.sim.engine(b.partner).bytes(), vec![0x11]);
    let b = Bench::new(config(FlowControl::RtsCts));
    assert!(
        b.sim.engine(b.partner).signals.cts,
        "module RTS = partner CTS"
    );
}

#[test]
fn s8_4_s_xon_changes_the_characters_and_is_0550_under_other_flow_control() {
    let mut b = Bench::new(config(FlowControl::XonXoff));
    let mut s_xon = SXon::default();
    let wait = Duration::from_millis(100);
    let out = b
        .sim
        .with(b.link, |l, _| s_xon.call(l, true, false, 0x01, 0x02, wait));
    assert!(out.done);
    assert_eq!(
        b.sim.engine(b.link).config().xon_xoff,
        XonXoff {
            xon: 0x01,
            xoff: 0x02,
            wait_for_xon: si_core::Duration::from_millis(100),
        }
    );
    // Only the edge counts.
    let again = b
        .sim
        .with(b.link, |l, _| s_xon.call(l, true, false, 0x01, 0x02, wait));
    assert!(!again.done && !again.error);
    // Out of range: 1E20H.
    let bad = Duration::from_millis(5);
    b.sim
        .with(b.link, |l, _| s_xon.call(l, false, false, 0x01, 0x02, bad));
    let out = b
        .sim
        .with(b.link, |l, _| s_xon.call(l, true, false, 0x01, 0x02, bad));
    assert_eq!(
        (out.error, out.status),
        (true, status::PARAMETER_OUT_OF_RANGE)
    );

    let mut b = Bench::new(config(FlowControl::None));
    let out = b.sim.with(b.link, |l, _| {
        SXon::default().call(l, true, false, 0x01, 0x02, wait)
    });
    assert_eq!(
        (out.error, out.status),
        (true, status::FLOW_PARAMETERS_MISMATCH)
    );
}

fn auto_v24() -> Config {
    Config {
        settings: settings(9_600),
        end: EndCriterion::DEFAULT_END_CHARS,
        flow_control: FlowControl::AutoV24,
        ..Config::default()
    }
}

#[test]
fn s6_8_automatic_v24_rts_on_cts_send_rts_off_after_the_rts_off_time() {
    let mut b = Bench::with_partner(auto_v24(), Partner::modem());
    // The partner is ready (its DTR is our DSR).
    b.sim.with(b.partner, |p, _| {
        p.set(SignalUpdate {
            dtr: Some(true),
            rts: None,
        })
    });
    assert!(
        b.sim.engine(b.link).signals().dtr,
        "DTR = ON on entering the mode"
    );
    let job = b
        .sim
        .with(b.link, |l, now| l.send(now, "data\x03".into()))
        .unwrap();
    b.run_for_ms(500);
    assert_eq!(b.sim.engine(b.partner).bytes(), b"data\x03");
    let last_byte = b.sim.trace().received("P").last().unwrap().0;
    let sent_at = last_byte + Duration::from_millis(10);
    assert_eq!(b.events(), vec![Event::Sent { job, at: sent_at }]);
    assert!(!b.sim.engine(b.link).signals().rts, "RTS off again");
}

#[test]
fn s6_8_automatic_v24_no_cts_within_the_data_output_wait_time_is_0818() {
    let mut b = Bench::new(auto_v24());
    b.sim.with(b.partner, |p, _| {
        p.set(SignalUpdate {
            dtr: Some(true),
            rts: None,
        })
    });
    let t0 = b.sim.now();
    let job = b
        .sim
        .with(b.link, |l, now| l.send(now, "x".into()))
        .unwrap();
    b.run_for_ms(500);
    assert_eq!(
        b.events(),
        vec![Event::SendFailed {
            job,
            status: status::DSR_CTS_OFF,
            at: t0 + Duration::from_millis(10)
        }]
    );
    assert!(b.sim.engine(b.partner).bytes().is_empty());
    assert!(!b.sim.engine(b.link).signals().rts);
}

#[test]
fn s6_8_automatic_v24_partner_not_ready_is_0818_and_nothing_is_received() {
    let mut b = Bench::with_partner(auto_v24(), Partner::modem());
    let job = b
        .sim
        .with(b.link, |l, now| l.send(now, "x".into()))
        .unwrap();
    b.partner_sends(b"ignored\x03");
    b.run_for_ms(100);
    let events = b.events();
    assert!(
        matches!(events[..], [Event::SendFailed { job: j, status, .. }] if j == job && status == status::DSR_CTS_OFF)
    );
    assert!(b.frames().is_empty());
}

#[test]
fn s6_7_s_vset_is_refused_under_automatic_v24_and_s_vstat_always_reads() {
    let mut b = Bench::new(auto_v24());
    let mut vset = SVset::default();
    let out = b
        .sim
        .with(b.link, |l, _| vset.call(l, true, false, true, true));
    assert_eq!(
        (out.error, out.status),
        (true, status::NOT_POSSIBLE_IN_MODE)
    );
    b.sim.with(b.partner, |p, _| {
        p.set(SignalUpdate {
            dtr: Some(true),
            rts: Some(true),
        })
    });
    let mut vstat = SVstat::default();
    let s = b.sim.with(b.link, |l, _| vstat.call(l, true, false));
    assert!(s.result.done);
    assert!(s.dtr_out && s.dsr_in && s.cts_in && s.dcd_in && !s.rts_out);

    // Without flow control S_VSET drives both outputs.
    let mut b = Bench::new(config(FlowControl::None));
    let out = b.sim.with(b.link, |l, _| {
        SVset::default().call(l, true, false, true, false)
    });
    assert!(out.done);
    let p = b.sim.engine(b.partner).signals;
    assert!(p.cts && !p.dsr);
    // Under RTS/CTS, RTS is the flow control's.
    let mut b = Bench::new(config(FlowControl::RtsCts));
    let out = b.sim.with(b.link, |l, _| {
        SVset::default().call(l, true, false, true, true)
    });
    assert_eq!(out.status, status::NOT_POSSIBLE_IN_MODE);
    assert!(b
        .sim
        .with(b.link, |l, _| l.set_signals(SignalUpdate {
            dtr: Some(true),
            rts: None
        }))
        .is_ok());
}

#[test]
fn s6_4_with_xon_xoff_the_flow_characters_are_not_data() {
    let c = Config {
        settings: settings(9_600),
        end: EndCriterion::CharDelay,
        flow_control: FlowControl::XonXoff,
        ..Config::default()
    };
    let mut b = Bench::new(c);
    b.partner_sends(b"ab\x11cd");
    b.run_for_ms(100);
    assert_eq!(b.frames(), vec![b"abcd".to_vec()]);
    // Sending them is refused ([ET200S SI] §2.8, Fig. 2-17), also when a 7-bit line would strip the
    // top bit.
    let err = b.sim.with(b.link, |l, now| l.send(now, "x\x13".into()));
    assert_eq!(err, Err(si_ascii::SendError::FlowCharacter(0x13)));
    let c7 = Config {
        settings: SerialSettings::new(9_600, 7, si_core::Parity::Even, 1).unwrap(),
        ..c
    };
    let mut link = Link::new(c7).unwrap();
    assert_eq!(
        link.send(Instant::ZERO, bytes::Bytes::from_static(&[0x91])),
        Err(si_ascii::SendError::FlowCharacter(0x91))
    );
}

#[test]
fn s9_8_job_code_5_parameter_block_applies_or_is_0550() {
    use si_ascii::frame::ParamBlock;
    // Table 2-27's stream, as a non-S7 master sends it: block 20H, XON/XOFF, 2000 ms.
    let block = ParamBlock::decode(&[0x20, 0x00, 0x04, 0x0B, 0x0D, 0x00, 0xC8]).unwrap();
    let mut link = Link::new(config(FlowControl::XonXoff)).unwrap();
    link.apply_param_block(block).unwrap();
    assert_eq!(link.config().xon_xoff.xon, 0x0B);
    assert_eq!(
        link.config().xon_xoff.wait_for_xon,
        si_core::Duration::from_millis(2_000)
    );
    // A block for another flow control: 0550H.
    let rts = ParamBlock::decode(&[0x21, 0x00, 0x02, 0x00, 0x01]).unwrap();
    assert_eq!(
        link.apply_param_block(rts).unwrap_err().status,
        status::FLOW_PARAMETERS_MISMATCH
    );
    // 10 ms for the CTS wait is below its 20 ms minimum: 1E20H.
    let mut link = Link::new(config(FlowControl::RtsCts)).unwrap();
    assert_eq!(
        link.apply_param_block(rts).unwrap_err().status,
        status::PARAMETER_OUT_OF_RANGE
    );
}

#[test]
fn s6_8_automatic_v24_cts_dropping_during_the_send_is_0818() {
    let mut b = Bench::with_partner(auto_v24(), Partner::modem());
    b.sim.with(b.partner, |p, _| {
        p.set(SignalUpdate {
            dtr: Some(true),
            rts: None,
        })
    });
    let job = b
        .sim
        .with(b.link, |l, now| l.send(now, vec![b'x'; 40].into()))
        .unwrap();
    b.run_for_ms(5);
    let dropped_at = b.sim.now();
    b.sim.with(b.partner, |p, _| {
        p.answer_rts = false;
        p.set(SignalUpdate {
            dtr: None,
            rts: Some(false),
        })
    });
    b.run_for_ms(200);
    assert_eq!(
        b.events(),
        vec![Event::SendFailed {
            job,
            status: status::DSR_CTS_OFF,
            at: dropped_at
        }]
    );
    assert!(
        !b.sim.engine(b.link).signals().rts,
        "RTS off after the abort"
    );
    // Only what was already handed to the line went out.
    assert!(b.sim.engine(b.partner).bytes().len() < 40);
}

#[test]
fn s6_8_automatic_v24_dsr_dropping_during_the_rts_off_time_is_0818() {
    let mut b = Bench::with_partner(auto_v24(), Partner::modem());
    b.sim.with(b.partner, |p, _| {
        p.set(SignalUpdate {
            dtr: Some(true),
            rts: None,
        })
    });
    let job = b
        .sim
        .with(b.link, |l, now| l.send(now, "data\x03".into()))
        .unwrap();
    // Until the last byte has reached the partner: the RTS-off time (10 ms) is running.
    for _ in 0..100 {
        if b.sim.engine(b.partner).bytes().len() == 5 {
            break;
        }
        b.sim.run_for(Duration::from_micros(100));
    }
    assert_eq!(b.sim.engine(b.partner).bytes(), b"data\x03");
    assert!(b.sim.engine(b.link).signals().rts, "RTS still on");
    let dropped_at = b.sim.now();
    b.sim.with(b.partner, |p, _| {
        p.set(SignalUpdate {
            dtr: Some(false),
            rts: None,
        })
    });
    b.run_for_ms(100);
    assert_eq!(
        b.events(),
        vec![Event::SendFailed {
            job,
            status: status::DSR_CTS_OFF,
            at: dropped_at
        }],
        "the send job is done only once RTS is off, so DSR dropping aborts it"
    );
    assert!(!b.sim.engine(b.link).signals().rts);
}

#[test]
fn s6_8_automatic_v24_dsr_dropping_aborts_the_reception_with_0818() {
    let mut b = Bench::new(auto_v24());
    b.sim.with(b.partner, |p, _| {
        p.set(SignalUpdate {
            dtr: Some(true),
            rts: None,
        })
    });
    b.partner_sends(b"abc");
    b.run_for_ms(2);
    let dropped_at = b.sim.now();
    b.sim.with(b.partner, |p, _| {
        p.set(SignalUpdate {
            dtr: Some(false),
            rts: None,
        })
    });
    b.run_for_ms(100);
    assert_eq!(
        errors(&b.events()),
        vec![(status::DSR_CTS_OFF.code(), dropped_at)]
    );
    assert!(b.frames().is_empty());
}

#[test]
fn s8_6_s_v24_sets_the_rts_off_time() {
    use si_ascii::fb::SV24;
    use si_ascii::AutoV24;
    let mut b = Bench::with_partner(auto_v24(), Partner::modem());
    b.sim.with(b.partner, |p, _| {
        p.set(SignalUpdate {
            dtr: Some(true),
            rts: None,
        })
    });
    let mut s_v24 = SV24::default();
    let params = AutoV24 {
        time_rts_off: si_core::Duration::from_millis(50),
        data_wait_time: si_core::Duration::from_millis(20),
    };
    let (rts_off, data_wait) = (Duration::from_millis(50), Duration::from_millis(20));
    let out = b.sim.with(b.link, |l, _| {
        s_v24.call(l, true, false, rts_off, data_wait)
    });
    assert!(out.done && !out.error);
    let job = b
        .sim
        .with(b.link, |l, now| l.send(now, "ok\x03".into()))
        .unwrap();
    b.run_for_ms(500);
    let last_byte = b.sim.trace().received("P").last().unwrap().0;
    assert_eq!(
        b.events(),
        vec![Event::Sent {
            job,
            at: last_byte + Duration::from_millis(50)
        }]
    );
    // 5 ms is not a multiple of 10 ms: 1E20H, and the old value stays.
    let bad = Duration::from_millis(5);
    b.sim
        .with(b.link, |l, _| s_v24.call(l, false, false, bad, data_wait));
    let out = b
        .sim
        .with(b.link, |l, _| s_v24.call(l, true, false, bad, data_wait));
    assert_eq!(out.status, status::PARAMETER_OUT_OF_RANGE);
    assert_eq!(b.sim.engine(b.link).config().auto_v24, params);
}
