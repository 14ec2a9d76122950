//! Zero heap allocations per job in steady state through the module in Modbus master mode
//! (`si_dp_coord::modbus`): a host's send job carries an FC03 read through the window, the
//! module's si-modbus master asks si-modbus's slave on an instant line ([`si_sim::Pair`]),
//! and the host's receive job fetches the response in the S_RCV layout.
//!
//! The job goes to the master as `Bytes` cut from the adapter's send pool; the response is
//! stored into a scratch area and cut from the adapter's receive pool.

use bytes::Bytes;
use si_core::Duration;
use si_dp_coord::host::HostEvent;
use si_dp_coord::line::EngineSerial;
use si_dp_coord::modbus;
use si_dp_coord::{Host, HostConfig, Job, Module, Outcome, WindowSize};
use si_modbus::master::Master;
use si_modbus::slave::{Slave, Tables};
use si_modbus::{MasterConfig, SlaveConfig};
use si_sim::Pair;
use si_testkit::alloc::assert_no_alloc;

pub(crate) fn run() {
    modbus_master_jobs_through_the_window_do_not_allocate();
    println!("no_alloc: modbus: 300 FC03 jobs through the window: ok");
}

const WINDOW: WindowSize = WindowSize::Eight;
/// A DP cycle.
const CYCLE: Duration = Duration::from_millis(1);

struct Bench {
    pair: Pair<Module<EngineSerial<Master>>, Slave<Tables>>,
    host: Host,
    input: [u8; 8],
}

impl Bench {
    fn cycle(&mut self) {
        let now = self.pair.now + CYCLE;
        self.pair.run_until(now);
        let mut output = [0u8; 8];
        output.copy_from_slice(self.host.cycle(now, &self.input));
        self.input.copy_from_slice(self.pair.a.cycle(now, &output));
        self.pair.settle();
    }

    fn run(&mut self, job: Job) -> Outcome {
        let id = self.host.submit(job).unwrap();
        for _ in 0..10_000 {
            self.cycle();
            if let Some(event) = self.host.poll_event() {
                match event {
                    HostEvent::Completed {
                        id: done, result, ..
                    } if done == id => return result.expect("the job succeeds"),
                    other => panic!("unexpected event: {other:?}"),
                }
            }
        }
        panic!("job {id:?} did not complete");
    }

    /// One read job and the receive job fetching its response.
    fn read(&mut self, job: &Bytes, expected: &[u8]) {
        assert_eq!(self.run(Job::Send(job.clone())), Outcome::Sent);
        match self.run(Job::Receive) {
            Outcome::Received(frame) => assert_eq!(&frame[..], expected),
            other => panic!("the receive job got {other:?}"),
        }
    }
}

fn modbus_master_jobs_through_the_window_do_not_allocate() {
    let module =
        modbus::master_module(WINDOW, Master::new(MasterConfig::default()).unwrap()).unwrap();
    let mut tables = Tables::new(8, 8, 16, 8);
    for (i, r) in tables.holding_registers.iter_mut().enumerate() {
        *r = 0x4000 + i as u16;
    }
    let config = SlaveConfig {
        address: 1,
        ..SlaveConfig::default()
    };
    let slave = Slave::new(config, tables).unwrap();
    let mut input = [0u8; 8];
    input.copy_from_slice(module.input());
    let mut bench = Bench {
        pair: Pair::new(module, slave),
        host: Host::new(HostConfig {
            max_frame_len: modbus::MAX_FRAME_LEN,
            ..HostConfig::new(WINDOW)
        })
        .unwrap(),
        input,
    };
    let job = Bytes::from_static(&[0x01, 0x03, 0x00, 0x00, 0x00, 0x0A]);
    let expected: Vec<u8> = (0x4000..0x400Au16).flat_map(u16::to_be_bytes).collect();
    for _ in 0..20 {
        bench.read(&job, &expected);
    }
    assert_no_alloc("modbus: 300 FC03 jobs through the window", || {
        for _ in 0..300 {
            bench.read(&job, &expected);
        }
    });
    assert_eq!(bench.pair.a.stats().frames_dropped, 0);
}
