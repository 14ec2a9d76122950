//! Function codes the master does not know, passed through as they are
//! (`Master::request_pass_through`, a host extension for gateways): the request goes out with
//! its CRC, the answer ends by the gap and comes back as bytes, an exception answer is the
//! slave's exception; driven by hand in virtual time.

use si_core::{Engine, Instant, Output};
use si_modbus::frame::crc16;
use si_modbus::master::{Master, MasterEvent, RequestError};
use si_modbus::{status, MasterConfig};

fn ms(n: u64) -> Instant {
    Instant::from_micros(n * 1000)
}

fn with_crc(bytes: &[u8]) -> Vec<u8> {
    let mut v = bytes.to_vec();
    v.extend_from_slice(&crc16(bytes).to_le_bytes());
    v
}

/// The master's outputs at `now` (tx-done reported at once): frames sent and events.
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

/// Pass `request` through, answer it with `answer` at 10 ms, and return the job's end.
fn exchange(request: &[u8], answer: &[u8]) -> MasterEvent {
    let mut m = Master::new(MasterConfig::default()).unwrap();
    m.request_pass_through(ms(0), request).unwrap();
    let (sent, _) = drain(&mut m, ms(0));
    assert_eq!(sent, [with_crc(request)]);
    m.handle_rx(ms(10), &with_crc(answer));
    for t in 11..100 {
        m.handle_timeout(ms(t));
        let (_, events) = drain(&mut m, ms(t));
        if let Some(e) = events.into_iter().next() {
            return e;
        }
    }
    panic!("the job did not end");
}

#[test]
fn read_device_identification_passes_through_and_its_answer_comes_back_whole() {
    let answer = [1, 0x2B, 0x0E, 1, 1, 0, 0, 1, 0, 3, b's', b'i', b'!'];
    let MasterEvent::Completed(c) = exchange(&[1, 0x2B, 0x0E, 1, 0], &answer) else {
        panic!("not completed")
    };
    assert_eq!(c.response_bytes(), Some(&with_crc(&answer)[..]));
}

#[test]
fn an_exception_to_a_passed_through_code_is_the_slaves_exception() {
    let end = exchange(&[1, 0x41, 7], &[1, 0xC1, 0x01]);
    assert!(
        matches!(end, MasterEvent::Failed { status: s, .. } if s == status::for_exception(si_modbus::frame::ExceptionCode::IllegalFunction)),
        "{end:?}"
    );
}

#[test]
fn an_answer_with_another_function_code_is_refused() {
    let end = exchange(&[1, 0x41, 7], &[1, 0x42, 7]);
    assert!(
        matches!(end, MasterEvent::Failed { status: s, .. } if s == status::WRONG_FUNCTION),
        "{end:?}"
    );
}

#[test]
fn broadcasts_and_frames_without_a_function_or_too_long_are_refused() {
    let mut m = Master::new(MasterConfig::default()).unwrap();
    let refused = |m: &mut Master, r: &[u8]| match m.request_pass_through(ms(0), r) {
        Err(RequestError::Invalid(s)) => s,
        other => panic!("{other:?}"),
    };
    assert_eq!(refused(&mut m, &[1]), status::INVALID_FUNCTION);
    assert_eq!(
        refused(&mut m, &[0, 0x41]),
        status::BROADCAST_NOT_ALLOWED_FOR_FC
    );
    assert_eq!(refused(&mut m, &[1; 255]), status::WRITE_COUNT);
    assert!(
        m.request_pass_through(ms(0), &[1; 254]).is_ok(),
        "254 + CRC = 256 bytes fit"
    );
}
