//! Zero heap allocations per job in steady state (the si-core contract, ARCHITECTURE.md): a
//! [`Host`] and a [`Module`] exchange send and receive jobs of 200 bytes through an 8-byte
//! window under a counting global allocator. The module loops each sent frame back to its
//! receive buffer, and the host's receive job fetches it; received frames are cut from a buffer
//! the host keeps, and come back to it once the application drops them.
//!
//! [`LoopbackSerial`](si_dp_coord::LoopbackSerial) copies every frame it is handed into a new
//! `Bytes` (a test fake), so the module runs here over [`PoolLoopback`], a minimal serial side
//! that cuts its frames from a buffer it keeps.

use bytes::{Bytes, BytesMut};
use si_core::{Duration, Instant, Status};
use si_dp_coord::host::HostEvent;
use si_dp_coord::{
    Host, HostConfig, Job, Module, ModuleConfig, Outcome, ParamBlock, SerialEvent, SerialSide,
    V24Signals, WindowSize,
};
use si_testkit::alloc::assert_no_alloc;

pub(crate) fn run() {
    steady_state_window_jobs_do_not_allocate();
    println!("no_alloc: window: 1000 send and 1000 receive jobs allocate nothing: ok");
}

const WINDOW: usize = 8;
/// A DP cycle.
const CYCLE: Duration = Duration::from_millis(1);

fn steady_state_window_jobs_do_not_allocate() {
    let window = WindowSize::Eight;
    assert_eq!(window.bytes(), WINDOW);
    let host = Host::new(HostConfig::new(window)).unwrap();
    let module_cfg = ModuleConfig::new(window);
    let serial = PoolLoopback::new(module_cfg.max_frame_len);
    let module = Module::new(module_cfg, serial).unwrap();
    let mut bus = Bus {
        host,
        module,
        now: Instant::ZERO,
        input: [0; WINDOW],
    };
    let payload: Bytes = (0..200u8)
        .map(|i| i.wrapping_mul(7))
        .collect::<Vec<u8>>()
        .into();
    let cycle = |bus: &mut Bus| {
        assert_eq!(bus.run(Job::Send(payload.clone())), Outcome::Sent);
        match bus.run(Job::Receive) {
            Outcome::Received(frame) => assert_eq!(frame, payload),
            other => panic!("the receive job got {other:?}"),
        }
    };
    for _ in 0..20 {
        cycle(&mut bus); // warm up: queues reach their working size
    }
    let before = (bus.host.stats(), bus.module.stats());
    assert_no_alloc("1000 send and 1000 receive jobs", || {
        for _ in 0..1_000 {
            cycle(&mut bus);
        }
    });
    let after = (bus.host.stats(), bus.module.stats());
    assert_eq!(after.1.jobs - before.1.jobs, 2_000);
    assert_eq!(after.1.frames_delivered - before.1.frames_delivered, 1_000);
    assert_eq!(after.1.out_of_order, before.1.out_of_order);
    assert_eq!(after.0.resends, before.0.resends);
}

/// Host and module on one DP cycle each, without lag: the host's output window is the module's
/// next input, and the module's input window the host's next. Allocates nothing itself.
struct Bus {
    host: Host,
    module: Module<PoolLoopback>,
    now: Instant,
    /// The input window the host reads next.
    input: [u8; WINDOW],
}

impl Bus {
    /// Submit `job` and run DP cycles until it completes; its outcome.
    fn run(&mut self, job: Job) -> Outcome {
        let id = self.host.submit(job).unwrap();
        for _ in 0..10_000 {
            self.now += CYCLE;
            let mut output = [0; WINDOW];
            output.copy_from_slice(self.host.cycle(self.now, &self.input));
            self.input
                .copy_from_slice(self.module.cycle(self.now, &output));
            // Any event ends the job or the test, so one look per cycle is enough.
            if let Some(event) = self.host.poll_event() {
                match event {
                    HostEvent::Completed {
                        id: done, result, ..
                    } if done == id => {
                        return result.expect("the job succeeds");
                    }
                    other => panic!("unexpected host event {other:?}"),
                }
            }
        }
        panic!("job {id:?} did not complete");
    }
}

/// A serial side that loops every frame back as received at once, cutting it from a buffer it
/// keeps (`split().freeze()`, as the line engines do), so it allocates nothing in steady state.
struct PoolLoopback {
    pool: BytesMut,
    /// The frame handed over and not yet reported done.
    sending: Option<Bytes>,
    /// The looped-back frame not yet reported received.
    received: Option<Bytes>,
}

impl PoolLoopback {
    fn new(max_frame_len: usize) -> Self {
        PoolLoopback {
            pool: BytesMut::with_capacity(max_frame_len),
            sending: None,
            received: None,
        }
    }
}

impl SerialSide for PoolLoopback {
    fn send(&mut self, _now: Instant, frame: &[u8]) -> Result<(), Status> {
        self.pool.reserve(frame.len());
        self.pool.extend_from_slice(frame);
        self.sending = Some(self.pool.split().freeze());
        Ok(())
    }

    fn poll(&mut self, _now: Instant) -> Option<SerialEvent> {
        if let Some(frame) = self.sending.take() {
            self.received = Some(frame);
            return Some(SerialEvent::SendDone(Ok(())));
        }
        self.received.take().map(SerialEvent::Received)
    }

    fn signals(&self) -> V24Signals {
        V24Signals::default()
    }

    fn set_signals(&mut self, _now: Instant, _rts: bool, _dtr: bool) -> Result<(), Status> {
        Ok(())
    }

    fn set_flow_control(&mut self, _now: Instant, _block: ParamBlock) -> Result<(), Status> {
        Ok(())
    }
}
