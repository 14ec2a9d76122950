//! A bound on every job: an RK 512 FETCH or SEND ends with a non-zero STATUS within
//! [`Config::job_bound`] whatever the partner does: silence, random characters, an endless
//! 3964(R) frame, a flood, noise that stops. Virtual time on the line simulator; the noise peer
//! is si-testkit's.

use proptest::prelude::*;
use si_3964r::frame::DLE;
use si_3964r::Priority;
use si_core::{Duration, Instant, SerialSettings, Status};
use si_rk512::frame::{Address, Coordination};
use si_rk512::{status, Config, Event, JobId, Station};
use si_sim::{Simulator, StationId};
use si_testkit::job_run::run_while;
use si_testkit::noise::{facing, issue_patterns, Facing, Noise, Pattern, Source};

fn line() -> SerialSettings {
    SerialSettings::default()
}

/// Short timers so each case runs seconds of virtual time; the bound scales with them.
fn short(priority: Priority) -> Config {
    let mut c = Config {
        response_timeout: Duration::from_millis(1_000),
        ..Config::default()
    };
    c.link.priority = priority;
    c.link.ack_delay = si_core::Duration::from_millis(200);
    c.link.char_delay = si_core::Duration::from_millis(50);
    c.link.connection_attempts = 2;
    c.link.transmission_attempts = 2;
    c
}

const DB: Address = Address::Db { db: 10, dw: 0 };

#[derive(Debug, Clone, Copy)]
enum Job {
    Fetch(usize),
    Send(usize),
}

impl Job {
    fn len(self) -> usize {
        match self {
            Job::Fetch(n) | Job::Send(n) => n,
        }
    }

    fn start(self, station: &mut Station, now: Instant) -> JobId {
        match self {
            Job::Fetch(n) => station.fetch(now, DB, Coordination::NONE, n),
            Job::Send(n) => station.send(now, DB, Coordination::NONE, vec![0x21; n]),
        }
        .unwrap()
    }
}

/// The noise patterns (si-testkit's; the STX flood is an endless 3964(R) frame) and a `DLE`
/// flood (after an `STX`, `DLE`-doubled data with no end).
fn patterns() -> Vec<Pattern> {
    let mut all = issue_patterns(line().char_time());
    all.push(Pattern {
        name: "DLE flood",
        noise: Noise::Flood(Source::Fixed(DLE)),
        until: None,
    });
    all
}

/// The host station facing `noise` runs `job` from `at` until it ends; returns how long it
/// took, its failure STATUS and the host's events.
fn run_job(
    config: Config,
    noise: Pattern,
    seed: u64,
    at: Duration,
    job: Job,
) -> (Duration, Status, Vec<Event>) {
    let Facing {
        mut sim,
        engine: host,
        ..
    } = facing(
        seed,
        line(),
        Station::new(config.with_settings(line())).unwrap(),
        noise,
    );
    sim.run_for(at);
    let start = sim.now();
    let id = sim.with(host, |s, now| job.start(s, now));
    let bound = config.job_bound(&line(), job.len());
    let end = run_while(&mut sim, start + bound, |sim| sim.engine(host).is_busy());
    (
        end.saturating_since(start),
        failure(&sim, host, id, noise.name),
        sim.take_events(host),
    )
}

fn failure(sim: &Simulator, host: StationId<Station>, id: JobId, noise: &str) -> Status {
    match sim.engine(host).job_outcome(id) {
        Some(Err(status)) => status,
        other => panic!("{noise}: job {id:?} ended with {other:?}"),
    }
}

#[test]
fn every_pattern_ends_fetch_and_send_with_a_status_within_the_bound() {
    for priority in [Priority::Low, Priority::High] {
        for (i, noise) in patterns().into_iter().enumerate() {
            for job in [Job::Fetch(10), Job::Send(10), Job::Fetch(200)] {
                for at in [Duration::ZERO, Duration::from_millis(23)] {
                    let (_, status, events) = run_job(short(priority), noise, i as u64, at, job);
                    assert!(!status.is_ok(), "{} {job:?}", noise.name);
                    let failed = events
                        .iter()
                        .filter(|e| matches!(e, Event::Failed { status: s, .. } if *s == status))
                        .count();
                    assert_eq!(failed, 1, "{priority:?} {} {job:?}: {events:?}", noise.name);
                }
            }
        }
    }
}

/// A silent partner: the command telegram is never acknowledged, so the 3964(R) link gives up
/// (0703) and the job ends with 051A, after the link's connection attempts.
#[test]
fn a_silent_partner_ends_the_job_with_051a_after_the_link_gave_up() {
    let (took, status, events) = run_job(
        short(Priority::Low),
        patterns()[0],
        1,
        Duration::ZERO,
        Job::Fetch(10),
    );
    assert_eq!(status, status::COMMAND_NOT_SENT);
    assert!(events.contains(&Event::ProcedureError(si_3964r::status::SETUP_TIMEOUT)));
    let per_try = line().char_time() + Duration::from_millis(200);
    assert_eq!(took, per_try.saturating_mul(2));
}

/// The defaults at 9600 bit/s hold their documented bound against a flood (si_rk512::bound).
#[test]
fn the_defaults_hold_their_documented_bound_against_a_flood() {
    assert_eq!(
        Config::default().job_bound(&line(), 128),
        Duration::from_micros(185_952_120)
    );
    let (_, status, _) = run_job(
        Config::default(),
        Pattern {
            name: "random flood",
            noise: Noise::Flood(Source::Random(21)),
            until: None,
        },
        21,
        Duration::ZERO,
        Job::Fetch(128),
    );
    assert!(!status.is_ok());
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]

    /// Random bursts of random bytes at a random period, from any instant, stopping or not:
    /// FETCH ends within its bound with a STATUS.
    #[test]
    fn random_noise_ends_a_fetch_within_the_bound(
        every_us in 300u64..5_000,
        burst in 1usize..64,
        stop_ms in prop::option::of(0u64..3_000),
        seed in any::<u64>(),
        at_ms in 0u64..500,
        words in 1usize..150,
        high in any::<bool>(),
    ) {
        let noise = Pattern {
            name: "random bursts",
            noise: Noise::Every {
                every: Duration::from_micros(every_us),
                burst,
                bytes: Source::Random(seed),
            },
            until: stop_ms.map(|ms| Instant::from_micros(ms * 1_000)),
        };
        let priority = if high { Priority::High } else { Priority::Low };
        let (_, status, _) = run_job(short(priority), noise, seed, Duration::from_millis(at_ms), Job::Fetch(2 * words));
        prop_assert!(!status.is_ok());
    }
}

/// Drains the station's outputs and returns its events.
fn events_of(station: &mut Station) -> Vec<Event> {
    use si_core::{Engine, Output};
    let mut events = Vec::new();
    loop {
        match station.poll_output() {
            Output::Event(e) => events.push(e),
            Output::Wait(_) => return events,
            _ => {}
        }
    }
}

/// A driver flooded with input may call the engine only with bytes, never on its timer: TRES
/// is still judged, on the bytes' arrival (si_rk512::bound).
#[test]
fn tres_ends_the_job_on_input_alone_when_the_timer_never_fires() {
    use si_core::Engine;
    let config = short(Priority::High);
    let mut station = Station::new(config.with_settings(line())).unwrap();
    let t0 = Instant::ZERO;
    let id = Job::Fetch(10).start(&mut station, t0);
    events_of(&mut station); // the startup NAK and our STX
    let acked = t0 + Duration::from_millis(5);
    station.handle_rx(acked, &[DLE]); // connection acknowledged: the telegram goes out
    events_of(&mut station);
    station.handle_rx(acked + Duration::from_millis(20), &[DLE]); // telegram acknowledged
    assert!(events_of(&mut station).is_empty());
    let tres = acked + Duration::from_millis(20) + config.response_timeout;
    station.handle_rx(tres, &[0x01]);
    assert_eq!(
        events_of(&mut station),
        vec![Event::Failed {
            job: id,
            status: status::NO_REACTION
        }]
    );
}
