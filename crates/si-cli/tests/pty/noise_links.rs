//! Issue 21, "A noise test per role": `si 3964r send` and `si rk512 fetch` against a noise peer
//! (a thread writing to the other end of a socat pty pair, every pattern of `common::noise`)
//! exit non-zero within twice their documented bound (si_3964r::bound, si_rk512::bound). Twice
//! the bound is a bound, not a timing claim: it leaves room for the process start and a loaded
//! machine. Skips without socat (fails with `CI` set).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use crate::common::noise::{noise_peer, one_at_a_time, Noise};
use crate::common::{pty_pair, si_command, stderr, PtyPair};
use si_core::delivery::MAX_LATENCY;
use si_core::SerialSettings;

/// QVZ and ZVZ get at most the port's delivery allowance (si_core::delivery: the largest
/// latency plus one character) on a pty that hands bytes over in bursts.
fn allowance_ms() -> u32 {
    let t = MAX_LATENCY + SerialSettings::default().char_time();
    u32::try_from(t.as_millis()).unwrap() + 1
}

/// Runs `si` with `args` on side `a` while the noise peer writes to side `b`; returns how
/// long it ran and its stderr, after asserting a non-zero exit.
fn run_against(pair: &PtyPair, pattern: Noise, args: &[&str]) -> (Duration, String) {
    eprintln!("noise peer: {pattern:?}, si {args:?}");
    let stop = Arc::new(AtomicBool::new(false));
    noise_peer(&pair.b, pattern, stop.clone());
    let start = Instant::now();
    let o = si_command()
        .args(["--port", &pair.a])
        .args(args)
        .output()
        .expect("run si");
    let took = start.elapsed();
    stop.store(true, Ordering::Relaxed);
    assert!(
        !o.status.success(),
        "{pattern:?}: {args:?} exited 0: {}",
        String::from_utf8_lossy(&o.stdout)
    );
    (took, stderr(&o))
}

/// Each pattern against `si ARGS`: a non-zero exit within twice `bound`, its stderr holding
/// `expected`. Returns early (a skip) without socat.
fn each_pattern_within(bound: si_core::Duration, args: &[&str], expected: &str) {
    let _one = one_at_a_time();
    for pattern in [
        Noise::Silent,
        Noise::RandomEvery2Ms,
        Noise::OneEvery2Ms,
        Noise::Flood,
        Noise::RandomForOneSecond,
        Noise::EndlessFrame,
    ] {
        let Some(pair) = pty_pair() else {
            return;
        };
        let (took, err) = run_against(&pair, pattern, args);
        assert!(
            took < Duration::from(bound) * 2,
            "{pattern:?}: took {took:?}, bound {bound}: {err}"
        );
        assert!(err.contains(expected), "{pattern:?}: {expected} in {err}");
    }
}

#[test]
fn send_3964r_ends_non_zero_within_its_bound_against_noise() {
    let config = si_3964r::Config {
        ack_delay_ms: 100 + allowance_ms(),
        char_delay_ms: 50 + allowance_ms(),
        connection_attempts: 2,
        transmission_attempts: 2,
        ..si_3964r::Config::default()
    };
    let args = [
        "3964r",
        "send",
        "01",
        "--qvz-ms",
        "100",
        "--zvz-ms",
        "50",
        "--connection-attempts",
        "2",
        "--transmission-attempts",
        "2",
    ];
    let bound = config.send_job_bound(&SerialSettings::default(), 1);
    each_pattern_within(bound, &args, "send failed: 16#07");
}

#[test]
fn fetch_rk512_ends_non_zero_within_its_bound_against_noise() {
    let mut config = si_rk512::Config {
        response_timeout_ms: 200,
        ..si_rk512::Config::default()
    };
    config.link.priority = si_3964r::Priority::High;
    config.link.ack_delay_ms = 100 + allowance_ms();
    config.link.char_delay_ms += allowance_ms();
    let args = [
        "rk512",
        "fetch",
        "--db",
        "10",
        "--count",
        "2",
        "--qvz-ms",
        "100",
        "--tres-ms",
        "200",
    ];
    // A word count of 2 is 4 bytes: one telegram, like 2 bytes.
    let bound = config.job_bound(&SerialSettings::default(), 2);
    each_pattern_within(bound, &args, "16#");
}
