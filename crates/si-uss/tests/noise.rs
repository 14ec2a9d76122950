//! A bound on every USS master job under noise (the crate docs, "Bounds"): against a
//! line that never carries a valid response (silent, random bytes, 01H every 2 ms, an endless
//! frame, floods, noise that stops), a parameter job (`uss read-param`) ends with a failure
//! within [`MasterConfig::job_bound`] and a cycle (`uss poll --cycles 1`) within
//! [`MasterConfig::cycle_bound`], in virtual time.

use proptest::prelude::*;
use si_core::{Duration, Instant};
use si_sim::{Simulator, StationId};
use si_testkit::noise::{drive, facing, issue_patterns, Facing, Pattern};
use si_uss::config::{uss_settings, MasterConfig, PollEntry};
use si_uss::frame::PkwWords;
use si_uss::master::{Event, Master, ParamRequest};

fn config(retries: u16) -> MasterConfig {
    let mut c = MasterConfig::new(vec![PollEntry::new(1, PkwWords::Four, 2)]);
    c.settings = uss_settings(9_600).unwrap();
    c.retries = retries;
    c
}

/// A master on a line with `pattern` as its only partner, after 50 ms of it.
fn on_noise(config: &MasterConfig, pattern: Pattern) -> (Simulator, StationId<Master>) {
    let Facing {
        mut sim, engine: m, ..
    } = facing(
        2,
        config.settings,
        Master::new(config.clone()).unwrap(),
        pattern,
    );
    sim.run_until(Instant::from_micros(50_000));
    (sim, m)
}

fn is_job_end(e: &Event) -> bool {
    matches!(
        e,
        Event::ParameterDone { .. } | Event::ParameterFailed { .. }
    )
}

#[test]
fn read_param_fails_within_its_bound_under_every_noise() {
    for retries in [0, 2] {
        let config = config(retries);
        for pattern in issue_patterns(config.settings.char_time()) {
            let (mut sim, m) = on_noise(&config, pattern);
            let start = sim.now();
            sim.with(m, |e, now| {
                e.start(now);
                e.request_parameter(now, 1, ParamRequest::read(700, 0))
                    .unwrap();
                e.stop_when_idle();
            });
            sim.run_until(start + config.job_bound());
            let ends: Vec<_> = sim.take_events(m).into_iter().filter(is_job_end).collect();
            let what = format!("{}, WDH {retries}: {ends:?}", pattern.name);
            assert!(
                matches!(ends[..], [Event::ParameterFailed { status, .. }] if status.code() != 0),
                "{what}"
            );
        }
    }
}

#[test]
fn one_cycle_ends_within_its_bound_under_every_noise() {
    let config = config(20);
    for pattern in issue_patterns(config.settings.char_time()) {
        let (mut sim, m) = on_noise(&config, pattern);
        let start = sim.now();
        sim.with(m, |e, now| {
            e.stop_after_cycles(1);
            e.start(now);
        });
        // The first poll is due at once; a cycle is one poll here.
        sim.run_until(start + config.cycle_bound());
        let events = sim.take_events(m);
        let what = format!("{}: {events:?}", pattern.name);
        assert!(
            events
                .iter()
                .any(|e| matches!(e, Event::NoAnswer { .. } | Event::Rejected { .. })),
            "{what}"
        );
        assert!(
            events.iter().any(|e| matches!(e, Event::CycleDone { .. })),
            "{what}"
        );
    }
}

#[test]
fn a_poll_under_a_flood_goes_out_after_the_wait_for_silence() {
    // Without the bound a master waits for a start interval of silence forever.
    let config = config(0);
    let flood = issue_patterns(config.settings.char_time())
        .into_iter()
        .find(|p| p.name == "01H flood")
        .unwrap();
    let (mut sim, m) = on_noise(&config, flood);
    let start = sim.now();
    sim.with(m, |e, now| e.start(now));
    // Due after a start interval since the last character, then at most the wait.
    let wait = config.max_wait_for_silence();
    sim.run_until(start + wait);
    assert_eq!(sim.engine(m).counters().sent, 0);
    sim.run_until(start + wait + config.start_interval() + Duration::from_millis(2));
    assert_eq!(sim.engine(m).counters().sent, 1);
}

#[test]
fn the_crate_docs_example_numbers() {
    // "Bounds" in the crate docs: 9600 bit/s, one slave, 20 ms.
    assert_eq!(config(0).max_wait_for_silence().as_micros(), 697_866);
    assert_eq!(config(0).poll_bound().as_micros(), 1_962_920);
    assert_eq!(config(0).job_bound().as_micros(), 2 * 1_962_920);
    assert_eq!(config(20).job_bound().as_micros(), 22 * 1_962_920);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    /// Any noise stream with any timing (a pattern of chunks mostly 0–2 ms apart, under the
    /// start interval, some 0–20 ms, repeated for up to 8000 chunks, then silence): a parameter job ends within its bound, and the
    /// engine never asks for the same instant over and over (no busy loop).
    #[test]
    fn any_noise_ends_a_parameter_job_within_its_bound(
        pattern in prop::collection::vec(
            (prop_oneof![3 => 0u64..2_000, 1 => 0u64..20_000], prop::collection::vec(any::<u8>(), 0..64)),
            1..20,
        ),
        total in 0usize..8_000,
        retries in 0u16..3,
    ) {
        let config = config(retries);
        let mut master = Master::new(config.clone()).unwrap();
        let start = Instant::from_micros(1_000);
        master.start(start);
        master.request_parameter(start, 1, ParamRequest::read(700, 0)).unwrap();
        master.stop_when_idle();
        let chunks: Vec<_> = pattern.iter().cycle().take(total).cloned().collect();
        let bound = config.job_bound();
        let end = drive(
            &mut master,
            start,
            &chunks,
            config.settings.char_time(),
            start + bound + Duration::from_secs(10),
            is_job_end,
        );
        let Some((at, _)) = end else {
            return Err(TestCaseError::fail("the job never ended"));
        };
        prop_assert!(at <= start + bound, "ended at {:?}, bound {:?}", at, bound);
    }
}
