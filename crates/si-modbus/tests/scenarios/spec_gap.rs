//! `Master::with_gap` (a host extension): frames end, and the next request waits, at the gap
//! given (the Modbus specification's t3.5, [Modbus serial] §2.5.1.1) instead of the module's
//! Table 3-11 gap ([Modbus/USS] §3.3.5); driven by hand in virtual time at 19200 bit/s, where
//! the table says 4 ms and the specification 1.75 ms.

use si_core::{Engine, Instant, Output, Parity, SerialSettings};
use si_modbus::frame::{crc16, Request};
use si_modbus::master::{Master, MasterEvent};
use si_modbus::MasterConfig;

fn us(n: u64) -> Instant {
    Instant::from_micros(n)
}

/// A master at 19200 8N1 whose gap is `gap` µs (`None`: the module's).
fn master(gap: Option<u64>) -> Master {
    let mut config = MasterConfig::default();
    config.line.settings = SerialSettings::new(19_200, 8, Parity::None, 1).unwrap();
    let m = Master::new(config).unwrap();
    match gap {
        Some(g) => m.with_gap(std::time::Duration::from_micros(g)),
        None => m,
    }
}

/// Read one register; its answer `01 03 02 00 07 CRC` arrives from 10 ms on, with a hole of
/// 3 ms after its fourth byte. Returns whether the job completed with the value.
fn split_answer_completes(gap: Option<u64>) -> bool {
    let mut m = master(gap);
    let read = Request::ReadHoldingRegisters {
        address: 0,
        quantity: 1,
    };
    m.request(us(0), 1, &read).unwrap();
    let mut answer = vec![1, 3, 2, 0, 7];
    answer.extend_from_slice(&crc16(&answer).to_le_bytes());
    let mut events = Vec::new();
    let mut step = |m: &mut Master, now: Instant| loop {
        match m.poll_output() {
            Output::Transmit(_) => m.handle_tx_done(now),
            Output::Event(e) => events.push(e),
            Output::SetSignals(_) => {}
            Output::Wait(_) => break,
        }
    };
    step(&mut m, us(0));
    // Byte by byte, one character time (521 µs) apart, as a UART delivers them: a port that
    // hands over several bytes at once would be taken for a packetising one.
    let mut t = 10_000;
    for (i, byte) in answer.iter().enumerate() {
        let until = t + if i == 3 { 3_000 } else { 521 };
        m.handle_rx(us(t), &[*byte]);
        step(&mut m, us(t));
        while t < until {
            t += 50;
            m.handle_timeout(us(t));
            step(&mut m, us(t));
        }
    }
    for t in (t..t + 20_000).step_by(100) {
        m.handle_timeout(us(t));
        step(&mut m, us(t));
    }
    matches!(events.first(), Some(MasterEvent::Completed(_)))
}

#[test]
fn a_3_ms_hole_ends_the_frame_at_the_specifications_gap_but_not_at_the_modules() {
    assert!(split_answer_completes(None), "4 ms: one frame");
    assert!(
        !split_answer_completes(Some(1_750)),
        "1.75 ms: the frame ended"
    );
}
