//! A noise test per role: `si 3964r send` and `si rk512 fetch` against a noise peer
//! (a thread writing to the other end of a socat pty pair, every pattern of `common::noise`)
//! exit with code 1 and a STATUS on stderr within twice their documented bound
//! (si_3964r::bound, si_rk512::bound; the runner is `common::noise::each_pattern_within`).
//! Skips without socat (fails with `CI` set).

use crate::common::noise::{each_pattern_within, Noise};
use si_core::delivery::MAX_LATENCY;
use si_core::SerialSettings;

/// Every noise pattern, the endless 3964(R) block included.
const PATTERNS: [Noise; 6] = [
    Noise::Silent,
    Noise::RandomEvery2Ms,
    Noise::OneEvery2Ms,
    Noise::Flood,
    Noise::RandomForOneSecond,
    Noise::EndlessFrame,
];

/// QVZ and ZVZ get at most the port's delivery allowance (si_core::delivery: the largest
/// latency plus one character) on a pty that hands bytes over in bursts.
fn allowance_ms() -> u32 {
    let t = MAX_LATENCY + SerialSettings::default().char_time();
    u32::try_from(t.as_millis()).unwrap() + 1
}

#[test]
fn send_3964r_ends_non_zero_within_its_bound_against_noise() {
    let config = si_3964r::Config {
        ack_delay: si_core::Duration::from_millis((100 + allowance_ms()).into()),
        char_delay: si_core::Duration::from_millis((50 + allowance_ms()).into()),
        connection_attempts: 2,
        transmission_attempts: 2,
        ..si_3964r::Config::default()
    };
    let args = [
        "3964r",
        "send",
        "01",
        "--ack-delay-ms",
        "100",
        "--char-delay-ms",
        "50",
        "--connection-attempts",
        "2",
        "--transmission-attempts",
        "2",
    ];
    let bound = config.send_job_bound(&SerialSettings::default(), 1);
    each_pattern_within(&PATTERNS, bound.into(), &args, "send failed: 16#07");
}

#[test]
fn fetch_rk512_ends_non_zero_within_its_bound_against_noise() {
    let mut config = si_rk512::Config {
        response_timeout: si_core::Duration::from_millis(200),
        ..si_rk512::Config::default()
    };
    config.link.priority = si_3964r::Priority::High;
    config.link.ack_delay = si_core::Duration::from_millis((100 + allowance_ms()).into());
    config.link.char_delay =
        config.link.char_delay + si_core::Duration::from_millis(allowance_ms().into());
    let args = [
        "rk512",
        "fetch",
        "--db",
        "10",
        "--count",
        "2",
        "--ack-delay-ms",
        "100",
        "--response-timeout-ms",
        "200",
    ];
    // A word count of 2 is 4 bytes: one telegram, like 2 bytes.
    let bound = config.job_bound(&SerialSettings::default(), 2);
    each_pattern_within(&PATTERNS, bound.into(), &args, "16#");
}
