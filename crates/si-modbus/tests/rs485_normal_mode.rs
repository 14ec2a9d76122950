//! et200s-si-modbus-uss.md §2.5 against §3.7: in Normal mode a master on RS-485 recognises the
//! response by a correctly received slave address, so a turnaround glitch before it (a stray
//! byte, or a framing error as the bus changes direction) is skipped; on RS-422 (and RS-232C)
//! Normal mode still fails the job with 0831H.

use si_core::sim::{Simulator, StationId};
use si_core::{Duration, Engine, Instant, Interface, LineError, Output, SerialSettings};
use si_modbus::frame::{crc16, Request};
use si_modbus::master::{Master, MasterEvent};
use si_modbus::{status, MasterConfig};

#[derive(Default)]
struct Partner;
impl Engine for Partner {
    type Event = ();
    fn handle_rx(&mut self, _: Instant, _: &[u8]) {}
    fn handle_timeout(&mut self, _: Instant) {}
    fn poll_output(&mut self) -> Output<()> {
        Output::Wait(None)
    }
}

const READ1: Request<'static> = Request::ReadHoldingRegisters {
    address: 0,
    quantity: 1,
};

fn response() -> Vec<u8> {
    let mut v = vec![1, 3, 2, 0x12, 0x34];
    let c = crc16(&v).to_le_bytes();
    v.extend_from_slice(&c);
    v
}

/// A Normal-mode master on `interface` whose request went out 20 ms ago.
fn rig(interface: Interface) -> (Simulator, StationId<Master>, StationId<Partner>) {
    let mut sim = Simulator::new(485);
    let s = SerialSettings::default();
    let master = Master::new(MasterConfig::default())
        .unwrap()
        .with_interface(interface);
    let m = sim.add_station("master", s, master);
    let p = sim.add_station("partner", s, Partner);
    sim.connect(m, p);
    sim.with(m, |e, now| e.request(now, 1, &READ1)).unwrap();
    sim.run_for(Duration::from_millis(20));
    (sim, m, p)
}

fn outcome(sim: &mut Simulator, m: StationId<Master>) -> MasterEvent {
    sim.run_until_quiet(Instant::from_micros(10_000_000));
    let mut events = sim.take_events(m);
    assert_eq!(events.len(), 1, "{events:?}");
    events.pop().unwrap()
}

#[test]
fn s2_5_rs485_normal_mode_skips_a_glitch_byte_before_the_address() {
    let (mut sim, m, p) = rig(Interface::Rs485);
    let mut bytes = vec![0xFF];
    bytes.extend(response());
    sim.transmit(p, &bytes);
    let MasterEvent::Completed(c) = outcome(&mut sim, m) else {
        panic!("not completed");
    };
    assert_eq!(c.response_bytes(), Some(&response()[..]));
    assert_eq!(sim.engine(m).counters().skipped_bytes, 1);
}

#[test]
fn s2_5_rs485_normal_mode_ignores_a_framing_error_before_the_address() {
    let (mut sim, m, p) = rig(Interface::Rs485);
    sim.with(m, |e, now| e.handle_line_error(now, LineError::Framing));
    sim.transmit(p, &response());
    assert!(matches!(outcome(&mut sim, m), MasterEvent::Completed(_)));
}

#[test]
fn s3_7_rs422_normal_mode_keeps_0831h_for_a_glitch_byte() {
    for interface in [Interface::Rs422, Interface::Rs232] {
        let (mut sim, m, p) = rig(interface);
        let mut bytes = vec![0xFF];
        bytes.extend(response());
        sim.transmit(p, &bytes);
        assert_eq!(
            outcome(&mut sim, m),
            MasterEvent::Failed {
                unit: 1,
                function: 3,
                status: status::WRONG_SLAVE_ADDRESS
            },
            "{interface:?}"
        );
    }
}
