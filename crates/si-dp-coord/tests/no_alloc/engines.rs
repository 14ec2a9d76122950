//! Zero heap allocations per frame in steady state through the window-bridged line engines
//! (the si-core contract, ARCHITECTURE.md; `si_dp_coord::engines`): two hosts, each with a
//! simulated module running a real line engine, the modules wired back to back
//! ([`si_sim::Pair`]). Host A's send job puts a 200-byte frame through module A's window
//! onto the line, module B's engine receives it, and host B's receive job fetches it through
//! module B's window; then the same back from B to A. Once for 3964(R), once for ASCII, under
//! a counting global allocator.
//!
//! The adapters hand frames to send over as `Bytes` cut from a buffer they keep, and take
//! received frames from the engines' kept buffers, so nothing is allocated per frame.

use bytes::Bytes;
use si_core::{Duration, Engine, SerialSettings};
use si_dp_coord::engines;
use si_dp_coord::host::HostEvent;
use si_dp_coord::line::EngineSerial;
use si_dp_coord::{Host, HostConfig, Job, Module, Outcome, WindowSize};
use si_sim::Pair;
use si_testkit::alloc::assert_no_alloc;

pub(crate) fn run() {
    r3964r_exchanges_through_the_window_do_not_allocate();
    println!("no_alloc: engines: 3964(R), 500 frames each way through the windows: ok");
    ascii_exchanges_through_the_window_do_not_allocate();
    println!("no_alloc: engines: ASCII, 500 frames each way through the windows: ok");
}

const WINDOW: WindowSize = WindowSize::ThirtyTwo;
/// A DP cycle.
const CYCLE: Duration = Duration::from_millis(1);
/// Exchanges before counting: queues and pools reach their working size.
const WARM_UP: usize = 20;
/// Exchanges counted, each a frame from A to B and one from B to A.
const COUNTED: usize = 500;

fn r3964r_exchanges_through_the_window_do_not_allocate() {
    let line = SerialSettings::default();
    let link = |priority| {
        let config = si_3964r::Config {
            priority,
            ..si_3964r::Config::default()
        };
        si_3964r::Link::new(config.with_settings(line)).unwrap()
    };
    let a = engines::r3964r_module(WINDOW, link(si_3964r::config::Priority::High)).unwrap();
    let b = engines::r3964r_module(WINDOW, link(si_3964r::config::Priority::Low)).unwrap();
    steady_state_does_not_allocate(Bridge::new(a, b), "3964(R)");
}

fn ascii_exchanges_through_the_window_do_not_allocate() {
    // The character delay time ends each frame, so any 200 bytes are one frame.
    let link = || si_ascii::Link::new(si_ascii::Config::default()).unwrap();
    let a = engines::ascii_module(WINDOW, link()).unwrap();
    let b = engines::ascii_module(WINDOW, link()).unwrap();
    steady_state_does_not_allocate(Bridge::new(a, b), "ASCII");
}

fn steady_state_does_not_allocate<E: Engine>(mut bridge: Bridge<E>, name: &str) {
    let payload: Bytes = (0..200u8)
        .map(|i| i.wrapping_mul(7).wrapping_add(1))
        .collect::<Vec<u8>>()
        .into();
    let exchange = |bridge: &mut Bridge<E>| {
        bridge.transfer(Side::A, &payload);
        bridge.transfer(Side::B, &payload);
    };
    for _ in 0..WARM_UP {
        exchange(&mut bridge);
    }
    let before = (bridge.pair.a.stats(), bridge.pair.b.stats());
    assert_no_alloc(&format!("{name}: {COUNTED} frames each way"), || {
        for _ in 0..COUNTED {
            exchange(&mut bridge);
        }
    });
    // Every frame went over the line and through both windows exactly once.
    let after = (bridge.pair.a.stats(), bridge.pair.b.stats());
    let counted = COUNTED as u64;
    assert_eq!(
        after.0.frames_delivered - before.0.frames_delivered,
        counted
    );
    assert_eq!(
        after.1.frames_delivered - before.1.frames_delivered,
        counted
    );
    assert_eq!(after.0.frames_dropped, 0);
    assert_eq!(after.1.frames_dropped, 0);
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Side {
    A,
    B,
}

/// Two hosts on one DP cycle each, their modules back to back on an instant line. Allocates
/// nothing itself.
struct Bridge<E: Engine> {
    pair: Pair<Module<EngineSerial<E>>, Module<EngineSerial<E>>>,
    hosts: [Host; 2],
    /// The input window each host reads next.
    inputs: [[u8; 32]; 2],
}

impl<E: Engine> Bridge<E> {
    fn new(a: Module<EngineSerial<E>>, b: Module<EngineSerial<E>>) -> Self {
        let mut inputs = [[0; 32]; 2];
        inputs[0].copy_from_slice(a.input());
        inputs[1].copy_from_slice(b.input());
        let host = || Host::new(HostConfig::new(WINDOW)).unwrap();
        Bridge {
            pair: Pair::new(a, b),
            hosts: [host(), host()],
            inputs,
        }
    }

    /// One DP cycle of both sides, after the line has run up to it.
    fn cycle(&mut self) {
        let now = self.pair.now + CYCLE;
        self.pair.run_until(now);
        let mut output = [0u8; 32];
        output.copy_from_slice(self.hosts[0].cycle(now, &self.inputs[0]));
        self.inputs[0].copy_from_slice(self.pair.a.cycle(now, &output));
        output.copy_from_slice(self.hosts[1].cycle(now, &self.inputs[1]));
        self.inputs[1].copy_from_slice(self.pair.b.cycle(now, &output));
        // What the modules' cycles handed their engines goes on the line now.
        self.pair.settle();
    }

    /// Submit `job` on `side`'s host and run cycles until it completes; its outcome.
    fn run(&mut self, side: Side, job: Job) -> Outcome {
        let host = side as usize;
        let id = self.hosts[host].submit(job).unwrap();
        for _ in 0..10_000 {
            self.cycle();
            for (h, other) in self.hosts.iter_mut().enumerate() {
                if let Some(event) = other.poll_event() {
                    match event {
                        HostEvent::Completed {
                            id: done, result, ..
                        } if h == host && done == id => {
                            return result.expect("the job succeeds");
                        }
                        other => panic!("unexpected event on host {h}: {other:?}"),
                    }
                }
            }
        }
        panic!("job {id:?} on {side:?} did not complete");
    }

    /// `from`'s host sends `payload`; the other host's receive jobs fetch it.
    fn transfer(&mut self, from: Side, payload: &Bytes) {
        let to = match from {
            Side::A => Side::B,
            Side::B => Side::A,
        };
        assert_eq!(self.run(from, Job::Send(payload.clone())), Outcome::Sent);
        // The frame may still be on its way into the receiving module (the ASCII engine ends
        // it a character delay time after its last byte): ask again until it is there.
        for _ in 0..100 {
            match self.run(to, Job::Receive) {
                Outcome::Received(frame) => {
                    assert_eq!(&frame, payload);
                    return;
                }
                Outcome::NoMessage => {}
                other => panic!("the receive job got {other:?}"),
            }
        }
        panic!("no frame arrived at {to:?}");
    }
}
