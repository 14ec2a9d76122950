//! Every master command ends with a non-zero exit within its documented bound when
//! the line carries only noise (si_modbus and si_uss crate docs, "Bounds"). The noise peer is a
//! thread writing to the far end of a socat pty pair: silence, random bytes every 2 ms, 01H
//! every 2 ms, a flood, and random bytes for 1 s then silence. Each command must exit with
//! code 1 and a STATUS (`16#…`) on stderr (`uss poll`: the silent node named) in under twice
//! its bound: a bound, not a timing claim (the process start and a loaded machine fit in the
//! slack).

use std::time::Duration;

use crate::common::noise::{each_pattern_within, Noise};

const PATTERNS: [Noise; 5] = [
    Noise::Silent,
    Noise::RandomEvery2Ms,
    Noise::OneEvery2Ms,
    Noise::Flood,
    Noise::RandomForOneSecond,
];

/// `si <args>` against each noise pattern: exit code 1 in under twice `bound`, a STATUS
/// (`16#…`) on stderr.
fn ends_within(args: &[&str], bound: Duration) {
    each_pattern_within(&PATTERNS, bound, args, "16#");
}

fn modbus_bound() -> Duration {
    let config = si_modbus::MasterConfig {
        response_timeout: si_core::Duration::from_millis(500),
        ..si_modbus::MasterConfig::default()
    };
    Duration::from_micros(config.job_bound().as_micros())
}

fn uss_config() -> si_uss::config::MasterConfig {
    use si_uss::config::PollEntry;
    use si_uss::frame::PkwWords;
    // `si uss`'s defaults: 9600 8E1, PKW 4 words, PZD 2 words, 20 ms.
    let mut c = si_uss::config::MasterConfig::new(vec![PollEntry::new(1, PkwWords::Four, 2)]);
    c.retries = 0;
    c
}

#[test]
fn modbus_read_ends_within_its_bound_under_noise() {
    // The example: under 2.5 s at 9600 bit/s.
    assert!(modbus_bound() < Duration::from_millis(2_500));
    ends_within(
        &[
            "modbus",
            "read",
            "holding",
            "--unit",
            "1",
            "--response-timeout-ms",
            "500",
        ],
        modbus_bound(),
    );
}

#[test]
fn modbus_write_ends_within_its_bound_under_noise() {
    ends_within(
        &[
            "modbus",
            "write",
            "register",
            "--unit",
            "1",
            "--response-timeout-ms",
            "500",
            "7",
        ],
        modbus_bound(),
    );
}

#[test]
fn modbus_diag_ends_within_its_bound_under_noise() {
    ends_within(
        &[
            "modbus",
            "diag",
            "--unit",
            "1",
            "--response-timeout-ms",
            "500",
        ],
        modbus_bound(),
    );
}

#[test]
fn uss_read_param_ends_within_its_bound_under_noise() {
    let bound = Duration::from_micros(uss_config().job_bound().as_micros());
    ends_within(
        &["uss", "read-param", "--slave", "1", "--retries", "0", "700"],
        bound,
    );
}

#[test]
fn uss_poll_one_cycle_ends_within_its_bound_under_noise() {
    let bound = Duration::from_micros(uss_config().cycle_bound().as_micros());
    // `si uss poll` names the node and the STATUS of a node that does not answer (1408H).
    each_pattern_within(
        &PATTERNS,
        bound,
        &["uss", "poll", "--slaves", "1", "--cycles", "1"],
        "node 1 never answered (no valid response in 1 cycles): 16#1408",
    );
}
