//! A bound on every job: a 3964(R) send job ends with a non-zero STATUS within
//! [`Config::send_job_bound`] whatever the partner does: silence, random characters, an
//! endless frame (`STX` then data for ever, `DLE`-doubled data with no `DLE ETX`), a flood, noise
//! that stops. Virtual time on the line simulator; the noise peers are si-testkit's
//! ([`issue_patterns`]).

use proptest::prelude::*;
use si_3964r::frame::{DLE, STX};
use si_3964r::status::*;
use si_3964r::{Config, Event, JobId, Link, Priority};
use si_core::{Duration, Instant, SerialSettings, Status};
use si_sim::{Simulator, StationId};
use si_testkit::job_run::run_while;
use si_testkit::noise::{facing, issue_patterns, Facing, Noise, Pattern, Source, SILENT};

fn line() -> SerialSettings {
    SerialSettings::default()
}

/// Short timers so each case runs a few seconds of virtual time; the bound scales with them.
fn short(priority: Priority) -> Config {
    Config {
        priority,
        ack_delay: si_core::Duration::from_millis(200),
        char_delay: si_core::Duration::from_millis(50),
        connection_attempts: 3,
        transmission_attempts: 3,
        max_block_len: 64,
        ..Config::default()
    }
}

/// A partner that sends `DLE` for ever: after an `STX`, `DLE`-doubled data with no `DLE ETX`.
/// Its `DLE`s also acknowledge our `STX` and our block when they come at the right moment
/// ([ET200S SI] §2.7, sending: connection setup and cleardown), so a job facing it may end with
/// success; it must still end in time.
fn endless_dles() -> Pattern {
    Pattern {
        name: "DLE flood",
        noise: Noise::Flood(Source::Fixed(DLE)),
        until: None,
    }
}

/// Every noise pattern (the STX flood is an endless frame: `STX`, then data for ever).
/// None holds a `DLE` that acknowledges at the right moment (the random ones by their seeds),
/// so each must fail the job.
fn patterns() -> Vec<Pattern> {
    issue_patterns(line().char_time())
}

/// The host link facing `pattern`; sends `len` bytes at `at` and runs until the job ends.
/// Returns how long it took, the outcome and the host's events.
fn send_into(
    config: Config,
    pattern: Pattern,
    seed: u64,
    at: Duration,
    len: usize,
) -> (Duration, Result<(), Status>, Vec<Event>) {
    let Facing {
        mut sim,
        engine: host,
        ..
    } = facing(
        seed,
        line(),
        Link::new(config.with_settings(line())).unwrap(),
        pattern,
    );
    sim.run_for(at);
    let start = sim.now();
    let job = sim
        .with(host, |l, now| l.send(now, vec![0x55; len]))
        .unwrap();
    let bound = config.send_job_bound(&line(), len);
    let end = run_while(&mut sim, start + bound, |sim| sim.engine(host).is_sending());
    let outcome = outcome(&sim, host, job);
    (end.saturating_since(start), outcome, sim.take_events(host))
}

fn outcome(sim: &Simulator, host: StationId<Link>, job: JobId) -> Result<(), Status> {
    let outcome = sim.engine(host).job_outcome(job);
    outcome.unwrap_or_else(|| panic!("job {job:?} ended without an outcome"))
}

/// Exactly one end event for the job, matching its outcome.
fn ends_once(events: &[Event], outcome: Result<(), Status>) -> bool {
    let ends: Vec<_> = events
        .iter()
        .filter(|e| matches!(e, Event::Sent { .. } | Event::SendFailed { .. }))
        .collect();
    match (ends.as_slice(), outcome) {
        ([Event::Sent { .. }], Ok(())) => true,
        ([Event::SendFailed { status, .. }], Err(s)) => *status == s && !s.is_ok(),
        _ => false,
    }
}

#[test]
fn every_pattern_ends_the_job_with_a_status_within_the_bound() {
    for priority in [Priority::Low, Priority::High] {
        for (i, noise) in patterns().into_iter().enumerate() {
            let name = noise.name;
            for at in [Duration::ZERO, Duration::from_millis(37)] {
                let (took, outcome, events) = send_into(short(priority), noise, i as u64, at, 10);
                assert!(outcome.is_err(), "{priority:?} {name}: {outcome:?}");
                assert!(ends_once(&events, outcome), "{name}: {events:?}");
                assert!(took > Duration::ZERO, "{name}");
            }
        }
    }
}

#[test]
fn an_endless_dle_doubled_frame_ends_the_job_within_the_bound() {
    for priority in [Priority::Low, Priority::High] {
        for at in [Duration::ZERO, Duration::from_millis(37)] {
            // send_into asserts the bound; the outcome may be either (see endless_dles).
            let (_, outcome, events) = send_into(short(priority), endless_dles(), 3, at, 10);
            assert!(ends_once(&events, outcome), "{events:?}");
        }
    }
}

#[test]
fn a_silent_partner_ends_the_job_after_the_connection_attempts_with_0703() {
    let config = short(Priority::Low);
    let (took, outcome, _) = send_into(config, patterns()[0], 1, Duration::ZERO, 10);
    assert_eq!(outcome, Err(SETUP_TIMEOUT));
    // Three STX, each waiting one character and QVZ: the manual's own ending, well inside the
    // bound.
    let per_try = line().char_time() + Duration::from_millis(200);
    assert_eq!(took, per_try.saturating_mul(3));
}

/// The defaults at 9600 bit/s: a flood and an endless frame end within the documented
/// 88.83 s for a 200-byte block (si_3964r::bound).
#[test]
fn the_defaults_hold_their_documented_bound_against_a_flood_and_an_endless_frame() {
    assert_eq!(
        Config::default().send_job_bound(&line(), 200),
        Duration::from_micros(88_828_558)
    );
    for noise in patterns()
        .into_iter()
        .filter(|p| matches!(p.noise, Noise::Flood(_)) && p.until.is_none())
    {
        let (_, outcome, events) = send_into(Config::default(), noise, 21, Duration::ZERO, 200);
        assert!(outcome.is_err(), "{}", noise.name);
        assert!(ends_once(&events, outcome), "{events:?}");
    }
    // send_into asserts the bound whatever the outcome.
    let _ = send_into(Config::default(), endless_dles(), 21, Duration::ZERO, 200);
}

/// A partner that sends `STX` and then data for ever is cut off with NAK after the maximum
/// block length, reported as 0850, instead of holding the receiver (and the pending job).
#[test]
fn an_endless_frame_is_cut_off_at_the_maximum_length_with_0850() {
    let config = short(Priority::Low);
    let Facing {
        mut sim,
        engine: host,
        peer,
    } = facing(
        5,
        line(),
        Link::new(config.with_settings(line())).unwrap(),
        SILENT,
    );
    let mut frame = vec![STX];
    frame.extend([b'A'; 1_000]);
    sim.transmit(peer, &frame);
    // STX, then 64 bytes fit; the 65th, the 66th character, is one too many.
    sim.run_until(Instant::ZERO + line().chars_time(65));
    assert_eq!(sim.engine(host).counters().blocks_rejected, 0);
    sim.run_until(Instant::ZERO + line().chars_time(67));
    assert_eq!(sim.engine(host).counters().blocks_rejected, 1);
    // No STX follows, so no repetition comes within the 4 s block wait: 0850 ([ET200S SI] §2.7,
    // Fig. 2-15), then 0809 for the repetition that never came ([derived]).
    sim.run_for(Duration::from_millis(4_100));
    assert_eq!(
        sim.take_events(host),
        vec![
            Event::ReceiveError(BLOCK_TOO_LONG),
            Event::ReceiveError(REPETITIONS_DIFFER)
        ]
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Random bursts of random characters with random gaps, from any instant: the job ends
    /// within its bound, and when it fails, with a STATUS.
    #[test]
    fn random_noise_streams_end_the_job_within_the_bound(
        bursts in prop::collection::vec(
            (prop::collection::vec(any::<u8>(), 1..40), 0u64..300),
            0..40,
        ),
        high in any::<bool>(),
        len in 1usize..64,
    ) {
        let config = short(if high { Priority::High } else { Priority::Low });
        let Facing { mut sim, engine: host, peer } =
            facing(9, line(), Link::new(config.with_settings(line())).unwrap(), SILENT);
        let job = sim.with(host, |l, now| l.send(now, vec![0xAA; len])).unwrap();
        let limit = Instant::ZERO + config.send_job_bound(&line(), len);
        let mut end = None;
        'feed: for (burst, gap_ms) in bursts {
            sim.transmit(peer, &burst);
            let until = sim.now() + line().chars_time(burst.len() as u64) + Duration::from_millis(gap_ms);
            while sim.now() < until {
                if !sim.step() {
                    sim.run_until(until);
                }
                if !sim.engine(host).is_sending() {
                    end = Some(sim.now());
                    break 'feed;
                }
            }
        }
        let end = match end {
            Some(end) => end,
            None => run_while(&mut sim, limit, |sim| sim.engine(host).is_sending()),
        };
        prop_assert!(end <= limit, "ended at {end}, bound {limit}");
        match sim.engine(host).job_outcome(job) {
            Some(Ok(())) => {}
            Some(Err(status)) => prop_assert!(!status.is_ok()),
            None => prop_assert!(false, "no outcome"),
        }
    }
}

/// A driver flooded with input may call the engine only with bytes, never on its timer: the
/// job's bound is still judged, on the bytes' arrival (si_3964r::bound).
#[test]
fn the_bound_ends_the_job_on_input_alone_when_the_timer_never_fires() {
    use si_core::{Engine, Output};
    let config = short(Priority::Low);
    let mut link = Link::new(config.with_settings(line())).unwrap();
    link.set_rx_latency(Duration::ZERO); // a byte-by-byte port: the manual's bound
    let job = link.send(Instant::ZERO, vec![1, 2, 3]).unwrap();
    let bound = Instant::ZERO + config.send_job_bound(&line(), 3);
    // The partner's STX (we yield), then data every millisecond: the link receives, cuts the
    // block off and waits for a repetition whose 4 s timer never fires.
    let mut events = Vec::new();
    let mut now = Instant::ZERO;
    // Input comes every millisecond: the job ends at the first input after its bound.
    let last = bound + Duration::from_millis(1);
    while now <= last {
        let byte = if now == Instant::ZERO { STX } else { b'A' };
        link.handle_rx(now, &[byte]);
        while let Some(output) = match link.poll_output() {
            Output::Wait(_) => None,
            other => Some(other),
        } {
            if let Output::Event(e) = output {
                events.push((now, e));
            }
        }
        now += Duration::from_millis(1);
    }
    let ends: Vec<_> = events
        .iter()
        .filter(|(_, e)| matches!(e, Event::SendFailed { .. }))
        .collect();
    assert_eq!(ends.len(), 1, "{events:?}");
    assert!(ends[0].0 >= bound && ends[0].0 <= last, "{:?}", ends[0]);
    assert!(
        matches!(ends[0].1, Event::SendFailed { job: j, status } if j == job && !status.is_ok())
    );
}
