//! How long a job waits for a partner that never answers, at each protocol's defaults: the
//! numbers the README gives, measured on the async handles in tokio's virtual time (the clock
//! is paused and jumps to each timer, so nothing here depends on the machine's speed), and
//! checked against the configs they come from.
#![cfg(all(
    feature = "tokio",
    feature = "3964r",
    feature = "rk512",
    feature = "uss"
))]

use si_serial::core::{delivery, Duration};
use si_serial::rk512::frame::{Address, Coordination};
use si_serial::uss::config::{MasterConfig, PollEntry};
use si_serial::uss::frame::PkwWords;
use si_serial::{r3964, rk512, uss};
use std::time::Duration as StdDuration;
use tokio::time::Instant;

/// The partner's end of the line: kept open, never read, never written.
fn silent_line() -> (tokio::io::DuplexStream, tokio::io::DuplexStream) {
    tokio::io::duplex(1 << 16)
}

fn elapsed_since(start: Instant) -> Duration {
    Duration::from(start.elapsed())
}

/// 3964(R): every connection attempt (STX) waits QVZ for the partner's DLE; after the last
/// one the job fails with 0703H. 6 × (QVZ 2 s + one character) = 12.007 s at 9600 8E1, plus,
/// on a port whose delivery nobody declared (this in-memory pipe, a pty, a CH340), a USB
/// adapter's assumed hold and one character per wait (`si_core::delivery`): 12.11 s.
#[tokio::test(start_paused = true)]
async fn a_3964r_send_to_a_silent_partner_ends_after_the_connection_attempts() {
    let config = r3964::Config::default();
    let (ours, _theirs) = silent_line();
    let link = r3964::tokio::Handle::spawn(config, ours).unwrap();
    let start = Instant::now();
    let e = link.send(&b"x"[..]).await.unwrap_err();
    let took = elapsed_since(start);
    assert_eq!(e.status(), Some(r3964::status::SETUP_TIMEOUT));
    let attempts = u64::from(config.connection_attempts);
    let per_attempt = config.ack_delay + config.settings.char_time();
    let allowance = delivery::ASSUMED_HOLD + config.settings.char_time();
    assert!(took >= per_attempt.saturating_mul(attempts), "{took}");
    assert!(
        took < (per_attempt + allowance).saturating_mul(attempts) + Duration::from_millis(50),
        "{took}"
    );
    assert_eq!(took.as_millis() / 1000, 12, "{took}");
}

/// RK 512: the command telegram goes out over 3964(R), which gives up as above; the job ends
/// with 051AH after the same 12 s (the response time TRES, 10 s, only runs once the telegram
/// was acknowledged).
#[tokio::test(start_paused = true)]
async fn an_rk512_fetch_from_a_silent_partner_ends_with_the_3964r_attempts() {
    let config = rk512::Config::default();
    let (ours, _theirs) = silent_line();
    let station = rk512::tokio::Handle::spawn(config, ours).unwrap();
    let start = Instant::now();
    let at = Address::Db { db: 1, dw: 0 };
    let e = station.fetch(at, Coordination::NONE, 2).await.unwrap_err();
    let took = elapsed_since(start);
    assert_eq!(e.status(), Some(rk512::status::COMMAND_NOT_SENT));
    assert_eq!(took.as_millis() / 1000, 12, "{took}");
}

/// USS: a parameter job goes out with its node's poll, at most 1 + WDH (20) times, each time
/// waiting the response timeout (20 ms) after the request; then it fails with 1408H ("node
/// does not answer"). With one node at 9600 8E1 that is 21 polls, each wait also allowing a USB
/// adapter's assumed hold on this undeclared port (`si_core::delivery`): 1.18 s, within the
/// config's own bound (`MasterConfig::job_bound`).
#[tokio::test(start_paused = true)]
async fn a_uss_parameter_job_to_a_silent_node_ends_after_its_repetitions() {
    let config = MasterConfig::new(vec![PollEntry::new(3, PkwWords::Four, 2)]);
    let bound = config.job_bound();
    let floor = config
        .response_timeout
        .saturating_mul(u64::from(config.retries) + 1);
    let (ours, _theirs) = silent_line();
    let drives = uss::tokio::Handle::spawn(config, ours).unwrap();
    let start = Instant::now();
    let e = drives.read_parameter(3, 700, 0).await.unwrap_err();
    let took = elapsed_since(start);
    assert_eq!(e.status(), Some(uss::status::NO_ANSWER));
    assert!(
        took >= floor && took <= bound,
        "{took} not in {floor} … {bound}"
    );
    assert!(
        took < Duration::from(StdDuration::from_millis(1_200)),
        "{took}"
    );
    println!("USS silent node: {took} (bound {bound})");
}

/// Modbus RTU: the master waits the "Response Time" (2 s) for the start of a response, once
/// (no retries by default), then the job fails with 0830H.
#[cfg(feature = "modbus")]
#[tokio::test(start_paused = true)]
async fn a_modbus_request_to_a_silent_unit_ends_after_the_response_time() {
    use si_serial::modbus::{self, Client as _};
    let config = modbus::MasterConfig::default();
    let (ours, _theirs) = silent_line();
    let plc = modbus::tokio::Master::spawn(config, ours).unwrap();
    let start = Instant::now();
    let e = plc.read_holding_registers(1, 0, 1).await.unwrap_err();
    let took = elapsed_since(start);
    assert_eq!(e.status(), Some(modbus::status::RESPONSE_TIMEOUT));
    assert_eq!(took.as_millis() / 100, 20, "{took}");
}
