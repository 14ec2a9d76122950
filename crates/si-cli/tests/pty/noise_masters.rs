//! Issue 21: every master command ends with a non-zero exit within its documented bound when
//! the line carries only noise (si_modbus and si_uss crate docs, "Bounds"). The noise peer is a
//! thread writing to the far end of a socat pty pair: silence, random bytes every 2 ms, 01H
//! every 2 ms, a flood, and random bytes for 1 s then silence. Each command must exit non-zero
//! in under twice its bound: a bound, not a timing claim (the process start and a loaded
//! machine fit in the slack).

use std::process::Stdio;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use crate::common;

use common::noise::{noise_peer, one_at_a_time, Noise};
use common::{pty_pair, si_command, Kill};

const PATTERNS: [Noise; 5] = [
    Noise::Silent,
    Noise::RandomEvery2Ms,
    Noise::OneEvery2Ms,
    Noise::Flood,
    Noise::RandomForOneSecond,
];

/// Run `si <args> --port <pty>` against each noise pattern: it must exit non-zero in under
/// twice `bound`.
fn ends_within(args: &[&str], bound: Duration) {
    let _one = one_at_a_time();
    for noise in PATTERNS {
        let Some(pair) = pty_pair() else { return };
        let stop = Arc::new(AtomicBool::new(false));
        noise_peer(&pair.b, noise, stop.clone());
        // The line is already noisy when the job starts.
        std::thread::sleep(Duration::from_millis(100));
        let started = Instant::now();
        let mut si = Kill(
            si_command()
                .args(args)
                .args(["--port", &pair.a])
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .spawn()
                .expect("start si"),
        );
        let limit = bound * 2;
        let status = loop {
            if let Some(status) = si.0.try_wait().expect("wait for si") {
                break status;
            }
            assert!(
                started.elapsed() < limit,
                "si {args:?} against {noise:?} still running after {limit:?} (bound {bound:?})"
            );
            std::thread::sleep(Duration::from_millis(20));
        };
        stop.store(true, Ordering::Relaxed);
        assert!(!status.success(), "si {args:?} against {noise:?} succeeded");
    }
}

fn modbus_bound() -> Duration {
    let config = si_modbus::MasterConfig {
        response_timeout_ms: 500,
        ..si_modbus::MasterConfig::default()
    };
    Duration::from_micros(config.job_bound().as_micros())
}

fn uss_config() -> si_uss::config::MasterConfig {
    use si_uss::config::PollEntry;
    use si_uss::frame::PkwWords;
    // `si uss`'s defaults: 9600 8E1, PKW 4 words, PZD 2 words, 20 ms.
    let mut c = si_uss::config::MasterConfig::new(vec![PollEntry::new(1, PkwWords::Four, 2)]);
    c.pkw_retries = 0;
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
            "--timeout",
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
            "--timeout",
            "500",
            "7",
        ],
        modbus_bound(),
    );
}

#[test]
fn modbus_diag_ends_within_its_bound_under_noise() {
    ends_within(
        &["modbus", "diag", "--unit", "1", "--timeout", "500"],
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
    ends_within(&["uss", "poll", "--slaves", "1", "--cycles", "1"], bound);
}
