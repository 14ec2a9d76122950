//! A bound on every master job under noise (the crate docs, "Bounds"): against a
//! partner that never sends a valid response (silent, random bytes, 01H every 2 ms, an endless
//! frame, a flood, noise that stops), every job — read, write, diagnostics — ends with a
//! non-zero STATUS within [`MasterConfig::job_bound`], in virtual time, through S_SEND too.

use proptest::prelude::*;
use si_core::{Duration, Instant, SerialSettings};
use si_modbus::frame::{Registers, Request};
use si_modbus::master::{Master, MasterEvent};
use si_modbus::{status, FrameEnd, MasterConfig, Mode};
use si_sim::UsbAdapter;
use si_testkit::noise::{drive, facing, issue_patterns, Facing, Pattern};

const WORDS: [u16; 2] = [1, 2];

/// `modbus read`, `modbus write` (one and several registers), `modbus diag`.
fn jobs() -> [Request<'static>; 4] {
    [
        Request::ReadHoldingRegisters {
            address: 0,
            quantity: 10,
        },
        Request::WriteSingleRegister {
            address: 1,
            value: 7,
        },
        Request::WriteMultipleRegisters {
            address: 1,
            values: Registers::Words(&WORDS),
        },
        Request::Diagnostics { data: 0x1234 },
    ]
}

fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}

fn configs() -> Vec<(MasterConfig, FrameEnd)> {
    let mut out = Vec::new();
    for mode in [Mode::Normal, Mode::InterferenceSuppression] {
        for retries in [0, 2] {
            for frame_end in [FrameEnd::Gap, FrameEnd::Length] {
                let mut c = MasterConfig {
                    response_timeout: si_core::Duration::from_millis(500),
                    retries,
                    ..MasterConfig::default()
                };
                c.line.mode = mode;
                out.push((c, frame_end));
            }
        }
    }
    out
}

/// Run `job` against `noise` and return the job's end: it must be a failure, within the bound.
fn assert_bounded(
    config: MasterConfig,
    frame_end: FrameEnd,
    adapter: bool,
    job: &Request<'_>,
    pattern: Pattern,
) {
    let name = pattern.name;
    let master = Master::new(config).unwrap().with_frame_end(frame_end);
    let Facing {
        mut sim, engine: m, ..
    } = facing(1, SerialSettings::default(), master, pattern);
    if adapter {
        sim.set_adapter(m, UsbAdapter::FTDI_DEFAULT.unannounced())
            .unwrap();
    }
    // Noise first, so the job starts on a busy line.
    sim.run_until(Instant::from_micros(50_000));
    let start = sim.now();
    sim.with(m, |e, now| e.request(now, 1, job)).unwrap();
    let bound = config.job_bound();
    sim.run_until(start + bound);
    let what = format!("{name}, {job:?}, {config:?}, {frame_end:?}, adapter {adapter}");
    let events: Vec<_> = sim
        .take_events(m)
        .into_iter()
        .filter(|e| !matches!(e, MasterEvent::Diagnostic(_)))
        .collect();
    assert_eq!(events.len(), 1, "{what}: {events:?}");
    let MasterEvent::Failed { status, .. } = events[0] else {
        panic!("{what}: {events:?}")
    };
    assert_ne!(status.code(), 0, "{what}");
    assert!(!sim.engine(m).is_busy(), "{what}");
}

#[test]
fn every_job_ends_with_a_status_within_its_bound_under_every_noise() {
    for (config, frame_end) in configs() {
        for job in &jobs() {
            for pattern in issue_patterns(SerialSettings::default().char_time()) {
                assert_bounded(config, frame_end, false, job, pattern);
            }
        }
    }
}

#[test]
fn behind_a_usb_adapter_too() {
    let config = MasterConfig {
        response_timeout: si_core::Duration::from_millis(500),
        ..MasterConfig::default()
    };
    for pattern in issue_patterns(SerialSettings::default().char_time()) {
        assert_bounded(config, FrameEnd::Gap, true, &jobs()[0], pattern);
    }
}

#[test]
fn an_s_send_job_ends_with_error_within_the_bound_under_every_noise() {
    // The FB layer (S_SEND over the master, si_core::fb) inherits the master's bound.
    let config = MasterConfig {
        response_timeout: si_core::Duration::from_millis(500),
        ..MasterConfig::default()
    };
    let s = SerialSettings::default();
    for pattern in issue_patterns(s.char_time()) {
        let Facing {
            mut sim, engine: m, ..
        } = facing(1, s, Master::new(config).unwrap(), pattern);
        sim.run_until(Instant::from_micros(50_000));
        let start = sim.now();
        let job = [0x01, 0x03, 0x00, 0x00, 0x00, 0x01];
        let mut s_send = si_core::fb::SSend::default();
        let first = sim.with(m, |e, now| s_send.call(e, now, true, false, &job));
        assert!(!first.done && !first.error, "{}", pattern.name);
        sim.run_until(start + config.job_bound());
        let out = sim.with(m, |e, now| s_send.call(e, now, true, false, &job));
        assert!(
            out.error && out.status.code() != 0,
            "{}: {out:?}",
            pattern.name
        );
    }
}

#[test]
fn a_silent_partner_gives_0830h_after_the_response_time() {
    // The bound does not change the manual's timing: silence is 0830H at the response time.
    let config = MasterConfig {
        response_timeout: si_core::Duration::from_millis(500),
        ..MasterConfig::default()
    };
    let Facing {
        mut sim, engine: m, ..
    } = facing(
        1,
        SerialSettings::default(),
        Master::new(config).unwrap(),
        si_testkit::noise::SILENT,
    );
    sim.with(m, |e, now| e.request(now, 1, &jobs()[0])).unwrap();
    // 8 request bytes (9.2 ms) + 500 ms.
    sim.run_until(Instant::from_micros(509_000));
    assert!(sim.take_events(m).is_empty());
    sim.run_until(Instant::from_micros(510_000));
    assert!(matches!(
        sim.take_events(m)[..],
        [MasterEvent::Failed { status, .. }] if status == status::RESPONSE_TIMEOUT
    ));
}

#[test]
fn the_issue_s_example_is_under_2_5_s() {
    // `modbus read --response-timeout-ms 500` at 9600 bit/s (8E1), no retries.
    let config = MasterConfig {
        response_timeout: si_core::Duration::from_millis(500),
        ..MasterConfig::default()
    };
    assert!(config.job_bound() < ms(2_500), "{:?}", config.job_bound());
    // The crate docs' worked example ("Bounds").
    assert_eq!(config.max_response_duration().as_micros(), 562_646);
    assert_eq!(config.job_bound().as_micros(), 2_183_938);
    // And each retry adds one attempt.
    let twice = MasterConfig {
        retries: 1,
        ..config
    };
    assert_eq!(twice.job_bound(), config.attempt_bound().saturating_mul(2));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// Any noise stream with any timing: a pattern of chunks (up to 64 bytes, 0–3 ms apart so
    /// that the line seldom goes quiet, or 0–20 ms), repeated for up to 3000 chunks, faster than
    /// the line or not, then silence: the job ends within its bound.
    #[test]
    fn any_noise_ends_the_job_within_its_bound(
        pattern in prop::collection::vec(
            (prop_oneof![0u64..3_000, 0u64..20_000], prop::collection::vec(any::<u8>(), 0..64)),
            1..20,
        ),
        total in 0usize..3_000,
        suppress in any::<bool>(),
        length in any::<bool>(),
        retries in 0u8..3,
        timeout in 50u32..1_000,
        job in 0usize..4,
    ) {
        let mut config = MasterConfig {
            response_timeout: si_core::Duration::from_millis(timeout.into()),
            retries,
            ..MasterConfig::default()
        };
        if suppress {
            config.line.mode = Mode::InterferenceSuppression;
        }
        let frame_end = if length { FrameEnd::Length } else { FrameEnd::Gap };
        let mut master = Master::new(config).unwrap().with_frame_end(frame_end);
        let start = Instant::from_micros(1_000);
        master.request(start, 1, &jobs()[job]).unwrap();
        let bound = config.job_bound();
        let chunks: Vec<_> = pattern.iter().cycle().take(total).cloned().collect();
        let end = drive(
            &mut master,
            start,
            &chunks,
            config.line.settings.char_time(),
            start + bound + ms(10_000),
            |e| !matches!(e, MasterEvent::Diagnostic(_)),
        );
        let Some((at, _)) = end else {
            return Err(TestCaseError::fail("the job never ended"));
        };
        prop_assert!(at <= start + bound, "ended at {:?}, bound {:?}", at, bound);
    }
}
