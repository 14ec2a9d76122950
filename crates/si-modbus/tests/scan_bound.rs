//! A scan's announced time holds on a noisy line: one probe ([`PROBE`], one try) against a
//! peer that garbles or never goes quiet ends, in the engine's own time, within
//! [`probe_bound`], the per-probe share of what `si modbus scan` announces. The worst of these
//! peers makes a probe last longer than the response time plus a valid answer's 7 characters:
//! a garbled answer runs to the longest frame, and a request waits for silence first.

use si_core::{Duration, Instant, SerialSettings};
use si_modbus::master::{Master, MasterEvent};
use si_modbus::scan::{probe_bound, PROBE};
use si_modbus::{status, FrameEnd, MasterConfig};
use si_sim::{Simulator, StationId};
use si_testkit::noise::{facing, issue_patterns, Facing, Noise, Pattern, Source};

fn config() -> MasterConfig {
    MasterConfig {
        response_timeout: Duration::from_millis(200),
        retries: 0,
        ..MasterConfig::default()
    }
}

/// A line that never goes quiet: a random character every two character times (never an
/// end-of-frame gap), from the start, forever.
fn never_quiet(seed: u64) -> Pattern {
    Pattern {
        name: "a character every two character times, never a gap",
        noise: Noise::Every {
            every: SerialSettings::default().char_time().saturating_mul(2),
            burst: 1,
            bytes: Source::Random(seed),
        },
        until: None,
    }
}

/// Start a probe on `m` now and step the simulator until it ends: how long it took in the
/// simulator's (the engine's) time, and its STATUS (0: completed). `None` if it has not ended
/// by `horizon`.
fn probe(sim: &mut Simulator, m: StationId<Master>, horizon: Duration) -> Option<(Duration, u16)> {
    sim.with(m, |e, now| e.request(now, 1, &PROBE)).unwrap();
    let began = sim.now();
    loop {
        // The instant the step runs at is the one its events happen at.
        let at = sim.now();
        if at.saturating_since(began) > horizon || !sim.step() {
            return None;
        }
        let at = sim.now().max(at);
        for event in sim.take_events(m) {
            match event {
                MasterEvent::Failed { status, .. } => {
                    return Some((at.saturating_since(began), status.code()))
                }
                MasterEvent::Completed(_) => return Some((at.saturating_since(began), 0)),
                MasterEvent::Diagnostic(_) => {}
            }
        }
    }
}

#[test]
fn a_probe_ends_within_its_bound_under_every_noise() {
    let c = config();
    let mut worst = Duration::ZERO;
    for frame_end in [FrameEnd::Gap, FrameEnd::Length] {
        let mut patterns = issue_patterns(SerialSettings::default().char_time());
        patterns.push(never_quiet(77));
        for pattern in patterns {
            let engine = Master::new(c).unwrap().with_frame_end(frame_end);
            let bound = probe_bound(&engine, Duration::ZERO);
            let Facing {
                mut sim, engine: m, ..
            } = facing(3, SerialSettings::default(), engine, pattern);
            // Noise first, so the probe starts on a busy line.
            sim.run_until(Instant::from_micros(50_000));
            let what = format!("{} ({frame_end:?})", pattern.name);
            let (took, status) = probe(&mut sim, m, bound.saturating_mul(3))
                .unwrap_or_else(|| panic!("{what}: no end within 3 × {bound}"));
            assert!(took <= bound, "{what}: {took} > {bound}");
            assert_ne!(status, 0, "{what}");
            worst = worst.max(took);
        }
    }
    // The peers do stretch a probe beyond the response time and a valid answer's 23
    // characters (request, answer, two gaps: the scan's former bound) and beyond the response
    // time and the longest frame.
    let valid = SerialSettings::default().chars_time(8 + 7 + 8) + c.response_timeout;
    assert!(worst > valid, "worst {worst}, a valid answer's {valid}");
    assert!(worst > c.response_timeout + c.max_frame_time(), "{worst}");
}

#[test]
fn a_probe_held_by_the_quiet_guard_ends_within_its_bound() {
    // The first probe fails on a line that never goes quiet; the guard then holds the second
    // as long as it may before the second's own job time starts: longer than the job bound
    // alone.
    let c = config();
    let quiet = Duration::from_millis(1_000);
    let engine = Master::new(c).unwrap().with_quiet_after_timeout(quiet);
    let bound = probe_bound(&engine, Duration::ZERO);
    let Facing {
        mut sim, engine: m, ..
    } = facing(4, SerialSettings::default(), engine, never_quiet(5));
    let (_, first) = probe(&mut sim, m, bound).expect("the first probe ends");
    assert_eq!(first, status::RESPONSE_TIMEOUT.code());
    let (took, second) = probe(&mut sim, m, bound.saturating_mul(3)).expect("the second ends");
    assert_eq!(second, status::RESPONSE_TIMEOUT.code());
    assert!(took <= bound, "{took} > {bound}");
    assert!(took > c.job_bound(), "{took}: the guard did not hold it");
}
