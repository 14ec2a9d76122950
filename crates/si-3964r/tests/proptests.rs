//! Properties: the codec round-trips every payload up to the maximum, the decoder and the engine
//! never panic on arbitrary bytes at arbitrary times, and every job ends exactly once.

use proptest::prelude::*;
use si_3964r::frame::{decode, encode, Decoder, Mode};
use si_3964r::{Config, Event, JobId, Link, Priority};
use si_core::{Duration, Engine, Instant, LineError, Output, SerialSettings};
use std::collections::HashSet;

fn mode() -> impl Strategy<Value = Mode> {
    prop_oneof![Just(Mode::BlockCheck), Just(Mode::NoBlockCheck)]
}

proptest! {
    #[test]
    fn decode_of_encode_is_identity(payload in prop::collection::vec(any::<u8>(), 0..=200), mode in mode()) {
        let block = encode(&payload, mode);
        prop_assert_eq!(decode(&block, mode, 200), Ok(payload));
    }

    #[test]
    fn decode_of_encode_is_identity_up_to_1024(payload in prop::collection::vec(any::<u8>(), 201..=1024)) {
        let block = encode(&payload, Mode::BlockCheck);
        prop_assert_eq!(decode(&block, Mode::BlockCheck, 1024), Ok(payload));
    }

    #[test]
    fn one_more_byte_than_the_maximum_is_too_long(payload in prop::collection::vec(any::<u8>(), 1..=200)) {
        let block = encode(&payload, Mode::BlockCheck);
        let max = payload.len() - 1;
        prop_assert_eq!(decode(&block, Mode::BlockCheck, max), Err(si_3964r::FrameError::TooLong { max }));
    }

    #[test]
    fn decode_never_panics(bytes in prop::collection::vec(any::<u8>(), 0..600), mode in mode(), max in 0usize..300) {
        let _ = decode(&bytes, mode, max);
        let mut d = Decoder::new(mode, max);
        for b in bytes {
            let _ = d.push(b);
            prop_assert!(d.payload().len() <= max);
        }
    }

    #[test]
    fn a_single_flipped_bit_is_always_detected(payload in prop::collection::vec(any::<u8>(), 1..=60), at in any::<prop::sample::Index>(), bit in 0u8..8) {
        let mut block = encode(&payload, Mode::BlockCheck);
        let i = at.index(block.len());
        block[i] ^= 1 << bit;
        prop_assert!(decode(&block, Mode::BlockCheck, 200).is_err());
    }
}

/// One input to the engine.
#[derive(Debug, Clone)]
enum Step {
    Rx(Vec<u8>),
    Wait(u32),
    Timeout,
    LineError(u8),
    TxDone,
    Send(u16),
    Take,
    /// CPU STOP → RUN (clears the buffer with `clear_at_startup`).
    Restart,
}

fn step() -> impl Strategy<Value = Step> {
    // Bytes biased towards the control characters, so every state is reached.
    let byte = prop_oneof![
        4 => prop::sample::select(vec![0x02u8, 0x03, 0x10, 0x15]),
        1 => any::<u8>(),
    ];
    prop_oneof![
        4 => prop::collection::vec(byte, 1..8).prop_map(Step::Rx),
        3 => (0u32..5_000_000).prop_map(Step::Wait),
        2 => Just(Step::Timeout),
        1 => (0u8..4).prop_map(Step::LineError),
        1 => Just(Step::TxDone),
        1 => (0u16..260).prop_map(Step::Send),
        1 => Just(Step::Take),
        1 => Just(Step::Restart),
    ]
}

fn config() -> impl Strategy<Value = Config> {
    (
        any::<bool>(),
        any::<bool>(),
        1u8..4,
        1u8..4,
        1u8..3,
        any::<bool>(),
    )
        .prop_map(|(bcc, high, c, t, buf, clear)| {
            let mut config = if bcc {
                Config::default()
            } else {
                Config::without_block_check()
            };
            config.priority = if high { Priority::High } else { Priority::Low };
            config.connection_attempts = c;
            config.transmission_attempts = t;
            config.receive_buffer_blocks = buf;
            config.clear_at_startup = clear;
            config
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]
    #[test]
    fn the_engine_never_panics_and_ends_every_job_once(config in config(), steps in prop::collection::vec(step(), 0..200)) {
        let line = SerialSettings::default();
        let mut link = Link::new(config.with_settings(line)).unwrap();
        let mut now = Instant::ZERO;
        let mut deadline = None;
        let mut started: HashSet<JobId> = HashSet::new();
        let mut ended: HashSet<JobId> = HashSet::new();
        let mut announced = 0usize;
        let mut taken = 0usize;
        let mut cleared = 0usize;
        for step in steps {
            match step {
                Step::Rx(bytes) => link.handle_rx(now, &bytes),
                Step::Wait(us) => now += Duration::from_micros(u64::from(us)),
                Step::Timeout => {
                    if let Some(d) = deadline {
                        now = now.max(d);
                    }
                    link.handle_timeout(now);
                }
                Step::LineError(k) => {
                    let e = [LineError::Parity, LineError::Framing, LineError::Overrun, LineError::Break][usize::from(k)];
                    link.handle_line_error(now, e);
                }
                Step::TxDone => link.handle_tx_done(now),
                Step::Send(len) => {
                    if let Ok(job) = link.send(now, vec![0x10; usize::from(len)]) {
                        prop_assert!(started.insert(job));
                    }
                }
                Step::Take => {
                    if link.take_block(now).is_some() {
                        taken += 1;
                    }
                }
                Step::Restart => {
                    let before = link.received_blocks();
                    link.restart(now);
                    cleared += before - link.received_blocks();
                    if !config.clear_at_startup {
                        prop_assert_eq!(link.received_blocks(), before);
                    }
                }
            }
            // Drain: bounded output per input, deadlines never in the past of the input time
            // by more than the engine could know.
            let mut outputs = 0;
            loop {
                outputs += 1;
                prop_assert!(outputs < 64, "unbounded output");
                match link.poll_output() {
                    Output::Event(Event::Sent { job }) | Output::Event(Event::SendFailed { job, .. }) => {
                        prop_assert!(started.contains(&job), "completion of a job never started");
                        prop_assert!(ended.insert(job), "job ended twice");
                    }
                    Output::Event(Event::Received { .. }) => announced += 1,
                    Output::Wait(d) => {
                        deadline = d;
                        break;
                    }
                    _ => {}
                }
            }
            prop_assert!(link.received_blocks() <= usize::from(config.receive_buffer_blocks));
            prop_assert_eq!(announced, taken + cleared + link.received_blocks());
        }
        // Every job ends: run the clock until the engine has nothing left to wait for.
        for _ in 0..10_000 {
            let Some(d) = deadline else { break };
            now = now.max(d);
            link.handle_timeout(now);
            loop {
                match link.poll_output() {
                    Output::Event(Event::Sent { job }) | Output::Event(Event::SendFailed { job, .. }) => {
                        prop_assert!(ended.insert(job), "job ended twice");
                    }
                    Output::Wait(d) => {
                        deadline = d;
                        break;
                    }
                    _ => {}
                }
            }
        }
        prop_assert_eq!(started, ended, "a job never ended");
    }
}
