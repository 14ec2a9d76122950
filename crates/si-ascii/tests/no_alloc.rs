//! The engine allocates nothing per frame in steady state (the si-core contract): received
//! frames go into the preallocated 1024-byte ring and out into the caller's buffer; sent
//! frames go out as slices of the caller's `Bytes`; XON/XOFF come from a static table. The
//! S_SEND FB cuts its frames from a buffer it keeps, and `read_frame_bytes` from one the link
//! keeps.

use bytes::Bytes;
use si_ascii::fb::{SRcv, SSend};
use si_ascii::{Config, EndCriterion, FlowControl, Link};
use si_core::{Duration, Engine, Instant, ModulePreset, Output};
use si_testkit::alloc::assert_no_alloc;

fn drain(link: &mut Link) -> usize {
    let mut outputs = 0;
    while !matches!(link.poll_output(), Output::Wait(_)) {
        outputs += 1;
    }
    outputs
}

fn main() {
    steady_state_receive_and_send_do_not_allocate();
    println!("no_alloc: steady-state receive and send allocate nothing: ok");
    steady_state_fb_jobs_and_pooled_reads_do_not_allocate();
    println!("no_alloc: S_SEND / S_RCV jobs and read_frame_bytes allocate nothing: ok");
    cp341_frames_of_1_kb_do_not_allocate();
    println!("no_alloc: 1 KB frames of the CP 341 preset allocate nothing: ok");
}

fn steady_state_receive_and_send_do_not_allocate() {
    let config = Config {
        end: EndCriterion::EndChars {
            first: b'\r',
            second: b'\n',
        },
        flow_control: FlowControl::XonXoff,
        ..Config::default()
    };
    let mut link = Link::new(config).unwrap();
    let frame = Bytes::from_static(b"0123456789 steady state\r\n");
    let mut buf = [0u8; 200];
    let mut now = Instant::ZERO;
    let step = Duration::from_millis(1);
    let mut cycle = |link: &mut Link, now: &mut Instant| {
        // Receive one frame, fill the buffer towards XOFF now and then, read it back.
        link.handle_rx(*now, &frame);
        drain(link);
        assert_eq!(link.read_frame(*now, &mut buf), Some(frame.len()));
        drain(link);
        // Send one frame, one character per tx-done as flow control requires.
        link.send(*now, frame.clone()).unwrap();
        while link.is_sending() {
            drain(link);
            *now += step;
            link.handle_tx_done(*now);
        }
        drain(link);
        *now += step;
        link.handle_timeout(*now);
        drain(link);
    };
    for _ in 0..10 {
        cycle(&mut link, &mut now); // warm up
    }
    assert_no_alloc("3000 frames each way", || {
        for _ in 0..3_000 {
            cycle(&mut link, &mut now);
        }
    });
}

/// [ET200S SI] §2.10, Table 2-13 / §2.10, Table 2-14 with the FBs: an S_SEND job per frame (REQ
/// edge, then calls until DONE), the received frame read by S_RCV or by `read_frame_bytes`, every 1
/// ms.
fn steady_state_fb_jobs_and_pooled_reads_do_not_allocate() {
    let config = Config {
        end: EndCriterion::DEFAULT_END_CHARS,
        ..Config::default()
    };
    let mut link = Link::new(config).unwrap();
    let (mut s_send, mut s_rcv) = (SSend::default(), SRcv::default());
    let data: Vec<u8> = (0..199u8).map(|i| b'A' + i % 26).chain([0x03]).collect();
    let mut db = [0u8; 200];
    let mut now = Instant::ZERO;
    let step = Duration::from_millis(1);
    let mut cycle = |link: &mut Link, now: &mut Instant, n: usize| {
        // S_SEND: the REQ edge, then calls with REQ low until DONE; the line confirms at once.
        let mut req = true;
        loop {
            let out = s_send.call(link, *now, req, false, &data);
            assert!(!out.error, "{out:?}");
            if out.done {
                break;
            }
            req = false;
            drain(link);
            *now += step;
            link.handle_tx_done(*now);
        }
        // The partner's frame, read one way or the other.
        link.handle_rx(*now, &data);
        drain(link);
        if n.is_multiple_of(2) {
            let out = s_rcv.call(link, *now, true, false, &mut db);
            assert!(out.ndr && out.len == data.len(), "{out:?}");
        } else {
            let frame = link.read_frame_bytes(*now).expect("a frame");
            assert_eq!(frame.len(), data.len());
        }
        drain(link);
        *now += step;
    };
    for n in 0..10 {
        cycle(&mut link, &mut now, n); // warm up
    }
    assert_no_alloc("2000 S_SEND jobs and 2000 reads", || {
        for n in 0..2_000 {
            cycle(&mut link, &mut now, n);
        }
    });
}

/// The CP 341 preset's 1024-byte frames: the receive pool is sized from the
/// configured maximum at creation, so the longest frames are read without allocating either.
fn cp341_frames_of_1_kb_do_not_allocate() {
    let config = Config {
        end: EndCriterion::EndChars {
            first: b'\r',
            second: b'\n',
        },
        ..Config::for_module(ModulePreset::Cp341)
    };
    let mut link = Link::new(config).unwrap();
    let frame: Bytes = [&[b'K'; 1022][..], b"\r\n"].concat().into();
    let mut now = Instant::ZERO;
    let cycle = |link: &mut Link, now: &mut Instant| {
        link.handle_rx(*now, &frame);
        drain(link);
        let got = link.read_frame_bytes(*now).expect("one frame");
        assert_eq!(got.len(), 1024);
        drop(got);
        drain(link);
        *now += Duration::from_millis(1);
        link.handle_timeout(*now);
        drain(link);
    };
    for _ in 0..10 {
        cycle(&mut link, &mut now); // warm up
    }
    assert_no_alloc("1000 frames of 1 KB", || {
        for _ in 0..1_000 {
            cycle(&mut link, &mut now);
        }
    });
}
