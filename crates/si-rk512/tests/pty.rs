//! The library's async RK 512 handle on a pseudo-terminal: an active station on one end of a
//! socat pty pair, a station serving from its memory on the other. SEND writes a data block
//! that FETCH reads back; a FETCH beyond the block is refused by the partner.
//!
//! Peer: `apt-get install socat`. Missing, the test is skipped with a message; with `CI` set it
//! fails instead.
#![cfg(all(feature = "tokio", target_os = "linux"))]

use std::time::Duration;

use si_3964r::Priority;
use si_core::port::{self, PortOptions};
use si_core::SerialSettings;
use si_rk512::frame::{Address, Coordination};
use si_rk512::passive::ServerConfig;
use si_rk512::tokio::Handle;
use si_rk512::{Config, Station};
use si_testkit::pty::pty_pair;
use tokio::time::timeout;

/// Ignored: it fails in about half the runs with 051A after six transmission attempts each
/// ended by a NAK (0705H) or a code other than DLE after STX (0702H), within 0.5 s. On a pty
/// the partner has the whole telegram at once and reacts while our link still counts the
/// telegram's time on a 9600 bit/s line; whether the 3964(R) link mishandles a partner that
/// fast, or the test's set-up, is open. `cargo test -p si-rk512 --all-features --test pty --
/// --ignored` shows it.
#[tokio::test]
#[ignore = "flaky on a pty: 051A after 0705H/0702H, see the doc comment"]
async fn send_then_fetch_through_a_serving_station_on_a_pty() {
    let Some(pair) = pty_pair() else { return };
    let settings = SerialSettings::default();
    let mut memory = ServerConfig::default();
    memory.memory.dbs.insert(10, 512);
    let partner = Station::serving(Config::default().with_settings(settings), &memory).unwrap();
    let partner_line = port::open(&pair.b, &settings, &PortOptions::default()).unwrap();
    let _partner = Handle::spawn_engine(partner, partner_line);

    let mut config = Config::default();
    config.link.priority = Priority::High;
    let us = Handle::open(config, &pair.a).unwrap();
    // Both links send a NAK when they start (the module's startup); a job started at once
    // meets the partner's startup NAK as the answer to its STX. Let the startups pass first.
    tokio::time::sleep(Duration::from_millis(200)).await;
    let limit = Duration::from_secs(20);
    let db = Address::Db { db: 10, dw: 4 };
    // 300 bytes: three telegrams, the first 128 bytes and two continuations.
    let data: Vec<u8> = (0..300u32).map(|i| (i * 13 + 1) as u8).collect();
    let sent = timeout(limit, us.send(db, Coordination::NONE, data.clone()))
        .await
        .expect("SEND in time");
    if sent.is_err() {
        let cause = us.call(|s, _| (s.last_cause(), s.link().counters())).await;
        panic!("{sent:?}, caused by {cause:?}");
    }
    let back = timeout(limit, us.fetch(db, Coordination::NONE, 300))
        .await
        .expect("FETCH in time")
        .unwrap();
    assert_eq!(back[..], data[..]);
    let beyond = Address::Db { db: 10, dw: 250 };
    let e = timeout(limit, us.fetch(beyond, Coordination::NONE, 20))
        .await
        .expect("FETCH in time")
        .unwrap_err();
    assert!(e.status().is_some_and(|s| !s.is_ok()), "{e:?}");
}
