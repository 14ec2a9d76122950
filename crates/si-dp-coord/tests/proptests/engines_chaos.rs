//! Two window modules running the real line engines (si-3964r or si-ascii), or one in Modbus
//! master mode asking si-modbus's slave, on a line with seeded faults (bit flips, lost and
//! inserted characters), each module behind its own host with random jobs: nothing panics, and every job ends in exactly one completion
//! (ARCHITECTURE.md "every job the user starts ends in exactly one completion event"), with
//! STATUS 0000H on success or a nonzero STATUS on failure.

use bytes::Bytes;
use proptest::prelude::*;
use si_core::{Duration, Engine, SerialSettings};
use si_dp_coord::engines;
use si_dp_coord::host::{Host, HostEvent, Job, JobId};
use si_dp_coord::line::EngineSerial;
use si_dp_coord::module::Module;
use si_dp_coord::{HostConfig, ParamBlock, WindowSize};
use si_sim::{Faults, Simulator, StationId};
use std::collections::HashMap;

const CYCLE: Duration = Duration::from_millis(2);

fn window_size() -> impl Strategy<Value = WindowSize> {
    prop_oneof![
        Just(WindowSize::Four),
        Just(WindowSize::Eight),
        Just(WindowSize::ThirtyTwo)
    ]
}

fn job() -> impl Strategy<Value = Job> {
    prop_oneof![
        4 => proptest::collection::vec(0x20u8..0x7F, 1..=200).prop_map(|v| Job::Send(Bytes::from(v))),
        3 => Just(Job::Receive),
        1 => Just(Job::ReadV24),
        1 => (any::<bool>(), any::<bool>()).prop_map(|(rts, dtr)| Job::WriteV24 { rts, dtr }),
        1 => Just(Job::Parameters(ParamBlock::XON_XOFF_DEFAULT)),
    ]
}

/// (cycle at which to submit, which side, the job)
fn plan() -> impl Strategy<Value = Vec<(usize, bool, Job)>> {
    proptest::collection::vec((0usize..1_500, any::<bool>(), job()), 1..12)
}

fn faults() -> impl Strategy<Value = Faults> {
    (0.0..0.02f64, 0.0..0.02f64, 0.0..0.02f64).prop_map(|(bit_flip, drop, insert)| Faults {
        bit_flip,
        drop,
        insert,
        ..Faults::default()
    })
}

struct Side<E: Engine> {
    station: StationId<Module<EngineSerial<E>>>,
    host: Host,
    input: Vec<u8>,
    submitted: Vec<JobId>,
    completions: HashMap<JobId, Vec<u16>>,
}

impl<E: Engine + 'static> Side<E>
where
    E::Event: 'static,
{
    fn new(
        sim: &mut Simulator,
        name: &str,
        line: SerialSettings,
        module: Module<EngineSerial<E>>,
    ) -> Self {
        let input = module.input().to_vec();
        let host = Host::new(HostConfig::new(module.config().window)).unwrap();
        Side {
            station: sim.add_station(name, line, module),
            host,
            input,
            submitted: Vec::new(),
            completions: HashMap::new(),
        }
    }

    fn cycle(&mut self, sim: &mut Simulator) {
        let out = self.host.cycle(sim.now(), &self.input).to_vec();
        self.input = sim.with(self.station, |m, now| m.cycle(now, &out).to_vec());
        while let Some(e) = self.host.poll_event() {
            if let HostEvent::Completed { id, result, .. } = e {
                let word = result.err().map_or(0, |s| s.code());
                self.completions.entry(id).or_default().push(word);
            }
        }
    }

    fn check(&self) -> Result<(), TestCaseError> {
        for id in &self.submitted {
            let c = self.completions.get(id).map_or(0, Vec::len);
            prop_assert_eq!(c, 1, "job {:?} completed {} times", id, c);
        }
        prop_assert_eq!(self.completions.len(), self.submitted.len());
        Ok(())
    }
}

fn run<E: Engine + 'static>(
    mut sim: Simulator,
    mut a: Side<E>,
    mut b: Side<E>,
    plan: &[(usize, bool, Job)],
) -> Result<(), TestCaseError>
where
    E::Event: 'static,
{
    // 1 500 cycles with jobs arriving, then up to 40 s of virtual time for them to end (the host
    // watchdog is 30 s).
    for cycle in 0..21_500 {
        for (at, on_a, job) in plan {
            if *at == cycle {
                let side = if *on_a {
                    &mut a.submitted
                } else {
                    &mut b.submitted
                };
                let host = if *on_a { &mut a.host } else { &mut b.host };
                if let Ok(id) = host.submit(job.clone()) {
                    side.push(id);
                }
            }
        }
        a.cycle(&mut sim);
        b.cycle(&mut sim);
        sim.run_for(CYCLE);
        if cycle > 1_500
            && a.completions.len() == a.submitted.len()
            && b.completions.len() == b.submitted.len()
        {
            break;
        }
    }
    a.check()?;
    b.check()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    #[test]
    fn r3964r_modules_on_a_faulty_line_end_every_job_once(
        seed in any::<u64>(), window in window_size(), fa in faults(), fb in faults(), plan in plan(),
    ) {
        let line = SerialSettings::default();
        let config = |priority| si_3964r::Config {
            priority,
            char_delay: si_core::Duration::from_millis(20),
            ack_delay: si_core::Duration::from_millis(50),
            ..si_3964r::Config::default()
        };
        let mut sim = Simulator::new(seed).without_trace();
        let ma = engines::r3964r_module(window, si_3964r::Link::new(config(si_3964r::config::Priority::High).with_settings(line)).unwrap()).unwrap();
        let mb = engines::r3964r_module(window, si_3964r::Link::new(config(si_3964r::config::Priority::Low).with_settings(line)).unwrap()).unwrap();
        let a = Side::new(&mut sim, "A", line, ma);
        let b = Side::new(&mut sim, "B", line, mb);
        sim.connect(a.station, b.station);
        sim.set_faults(a.station, fa);
        sim.set_faults(b.station, fb);
        run(sim, a, b, &plan)?;
    }

    #[test]
    fn ascii_modules_on_a_faulty_line_end_every_job_once(
        seed in any::<u64>(), window in window_size(), fa in faults(), fb in faults(), plan in plan(),
        xon_xoff in any::<bool>(),
    ) {
        let config = si_ascii::Config {
            flow_control: if xon_xoff { si_ascii::FlowControl::XonXoff } else { si_ascii::FlowControl::None },
            tx_chunk: 1,
            ..si_ascii::Config::default()
        };
        let mut sim = Simulator::new(seed).without_trace();
        let a = Side::new(&mut sim, "A", config.settings, engines::ascii_module(window, si_ascii::Link::new(config).unwrap()).unwrap());
        let b = Side::new(&mut sim, "B", config.settings, engines::ascii_module(window, si_ascii::Link::new(config).unwrap()).unwrap());
        sim.connect(a.station, b.station);
        sim.set_faults(a.station, fa);
        sim.set_faults(b.station, fb);
        run(sim, a, b, &plan)?;
    }
}

/// One input to a module station: a DP cycle with any output window, line bytes, a line error,
/// or the passing of time.
#[derive(Debug, Clone)]
enum Input {
    Cycle(Vec<u8>),
    Rx(Vec<u8>),
    LineError,
    Wait(u64),
}

fn inputs(window: WindowSize) -> impl Strategy<Value = Vec<Input>> {
    let n = window.bytes();
    proptest::collection::vec(
        prop_oneof![
            4 => proptest::collection::vec(any::<u8>(), n..=n).prop_map(Input::Cycle),
            1 => proptest::collection::vec(any::<u8>(), 0..40).prop_map(Input::Cycle),
            3 => proptest::collection::vec(any::<u8>(), 1..64).prop_map(Input::Rx),
            1 => Just(Input::LineError),
            2 => (0u64..3_000_000).prop_map(Input::Wait),
        ],
        0..200,
    )
}

/// Drives a module station by hand the way a driver would: every input, then its outputs
/// drained until `Wait`, its timer honoured.
fn drive<E: Engine>(mut m: Module<EngineSerial<E>>, script: &[Input]) -> Result<(), TestCaseError> {
    let mut now = si_core::Instant::ZERO;
    let mut deadline = None;
    for input in script {
        match input {
            Input::Cycle(w) => {
                let _ = m.cycle(now, w);
            }
            Input::Rx(bytes) => m.handle_rx(now, bytes),
            Input::LineError => m.handle_line_error(now, si_core::LineError::Framing),
            Input::Wait(us) => {
                now += Duration::from_micros(*us);
                if deadline.is_some_and(|d| d <= now) {
                    m.handle_timeout(now);
                }
            }
        }
        let mut outputs = 0;
        loop {
            match m.poll_output() {
                si_core::Output::Wait(d) => {
                    deadline = d;
                    break;
                }
                si_core::Output::Transmit(_) => m.handle_tx_done(now),
                _ => {}
            }
            outputs += 1;
            prop_assert!(outputs < 10_000, "outputs never end");
        }
        prop_assert!(m.buffered() <= m.config().rx_buffer_frames + 1);
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    #[test]
    fn module_with_3964r_never_panics_on_any_window_bytes_or_timing(
        (window, script) in window_size().prop_flat_map(|w| (Just(w), inputs(w))),
    ) {
        let link = si_3964r::Link::new(si_3964r::Config::default().with_settings(SerialSettings::default())).unwrap();
        drive(engines::r3964r_module(window, link).unwrap(), &script)?;
    }

    #[test]
    fn module_with_ascii_never_panics_on_any_window_bytes_or_timing(
        (window, script) in window_size().prop_flat_map(|w| (Just(w), inputs(w))), xon in any::<bool>(),
    ) {
        let config = si_ascii::Config {
            flow_control: if xon { si_ascii::FlowControl::XonXoff } else { si_ascii::FlowControl::None },
            ..si_ascii::Config::default()
        };
        drive(engines::ascii_module(window, si_ascii::Link::new(config).unwrap()).unwrap(), &script)?;
    }
}

/// A job for the module in Modbus master mode: FC03 and FC06 source areas (slave 0, 1 or 2,
/// where only 1 exists and 0 is a broadcast), any bytes, or a receive job.
fn modbus_job() -> impl Strategy<Value = Job> {
    let area = |unit: u8, fc: u8, w2: u16, w4: u16| {
        let [a, b] = w2.to_be_bytes();
        let [c, d] = w4.to_be_bytes();
        Job::Send(Bytes::from(vec![unit, fc, a, b, c, d]))
    };
    prop_oneof![
        3 => (0u8..3, 0u16..40, 0u16..12).prop_map(move |(u, a, n)| area(u, 3, a, n)),
        2 => (0u8..3, 0u16..40, any::<u16>()).prop_map(move |(u, a, v)| area(u, 6, a, v)),
        1 => proptest::collection::vec(any::<u8>(), 1..=24).prop_map(|v| Job::Send(Bytes::from(v))),
        3 => Just(Job::Receive),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    #[test]
    fn modbus_master_module_on_a_faulty_line_ends_every_job_once(
        seed in any::<u64>(), window in window_size(), fm in faults(), fs in faults(),
        plan in proptest::collection::vec((0usize..1_500, modbus_job()), 1..12),
    ) {
        let line = SerialSettings::default();
        let config = si_modbus::MasterConfig { response_timeout: si_core::Duration::from_millis(200), ..si_modbus::MasterConfig::default() };
        let module = si_dp_coord::modbus::master_module(window, si_modbus::Master::new(config).unwrap()).unwrap();
        let mut sim = Simulator::new(seed).without_trace();
        let mut side = Side::new(&mut sim, "module", line, module);
        side.host = Host::new(HostConfig { max_frame_len: 200, ..HostConfig::new(window) }).unwrap();
        let slave_config = si_modbus::SlaveConfig { address: 1, ..si_modbus::SlaveConfig::default() };
        let slave = sim.add_station("slave", line, si_modbus::Slave::new(slave_config, si_modbus::Tables::new(32, 32, 32, 32)).unwrap());
        sim.connect(side.station, slave);
        sim.set_faults(side.station, fm);
        sim.set_faults(slave, fs);
        for cycle in 0..21_500 {
            for (at, job) in &plan {
                if *at == cycle {
                    if let Ok(id) = side.host.submit(job.clone()) {
                        side.submitted.push(id);
                    }
                }
            }
            side.cycle(&mut sim);
            sim.run_for(CYCLE);
            if cycle > 1_500 && side.completions.len() == side.submitted.len() {
                break;
            }
        }
        side.check()?;
    }

    #[test]
    fn module_in_modbus_master_mode_never_panics_on_any_window_bytes_or_timing(
        (window, script) in window_size().prop_flat_map(|w| (Just(w), inputs(w))),
    ) {
        let master = si_modbus::Master::new(si_modbus::MasterConfig::default()).unwrap();
        drive(si_dp_coord::modbus::master_module(window, master).unwrap(), &script)?;
    }
}
