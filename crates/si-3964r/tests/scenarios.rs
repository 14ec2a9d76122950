//! One scenario per path of the manuals' flow descriptions, each named after its section and
//! asserting the STATUS ([ET200S SI] §2.7, [CP 341] §2.2.2, §2.3.1).

#[path = "scenarios/character_delay.rs"]
mod character_delay;
mod common;
#[path = "scenarios/fifo_uart.rs"]
mod fifo_uart;
#[path = "scenarios/line_errors.rs"]
mod line_errors;
#[path = "scenarios/restart.rs"]
mod restart;
#[path = "scenarios/usb_adapter.rs"]
mod usb_adapter;

use common::*;
use si_3964r::frame::{encode, Mode, DLE, ETX, NAK, STX};
use si_3964r::status::*;
use si_3964r::{Config, Event, JobId, Link, Priority};
use si_core::{Duration, Instant};

const ZVZ: Duration = Duration::from_millis(220);
const QVZ: Duration = Duration::from_millis(2000);

fn take(sim: &mut si_sim::Simulator, s: si_sim::StationId<Link>) -> Option<Vec<u8>> {
    sim.with(s, |l, now| l.take_block(now)).map(|b| b.to_vec())
}

// --- [ET200S SI] §2.7 / §2.7: clean exchanges
// ---------------------------------------------------------

#[test]
fn s5_3_send_low_priority_to_high_is_acknowledged_status_0000() {
    let (mut sim, a, b) = pair(with_priority(Priority::Low), with_priority(Priority::High));
    let job = sim.with(a, |l, now| {
        l.send(now, vec![0x41, 0x42, 0x10, 0x43]).unwrap()
    });
    settle(&mut sim);
    assert_eq!(sim.take_events(a), vec![Event::Sent { job }]);
    assert_eq!(sim.engine(a).job_outcome(job), Some(Ok(())));
    assert_eq!(sim.take_events(b), vec![Event::Received { len: 4 }]);
    assert_eq!(take(&mut sim, b).unwrap(), [0x41, 0x42, 0x10, 0x43]);
    // Startup NAK, STX, then the [ET200S SI] §2.7, Fig. 2-12 worked example block.
    assert_eq!(
        sent_bytes(&sim, "A"),
        [NAK, STX, 0x41, 0x42, 0x10, 0x10, 0x43, DLE, ETX, 0x53]
    );
    // Startup NAK, DLE for the STX, DLE for the block.
    assert_eq!(sent_bytes(&sim, "B"), [NAK, DLE, DLE]);
}

#[test]
fn s5_4_receive_low_priority_from_high_is_delivered_once() {
    let (mut sim, a, b) = pair(with_priority(Priority::High), with_priority(Priority::Low));
    let job = sim.with(a, |l, now| l.send(now, &b"from high"[..]).unwrap());
    settle(&mut sim);
    assert_eq!(sim.take_events(a), vec![Event::Sent { job }]);
    assert_eq!(sim.take_events(b), vec![Event::Received { len: 9 }]);
    assert_eq!(take(&mut sim, b).unwrap(), b"from high");
    assert_eq!(take(&mut sim, b), None);
}

#[test]
fn s5_3_both_directions_one_after_the_other() {
    let (mut sim, a, b) = pair(with_priority(Priority::High), with_priority(Priority::Low));
    let ja = sim.with(a, |l, now| l.send(now, &b"ping"[..]).unwrap());
    settle(&mut sim);
    let jb = sim.with(b, |l, now| l.send(now, &b"pong"[..]).unwrap());
    settle(&mut sim);
    assert_eq!(
        sim.take_events(a),
        vec![Event::Sent { job: ja }, Event::Received { len: 4 }]
    );
    assert_eq!(
        sim.take_events(b),
        vec![Event::Received { len: 4 }, Event::Sent { job: jb }]
    );
}

// --- [ET200S SI] §2.7, Fig. 2-16 initialization conflict
// -----------------------------------------------------------

fn conflict(a_prio: Priority, b_prio: Priority) -> (Vec<Event>, Vec<Event>, JobId, JobId) {
    let (mut sim, a, b) = pair(with_priority(a_prio), with_priority(b_prio));
    let ja = sim.with(a, |l, now| l.send(now, &b"AAAA"[..]).unwrap());
    let jb = sim.with(b, |l, now| l.send(now, &b"BBBBBB"[..]).unwrap());
    settle(&mut sim);
    (sim.take_events(a), sim.take_events(b), ja, jb)
}

#[test]
fn s5_6_conflict_low_yields_to_high_then_sends() {
    let (ea, eb, ja, jb) = conflict(Priority::Low, Priority::High);
    // A (low) answers B's STX with DLE, receives, then sends its postponed job.
    assert_eq!(
        ea,
        vec![Event::Received { len: 6 }, Event::Sent { job: ja }]
    );
    assert_eq!(
        eb,
        vec![Event::Sent { job: jb }, Event::Received { len: 4 }]
    );
}

#[test]
fn s5_6_conflict_high_keeps_waiting_for_dle() {
    let (ea, eb, ja, jb) = conflict(Priority::High, Priority::Low);
    assert_eq!(
        ea,
        vec![Event::Sent { job: ja }, Event::Received { len: 6 }]
    );
    assert_eq!(
        eb,
        vec![Event::Received { len: 4 }, Event::Sent { job: jb }]
    );
}

#[test]
fn s5_6_conflict_both_high_is_070b() {
    let (ea, eb, ja, jb) = conflict(Priority::High, Priority::High);
    assert_eq!(
        ea,
        vec![Event::SendFailed {
            job: ja,
            status: CONFLICT_BOTH_HIGH
        }]
    );
    assert_eq!(
        eb,
        vec![Event::SendFailed {
            job: jb,
            status: CONFLICT_BOTH_HIGH
        }]
    );
}

#[test]
fn s5_6_conflict_both_low_is_070c() {
    let (ea, eb, ja, jb) = conflict(Priority::Low, Priority::Low);
    assert_eq!(
        ea,
        vec![Event::SendFailed {
            job: ja,
            status: CONFLICT_BOTH_LOW
        }]
    );
    assert_eq!(
        eb,
        vec![Event::SendFailed {
            job: jb,
            status: CONFLICT_BOTH_LOW
        }]
    );
}

// --- [ET200S SI] §2.7 sender error paths (scripted partner)
// ---------------------------------------------

#[test]
fn s5_3_nak_to_stx_then_dle_succeeds_after_one_repetition() {
    let (mut sim, a, p) = scripted(Config::default());
    let job = sim.with(a, |l, now| l.send(now, &b"x"[..]).unwrap());
    run_ms(&mut sim, 5);
    sim.transmit(p, &[NAK]); // refuse the first STX
    run_ms(&mut sim, 5);
    sim.transmit(p, &[DLE]); // accept the second
    run_ms(&mut sim, 20);
    sim.transmit(p, &[DLE]); // acknowledge the block
    settle(&mut sim);
    assert_eq!(sim.take_events(a), vec![Event::Sent { job }]);
    assert_eq!(count_tx(&sim, "A", STX), 2);
}

#[test]
fn s5_3_nak_to_every_stx_exhausts_connection_attempts_0702() {
    let (mut sim, a, p) = scripted(Config::default());
    let job = sim.with(a, |l, now| l.send(now, &b"x"[..]).unwrap());
    for _ in 0..10 {
        run_ms(&mut sim, 5);
        sim.transmit(p, &[NAK]);
    }
    settle(&mut sim);
    assert_eq!(
        sim.take_events(a),
        vec![Event::SendFailed {
            job,
            status: SETUP_REJECTED
        }]
    );
    // Six connection attempts, then NAK to the partner (startup NAK + final NAK).
    assert_eq!(count_tx(&sim, "A", STX), 6);
    assert_eq!(count_tx(&sim, "A", NAK), 2);
}

#[test]
fn s5_3_nak_after_every_block_exhausts_transmission_attempts_0706() {
    let (mut sim, a, p) = scripted(Config::default());
    let job = sim.with(a, |l, now| l.send(now, &b"data"[..]).unwrap());
    for _ in 0..6 {
        run_ms(&mut sim, 5);
        sim.transmit(p, &[DLE]); // accept the STX
        run_ms(&mut sim, 20); // the block is 7 characters, 8 ms
        sim.transmit(p, &[NAK]); // reject it
    }
    settle(&mut sim);
    assert_eq!(
        sim.take_events(a),
        vec![Event::SendFailed {
            job,
            status: END_REJECTED
        }]
    );
    assert_eq!(count_tx(&sim, "A", STX), 6);
    assert_eq!(count_tx(&sim, "A", b'd'), 6);
}

#[test]
fn s5_3_nak_during_the_block_then_success_0705_not_reported() {
    let config = Config {
        transmission_attempts: 2,
        ..Config::default()
    };
    let (mut sim, a, p) = scripted(config);
    let job = sim.with(a, |l, now| l.send(now, vec![0x55; 50]).unwrap());
    run_ms(&mut sim, 5);
    sim.transmit(p, &[DLE]);
    run_ms(&mut sim, 10); // in the middle of a 53-character block (61 ms)
    sim.transmit(p, &[NAK]);
    run_ms(&mut sim, 100);
    sim.transmit(p, &[DLE]);
    run_ms(&mut sim, 100);
    sim.transmit(p, &[DLE]);
    settle(&mut sim);
    assert_eq!(sim.take_events(a), vec![Event::Sent { job }]);
    assert_eq!(count_tx(&sim, "A", STX), 2);
}

#[test]
fn s5_3_nak_during_every_block_fails_with_0705() {
    let config = Config {
        transmission_attempts: 2,
        ..Config::default()
    };
    let (mut sim, a, p) = scripted(config);
    let job = sim.with(a, |l, now| l.send(now, vec![0x55; 50]).unwrap());
    for _ in 0..2 {
        run_ms(&mut sim, 5);
        sim.transmit(p, &[DLE]);
        run_ms(&mut sim, 10);
        sim.transmit(p, &[NAK]);
        run_ms(&mut sim, 100);
    }
    settle(&mut sim);
    assert_eq!(
        sim.take_events(a),
        vec![Event::SendFailed {
            job,
            status: NAK_WHILE_SENDING
        }]
    );
}

#[test]
fn s5_3_other_characters_during_the_block_wait_zvz_then_nak_0704() {
    let config = Config {
        transmission_attempts: 1,
        ..Config::default()
    };
    let (mut sim, a, p) = scripted(config);
    let job = sim.with(a, |l, now| l.send(now, vec![0x55; 50]).unwrap());
    run_ms(&mut sim, 5);
    sim.transmit(p, &[DLE]);
    run_ms(&mut sim, 10);
    sim.transmit(p, b"??");
    let last_char = sim.now() + line().chars_time(2);
    settle(&mut sim);
    assert_eq!(
        sim.take_events(a),
        vec![Event::SendFailed {
            job,
            status: ABORTED_BY_PARTNER
        }]
    );
    // The NAK goes out once the line has been quiet for ZVZ ([ET200S SI] §2.7, sending: partner
    // interrupts the send).
    let naks = tx_times(&sim, "A", NAK);
    assert_eq!(naks.len(), 2, "startup NAK and the quiet NAK");
    assert_eq!(naks[1], last_char + line().gap_limit(ZVZ));
}

#[test]
fn s5_3_dle_before_our_transmitter_is_done_is_the_acknowledgement() {
    // Reading "DLE too early" (link.rs): a host's tx-done lags the wire, so a DLE after the
    // block has started counts as the acknowledgement.
    let (mut sim, a, p) = scripted(Config::default());
    let job = sim.with(a, |l, now| l.send(now, vec![0x55; 50]).unwrap());
    run_ms(&mut sim, 5);
    sim.transmit(p, &[DLE]);
    run_ms(&mut sim, 10);
    sim.transmit(p, &[DLE]);
    settle(&mut sim);
    assert_eq!(sim.take_events(a), vec![Event::Sent { job }]);
    assert_eq!(count_tx(&sim, "A", STX), 1);
}

#[test]
fn s5_3_qvz_expires_after_stx_0703() {
    let (mut sim, a, _p) = scripted(Config::default());
    let job = sim.with(a, |l, now| l.send(now, &b"x"[..]).unwrap());
    settle(&mut sim);
    assert_eq!(
        sim.take_events(a),
        vec![Event::SendFailed {
            job,
            status: SETUP_TIMEOUT
        }]
    );
    let stx = tx_times(&sim, "A", STX);
    assert_eq!(stx.len(), 6);
    // Each repetition follows QVZ after the STX left the transmitter.
    for w in stx.windows(2) {
        assert_eq!(w[1] - w[0], line().char_time() + QVZ);
    }
}

#[test]
fn s5_3_qvz_expires_after_the_block_0707() {
    let config = Config {
        transmission_attempts: 1,
        ..Config::default()
    };
    let (mut sim, a, p) = scripted(config);
    let job = sim.with(a, |l, now| l.send(now, &b"x"[..]).unwrap());
    run_ms(&mut sim, 5);
    sim.transmit(p, &[DLE]);
    settle(&mut sim);
    assert_eq!(
        sim.take_events(a),
        vec![Event::SendFailed {
            job,
            status: END_TIMEOUT
        }]
    );
    // The final NAK: QVZ after the last block character left.
    let block_start = tx_times(&sim, "A", b'x')[0];
    let end = block_start + line().chars_time(4);
    assert_eq!(*tx_times(&sim, "A", NAK).last().unwrap(), end + QVZ);
}

#[test]
fn s5_9_connection_attempts_start_again_for_each_transmission_attempt() {
    // Our reading: five refused STX, then the block is NAKed; the repetition may again use
    // up to six STX. Eleven refused STX in all, and the job still succeeds.
    let (mut sim, a, p) = scripted(Config::default());
    let job = sim.with(a, |l, now| l.send(now, &b"x"[..]).unwrap());
    for round in 0..2 {
        for _ in 0..5 {
            run_ms(&mut sim, 5);
            sim.transmit(p, &[NAK]);
        }
        run_ms(&mut sim, 5);
        sim.transmit(p, &[DLE]);
        run_ms(&mut sim, 10);
        sim.transmit(p, &[if round == 0 { NAK } else { DLE }]);
    }
    settle(&mut sim);
    assert_eq!(sim.take_events(a), vec![Event::Sent { job }]);
    assert_eq!(count_tx(&sim, "A", STX), 12);
    assert_eq!(sim.engine(a).counters().repetitions, 1);
}

#[test]
fn s5_3_first_error_is_reported_not_the_last() {
    // First attempt: NAK to STX (0702); then silence (0703) until the attempts run out.
    let (mut sim, a, p) = scripted(Config::default());
    let job = sim.with(a, |l, now| l.send(now, &b"x"[..]).unwrap());
    run_ms(&mut sim, 5);
    sim.transmit(p, &[NAK]);
    settle(&mut sim);
    assert_eq!(
        sim.take_events(a),
        vec![Event::SendFailed {
            job,
            status: SETUP_REJECTED
        }]
    );
}

// --- [ET200S SI] §2.7 / §2.7, Fig. 2-15 receiver error paths
// --------------------------------------------------------

/// The partner sends STX, waits for our DLE, then sends `block`.
fn partner_sends(sim: &mut si_sim::Simulator, p: si_sim::StationId<Partner>, block: &[u8]) {
    sim.transmit(p, &[STX]);
    run_ms(sim, 5);
    sim.transmit(p, block);
    run_ms(sim, 5 + block.len() as u64 * 2);
}

#[test]
fn s5_4_zvz_expires_during_the_block_nak_0806() {
    let (mut sim, a, p) = scripted(Config::default());
    sim.transmit(p, &[STX]);
    run_ms(&mut sim, 5);
    sim.transmit(p, &[0x01, 0x02]);
    let last = sim.now() + line().chars_time(2);
    settle(&mut sim);
    assert_eq!(
        sim.take_events(a),
        vec![Event::ReceiveError(CHARACTER_DELAY)]
    );
    assert_eq!(
        *tx_times(&sim, "A", NAK).last().unwrap(),
        last + line().gap_limit(ZVZ)
    );
    assert_eq!(sim.engine(a).received_blocks(), 0);
}

#[test]
fn s5_4_zvz_expires_before_the_first_character_0806() {
    let (mut sim, a, p) = scripted(Config::default());
    sim.transmit(p, &[STX]);
    settle(&mut sim);
    assert_eq!(
        sim.take_events(a),
        vec![Event::ReceiveError(CHARACTER_DELAY)]
    );
}

#[test]
fn s5_5_bcc_error_is_nakked_and_the_repetition_accepted() {
    let (mut sim, a, p) = scripted(Config::default());
    let mut bad = encode(b"abc", Mode::BlockCheck);
    *bad.last_mut().unwrap() ^= 0xFF;
    partner_sends(&mut sim, p, &bad);
    assert_eq!(sent_bytes(&sim, "A"), [NAK, DLE, NAK]);
    assert!(
        sim.take_events(a).is_empty(),
        "reported only if the repetitions fail"
    );
    run_ms(&mut sim, 1000); // within the 4 s block wait
    partner_sends(&mut sim, p, &encode(b"abc", Mode::BlockCheck));
    settle(&mut sim);
    assert_eq!(sim.take_events(a), vec![Event::Received { len: 3 }]);
    assert_eq!(sent_bytes(&sim, "A"), [NAK, DLE, NAK, DLE, DLE]);
}

#[test]
fn s5_5_bcc_error_between_two_links_is_repaired_by_repetition() {
    let (mut sim, a, b) = pair(with_priority(Priority::High), with_priority(Priority::Low));
    // B receives: 0 = A's startup NAK, 1 = STX, 2.. = the block; corrupt a data byte.
    sim.corrupt_received(b, 3, 0x04);
    let job = sim.with(a, |l, now| l.send(now, &b"hello"[..]).unwrap());
    settle(&mut sim);
    assert_eq!(sim.take_events(a), vec![Event::Sent { job }]);
    assert_eq!(sim.take_events(b), vec![Event::Received { len: 5 }]);
    assert_eq!(take(&mut sim, b).unwrap(), b"hello");
    assert_eq!(count_tx(&sim, "A", STX), 2);
}

#[test]
fn s5_5_no_repetition_within_the_block_wait_0808_then_0809() {
    let (mut sim, a, p) = scripted(Config::default());
    let mut bad = encode(b"abc", Mode::BlockCheck);
    *bad.last_mut().unwrap() ^= 0x01;
    partner_sends(&mut sim, p, &bad);
    let nak_at = *tx_times(&sim, "A", NAK).last().unwrap();
    settle(&mut sim);
    // The first error, then: the partner gave up before our attempts ran out ([derived]).
    assert_eq!(
        sim.take_events(a),
        vec![
            Event::ReceiveError(BCC_ERROR),
            Event::ReceiveError(REPETITIONS_DIFFER)
        ]
    );
    // Given up after the 4 s block wait, silently (the NAK was already sent).
    assert_eq!(count_tx(&sim, "A", NAK), 2);
    assert!(sim.now() >= nak_at + Duration::from_secs(4));
}

#[test]
fn s5_5_s_rcv_shows_the_first_error_and_then_0809_in_two_calls() {
    use si_3964r::fb::SRcv;
    let (mut sim, a, p) = scripted(Config::default());
    let mut bad = encode(b"abc", Mode::BlockCheck);
    *bad.last_mut().unwrap() ^= 0x01;
    partner_sends(&mut sim, p, &bad);
    settle(&mut sim);
    // S_RCV called only now, after both codes were raised (both are to be seen, the reading in si-3964r link.rs).
    let mut s_rcv = SRcv::default();
    let mut db = [0u8; 16];
    let mut shown = Vec::new();
    for _ in 0..4 {
        let out = sim.with(a, |l, now| s_rcv.call(l, now, true, false, &mut db));
        assert!(!out.ndr);
        if out.error {
            shown.push(out.status);
        }
    }
    assert_eq!(shown, vec![BCC_ERROR, REPETITIONS_DIFFER]);
}

#[test]
fn s5_5_bcc_error_on_every_repetition_gives_up_after_the_attempts_0808() {
    let (mut sim, a, p) = scripted(Config::default());
    let mut bad = encode(b"abc", Mode::BlockCheck);
    *bad.last_mut().unwrap() ^= 0x01;
    for _ in 0..6 {
        partner_sends(&mut sim, p, &bad);
        run_ms(&mut sim, 100);
    }
    assert_eq!(sim.take_events(a), vec![Event::ReceiveError(BCC_ERROR)]);
    assert_eq!(count_tx(&sim, "A", NAK), 1 + 6);
    // A seventh attempt is a fresh reception.
    partner_sends(&mut sim, p, &encode(b"abc", Mode::BlockCheck));
    settle(&mut sim);
    assert_eq!(sim.take_events(a), vec![Event::Received { len: 3 }]);
}

#[test]
fn s5_7_receiver_reports_the_first_error_when_the_repetition_breaks_off() {
    // A BCC error (0808), then the repetition stops mid-block (ZVZ): the first error counts.
    let (mut sim, a, p) = scripted(Config::default());
    let mut bad = encode(b"abc", Mode::BlockCheck);
    *bad.last_mut().unwrap() ^= 0x01;
    partner_sends(&mut sim, p, &bad);
    partner_sends(&mut sim, p, &[0x61]);
    settle(&mut sim);
    assert_eq!(sim.take_events(a), vec![Event::ReceiveError(BCC_ERROR)]);
}

#[test]
fn s5_4_parity_error_in_the_block_receives_to_the_end_then_nak_080c() {
    let config = Config {
        transmission_attempts: 1,
        ..Config::default()
    };
    let (mut sim, a, p) = scripted(config);
    sim.transmit(p, &[STX]);
    run_ms(&mut sim, 5);
    sim.with(a, |l, now| {
        si_core::Engine::handle_line_error(l, now, si_core::LineError::Parity)
    });
    sim.transmit(p, &encode(b"ab", Mode::BlockCheck));
    settle(&mut sim);
    assert_eq!(
        sim.take_events(a),
        vec![Event::ReceiveError(TRANSMISSION_ERROR)]
    );
    assert_eq!(sent_bytes(&sim, "A"), [NAK, DLE, NAK]);
}

#[test]
fn s5_10_odd_dle_is_0805() {
    let config = Config {
        transmission_attempts: 1,
        ..Config::default()
    };
    let (mut sim, a, p) = scripted(config);
    let mut block = vec![0x41, DLE, 0x42, DLE, ETX];
    block.push(block.iter().fold(0, |x, b| x ^ b));
    partner_sends(&mut sim, p, &block);
    settle(&mut sim);
    assert_eq!(sim.take_events(a), vec![Event::ReceiveError(ODD_DLE)]);
}

#[test]
fn s5_10_zero_length_block_is_acknowledged_and_reported_0807() {
    let (mut sim, a, p) = scripted(Config::default());
    partner_sends(&mut sim, p, &encode(b"", Mode::BlockCheck));
    settle(&mut sim);
    assert_eq!(sim.take_events(a), vec![Event::ReceiveError(ZERO_LENGTH)]);
    assert_eq!(sent_bytes(&sim, "A"), [NAK, DLE, DLE]);
}

#[test]
fn overlong_block_is_cut_off_at_the_first_byte_too_many_with_nak_and_0850() {
    let config = Config {
        max_block_len: 4,
        transmission_attempts: 1,
        ..Config::default()
    };
    let (mut sim, a, p) = scripted(config);
    partner_sends(&mut sim, p, &encode(b"12345", Mode::BlockCheck));
    settle(&mut sim);
    // NAK at the fifth byte (si_3964r::bound); this scripted partner ignores the NAK and sends
    // the rest of its block, which the idle link then answers as stray characters ([ET200S SI]
    // §2.7, receiving: idle).
    assert_eq!(
        sim.take_events(a),
        vec![
            Event::ReceiveError(BLOCK_TOO_LONG),
            Event::ReceiveError(IDLE_GARBAGE)
        ]
    );
    assert_eq!(sent_bytes(&sim, "A"), [NAK, DLE, NAK, NAK]);
    let received = sim.trace().received("A");
    let nak_at = sent(&sim, "A")[2].0;
    let fifth = received[5].0; // STX, then "12345"
    assert_eq!(nak_at, fifth, "the NAK answers the first byte too many");
}

#[test]
fn s5_4_buffer_full_waits_400_ms_then_nak_080a() {
    let config = Config {
        receive_buffer_blocks: 1,
        ..Config::default()
    };
    let (mut sim, a, p) = scripted(config);
    partner_sends(&mut sim, p, &encode(b"one", Mode::BlockCheck));
    assert_eq!(sim.take_events(a), vec![Event::Received { len: 3 }]);
    sim.transmit(p, &[STX]);
    let stx_in = sim.now() + line().char_time();
    settle(&mut sim);
    assert_eq!(
        sim.take_events(a),
        vec![Event::ReceiveError(NO_FREE_BUFFER)]
    );
    assert_eq!(
        *tx_times(&sim, "A", NAK).last().unwrap(),
        stx_in + Duration::from_millis(400)
    );
    assert_eq!(sent_bytes(&sim, "A"), [NAK, DLE, DLE, NAK]);
}

#[test]
fn s5_4_buffer_freed_within_400_ms_answers_dle() {
    let config = Config {
        receive_buffer_blocks: 1,
        ..Config::default()
    };
    let (mut sim, a, p) = scripted(config);
    partner_sends(&mut sim, p, &encode(b"one", Mode::BlockCheck));
    sim.transmit(p, &[STX]);
    run_ms(&mut sim, 200);
    assert_eq!(take(&mut sim, a).unwrap(), b"one");
    assert_eq!(*sent_bytes(&sim, "A").last().unwrap(), DLE);
    run_ms(&mut sim, 5);
    sim.transmit(p, &encode(b"two", Mode::BlockCheck));
    settle(&mut sim);
    let events = sim.take_events(a);
    assert_eq!(events.last(), Some(&Event::Received { len: 3 }));
    assert_eq!(take(&mut sim, a).unwrap(), b"two");
}

#[test]
fn s5_4_other_character_in_idle_waits_for_quiet_then_nak_0802() {
    let (mut sim, a, p) = scripted(Config::default());
    sim.transmit(p, b"xyz");
    let last = sim.now() + line().chars_time(3);
    settle(&mut sim);
    assert_eq!(sim.take_events(a), vec![Event::ReceiveError(IDLE_GARBAGE)]);
    assert_eq!(
        *tx_times(&sim, "A", NAK).last().unwrap(),
        last + line().gap_limit(ZVZ)
    );
}

#[test]
fn s5_4_nak_in_idle_is_ignored() {
    let (mut sim, a, p) = scripted(Config::default());
    sim.transmit(p, &[NAK]);
    settle(&mut sim);
    assert!(sim.take_events(a).is_empty());
    assert_eq!(sent_bytes(&sim, "A"), [NAK]);
}

#[test]
fn s5_7_corrupted_character_in_idle_is_reported_at_once_080c() {
    let (mut sim, a, _p) = scripted(Config::default());
    sim.with(a, |l, now| {
        si_core::Engine::handle_line_error(l, now, si_core::LineError::Framing)
    });
    assert_eq!(
        sim.take_events(a),
        vec![Event::ReceiveError(TRANSMISSION_ERROR)]
    );
    // Reported only: no NAK.
    assert_eq!(sent_bytes(&sim, "A"), [NAK]);
}

#[test]
fn s5_7_break_during_reception_returns_to_idle_080d() {
    let (mut sim, a, p) = scripted(Config::default());
    sim.transmit(p, &[STX]);
    run_ms(&mut sim, 5);
    sim.transmit(p, b"abc");
    sim.schedule_break(a, sim.now() + Duration::from_millis(10));
    settle(&mut sim);
    assert_eq!(sim.take_events(a), vec![Event::ReceiveError(BREAK)]);
    // No NAK, no retry: only the startup NAK and the DLE.
    assert_eq!(sent_bytes(&sim, "A"), [NAK, DLE]);
    // Idle again: the next block is received.
    partner_sends(&mut sim, p, &encode(b"ok", Mode::BlockCheck));
    settle(&mut sim);
    assert_eq!(sim.take_events(a), vec![Event::Received { len: 2 }]);
}

#[test]
fn s5_7_break_during_a_send_job_ends_it_080d() {
    let (mut sim, a, _p) = scripted(Config::default());
    let job = sim.with(a, |l, now| l.send(now, &b"x"[..]).unwrap());
    sim.schedule_break(a, sim.now() + Duration::from_millis(100));
    settle(&mut sim);
    assert_eq!(
        sim.take_events(a),
        vec![
            Event::SendFailed { job, status: BREAK },
            Event::ReceiveError(BREAK)
        ]
    );
    assert_eq!(count_tx(&sim, "A", STX), 1);
}

// --- 3964 without block check ------------------------------------------------------------------

#[test]
fn s5_2_plain_3964_without_bcc_both_ways() {
    let (mut sim, a, b) = pair(
        Config {
            priority: Priority::High,
            ..Config::without_block_check()
        },
        Config::without_block_check(),
    );
    let job = sim.with(a, |l, now| l.send(now, vec![0x10, 0x20]).unwrap());
    settle(&mut sim);
    assert_eq!(sim.take_events(a), vec![Event::Sent { job }]);
    assert_eq!(sim.take_events(b), vec![Event::Received { len: 2 }]);
    assert_eq!(
        sent_bytes(&sim, "A"),
        [NAK, STX, 0x10, 0x10, 0x20, DLE, ETX]
    );
    let jb = sim.with(b, |l, now| l.send(now, vec![0x30]).unwrap());
    settle(&mut sim);
    assert_eq!(sim.take_events(b), vec![Event::Sent { job: jb }]);
    assert_eq!(take(&mut sim, a).unwrap(), [0x30]);
}

#[test]
fn s5_8_plain_3964_qvz_default_is_550_ms() {
    let (mut sim, a, _p) = scripted(Config::without_block_check());
    let job = sim.with(a, |l, now| l.send(now, &b"x"[..]).unwrap());
    settle(&mut sim);
    assert_eq!(
        sim.take_events(a),
        vec![Event::SendFailed {
            job,
            status: SETUP_TIMEOUT
        }]
    );
    let stx = tx_times(&sim, "A", STX);
    assert_eq!(
        stx[1] - stx[0],
        line().char_time() + Duration::from_millis(550)
    );
}

#[test]
fn s5_2_3964r_receiver_rejects_a_plain_3964_block() {
    let config = Config {
        transmission_attempts: 1,
        ..Config::default()
    };
    let (mut sim, a, p) = scripted(config);
    // DLE ETX and no BCC: the receiver waits ZVZ for the BCC, then NAKs.
    partner_sends(&mut sim, p, &encode(b"ab", Mode::NoBlockCheck));
    settle(&mut sim);
    assert_eq!(
        sim.take_events(a),
        vec![Event::ReceiveError(CHARACTER_DELAY)]
    );
}

// --- API refusals ---------------------------------------------------------------------------

#[test]
fn send_refuses_empty_overlong_and_second_jobs() {
    let (mut sim, a, _p) = scripted(Config::default());
    use si_3964r::SendError;
    sim.with(a, |l, now| {
        assert_eq!(l.send(now, Vec::new()), Err(SendError::Empty));
        assert_eq!(
            l.send(now, vec![0; 201]),
            Err(SendError::TooLong { len: 201, max: 200 })
        );
        assert!(l.send(now, vec![1]).is_ok());
        assert_eq!(l.send(now, vec![1]), Err(SendError::Busy));
    });
    assert_eq!(Instant::ZERO, sim.now());
}
