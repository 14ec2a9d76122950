//! The module in Modbus master mode through the window: the host's send job carries
//! the S_SEND source area of [Modbus/USS] §3.4.5–§3.4.16, the module runs si-modbus's master on
//! a simulated line to si-modbus's slave, and the receive job brings back the response in the
//! S_RCV layout of [Modbus/USS] §3.4.5–§3.4.16, or the job's STATUS (0E6xH exception, 0830H no
//! response).
//!
//! Each DP cycle (2 ms of virtual time) the host engine runs one cycle, then the module, then the
//! line simulator runs for the rest of the cycle. The first tests drive the host's jobs directly
//! (the window level); the last ones are end to end, with the user program's S_SEND and S_RCV
//! over the host.

use si_core::{Duration, Instant, SerialSettings, Status};
use si_dp_coord::fb::{Done, Received, SRcv, SSend};
use si_dp_coord::host::{Job, Outcome};
use si_dp_coord::line::EngineSerial;
use si_dp_coord::modbus;
use si_dp_coord::module::Module;
use si_dp_coord::status::INVALID_FRAME_LENGTH;
use si_dp_coord::{Host, HostConfig, HostEvent, RxStatus, WindowSize};
use si_modbus::master::Master;
use si_modbus::slave::{Slave, Tables};
use si_modbus::{status, MasterConfig, SlaveConfig};
use si_sim::{Simulator, StationId};

/// DP cycle of the simulated master.
const CYCLE: Duration = Duration::from_millis(2);

/// The slave's address on the line.
const SLAVE: u8 = 1;

/// Host, module in Modbus master mode, and a Modbus slave on the simulated line.
struct Bench {
    sim: Simulator,
    module: StationId<Module<EngineSerial<Master>>>,
    slave: StationId<Slave<Tables>>,
    host: Host,
    input: Vec<u8>,
}

impl Bench {
    /// Holding register `i` of the slave holds 100H + i.
    fn new(window: WindowSize) -> Self {
        let settings = SerialSettings::default();
        let mut sim = Simulator::new(18);
        let m =
            modbus::master_module(window, Master::new(MasterConfig::default()).unwrap()).unwrap();
        let input = m.input().to_vec();
        let module = sim.add_station("module", settings, m);
        let mut tables = Tables::new(64, 64, 100, 100);
        for (i, r) in tables.holding_registers.iter_mut().enumerate() {
            *r = 0x100 + i as u16;
        }
        let config = SlaveConfig {
            address: SLAVE,
            ..SlaveConfig::default()
        };
        let slave = sim.add_station("slave", settings, Slave::new(config, tables).unwrap());
        sim.connect(module, slave);
        let host = Host::new(HostConfig {
            max_frame_len: modbus::MAX_FRAME_LEN,
            ..HostConfig::new(window)
        })
        .unwrap();
        Bench {
            sim,
            module,
            slave,
            host,
            input,
        }
    }

    /// One DP cycle: host, module, then the line.
    fn dp_cycle(&mut self) {
        let out = self.host.cycle(self.sim.now(), &self.input).to_vec();
        self.input = self
            .sim
            .with(self.module, |m, now| m.cycle(now, &out).to_vec());
        self.sim.run_for(CYCLE);
    }

    /// Runs a host job to its one completion (at most 10 s of DP cycles).
    fn run(&mut self, job: Job) -> Result<Outcome, Status> {
        let id = self.host.submit(job).unwrap();
        for _ in 0..5_000 {
            self.dp_cycle();
            while let Some(e) = self.host.poll_event() {
                if let HostEvent::Completed {
                    id: done, result, ..
                } = e
                {
                    assert_eq!(done, id, "one job at a time");
                    return result;
                }
            }
        }
        panic!("job {id:?} did not end");
    }

    /// A send job with the S_SEND source area `area`.
    fn send(&mut self, area: &[u8]) -> Result<Outcome, Status> {
        self.run(Job::Send(area.to_vec().into()))
    }

    /// The bytes the slave received, in order.
    fn on_the_line(&self) -> Vec<u8> {
        self.sim
            .trace()
            .received("slave")
            .iter()
            .map(|r| r.1)
            .collect()
    }
}

fn received(bytes: &[u8]) -> Result<Outcome, Status> {
    Ok(Outcome::Received(bytes.to_vec().into()))
}

/// FC03 in every window size: the request leaves as the golden ADU, the send job ends once the
/// response is in, the idle window shows 0001H, and the receive job brings the registers in
/// register order ([Modbus/USS] §3.4.5–§3.4.16).
#[test]
fn m_4_3_fc03_read_through_the_window_in_every_size() {
    for window in WindowSize::ALL {
        let mut b = Bench::new(window);
        assert_eq!(
            b.send(&[SLAVE, 0x03, 0x00, 0x00, 0x00, 0x0A]),
            Ok(Outcome::Sent)
        );
        assert_eq!(
            b.on_the_line(),
            [0x01, 0x03, 0x00, 0x00, 0x00, 0x0A, 0xC5, 0xCD]
        );
        b.dp_cycle();
        assert_eq!(b.host.receive_status(), Some(RxStatus::FramePresent));
        let regs: Vec<u8> = (0x100..0x10Au16).flat_map(u16::to_be_bytes).collect();
        assert_eq!(b.run(Job::Receive), received(&regs), "{window}");
        assert_eq!(b.run(Job::Receive), Ok(Outcome::NoMessage));
    }
}

/// FC16 and FC06: the slave's registers change, and the receive job brings the echo (address,
/// FC, start, count / value, [Modbus/USS] §3.4.5–§3.4.16); a broadcast FC06 leaves nothing to
/// receive.
#[test]
fn m_4_3_fc16_and_fc06_writes_through_the_window() {
    let mut b = Bench::new(WindowSize::Four);
    let fc16 = [
        SLAVE, 0x10, 0x00, 0x10, 0x00, 0x03, 0x41, 0xA1, 0x42, 0xA2, 0x43, 0xA3,
    ];
    assert_eq!(b.send(&fc16), Ok(Outcome::Sent));
    // The module added the byte count (6) and the CRC.
    assert_eq!(
        b.on_the_line()[..13],
        [1, 0x10, 0, 0x10, 0, 3, 6, 0x41, 0xA1, 0x42, 0xA2, 0x43, 0xA3]
    );
    assert_eq!(b.run(Job::Receive), received(&fc16[..6]));
    let fc06 = [SLAVE, 0x06, 0x00, 0x05, 0x12, 0x34];
    assert_eq!(b.send(&fc06), Ok(Outcome::Sent));
    assert_eq!(b.run(Job::Receive), received(&fc06));
    let regs = b
        .sim
        .with(b.slave, |s, _| s.store().holding_registers[..20].to_vec());
    assert_eq!(regs[5], 0x1234);
    assert_eq!(regs[16..19], [0x41A1, 0x42A2, 0x43A3]);
    // A broadcast (address 0, FC06) gets no response: the send job ends after the master's
    // turnaround, and no response waits for a receive job.
    assert_eq!(
        b.send(&[0x00, 0x06, 0x00, 0x07, 0xAB, 0xCD]),
        Ok(Outcome::Sent)
    );
    let r7 = b.sim.with(b.slave, |s, _| s.store().holding_registers[7]);
    assert_eq!(r7, 0xABCD);
    assert_eq!(b.run(Job::Receive), Ok(Outcome::NoMessage));
}

/// An exception response (register 1000 does not exist: exception 02) ends the send job with
/// 7xH + 0E62H and the next receive job with 20H + 0E62H ([Modbus/USS] §3.3.6, Table 3-12, §3.4.2
/// `[derived]`).
#[test]
fn m_3_6_exception_reaches_the_send_and_the_receive_job_as_0e6xh() {
    let mut b = Bench::new(WindowSize::Eight);
    let exception = status::EXCEPTION_ILLEGAL_DATA_ADDRESS;
    assert_eq!(exception.code(), 0x0E62);
    assert_eq!(
        b.send(&[SLAVE, 0x03, 0x03, 0xE8, 0x00, 0x01]),
        Err(exception)
    );
    assert_eq!(b.run(Job::Receive), Err(exception));
    assert_eq!(b.run(Job::Receive), Ok(Outcome::NoMessage));
}

/// A slave that does not answer: the send job ends after the response time (2 s, [Modbus/USS]
/// §3.4.3, Table 3-17) with 0830H, and so does the next receive job.
#[test]
fn m_3_8_silent_slave_is_0830h_for_the_send_and_the_receive_job() {
    let mut b = Bench::new(WindowSize::Eight);
    b.sim.silence(b.slave, Instant::ZERO);
    let start = b.sim.now();
    assert_eq!(
        b.send(&[SLAVE, 0x03, 0x00, 0x00, 0x00, 0x01]),
        Err(status::RESPONSE_TIMEOUT)
    );
    assert!(b.sim.now().saturating_since(start) >= Duration::from_secs(2));
    assert_eq!(b.run(Job::Receive), Err(status::RESPONSE_TIMEOUT));
}

/// A source area breaking [Modbus/USS] §3.4.5–§3.4.16 ends the send job at once with its 0E4xH and
/// puts nothing on the line or in the receive buffer; a job longer than 200 bytes is 050EH from the
/// window module (`[derived]`).
#[test]
fn m_4_3_refused_jobs_end_at_once_and_reach_neither_line_nor_buffer() {
    let mut b = Bench::new(WindowSize::Eight);
    let r = b.send(&[SLAVE, 0x09, 0x00, 0x00, 0x00, 0x01]);
    assert_eq!(r.map_err(|s| s.code()), Err(0x0E42));
    let r = b.send(&[0x00, 0x03, 0x00, 0x00, 0x00, 0x01]);
    assert_eq!(r.map_err(|s| s.code()), Err(0x0E43), "no broadcast read");
    assert!(b.on_the_line().is_empty());
    assert_eq!(b.run(Job::Receive), Ok(Outcome::NoMessage));
    // A host allowing 224 bytes meets the module's 200.
    b.host = Host::new(HostConfig::new(WindowSize::Eight)).unwrap();
    assert_eq!(b.send(&[0u8; 201]), Err(INVALID_FRAME_LENGTH));
}

/// [Modbus/USS] §3.4.5–§3.4.16: a read whose result exceeds 200 bytes (FC03, 101 registers = 202
/// bytes) never reaches the host cut short. Either si-modbus's job check refuses it with 050EH
/// before the line (its reading of [Modbus/USS] §3.4.5–§3.4.16 `[derived]`), or the response
/// arrives and the window module refuses the frame (0850H) so that the receive job gets the error
/// instead of a frame.
#[test]
fn m_4_5_a_read_over_200_bytes_is_an_error_not_a_cut_frame() {
    let mut b = Bench::new(WindowSize::ThirtyTwo);
    b.sim.with(b.slave, |s, _| {
        s.store_mut().holding_registers.resize(101, 0x5A5A);
    });
    let sent = b.send(&[SLAVE, 0x03, 0x00, 0x00, 0x00, 101]);
    let received = b.run(Job::Receive);
    let codes = |r: Result<Outcome, Status>| r.map_err(|s| s.code());
    match (codes(sent), codes(received)) {
        (Err(0x050E), Ok(Outcome::NoMessage)) => assert!(b.on_the_line().is_empty()),
        (Ok(Outcome::Sent), Err(0x0850)) => {}
        other => panic!("{other:?}"),
    }
    assert_eq!(b.run(Job::Receive), Ok(Outcome::NoMessage));
}

/// What the user program's FBs saw over one run.
#[derive(Debug, Default)]
struct Seen {
    sends: Vec<Done>,
    receives: Vec<(Received, Vec<u8>)>,
}

/// End to end: S_SEND with `area` (REQ from the first call) and S_RCV (EN_R = 1) over the host,
/// for `cycles` DP cycles.
fn fbs(b: &mut Bench, area: &[u8], cycles: usize) -> Seen {
    let (mut s_send, mut s_rcv) = (SSend::default(), SRcv::default());
    let mut dest = [0u8; 200];
    let mut seen = Seen::default();
    for _ in 0..cycles {
        let now = b.sim.now();
        let d = s_send.call(&mut b.host, now, true, false, area);
        if d.done || d.error {
            seen.sends.push(d);
        }
        let r = s_rcv.call(&mut b.host, now, true, false, &mut dest);
        if r.ndr || r.error {
            seen.receives.push((r, dest[..r.len].to_vec()));
        }
        b.dp_cycle();
    }
    seen
}

/// Figure 3-7 end to end: S_SEND DONE and S_RCV NDR with the registers (FC03); the write's echo
/// (FC16); ERROR with the same STATUS on both blocks for an exception and a silent slave.
#[test]
fn figure_3_7_s_send_and_s_rcv_through_the_window_to_a_modbus_slave() {
    let mut b = Bench::new(WindowSize::Eight);
    let seen = fbs(&mut b, &[SLAVE, 0x03, 0x00, 0x02, 0x00, 0x02], 500);
    assert_eq!(seen.sends.len(), 1, "{seen:?}");
    assert!(seen.sends[0].done && !seen.sends[0].error);
    assert_eq!(seen.receives.len(), 1, "{seen:?}");
    let (r, data) = &seen.receives[0];
    assert!(r.ndr && !r.error && r.len == 4);
    assert_eq!(data, &[0x01, 0x02, 0x01, 0x03]);

    let fc16 = [SLAVE, 0x10, 0x00, 0x00, 0x00, 0x01, 0xBE, 0xEF];
    let seen = fbs(&mut b, &fc16, 500);
    assert!(seen.sends.len() == 1 && seen.sends[0].done);
    assert_eq!(seen.receives.len(), 1);
    assert_eq!(seen.receives[0].1, fc16[..6]);
    let r0 = b.sim.with(b.slave, |s, _| s.store().holding_registers[0]);
    assert_eq!(r0, 0xBEEF);

    let seen = fbs(&mut b, &[SLAVE, 0x04, 0x10, 0x00, 0x00, 0x01], 500);
    let exception = status::EXCEPTION_ILLEGAL_DATA_ADDRESS;
    assert_eq!(seen.sends.len(), 1);
    assert!(seen.sends[0].error && seen.sends[0].status == exception);
    assert_eq!(seen.receives.len(), 1);
    assert!(seen.receives[0].0.error && seen.receives[0].0.status == exception);

    b.sim.silence(b.slave, b.sim.now());
    let seen = fbs(&mut b, &[SLAVE, 0x03, 0x00, 0x00, 0x00, 0x01], 1_500);
    assert_eq!(seen.sends.len(), 1);
    assert_eq!(seen.sends[0].status, status::RESPONSE_TIMEOUT);
    assert_eq!(seen.receives.len(), 1);
    assert_eq!(seen.receives[0].0.status, status::RESPONSE_TIMEOUT);
}
