//! A bound on every window job under noise: a host sends through the window of a simulated
//! module whose serial line carries only noise (si-testkit's [`issue_patterns`]: silent, random
//! bytes, 01H every 2 ms, an endless frame, floods, noise that stops), and a host whose module
//! answers nothing sensible in the window itself. Every job ends exactly once, with a non-zero
//! STATUS, within its bound. Virtual time: the line simulator and one DP cycle every 2 ms.
//!
//! The bounds: a send job the module passes to its line ends when the line's own job ends (the
//! module acknowledges the end of a send job only then, [ET200S SI 2005] §2.9), so within the
//! line engine's bound plus the window's own exchange; a job the module never answers ends at
//! the host's job watchdog ([`HostConfig::job_timeout`], the window protocol has no timeout of
//! its own).

use si_core::{Duration, Engine, Instant, SerialSettings, Status};
use si_dp_coord::engines;
use si_dp_coord::host::{Host, HostEvent, Job};
use si_dp_coord::line::EngineSerial;
use si_dp_coord::module::Module;
use si_dp_coord::{HostConfig, WindowSize};
use si_sim::StationId;
use si_testkit::noise::{facing, issue_patterns, Facing, Pattern};

/// DP cycle of the simulated master.
const CYCLE: Duration = Duration::from_millis(2);

/// [derived] What the window adds to the line's bound: the segments of a frame of up to
/// [`LEN`] bytes going in (two of 7 bytes in the 8-byte window, one DP cycle each way per
/// segment), the end-of-job acknowledgement coming back and the host's final idle write; 50 DP
/// cycles are several times that.
const WINDOW_MARGIN: Duration = Duration::from_millis(100);

/// The frame every send job carries.
const LEN: usize = 10;

fn line() -> SerialSettings {
    SerialSettings::default()
}

/// 3964(R) with short timers, so each case runs seconds of virtual time.
fn r3964r() -> si_3964r::Config {
    si_3964r::Config {
        ack_delay: Duration::from_millis(200),
        char_delay: Duration::from_millis(50),
        connection_attempts: 3,
        transmission_attempts: 3,
        max_block_len: 64,
        ..si_3964r::Config::default()
    }
}

/// ASCII with RTS/CTS flow control: the noise peer never sets RTS, so our CTS stays OFF and the
/// send ends with 0708H after the wait time for CTS.
fn ascii() -> si_ascii::Config {
    let mut c = si_ascii::Config {
        flow_control: si_ascii::FlowControl::RtsCts,
        tx_chunk: 1,
        ..si_ascii::Config::default()
    };
    c.rts_cts.wait_for_cts = si_core::Duration::from_millis(200);
    c
}

/// Runs one send job of [`LEN`] bytes through the window of `module`, whose line faces
/// `pattern`, until the host reports its end; fails past `bound`. Returns how long the job took
/// and its STATUS.
fn send_through<E>(
    module: Module<EngineSerial<E>>,
    pattern: Pattern,
    bound: Duration,
) -> (Duration, Status)
where
    E: Engine + 'static,
    E::Event: 'static,
{
    let Facing {
        mut sim,
        engine: station,
        ..
    } = facing(11, line(), module, pattern);
    let mut host = Host::new(HostConfig::new(WindowSize::Eight)).unwrap();
    let mut input = sim.engine(station).input().to_vec();
    // Some noise first, so the job starts on a busy line.
    sim.run_for(Duration::from_millis(50));
    let start = sim.now();
    let id = host.submit(Job::Send(vec![0x55; LEN].into())).unwrap();
    let mut ends = Vec::new();
    while ends.is_empty() {
        assert!(
            sim.now() <= start + bound,
            "{}: the job still runs at {} (bound {})",
            pattern.name,
            sim.now(),
            start + bound
        );
        cycle(&mut sim, station, &mut host, &mut input);
        ends.extend(
            std::iter::from_fn(|| host.poll_event()).filter_map(|e| match e {
                HostEvent::Completed { id: j, result, .. } => Some((j, result)),
                HostEvent::BackedOff { .. } => None,
            }),
        );
    }
    let took = sim.now().saturating_since(start);
    // Exactly one end, also after the line has gone quiet for the window's margin.
    for _ in 0..WINDOW_MARGIN.as_micros() / CYCLE.as_micros() {
        cycle(&mut sim, station, &mut host, &mut input);
        ends.extend(
            std::iter::from_fn(|| host.poll_event()).filter_map(|e| match e {
                HostEvent::Completed { id: j, result, .. } => Some((j, result)),
                HostEvent::BackedOff { .. } => None,
            }),
        );
    }
    match ends.as_slice() {
        [(j, Err(status))] if *j == id => (took, *status),
        _ => panic!("{}: one failure for the job, got {ends:?}", pattern.name),
    }
}

/// One DP cycle: the host writes, the module reads and writes, the line runs for the cycle.
fn cycle<E>(
    sim: &mut si_sim::Simulator,
    station: StationId<Module<EngineSerial<E>>>,
    host: &mut Host,
    input: &mut Vec<u8>,
) where
    E: Engine + 'static,
    E::Event: 'static,
{
    let out = host.cycle(sim.now(), input).to_vec();
    *input = sim.with(station, |module, now| module.cycle(now, &out).to_vec());
    sim.run_for(CYCLE);
}

#[test]
fn a_send_through_a_3964r_module_ends_with_its_status_within_the_bound_under_every_noise() {
    let bound = r3964r().send_job_bound(&line(), LEN) + WINDOW_MARGIN;
    for pattern in issue_patterns(line().char_time()) {
        let link = si_3964r::Link::new(r3964r().with_settings(line())).unwrap();
        let module = engines::r3964r_module(WindowSize::Eight, link).unwrap();
        let (took, status) = send_through(module, pattern, bound);
        assert!(!status.is_ok(), "{}: {status:?}", pattern.name);
        assert!(took > Duration::ZERO, "{}", pattern.name);
    }
}

/// A silent partner: the module's 3964(R) link gives up after its connection attempts with
/// 0703H, and the host's send job ends with that STATUS, not with its watchdog's.
#[test]
fn a_silent_partner_behind_the_window_is_0703h() {
    let silent = issue_patterns(line().char_time())[0];
    let link = si_3964r::Link::new(r3964r().with_settings(line())).unwrap();
    let module = engines::r3964r_module(WindowSize::Eight, link).unwrap();
    let bound = r3964r().send_job_bound(&line(), LEN) + WINDOW_MARGIN;
    let (took, status) = send_through(module, silent, bound);
    assert_eq!(status, si_3964r::status::SETUP_TIMEOUT);
    // Three STX, each waiting one character and QVZ, then the window's acknowledgement.
    let line_time = (line().char_time() + Duration::from_millis(200)).saturating_mul(3);
    assert!(
        took >= line_time && took <= line_time + WINDOW_MARGIN,
        "{took}"
    );
}

#[test]
fn a_send_through_an_ascii_module_ends_with_0708h_within_the_wait_time_under_every_noise() {
    let bound = Duration::from_millis(200) + line().chars_time(LEN as u64) + WINDOW_MARGIN;
    for pattern in issue_patterns(line().char_time()) {
        let link = si_ascii::Link::new(ascii()).unwrap();
        let module = engines::ascii_module(WindowSize::Eight, link).unwrap();
        let (_, status) = send_through(module, pattern, bound);
        assert_eq!(
            status,
            si_ascii::status::XON_CTS_TIMEOUT,
            "{}",
            pattern.name
        );
    }
}

/// Noise in the window itself: a module whose input window is stuck at one image (all 00H,
/// all FFH, the reserved bit 7 with a job code, a stale acknowledgement) or changes at random
/// every cycle. Every kind of job ends exactly once within the host's watchdog; under a stuck
/// image with a non-zero STATUS.
#[test]
fn every_job_ends_within_the_watchdog_when_the_window_carries_noise() {
    let timeout = Duration::from_millis(500);
    let config = HostConfig {
        job_timeout: Some(timeout),
        ..HostConfig::new(WindowSize::Eight)
    };
    let jobs = [
        Job::Send(vec![0x55; LEN].into()),
        Job::Receive,
        Job::ReadV24,
        Job::WriteV24 {
            rts: true,
            dtr: true,
        },
    ];
    let stuck: [(&str, [u8; 8]); 4] = [
        ("00H", [0; 8]),
        ("FFH", [0xFF; 8]),
        ("reserved bit 7", [0x91, 0, 0, 0, 0, 0, 0, 0]),
        ("stale end of job", [0x20, 0x07, 0x03, 0, 0, 0, 0, 0]),
    ];
    for job in jobs {
        for (name, image) in stuck {
            let (took, status) = run_on_window(&config, job.clone(), |_| image);
            assert!(!status.is_ok(), "{name} {job:?}");
            assert!(took <= timeout + CYCLE, "{name} {job:?}: {took}");
        }
        let mut rng = 0x9E37_79B9_7F4A_7C15u64;
        let (took, status) = run_on_window(&config, job.clone(), |_| {
            let mut w = [0u8; 8];
            for b in &mut w {
                rng ^= rng << 13;
                rng ^= rng >> 7;
                rng ^= rng << 17;
                *b = (rng >> 24) as u8;
            }
            w
        });
        // A random window may complete a job by chance (Status::OK here); either way it ends
        // within the watchdog.
        let _ = status;
        assert!(took <= timeout + CYCLE, "random {job:?}: {took}");
    }
}

/// Runs `job` on a host whose input window is `window(cycle)` each DP cycle; returns when and
/// how it ended (`Status::OK` if it succeeded), asserting exactly one end.
fn run_on_window(
    config: &HostConfig,
    job: Job,
    mut window: impl FnMut(u64) -> [u8; 8],
) -> (Duration, Status) {
    let mut host = Host::new(config.clone()).unwrap();
    let id = host.submit(job.clone()).unwrap();
    let mut ends = Vec::new();
    let mut end = None;
    let limit = config.job_timeout.unwrap() + WINDOW_MARGIN + WINDOW_MARGIN;
    let mut n = 0;
    while Instant::ZERO + CYCLE.saturating_mul(n) <= Instant::ZERO + limit {
        let now = Instant::ZERO + CYCLE.saturating_mul(n);
        let input = window(n);
        host.cycle(now, &input);
        for e in std::iter::from_fn(|| host.poll_event()) {
            if let HostEvent::Completed { id: j, result, .. } = e {
                end.get_or_insert(now);
                ends.push((j, result));
            }
        }
        n += 1;
    }
    let Some(end) = end else {
        panic!("{job:?}: never ended")
    };
    match ends.as_slice() {
        [(j, result)] if *j == id => (
            end.saturating_since(Instant::ZERO),
            result.as_ref().err().copied().unwrap_or(Status::OK),
        ),
        _ => panic!("{job:?}: one end for the job, got {ends:?}"),
    }
}
