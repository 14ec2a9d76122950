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

#[tokio::test]
async fn send_then_fetch_through_a_serving_station_on_a_pty() {
    let Some(pair) = pty_pair() else { return };
    let settings = SerialSettings::default();
    let mut memory = ServerConfig::default();
    memory.memory.dbs.insert(10, 512);
    let partner = Station::serving(Config::default(), settings, &memory).unwrap();
    let partner_line = port::open(&pair.b, &settings, &PortOptions::default()).unwrap();
    let _partner = Handle::spawn_engine(partner, partner_line);

    let mut config = Config::default();
    config.link.priority = Priority::High;
    let line = port::open(&pair.a, &settings, &PortOptions::default()).unwrap();
    let us = Handle::spawn(config, settings, line).unwrap();
    let limit = Duration::from_secs(20);
    let db = Address::Db { db: 10, dw: 4 };
    // 300 bytes: three telegrams, the first 128 bytes and two continuations.
    let data: Vec<u8> = (0..300u32).map(|i| (i * 13 + 1) as u8).collect();
    timeout(limit, us.send(db, Coordination::NONE, data.clone()))
        .await
        .expect("SEND in time")
        .unwrap();
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
