//! The quiet guard after a timeout (`Master::with_quiet_after_timeout`, a host extension): a
//! slave's late answer to one request is never completed as the answer to the next, driven by
//! hand in virtual time (no line simulator: the test decides when each byte arrives).

use si_core::{Duration, Engine, Instant, Output};
use si_modbus::frame::{crc16, Request, Response};
use si_modbus::master::{Master, MasterEvent};
use si_modbus::{status, MasterConfig};

fn ms(n: u64) -> Instant {
    Instant::from_micros(n * 1000)
}

/// Read one holding register at `address`.
fn read(address: u16) -> Request<'static> {
    Request::ReadHoldingRegisters {
        address,
        quantity: 1,
    }
}

/// Unit 1's answer to a one-register read: `value`.
fn answer(value: u16) -> Vec<u8> {
    let [hi, lo] = value.to_be_bytes();
    let mut v = vec![1, 3, 2, hi, lo];
    let crc = crc16(&v).to_le_bytes();
    v.extend_from_slice(&crc);
    v
}

/// A master with a 500 ms response timeout, no retries, and `quiet` ms of guard.
fn master(quiet: u64) -> Master {
    let config = MasterConfig {
        response_timeout: Duration::from_millis(500),
        retries: 0,
        ..MasterConfig::default()
    };
    Master::new(config)
        .unwrap()
        .with_quiet_after_timeout(std::time::Duration::from_millis(quiet))
}

/// Everything the master outputs at `now` (tx-done reported for every transmission): the
/// frames it sent and its events.
fn drain(m: &mut Master, now: Instant) -> (Vec<Vec<u8>>, Vec<MasterEvent>) {
    let (mut sent, mut events) = (Vec::new(), Vec::new());
    loop {
        match m.poll_output() {
            Output::Transmit(b) => {
                sent.push(b.to_vec());
                m.handle_tx_done(now);
            }
            Output::Event(e) => events.push(e),
            Output::SetSignals(_) => {}
            Output::Wait(_) => return (sent, events),
        }
    }
}

/// Step the master's timers from `from` to `to` in 1 ms steps, collecting what it does.
fn run(m: &mut Master, from: u64, to: u64) -> (Vec<Vec<u8>>, Vec<MasterEvent>) {
    let (mut sent, mut events) = (Vec::new(), Vec::new());
    for t in from..=to {
        m.handle_timeout(ms(t));
        let (s, e) = drain(m, ms(t));
        sent.extend(s);
        events.extend(e);
    }
    (sent, events)
}

/// The sequence in one line: HR 10 times out at 500 ms; HR 20 is asked at once; HR 10's
/// answer comes at 700 ms. Returns what became of HR 20's job and the frames sent for it.
fn late_answer(quiet: u64) -> (Vec<MasterEvent>, Vec<Vec<u8>>) {
    let mut m = master(quiet);
    m.request(ms(0), 1, &read(10)).unwrap();
    drain(&mut m, ms(0));
    let (_, events) = run(&mut m, 1, 520);
    assert!(
        matches!(events[..], [MasterEvent::Failed { status: s, .. }] if s == status::RESPONSE_TIMEOUT),
        "{events:?}"
    );
    m.request(ms(520), 1, &read(20)).unwrap();
    let (mut sent, mut events) = drain(&mut m, ms(520));
    let (s, e) = run(&mut m, 521, 699);
    sent.extend(s);
    events.extend(e);
    m.handle_rx(ms(700), &answer(10));
    let (s, e) = run(&mut m, 700, 3000);
    sent.extend(s);
    events.extend(e);
    (events, sent)
}

#[test]
fn without_the_guard_a_late_answer_completes_the_next_request() {
    // The behaviour the guard exists for: HR 20's job ends with HR 10's value.
    let (events, _) = late_answer(0);
    let MasterEvent::Completed(c) = &events[0] else {
        panic!("{events:?}")
    };
    assert!(
        matches!(c.response(), Some(Response::ReadHoldingRegisters(r)) if r.get(0) == Some(10))
    );
}

#[test]
fn with_the_guard_the_late_answer_is_discarded_and_the_next_request_waits_for_silence() {
    let (events, sent) = late_answer(300);
    // HR 20 went out only after 300 ms of silence since the late answer, and nobody answered it.
    assert_eq!(sent.len(), 1, "{sent:02X?}");
    assert_eq!(sent[0][..6], [1, 3, 0, 20, 0, 1]);
    let ended: Vec<_> = events
        .iter()
        .filter(|e| !matches!(e, MasterEvent::Diagnostic(_)))
        .collect();
    assert!(
        matches!(ended[..], [MasterEvent::Failed { status: s, .. }] if *s == status::RESPONSE_TIMEOUT),
        "HR 20's job times out instead of taking HR 10's value: {events:?}"
    );
    assert!(
        events.contains(&MasterEvent::Diagnostic(status::UNSOLICITED_RESPONSE)),
        "the late answer is counted as unsolicited: {events:?}"
    );
}
