//! The library's async 3964(R) handle on a pseudo-terminal: two handles on the two ends of a
//! socat pty pair (high and low priority, block check on) exchange blocks both ways, one with
//! DLE characters in it (doubled on the line) and one of the full 200 bytes of the ET 200S.
//!
//! Peer: `apt-get install socat`. Missing, the test is skipped with a message; with `CI` set it
//! fails instead.
#![cfg(all(feature = "tokio", target_os = "linux"))]

use std::time::Duration;

use si_3964r::tokio::Handle;
use si_3964r::{Config, Priority};
use si_testkit::pty::pty_pair;
use tokio::time::timeout;

fn open(path: &str, priority: Priority) -> Handle {
    let config = Config {
        priority,
        ..Config::default()
    };
    Handle::open(config, path).unwrap()
}

#[tokio::test]
async fn two_handles_exchange_blocks_both_ways_on_a_pty() {
    let Some(pair) = pty_pair() else { return };
    let mut a = open(&pair.a, Priority::High);
    let mut b = open(&pair.b, Priority::Low);
    let limit = Duration::from_secs(10);
    let with_dles = vec![0x10, 0x02, 0x10, 0x10, 0x03, 0x41];
    timeout(limit, a.send(with_dles.clone()))
        .await
        .expect("sent in time")
        .unwrap();
    let got = timeout(limit, b.recv()).await.expect("received").unwrap();
    assert_eq!(got[..], with_dles[..]);
    let long: Vec<u8> = (0..200u32).map(|i| (i * 7) as u8).collect();
    timeout(limit, b.send(long.clone()))
        .await
        .expect("sent in time")
        .unwrap();
    let got = timeout(limit, a.recv()).await.expect("received").unwrap();
    assert_eq!(got[..], long[..]);
}
