//! Soak: two ASCII links (end characters CR LF) sending to each other all the time
//! on a faulty line (bit flips, lost and inserted characters) for a day of virtual
//! time.
//!
//! The ASCII driver has no check sum and no repetition ([ET200S SI] §2.8): a flipped
//! bit reaches the application, a lost CR LF joins two frames. What it does guarantee, asserted:
//! every send job ends in exactly one event, done or failed with a STATUS of the manual; every
//! receive error carries one; no frame is longer than the buffer allows; frames arrive in order
//! and never twice (the driver never repeats); and every frame the line did not touch arrives
//! exactly (each frame carries its own check, which the application verifies). The short test
//! runs in every `cargo test`; the day runs with
//! `cargo test --release -p si-ascii --test soak -- --ignored`.

use bytes::Bytes;
use si_ascii::{Config, EndCriterion, Event, FlowControl, JobId, Link};
use si_core::{Duration, Instant};
use si_sim::{Faults, Simulator, StationId};

/// Frame `seq` from `dir`: "D SSSSSSSS CC\r\n" with an 8-bit sum CC over the rest, so the
/// receiving application can tell intact frames from ones the line changed.
fn frame(dir: u8, seq: u32) -> Vec<u8> {
    let body = format!("{} {seq:08} ", dir as char);
    let sum = body.bytes().fold(0u8, |a, b| a.wrapping_add(b));
    format!("{body}{sum:02X}\r\n").into_bytes()
}

/// The sequence number of an intact frame from `dir`.
fn intact(dir: u8, bytes: &[u8]) -> Option<u32> {
    let text = std::str::from_utf8(bytes).ok()?;
    let seq: u32 = text.get(2..10)?.parse().ok()?;
    (bytes == frame(dir, seq).as_slice()).then_some(seq)
}

struct Side {
    id: StationId<Link>,
    dir: u8,
    next_seq: u32,
    open: Option<JobId>,
    sent: u64,
    failed: u64,
    intact: u64,
    damaged: u64,
    last_seq: u32,
}

fn service(sim: &mut Simulator, me: &mut Side, partner_dir: u8) {
    let mut buf = [0u8; 1024];
    for event in sim.take_events(me.id) {
        match event {
            Event::Sent { job, .. } => {
                assert_eq!(
                    me.open.take(),
                    Some(job),
                    "a completion for no or another job"
                );
                me.sent += 1;
            }
            Event::SendFailed { job, status, .. } => {
                assert_eq!(me.open.take(), Some(job), "a failure for no or another job");
                assert!(status.code() != 0 && status.info().is_some(), "{status:?}");
                me.failed += 1;
            }
            Event::Received { len, .. } => {
                let n = sim
                    .with(me.id, |l, now| l.read_frame(now, &mut buf))
                    .expect("Received announces a frame");
                assert_eq!(n, len);
                assert!(n <= 1024);
                match intact(partner_dir, &buf[..n]) {
                    Some(seq) => {
                        assert!(seq > me.last_seq, "frame {seq} after {}", me.last_seq);
                        me.last_seq = seq;
                        me.intact += 1;
                    }
                    None => me.damaged += 1,
                }
            }
            Event::ReceiveError { status, .. } => {
                assert!(status.code() != 0 && status.info().is_some(), "{status:?}");
            }
        }
    }
    if me.open.is_none() {
        me.next_seq += 1;
        let data = Bytes::from(frame(me.dir, me.next_seq));
        let job = sim
            .with(me.id, |l, now| l.send(now, data))
            .expect("no job is running");
        me.open = Some(job);
    }
}

fn soak(span: Duration, seed: u64) -> (Side, Side) {
    let config = Config {
        end: EndCriterion::EndChars {
            first: b'\r',
            second: b'\n',
        },
        // Without flow control: on this line an inserted or flipped byte is an XOFF now and
        // then, which rightly stops the sender until the XON wait time fails its job.
        flow_control: FlowControl::None,
        ..Config::default()
    };
    let settings = config.settings;
    let mut sim = Simulator::new(seed).without_trace();
    let a = sim.add_station("A", settings, Link::new(config).unwrap());
    let b = sim.add_station("B", settings, Link::new(config).unwrap());
    sim.connect(a, b);
    let faults = Faults {
        bit_flip: 0.000_2,
        drop: 0.000_2,
        insert: 0.000_2,
        extra_latency: Duration::ZERO,
    };
    sim.set_faults(a, faults);
    sim.set_faults(b, faults);
    let side = |id, dir| Side {
        id,
        dir,
        next_seq: 0,
        open: None,
        sent: 0,
        failed: 0,
        intact: 0,
        damaged: 0,
        last_seq: 0,
    };
    let (mut sa, mut sb) = (side(a, b'A'), side(b, b'B'));
    let end = Instant::ZERO + span;
    while sim.now() < end {
        service(&mut sim, &mut sa, b'B');
        service(&mut sim, &mut sb, b'A');
        sim.run_for(Duration::from_millis(20));
    }
    for (me, partner) in [(&sa, &sb), (&sb, &sa)] {
        eprintln!(
            "ascii soak {:?} {}: {} sent, {} failed; partner got {} intact, {} damaged",
            span, me.dir as char, me.sent, me.failed, partner.intact, partner.damaged
        );
        // Nothing appears from nowhere: intact frames are at most the frames sent.
        assert!(partner.intact <= me.sent + 1);
        // The line is faulty but usable: nearly every frame arrives intact.
        assert!(partner.intact * 100 > me.sent * 95, "too many frames lost");
        assert!(me.failed * 100 < me.sent);
    }
    (sa, sb)
}

#[test]
fn ten_minutes_of_faults_every_job_ends_once_and_intact_frames_arrive_in_order() {
    let (a, _) = soak(Duration::from_secs(600), 0x5EED);
    assert!(a.sent > 10_000);
}

#[test]
#[ignore = "a day of virtual time: run in release (see the module docs)"]
fn a_day_of_faults_every_job_ends_once_and_intact_frames_arrive_in_order() {
    let (a, _) = soak(Duration::from_secs(24 * 3600), 0xDA7);
    assert!(a.sent > 1_000_000);
}
