//! The tokio driver over a real Linux pseudo-terminal pair: bytes both ways, a timer, tx-done.

use bytes::Bytes;
use si_core::driver::{spawn, DriverOptions};
use si_core::{Duration, Engine, Instant, Output, SerialSettings};
use std::collections::VecDeque;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio_serial::SerialStream;

/// Reports received bytes, timeouts and tx-done; transmits and arms a timer on command.
#[derive(Default)]
struct Probe {
    out: VecDeque<Output<Seen>>,
    deadline: Option<Instant>,
}

#[derive(Debug, PartialEq)]
enum Seen {
    Rx(Vec<u8>),
    Timeout { deadline: Instant, fired: Instant },
    TxDone,
}

impl Engine for Probe {
    type Event = Seen;
    fn handle_rx(&mut self, _: Instant, bytes: &[u8]) {
        self.out.push_back(Output::Event(Seen::Rx(bytes.to_vec())));
    }
    fn handle_timeout(&mut self, now: Instant) {
        if let Some(deadline) = self.deadline.filter(|d| now >= *d) {
            self.deadline = None;
            self.out.push_back(Output::Event(Seen::Timeout {
                deadline,
                fired: now,
            }));
        }
    }
    fn handle_tx_done(&mut self, _: Instant) {
        self.out.push_back(Output::Event(Seen::TxDone));
    }
    fn poll_output(&mut self) -> Output<Seen> {
        self.out.pop_front().unwrap_or(Output::Wait(self.deadline))
    }
}

/// The documented tolerance: a timer never fires early and, on an idle machine, within a few
/// milliseconds late. CI machines are not idle, so the bound here is generous.
const LATE_TOLERANCE: Duration = Duration::from_millis(100);

#[tokio::test]
async fn bytes_flow_both_ways_and_a_timer_fires_over_a_pty_pair() {
    let (ours, mut theirs) = SerialStream::pair().expect("open a pseudo-terminal pair");
    let options = DriverOptions {
        settings: Some(SerialSettings::default()),
        ..DriverOptions::default()
    };
    let (mut handle, task) = spawn(Probe::default(), ours, options);

    // Engine → line.
    handle
        .call(|p, _| {
            p.out
                .push_back(Output::Transmit(Bytes::from_static(b"\x02hello\x10")))
        })
        .await
        .unwrap();
    let mut got = [0u8; 7];
    theirs.read_exact(&mut got).await.unwrap();
    assert_eq!(&got, b"\x02hello\x10");
    assert_eq!(handle.next_event().await, Some(Seen::TxDone));

    // Line → engine (may arrive in pieces).
    theirs.write_all(&[0x10, 0x03, 0xAA]).await.unwrap();
    let mut received = Vec::new();
    while received.len() < 3 {
        match handle.next_event().await {
            Some(Seen::Rx(b)) => received.extend(b),
            other => panic!("unexpected {other:?}"),
        }
    }
    assert_eq!(received, vec![0x10, 0x03, 0xAA]);

    // A 50 ms timer fires at or after its deadline, within the tolerance.
    handle
        .call(|p, now| p.deadline = Some(now + Duration::from_millis(50)))
        .await
        .unwrap();
    match handle.next_event().await {
        Some(Seen::Timeout { deadline, fired }) => {
            assert!(fired >= deadline, "fired early: {fired} < {deadline}");
            assert!(
                fired - deadline <= LATE_TOLERANCE,
                "late by {}",
                fired - deadline
            );
        }
        other => panic!("unexpected {other:?}"),
    }

    drop(handle);
    task.await.unwrap().unwrap();
}

#[tokio::test]
async fn the_driver_stops_cleanly_when_the_peer_closes() {
    let (ours, theirs) = tokio::io::duplex(64);
    let (mut handle, task) = spawn(Probe::default(), ours, DriverOptions::default());
    drop(theirs);
    assert_eq!(handle.next_event().await, None);
    task.await.unwrap().unwrap();
}
