//! `si 3964r probe`'s announced time holds on a line that chatters: the probe of one setting,
//! against a peer that chatters through the stale-byte reads, answers our `STX` at the last
//! moment of the acknowledgement delay time and then never goes quiet, ends within
//! [`Probe::setting_bound`], measured in tokio's paused (virtual) time, not the wall clock.

#![cfg(feature = "tokio")]

use si_3964r::probe::{Probe, Reply, STALE_READS, STALE_WAIT};
use si_core::{Duration, SerialSettings};
use std::cell::RefCell;
use tokio::io::{AsyncReadExt, AsyncWriteExt, DuplexStream};
use tokio::time::Instant;

const ACK_DELAY: Duration = Duration::from_millis(2_000);
const CHAR_DELAY: Duration = Duration::from_millis(220);

fn std(d: Duration) -> std::time::Duration {
    std::time::Duration::from_micros(d.as_micros())
}

/// The worst peer: a byte just within every stale read's wait until our `STX`, its answer just
/// within the acknowledgement delay time, then a byte every millisecond until the line closes.
async fn worst_peer(mut line: DuplexStream) {
    let chatter = STALE_WAIT.saturating_sub(Duration::from_millis(1));
    let mut buf = [0u8; 16];
    loop {
        tokio::select! {
            r = line.read(&mut buf) => match r {
                Ok(n) if n > 0 && buf[..n].contains(&0x02) => break,
                Ok(n) if n > 0 => {}
                _ => return,
            },
            _ = tokio::time::sleep(std(chatter)) => {
                if line.write_all(&[0x15]).await.is_err() {
                    return;
                }
            }
        }
    }
    tokio::time::sleep(std(ACK_DELAY.saturating_sub(Duration::from_millis(1)))).await;
    loop {
        if line.write_all(&[0x41]).await.is_err() {
            return;
        }
        tokio::time::sleep(std::time::Duration::from_millis(1)).await;
    }
}

#[tokio::test(start_paused = true)]
async fn a_setting_is_probed_within_its_bound_on_a_chattering_line() {
    let settings = vec![SerialSettings::default(); 2];
    let probe = Probe::new(settings, ACK_DELAY, CHAR_DELAY);
    let bound = probe.setting_bound();
    // Each setting's probe from its port's opening; the next opening (or the end) ends it.
    let opened = RefCell::new(Vec::new());
    let mut replies = Vec::new();
    probe
        .run(
            |_| {
                opened.borrow_mut().push(Instant::now());
                let (ours, theirs) = tokio::io::duplex(64);
                tokio::spawn(worst_peer(theirs));
                async move { Ok::<_, std::io::Error>(ours) }
            },
            |f| replies.push(f.answer),
        )
        .await
        .unwrap();
    let end = Instant::now();
    let mut marks = opened.into_inner();
    marks.push(end);
    assert_eq!(replies, [Reply::Other(0x41); 2]);
    for pair in marks.windows(2) {
        let took = Duration::from_micros(pair[1].duration_since(pair[0]).as_micros() as u64);
        assert!(took <= bound, "{took} > {bound}");
        // The stale reads did hold it: beyond QVZ and the partner's ZVZ twice.
        let without = ACK_DELAY + CHAR_DELAY + CHAR_DELAY;
        let stale = STALE_WAIT.saturating_mul(u64::from(STALE_READS - 1));
        assert!(took > without + stale, "{took}");
    }
}
