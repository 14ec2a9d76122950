//! Read jobs through S_SEND/S_RCV at the 200-byte limit ([Modbus/USS] §3.4.2 LEN
//! 1…200, [Modbus/USS] §3.4.5–§3.4.16 practical maxima, §3.6 050EH): a result that fits is
//! delivered whole with LEN up to 200; one that would not fit ends with 050EH before any request
//! goes on the line.

use si_core::{Duration, SerialSettings, Status};
use si_modbus::fb::{Done, Received, SRcv, SSend, MAX_LEN};
use si_modbus::master::Master;
use si_modbus::slave::{Slave, Tables};
use si_modbus::{status, MasterConfig, SlaveConfig};
use si_sim::{Simulator, StationId};

/// A PLC cycle: S_SEND and S_RCV are called this often.
const CYCLE: Duration = Duration::from_millis(10);
/// Enough cycles for the longest read at 9600 bit/s (about 300 ms) many times over.
const CYCLES: usize = 300;

/// What the PLC program saw for one job: S_SEND's end, S_RCV's first report, the destination
/// area, and how many bytes reached the slave.
struct Outcome {
    send: Done,
    rcv: Received,
    dest: Vec<u8>,
    sent_on_line: usize,
}

/// Slave 1 with the manual's largest tables (2040 bits, 127 registers), each value telling its
/// address: coil/input n is set when n % 3 == 0, register n holds 1000H + n.
fn slave() -> Slave<Tables> {
    let mut t = Tables::new(2040, 2040, 127, 127);
    for (i, b) in t.coils.iter_mut().enumerate() {
        *b = i % 3 == 0;
    }
    t.discrete_inputs.clone_from(&t.coils);
    for (i, r) in t.holding_registers.iter_mut().enumerate() {
        *r = 0x1000 + i as u16;
    }
    t.input_registers.clone_from(&t.holding_registers);
    let config = SlaveConfig {
        address: 1,
        ..SlaveConfig::default()
    };
    Slave::new(config, t).unwrap()
}

/// Runs the job `[01, fc, 00 00, quantity]` from a REQ edge until S_SEND reports, calling both
/// FBs once per cycle in virtual time.
fn read_job(function: u8, quantity: u16) -> Outcome {
    let mut sim = Simulator::new(11);
    let s = SerialSettings::default();
    let m: StationId<Master> =
        sim.add_station("master", s, Master::new(MasterConfig::default()).unwrap());
    let sl = sim.add_station("slave", s, slave());
    sim.connect(m, sl);
    let [q_hi, q_lo] = quantity.to_be_bytes();
    let job = [0x01, function, 0x00, 0x00, q_hi, q_lo];
    let (mut send, mut rcv) = (SSend::default(), SRcv::default());
    let mut dest = vec![0xEE; 256];
    let mut report = Received::default();
    for _ in 0..CYCLES {
        let done = sim.with(m, |e, now| send.call(e, now, true, false, &job));
        let r = sim.with(m, |e, now| rcv.call(e, now, true, false, &mut dest));
        if r.ndr || r.error {
            report = r;
        }
        if done.done || done.error {
            return Outcome {
                send: done,
                rcv: report,
                dest,
                sent_on_line: sim.trace().received("slave").len(),
            };
        }
        sim.run_for(CYCLE);
    }
    panic!("S_SEND did not report within {CYCLES} cycles");
}

fn assert_delivered(o: &Outcome, len: usize) {
    assert!(o.send.done && !o.send.error, "{:?}", o.send);
    assert!(o.rcv.ndr && !o.rcv.error, "{:?}", o.rcv);
    assert_eq!((o.rcv.len, o.rcv.status), (len, Status::OK));
    assert!(o.rcv.len <= MAX_LEN);
    assert_eq!(o.sent_on_line, 8, "one request of 8 bytes");
}

fn assert_refused(o: &Outcome) {
    assert!(o.send.error && !o.send.done, "{:?}", o.send);
    assert_eq!(o.send.status, status::FRAME_TOO_LONG);
    assert_eq!(o.send.status.code(), 0x050E);
    assert!(!o.rcv.ndr && !o.rcv.error, "S_RCV has nothing: {:?}", o.rcv);
    assert_eq!(o.sent_on_line, 0, "no request left the master");
    assert!(o.dest.iter().all(|&b| b == 0xEE), "destination untouched");
}

#[test]
fn s4_5_fc03_fc04_read_100_registers_and_refuse_101_with_050eh() {
    for function in [3, 4] {
        let o = read_job(function, 100);
        assert_delivered(&o, 200);
        // Register n = 1000H + n, high byte first ([Modbus/USS] §3.4.5–§3.4.16); the last one is
        // 1063H.
        assert_eq!(o.dest[..4], [0x10, 0x00, 0x10, 0x01]);
        assert_eq!(o.dest[198..200], [0x10, 0x63]);
        assert_eq!(o.dest[200], 0xEE, "nothing past LEN");
        assert_refused(&read_job(function, 101));
        // The range check of [Modbus/USS] §3.4.5–§3.4.16 still comes first.
        assert_eq!(read_job(function, 128).send.status.code(), 0x0E45);
    }
}

#[test]
fn s4_5_fc01_fc02_read_1600_bits_and_refuse_1601_with_050eh() {
    for function in [1, 2] {
        let o = read_job(function, 1600);
        assert_delivered(&o, 200);
        // Bits 0, 3, 6 set: first byte 0100_1001 = 49H goes to the low byte of data[1]
        // (offset +1), the second (bits 8–15: 9, 12, 15 → 1001_0010 = 92H) to offset +0.
        assert_eq!(o.dest[..2], [0x92, 0x49]);
        assert_eq!(o.dest[200], 0xEE, "nothing past LEN");
        assert_refused(&read_job(function, 1601));
        // 1593 bits are 200 bytes on the wire as well: still delivered.
        assert_delivered(&read_job(function, 1593), 200);
        assert_eq!(read_job(function, 2041).send.status.code(), 0x0E44);
    }
}

#[test]
fn s4_5_s_rcv_len_is_never_above_200_for_any_accepted_read() {
    for (function, quantities) in [(3u8, [1u16, 99, 100]), (1, [1, 1599, 1600])] {
        for q in quantities {
            let o = read_job(function, q);
            assert!(o.send.done, "{function} × {q}: {:?}", o.send);
            assert!(o.rcv.len <= MAX_LEN, "{function} × {q}: LEN {}", o.rcv.len);
        }
    }
}
